// The depth raster's AVX2 row kernel: this file alone is compiled with
// -mavx2 (and -ffp-contract=off, no FMA), and render_depth calls it only when
// detail::depth_raster_avx2_enabled(). Four pixels of a row per step in
// double lanes (the triangles of a band are a few pixels wide: a box up to
// four wide is one step per row), each lane evaluating the edge numerators,
// the coverage test and the depth with the IEEE operations of the portable
// kernel in the same order, so both write the same bits.
#include <immintrin.h>

#include <array>
#include <cstdint>
#include <limits>

#include "depth_raster_internal.hpp"

namespace fabrica::detail {

namespace {

// The 32-bit lane masks of the four-bit masks (lane i set when bit i is).
constexpr std::array<std::array<std::int32_t, 4>, 16> make_lane_masks() {
  std::array<std::array<std::int32_t, 4>, 16> m{};
  for (int b = 0; b < 16; ++b)
    for (int i = 0; i < 4; ++i) m[b][i] = (b >> i) & 1 ? -1 : 0;
  return m;
}
alignas(16) constexpr std::array<std::array<std::int32_t, 4>, 16> kRasterLaneMasks =
    make_lane_masks();

inline __m128i lane_mask(int bits) {
  return _mm_load_si128(reinterpret_cast<const __m128i*>(kRasterLaneMasks[bits].data()));
}

struct Avx2Rows {
  template <bool kFaces>
  static void draw(const RasterBand& band, const raster_band::Setup& s) {
    if (s.x1 - s.x0 >= 8)
      draw<kFaces, true>(band, s);
    else
      draw<kFaces, false>(band, s);
  }

  template <bool kFaces, bool kWide>
  static void draw(const RasterBand& band, const raster_band::Setup& s) {
    if (band.perspective) {
      if (s.positive)
        rows<kFaces, kWide, true, true>(band, s);
      else
        rows<kFaces, kWide, true, false>(band, s);
    } else {
      if (s.positive)
        rows<kFaces, kWide, false, true>(band, s);
      else
        rows<kFaces, kWide, false, false>(band, s);
    }
  }

  // kWide: boxes at least nine pixels wide, which skip empty steps.
  template <bool kFaces, bool kWide, bool kPerspective, bool kPositive>
  static void rows(const RasterBand& band, const raster_band::Setup& s) {
    const int W = band.width;
    const __m256d zero = _mm256_setzero_pd();
    const __m256d inv_area = _mm256_set1_pd(s.inv_area);
    const __m256d z0 = _mm256_set1_pd(s.z[0]), z1 = _mm256_set1_pd(s.z[1]),
                  z2 = _mm256_set1_pd(s.z[2]);
    const __m128i face = _mm_set1_epi32(s.face);
    // Columns four at a time, each run down the rows of the box: the
    // column terms ey[k] (px - ax[k]) are computed once per four columns.
    for (int xs = s.x0; xs <= s.x1; xs += 4) {
      const int n = s.x1 - xs + 1;
      const int box_bits = n >= 4 ? 15 : (1 << n) - 1;
      // (px = (xs + i) + 0.5, as an int sum converted, then the half added)
      const __m256d px = _mm256_add_pd(
          _mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(xs), _mm_setr_epi32(0, 1, 2, 3))),
          _mm256_set1_pd(0.5));
      __m256d col[3];
      for (int k = 0; k < 3; ++k)
        col[k] = _mm256_mul_pd(_mm256_set1_pd(s.ey[k]), _mm256_sub_pd(px, _mm256_set1_pd(s.ax[k])));
      // Whole four-pixel loads and stores when the four columns are in the
      // image (lanes outside the box are written back unchanged: the rows
      // are this band's), masked ones at the right edge.
      const bool whole = xs + 4 <= W;
      for (int y = s.y0; y <= s.y1; ++y) {
        const double py = y + 0.5;
        __m256d m[3];
        for (int k = 0; k < 3; ++k)
          m[k] = _mm256_sub_pd(_mm256_set1_pd(s.ex[k] * (py - s.ay[k])), col[k]);
        // Covered: no numerator of the sign opposite to the area's (NaN
        // counts as covered, as in the portable kernel).
        __m256d in;
        if constexpr (kPositive)
          in = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(m[0], zero, _CMP_NLT_UQ),
                                           _mm256_cmp_pd(m[1], zero, _CMP_NLT_UQ)),
                             _mm256_cmp_pd(m[2], zero, _CMP_NLT_UQ));
        else
          in = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(m[0], zero, _CMP_NGT_UQ),
                                           _mm256_cmp_pd(m[1], zero, _CMP_NGT_UQ)),
                             _mm256_cmp_pd(m[2], zero, _CMP_NGT_UQ));
        const int bits = _mm256_movemask_pd(in) & box_bits;
        // No branch on the coverage of small boxes (most rows of a
        // triangle a few pixels across are partly covered, in no
        // predictable pattern): their uncovered pixels are written back
        // unchanged. Wide boxes skip their empty steps.
        if constexpr (kWide)
          if (bits == 0) continue;
        const __m256d w0 = _mm256_mul_pd(m[0], inv_area), w1 = _mm256_mul_pd(m[1], inv_area),
                      w2 = _mm256_mul_pd(m[2], inv_area);
        __m256d d;
        if constexpr (kPerspective)
          d = _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_add_pd(_mm256_add_pd(_mm256_div_pd(w0, z0),
                                                                             _mm256_div_pd(w1, z1)),
                                                               _mm256_div_pd(w2, z2)));
        else
          d = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(w0, z0), _mm256_mul_pd(w1, z1)),
                            _mm256_mul_pd(w2, z2));
        const __m128 z = _mm256_cvtpd_ps(d);
        const std::size_t at = static_cast<std::size_t>(y) * W + static_cast<std::size_t>(xs);
        float* const dst = band.depth + at;
        const __m128i lanes = lane_mask(bits);
        const __m128 cur = whole ? _mm_loadu_ps(dst) : _mm_maskload_ps(dst, lanes);
        // The nearer depth wins (std::min(dst, z) keeps dst unless z < dst);
        // with faces, ties go to the lower face index.
        __m128 take = _mm_cmplt_ps(z, cur);
        __m128i ids;
        if constexpr (kFaces) {
          ids = whole ? _mm_loadu_si128(reinterpret_cast<const __m128i*>(band.seen + at))
                      : _mm_maskload_epi32(band.seen + at, lanes);
          const __m128 tie =
              _mm_and_ps(_mm_cmpeq_ps(z, cur), _mm_castsi128_ps(_mm_cmpgt_epi32(ids, face)));
          take = _mm_or_ps(take, tie);
        }
        take = _mm_and_ps(take, _mm_castsi128_ps(lanes));
        if (whole) {
          _mm_storeu_ps(dst, _mm_blendv_ps(cur, z, take));
          if constexpr (kFaces)
            _mm_storeu_si128(reinterpret_cast<__m128i*>(band.seen + at),
                             _mm_blendv_epi8(ids, face, _mm_castps_si128(take)));
        } else {
          _mm_maskstore_ps(dst, _mm_castps_si128(take), z);
          if constexpr (kFaces) _mm_maskstore_epi32(band.seen + at, _mm_castps_si128(take), face);
        }
      }
    }
  }
};

// (x x' + y y') + z z', as Eigen's Vec3 dot, for four vectors.
inline __m256d raster_dot4(__m256d x, __m256d y, __m256d z, const Vec3& w) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x, _mm256_set1_pd(w.x())),
                                     _mm256_mul_pd(y, _mm256_set1_pd(w.y()))),
                       _mm256_mul_pd(z, _mm256_set1_pd(w.z())));
}

// |v| < infinity (false for NaN).
inline __m256d raster_finite4(__m256d v) {
  const __m256d abs = _mm256_andnot_pd(_mm256_set1_pd(-0.0), v);
  return _mm256_cmp_pd(abs, _mm256_set1_pd(std::numeric_limits<double>::infinity()), _CMP_LT_OQ);
}

// centres_around (depth_raster.cpp) for four coordinates: v clamped to
// [-2, size + 1], f = floor(v), lo = f + (f + 0.5 < v), hi = f - (f + 0.5 > v).
inline void raster_centres4(__m256d v, int size, __m128i& lo, __m128i& hi) {
  v = _mm256_min_pd(_mm256_max_pd(v, _mm256_set1_pd(-2.0)),
                    _mm256_set1_pd(static_cast<double>(size) + 1.0));
  const __m256d f = _mm256_floor_pd(v);
  const __m256d mid = _mm256_add_pd(f, _mm256_set1_pd(0.5));
  const __m128i fi = _mm256_cvttpd_epi32(f);
  // (a true comparison is -1 in the 32-bit lanes)
  auto lanes = [](__m256d m) {
    return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
        _mm256_castpd_si256(m), _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7)));
  };
  lo = _mm_sub_epi32(fi, lanes(_mm256_cmp_pd(mid, v, _CMP_LT_OQ)));
  hi = _mm_add_epi32(fi, lanes(_mm256_cmp_pd(mid, v, _CMP_GT_OQ)));
}

}  // namespace

std::size_t project_corners_avx2(const Projector& project, const Vec3* positions,
                                 RasterCorner* corners, std::size_t begin, std::size_t end) {
  const bool perspective = project.perspective();
  const __m256d half = _mm256_set1_pd(0.5), one = _mm256_set1_pd(1.0);
  const __m256d width = _mm256_set1_pd(static_cast<double>(project.width()));
  const __m256d height = _mm256_set1_pd(static_cast<double>(project.height()));
  const Vec3& eye = project.eye();
  std::size_t i = begin;
  for (; i + 4 <= end; i += 4) {
    const double* p = positions[i].data();  // four Vec3, 12 doubles
    const __m256d dx =
        _mm256_sub_pd(_mm256_set_pd(p[9], p[6], p[3], p[0]), _mm256_set1_pd(eye.x()));
    const __m256d dy =
        _mm256_sub_pd(_mm256_set_pd(p[10], p[7], p[4], p[1]), _mm256_set1_pd(eye.y()));
    const __m256d dz =
        _mm256_sub_pd(_mm256_set_pd(p[11], p[8], p[5], p[2]), _mm256_set1_pd(eye.z()));
    const __m256d depth = raster_dot4(dx, dy, dz, project.forward());
    __m256d x = raster_dot4(dx, dy, dz, project.right());
    __m256d y = raster_dot4(dx, dy, dz, project.up());
    const __m256d h = perspective ? _mm256_mul_pd(depth, _mm256_set1_pd(project.half_height()))
                                  : _mm256_set1_pd(project.ortho_half_height());
    x = _mm256_div_pd(_mm256_div_pd(x, h), _mm256_set1_pd(project.aspect()));
    y = _mm256_div_pd(y, h);
    const __m256d px = _mm256_mul_pd(_mm256_mul_pd(half, _mm256_add_pd(x, one)), width);
    const __m256d py = _mm256_mul_pd(_mm256_mul_pd(half, _mm256_sub_pd(one, y)), height);
    __m256d valid =
        _mm256_and_pd(_mm256_and_pd(raster_finite4(px), raster_finite4(py)), raster_finite4(depth));
    if (perspective)
      valid = _mm256_andnot_pd(_mm256_cmp_pd(depth, _mm256_set1_pd(kRasterNearLimit), _CMP_LE_OQ),
                               valid);
    __m128i x_lo, x_hi, y_lo, y_hi;
    raster_centres4(px, project.width(), x_lo, x_hi);
    raster_centres4(py, project.height(), y_lo, y_hi);
    alignas(32) double xs[4], ys[4], zs[4];
    alignas(16) std::int32_t xl[4], xh[4], yl[4], yh[4];
    _mm256_store_pd(xs, px);
    _mm256_store_pd(ys, py);
    _mm256_store_pd(zs, depth);
    _mm_store_si128(reinterpret_cast<__m128i*>(xl), x_lo);
    _mm_store_si128(reinterpret_cast<__m128i*>(xh), x_hi);
    _mm_store_si128(reinterpret_cast<__m128i*>(yl), y_lo);
    _mm_store_si128(reinterpret_cast<__m128i*>(yh), y_hi);
    const int ok = _mm256_movemask_pd(valid);
    for (int l = 0; l < 4; ++l) {
      RasterCorner& c = corners[i + static_cast<std::size_t>(l)];
      c.x = xs[l];
      c.y = ys[l];
      c.z = zs[l];
      c.x_lo = static_cast<std::int16_t>(xl[l]);
      c.x_hi = static_cast<std::int16_t>(xh[l]);
      c.y_lo = static_cast<std::int16_t>(yl[l]);
      c.y_hi = static_cast<std::int16_t>(yh[l]);
      c.valid = (ok >> l) & 1;
    }
  }
  return i;
}

void draw_band_avx2(const RasterBand& band) {
  raster_band::draw_band<Avx2Rows>(band);
}

}  // namespace fabrica::detail
