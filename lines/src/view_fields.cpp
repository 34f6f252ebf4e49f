#include "fabrica/lines/view_fields.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/precompute.hpp"
#include "parallel.hpp"
#include "simd_avx2.hpp"
#include "view_fields_light.hpp"

namespace fabrica {

namespace {

// QᵀQ for Q = S P⁻¹ in principal coordinates (Judd et al. 2007;
// docs/algorithms.md §6.1) and its largest eigenvalue q1. u2, uv, w2 are the
// components of ŵ (the unit projected view direction) squared/multiplied.
struct ViewCurvature {
  double m11, m12, m22, q1;
};
inline ViewCurvature view_dependent_curvature(double k1, double k2, double ndotv, double u2,
                                              double uv, double w2) {
  const double an = std::abs(ndotv);
  const double sec_minus_1 = an > 0.0 ? 1.0 / an - 1.0 : 0.0;
  const double Q11 = k1 * (1.0 + sec_minus_1 * u2);
  const double Q12 = k1 * (sec_minus_1 * uv);
  const double Q21 = k2 * (sec_minus_1 * uv);
  const double Q22 = k2 * (1.0 + sec_minus_1 * w2);
  const double m11 = Q11 * Q11 + Q21 * Q21;
  const double m12 = Q11 * Q12 + Q21 * Q22;
  const double m22 = Q12 * Q12 + Q22 * Q22;
  const double mean = 0.5 * (m11 + m22);
  const double lambda = mean + std::sqrt(m12 * m12 + 0.25 * (m22 - m11) * (m22 - m11));
  return {m11, m12, m22, lambda};
}

// The unit eigenvector t1 of q1: (m22 - λ, -m12) or equivalently
// (m12, λ - m11); the better conditioned one.
inline Vec2 view_dependent_direction(const ViewCurvature& m) {
  Vec2 a(m.m22 - m.q1, -m.m12), b(m.m12, m.q1 - m.m11);
  const Vec2& e = a.squaredNorm() >= b.squaredNorm() ? a : b;
  const double len = e.norm();
  return len > 0.0 ? Vec2(e / len) : Vec2(1.0, 0.0);
}

// view_dependent_curvature from u = v·e1, w = v·e2 (u2 = u², w2 = w²)
// and csc2 = 1/sin²θ (0 when sin θ = 0).
inline ViewCurvature view_curvature_at(double k1, double k2, double ndotv, double u, double w,
                                       double u2, double w2, double csc2) {
  double hu2 = 1.0, huv = 0.0, hw2 = 0.0;
  if (csc2 > 0.0) {
    hu2 = u2 * csc2;
    huv = u * w * csc2;
    hw2 = w2 * csc2;
  }
  return view_dependent_curvature(k1, k2, ndotv, hu2, huv, hw2);
}

#if defined(FABRICA_LINES_AVX2)
// The vertex pass four vertices at a time with 256-bit vectors, from
// LinePrecompute::vertex_blocks(): the same IEEE operations in the same
// order as `vertex` and view_dependent_direction below (Eigen's Vec3 dot is
// (x x' + y y') + z z'; no fused multiply-adds), so the same bits. Compiled
// for AVX2 and called only when the CPU has it (vertex_pass_has_avx2).
struct VertexPassArgs {
  std::size_t nv;
  detail::ViewVector4 view;
  bool want_sc = false, want_app = false, cull = false, sc_bits = false;
  double cull_t = 0.0, sc_shift = 0.0;
  double min_ndotv = -std::numeric_limits<double>::infinity();  ///< kQ1Above needs !(n·v < it)
  double *ndotv = nullptr, *kr = nullptr, *sc_num = nullptr, *q1 = nullptr;
  Vec2* t1 = nullptr;
  Vec3* t1_world = nullptr;
  std::uint8_t* signs = nullptr;
};

// Blocks [b0, b1) whose four vertices all have valid curvature; the others
// go to `other(b)`.
// blocks[b - first] and valid[b - first] hold block b.
template <class Other>
[[gnu::target("avx2")]] void vertex_pass_avx2(const LinePrecompute::VertexBlock* blocks,
                                              const std::uint8_t* valid, std::size_t first,
                                              std::size_t b0, std::size_t b1,
                                              const VertexPassArgs& A, Other&& other) {
  blocks -= first;  // (first <= b0: the pointer is only used for b >= b0)
  valid -= first;
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d neg0 = _mm256_set1_pd(-0.0), three = _mm256_set1_pd(3.0);
  const __m256i lane_bits = _mm256_set_epi64x(8, 4, 2, 1);
  for (std::size_t b = b0; b < b1; ++b) {
    // The blocks are read once per view: fetched ahead without temporal
    // locality (on Zen, not kept in L2 nor evicted into L3), so 19 MB of
    // them do not push the fields and mesh arrays that the next passes
    // read out of the L3. Eight blocks (32 vertices, 4.6 KB) ahead: four
    // left the pass waiting (igea at 1T, min of 60: 1.23-1.35 → 1.11-1.21
    // ms; two: 1.34-1.49 ms).
    constexpr std::size_t kAhead = 8;
    if (b + kAhead < b1) {
      const char* ahead = reinterpret_cast<const char*>(blocks + b + kAhead);
      for (std::size_t l = 0; l < sizeof(LinePrecompute::VertexBlock); l += 64)
        _mm_prefetch(ahead + l, _MM_HINT_NTA);
    }
    if ((valid[b] & 0xF) != 0xF || 4 * b + 4 > A.nv) {
      other(b);
      continue;
    }
    const LinePrecompute::VertexBlock& k = blocks[b];
    const std::size_t i = 4 * b;
#define FABRICA_LD(x) _mm256_load_pd(x)
#define FABRICA_PICK(mask, x, y) detail::pick4((mask), (x), (y))
#define FABRICA_DOT(ax, ay, az, bx, by, bz) detail::dot4(ax, ay, az, bx, by, bz)
    __m256d vx, vy, vz;
    A.view(FABRICA_LD(k.p[0]), FABRICA_LD(k.p[1]), FABRICA_LD(k.p[2]), vx, vy, vz);
    const __m256d ndotv =
        FABRICA_DOT(vx, vy, vz, FABRICA_LD(k.n[0]), FABRICA_LD(k.n[1]), FABRICA_LD(k.n[2]));
    const __m256d u =
        FABRICA_DOT(vx, vy, vz, FABRICA_LD(k.e1[0]), FABRICA_LD(k.e1[1]), FABRICA_LD(k.e1[2]));
    const __m256d w =
        FABRICA_DOT(vx, vy, vz, FABRICA_LD(k.e2[0]), FABRICA_LD(k.e2[1]), FABRICA_LD(k.e2[2]));
    const __m256d k1 = FABRICA_LD(k.k1), k2 = FABRICA_LD(k.k2);
    const __m256d u2 = _mm256_mul_pd(u, u), w2 = _mm256_mul_pd(w, w);
    const __m256d kr = _mm256_add_pd(_mm256_mul_pd(k1, u2), _mm256_mul_pd(k2, w2));
    const __m256d sin2 = _mm256_add_pd(u2, w2);
    const __m256d csc2 = FABRICA_PICK(_mm256_cmp_pd(sin2, _mm256_set1_pd(1e-300), _CMP_GT_OQ),
                                      _mm256_div_pd(one, sin2), zero);
    const __m256d csc_pos = _mm256_cmp_pd(csc2, zero, _CMP_GT_OQ);
    _mm256_storeu_pd(A.ndotv + i, ndotv);
    _mm256_storeu_pd(A.kr + i, kr);
    __m256i scbits = _mm256_setzero_si256();
    if (A.want_sc) {
      const __m256d a = FABRICA_LD(k.a), bb = FABRICA_LD(k.b), c = FABRICA_LD(k.c),
                    d = FABRICA_LD(k.d);
      __m256d num = _mm256_add_pd(
          _mm256_mul_pd(
              u2, _mm256_add_pd(_mm256_mul_pd(u, a), _mm256_mul_pd(_mm256_mul_pd(three, w), bb))),
          _mm256_mul_pd(
              w2, _mm256_add_pd(_mm256_mul_pd(_mm256_mul_pd(three, u), c), _mm256_mul_pd(w, d))));
      num = _mm256_mul_pd(num, csc2);
      const __m256d tr =
          _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(_mm256_sub_pd(k2, k1), u), w), csc2);
      num = _mm256_sub_pd(
          num, _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(2.0), ndotv), tr), tr));
      const __m256i dbits = _mm256_set1_epi64x((valid[b] >> 4) & 0xF);
      const __m256d dvalid =
          _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(dbits, lane_bits), lane_bits));
      const __m256d sc = FABRICA_PICK(_mm256_and_pd(dvalid, csc_pos), num, zero);
      _mm256_storeu_pd(A.sc_num + i, sc);
      if (A.sc_bits) {
        // suggestive_test_bits, four lanes.
        const __m256d n = _mm256_sub_pd(sc, _mm256_mul_pd(_mm256_set1_pd(A.sc_shift), ndotv));
        scbits = _mm256_or_si256(
            detail::mask_bits4(_mm256_and_pd(_mm256_cmp_pd(n, zero, _CMP_LE_OQ),
                                             _mm256_cmp_pd(ndotv, zero, _CMP_GE_OQ)),
                               kScOffFront),
            detail::mask_bits4(_mm256_and_pd(_mm256_cmp_pd(n, zero, _CMP_GE_OQ),
                                             _mm256_cmp_pd(ndotv, zero, _CMP_LE_OQ)),
                               kScOffBack));
      }
    }
    // The sign byte of each lane: the compare masks ANDed with their bits.
    __m256i sbits = _mm256_or_si256(
        _mm256_or_si256(detail::mask_bits4(_mm256_cmp_pd(ndotv, zero, _CMP_GT_OQ), kNdotvPositive),
                        detail::mask_bits4(_mm256_cmp_pd(ndotv, zero, _CMP_LT_OQ), kNdotvNegative)),
        _mm256_or_si256(
            detail::mask_bits4(_mm256_cmp_pd(ndotv, zero, _CMP_NLE_UQ), kNdotvNotBack),
            _mm256_or_si256(detail::mask_bits4(_mm256_cmp_pd(kr, zero, _CMP_GT_OQ), kKrPositive),
                            detail::mask_bits4(_mm256_cmp_pd(kr, zero, _CMP_LT_OQ), kKrNegative))));
    sbits = _mm256_or_si256(sbits, scbits);
    if (A.want_app) {
      const __m256d an = _mm256_andnot_pd(neg0, ndotv);
      const __m256d sec = FABRICA_PICK(_mm256_cmp_pd(an, zero, _CMP_GT_OQ),
                                       _mm256_sub_pd(_mm256_div_pd(one, an), one), zero);
      const __m256d hu2 = FABRICA_PICK(csc_pos, _mm256_mul_pd(u2, csc2), one);
      const __m256d huv = FABRICA_PICK(csc_pos, _mm256_mul_pd(_mm256_mul_pd(u, w), csc2), zero);
      const __m256d hw2 = FABRICA_PICK(csc_pos, _mm256_mul_pd(w2, csc2), zero);
      const __m256d Q11 = _mm256_mul_pd(k1, _mm256_add_pd(one, _mm256_mul_pd(sec, hu2)));
      const __m256d Q12 = _mm256_mul_pd(k1, _mm256_mul_pd(sec, huv));
      const __m256d Q21 = _mm256_mul_pd(k2, _mm256_mul_pd(sec, huv));
      const __m256d Q22 = _mm256_mul_pd(k2, _mm256_add_pd(one, _mm256_mul_pd(sec, hw2)));
      const __m256d m11 = _mm256_add_pd(_mm256_mul_pd(Q11, Q11), _mm256_mul_pd(Q21, Q21));
      const __m256d m12 = _mm256_add_pd(_mm256_mul_pd(Q11, Q12), _mm256_mul_pd(Q21, Q22));
      const __m256d m22 = _mm256_add_pd(_mm256_mul_pd(Q12, Q12), _mm256_mul_pd(Q22, Q22));
      const __m256d mean = _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(m11, m22));
      const __m256d dm = _mm256_sub_pd(m22, m11);
      const __m256d q1 =
          _mm256_add_pd(mean, _mm256_sqrt_pd(_mm256_add_pd(
                                  _mm256_mul_pd(m12, m12),
                                  _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(0.25), dm), dm))));
      _mm256_storeu_pd(A.q1 + i, q1);
      if (A.cull)
        sbits = _mm256_or_si256(
            sbits,
            detail::mask_bits4(
                _mm256_and_pd(_mm256_cmp_pd(q1, _mm256_set1_pd(A.cull_t), _CMP_NLE_UQ),
                              _mm256_cmp_pd(ndotv, _mm256_set1_pd(A.min_ndotv), _CMP_NLT_UQ)),
                kQ1Above));
      // t1: view_dependent_direction.
      const __m256d a0 = _mm256_sub_pd(m22, q1), a1 = _mm256_xor_pd(m12, neg0);
      const __m256d c0 = m12, c1 = _mm256_sub_pd(q1, m11);
      const __m256d sa = _mm256_add_pd(_mm256_mul_pd(a0, a0), _mm256_mul_pd(a1, a1));
      const __m256d sb = _mm256_add_pd(_mm256_mul_pd(c0, c0), _mm256_mul_pd(c1, c1));
      const __m256d use_a = _mm256_cmp_pd(sa, sb, _CMP_GE_OQ);
      const __m256d f0 = FABRICA_PICK(use_a, a0, c0), f1 = FABRICA_PICK(use_a, a1, c1);
      const __m256d len =
          _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(f0, f0), _mm256_mul_pd(f1, f1)));
      const __m256d ok = _mm256_cmp_pd(len, zero, _CMP_GT_OQ);
      const __m256d t0 = FABRICA_PICK(ok, _mm256_div_pd(f0, len), one);
      const __m256d t1 = FABRICA_PICK(ok, _mm256_div_pd(f1, len), zero);
      const __m256d lo = _mm256_unpacklo_pd(t0, t1), hi = _mm256_unpackhi_pd(t0, t1);
      double* t1p = A.t1[i].data();
      _mm256_storeu_pd(t1p, _mm256_permute2f128_pd(lo, hi, 0x20));
      _mm256_storeu_pd(t1p + 4, _mm256_permute2f128_pd(lo, hi, 0x31));
      // t1_world = t1[0] e1 + t1[1] e2.
      __m256d wc[3];
      for (int c = 0; c < 3; ++c)
        wc[c] = _mm256_add_pd(_mm256_mul_pd(t0, FABRICA_LD(k.e1[c])),
                              _mm256_mul_pd(t1, FABRICA_LD(k.e2[c])));
      // (x, y, z) x 4 lanes -> x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3.
      const __m256d xy = _mm256_unpacklo_pd(wc[0], wc[1]);      // x0 y0 | x2 y2
      const __m256d zx = _mm256_shuffle_pd(wc[2], wc[0], 0xA);  // z0 x1 | z2 x3
      const __m256d yz = _mm256_shuffle_pd(wc[1], wc[2], 0xF);  // y1 z1 | y3 z3
      double* wp = A.t1_world[i].data();
      _mm256_storeu_pd(wp, _mm256_permute2f128_pd(xy, zx, 0x20));
      _mm256_storeu_pd(wp + 4, _mm256_permute2f128_pd(yz, xy, 0x30));
      _mm256_storeu_pd(wp + 8, _mm256_permute2f128_pd(zx, yz, 0x31));
    }
#undef FABRICA_LD
#undef FABRICA_PICK
#undef FABRICA_DOT
    // The low byte of each 64-bit lane, as four consecutive bytes.
    const __m256i packed = _mm256_shuffle_epi8(
        sbits, _mm256_setr_epi8(0, 8, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 8,
                                -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1));
    const std::uint32_t four = static_cast<std::uint32_t>(_mm256_extract_epi16(packed, 0)) |
                               static_cast<std::uint32_t>(_mm256_extract_epi16(packed, 8)) << 16;
    std::memcpy(A.signs + i, &four, 4);
  }
}
#endif

}  // namespace

void update_view_fields(ViewFields& fields, const Surface& surface, const Camera& camera,
                        const ViewFieldsRequest& request, const LinePrecompute* precompute) {
  detail::update_view_fields(fields, surface, camera, request, precompute, false);
}

void detail::update_view_fields(ViewFields& fields, const Surface& surface, const Camera& camera,
                                const ViewFieldsRequest& request, const LinePrecompute* precompute,
                                bool defer_dt1q1, bool same_surface, bool stream_vertex_blocks) {
  validate_camera(camera);
  if (request.apparent_min_ndotv && std::isnan(*request.apparent_min_ndotv))
    throw InputError("apparent ridges: min_ndotv must be a number (got NaN)");
  const std::size_t nv = surface.vertex_count();
  fields.camera = camera;
  const bool radial = request.radial || request.sc_test || request.apparent;
  detail::resize_or_clear(fields.ndotv, radial || request.light || request.pel, nv);
  detail::resize_or_clear(fields.kr, radial, nv);
  detail::resize_or_clear(fields.sc_num, request.sc_test, nv);
  detail::resize_or_clear(fields.q1, request.apparent, nv);
  detail::resize_or_clear(fields.t1, request.apparent, nv);
  detail::resize_or_clear(fields.t1_world, request.apparent, nv);
  detail::resize_or_clear(fields.dt1q1, request.apparent, nv);
  // Sized before: for this surface when same_surface, so the positions
  // written then are current. Written right after sizing, so a failure
  // later in this call cannot leave a sized array without them.
  const bool positioned = same_surface && fields.apparent_vertex.size() == nv;
  detail::resize_or_clear(fields.apparent_vertex, request.apparent, nv);
  if (request.apparent && same_surface && !positioned) {
    const auto& p = surface.positions();
    detail::parallel_range(nv, [&](std::size_t i) { fields.apparent_vertex[i].position = p[i]; });
  }
  detail::resize_or_clear(fields.signs, radial, nv);
  fields.apparent_cull_threshold =
      request.apparent ? request.apparent_cull_threshold : std::optional<double>{};
  fields.apparent_min_ndotv =
      fields.apparent_cull_threshold ? request.apparent_min_ndotv : std::optional<double>{};
  fields.suggestive_test_shift =
      request.sc_test ? request.suggestive_test_shift : std::optional<double>{};

  const auto& pos = surface.positions();
  const auto& normals = surface.vertex_normals();
  if (radial) {
    const auto& curv = surface.curvature();
    const auto& dcurv = surface.curvature_derivatives();
    const bool want_sc = request.sc_test;
    const bool want_app = request.apparent;
    const bool cull = want_app && request.apparent_cull_threshold.has_value();
    const double cull_t = cull ? *request.apparent_cull_threshold : 0.0;
    const double min_ndotv =
        fields.apparent_min_ndotv.value_or(-std::numeric_limits<double>::infinity());
    // kQ1Above of a vertex with n·v `ndotv` and q1 `q1`.
    auto q1_above = [&](double q1, double ndotv) {
      return unsigned(cull && !(q1 <= cull_t) && !(ndotv < min_ndotv)) * kQ1Above;
    };
    const bool sc_bits = want_sc && request.suggestive_test_shift.has_value();
    const double sc_shift = sc_bits ? *request.suggestive_test_shift : 0.0;
    // kScOffFront / kScOffBack of vertex i from its stored sc_num and n·v
    // (N as the suggestive-contour kernel's ShiftedNum computes it).
    auto sc_test_bits = [&](std::size_t i, double ndotv) -> unsigned {
      if (!sc_bits) return 0;
      const double n = fields.sc_num[i] - sc_shift * ndotv;
      return unsigned(n <= 0.0 && ndotv >= 0.0) * kScOffFront |
             unsigned(n >= 0.0 && ndotv <= 0.0) * kScOffBack;
    };
    // Pass 1: n·v, K_r, the suggestive-contour numerator, q1 and the sign
    // bits per vertex. Returns whether m (for t1) was filled.
    auto vertex = [&](std::size_t i, ViewCurvature& m) -> bool {
      const Vec3 v = camera.view_vector(pos[i]);
      const double ndotv = v.dot(normals[i]);
      fields.ndotv[i] = ndotv;
      const unsigned nbits = unsigned(ndotv > 0.0) * kNdotvPositive |
                             unsigned(ndotv < 0.0) * kNdotvNegative |
                             unsigned(!(ndotv <= 0.0)) * kNdotvNotBack;
      if (!curv.valid[i]) {
        fields.kr[i] = 0.0;
        if (want_sc) fields.sc_num[i] = 0.0;
        if (want_app) {
          fields.q1[i] = 0.0;
          fields.t1[i] = Vec2(1.0, 0.0);
          fields.t1_world[i] = Vec3::Zero();
        }
        fields.signs[i] =
            static_cast<std::uint8_t>(nbits | q1_above(0.0, ndotv) | sc_test_bits(i, ndotv));
        return false;
      }
      const double k1 = curv.k1[i], k2 = curv.k2[i];
      const double u = v.dot(curv.e1[i]), w = v.dot(curv.e2[i]);
      const double u2 = u * u, w2 = w * w;
      fields.kr[i] = k1 * u2 + k2 * w2;
      const double sin2 = u2 + w2;
      const double csc2 = sin2 > 1e-300 ? 1.0 / sin2 : 0.0;
      if (want_sc) {
        if (dcurv.valid[i] && csc2 > 0.0) {
          double num = u2 * (u * dcurv.a[i] + 3.0 * w * dcurv.b[i]) +
                       w2 * (3.0 * u * dcurv.c[i] + w * dcurv.d[i]);
          num *= csc2;
          const double tr = (k2 - k1) * u * w * csc2;
          num -= 2.0 * ndotv * tr * tr;
          fields.sc_num[i] = num;
        } else {
          fields.sc_num[i] = 0.0;
        }
      }
      unsigned bits = nbits | unsigned(fields.kr[i] > 0.0) * kKrPositive |
                      unsigned(fields.kr[i] < 0.0) * kKrNegative | sc_test_bits(i, ndotv);
      if (!want_app) {
        fields.signs[i] = static_cast<std::uint8_t>(bits);
        return false;
      }
      m = view_curvature_at(k1, k2, ndotv, u, w, u2, w2, csc2);
      fields.q1[i] = m.q1;
      bits |= q1_above(m.q1, ndotv);
      fields.signs[i] = static_cast<std::uint8_t>(bits);
      return true;
    };
    // `vertex` and, where it filled m, t1 and t1_world.
    auto vertex_and_direction = [&](std::size_t i) {
      ViewCurvature m{0.0, 0.0, 0.0, 0.0};
      if (!vertex(i, m)) return;
      const Vec2 t = view_dependent_direction(m);
      fields.t1[i] = t;
      fields.t1_world[i] = t[0] * curv.e1[i] + t[1] * curv.e2[i];
    };
#if defined(FABRICA_LINES_AVX2)
    if (precompute && detail::cpu_has_avx2()) {
      // In one-shot mode the blocks are packed 64 at a time (18 KB, in the
      // cache) just before the pass reads them, instead of all of them
      // (144 bytes per vertex) being built first and kept.
      const LinePrecompute::VertexBlocks* vb =
          stream_vertex_blocks ? nullptr : &precompute->vertex_blocks();
      if (stream_vertex_blocks) (void)surface.curvature_derivatives();
      VertexPassArgs args{nv, detail::ViewVector4(camera)};
      args.want_sc = want_sc;
      args.want_app = want_app;
      args.cull = cull;
      args.cull_t = cull_t;
      args.min_ndotv = min_ndotv;
      args.sc_bits = sc_bits;
      args.sc_shift = sc_shift;
      args.ndotv = fields.ndotv.data();
      args.kr = fields.kr.data();
      args.sc_num = want_sc ? fields.sc_num.data() : nullptr;
      args.q1 = want_app ? fields.q1.data() : nullptr;
      args.t1 = want_app ? fields.t1.data() : nullptr;
      args.t1_world = want_app ? fields.t1_world.data() : nullptr;
      args.signs = fields.signs.data();
      // Blocks with an invalid vertex (or the partial last one): per vertex.
      auto other = [&](std::size_t b) {
        for (std::size_t i = 4 * b; i < std::min(nv, 4 * b + 4); ++i) vertex_and_direction(i);
      };
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (nv + 3) / 4, 512),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          if (vb) {
                            vertex_pass_avx2(vb->block.data(), vb->valid.data(), 0, r.begin(),
                                             r.end(), args, other);
                            return;
                          }
                          constexpr std::size_t kPacked = 64;
                          LinePrecompute::VertexBlock packed[kPacked];
                          std::uint8_t packed_valid[kPacked];
                          for (std::size_t b = r.begin(); b < r.end(); b += kPacked) {
                            const std::size_t e = std::min(r.end(), b + kPacked);
                            precompute->pack_vertex_blocks(b, e, packed, packed_valid);
                            vertex_pass_avx2(packed, packed_valid, b, b, e, args, other);
                          }
                        });
    } else
#endif
      // Portable: one vertex at a time (the reference the AVX2 pass matches).
      detail::parallel_range(nv, vertex_and_direction);
    if (want_app && !defer_dt1q1)
      detail::update_dt1q1(fields, surface, cull, precompute, !same_surface);
  }

  detail::update_light_fields(fields, surface, camera, request, precompute, radial);
}

ViewFields compute_view_fields(const Surface& surface, const Camera& camera,
                               const ViewFieldsRequest& request, const LinePrecompute* precompute) {
  ViewFields fields;
  update_view_fields(fields, surface, camera, request, precompute);
  return fields;
}

}  // namespace fabrica
