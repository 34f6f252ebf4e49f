// The per-face curvature fits (curvature_fit_kernel.hpp) with an AVX2 lane
// type (inputs loaded row by row and transposed, not gathered: Zen's
// gathers cost more than the loads and shuffles): this file alone is
// compiled with -mavx2 (and -ffp-contract=off, no FMA), and curvature.cpp
// calls it only when the CPU has AVX2. Each lane operation is the IEEE
// single-precision operation the portable loop does, so both give the same
// bits.
#include <immintrin.h>

#include "curvature_fit_kernel.hpp"

namespace fabrica::detail {

namespace {

// Three doubles at p as (p[0], p[1], p[2], 0): two loads, nothing read
// past p[2] (the last vertex of an array is safe).
inline __m256d load_row3(const double* p) {
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_load_sd(p + 2), 1);
}

// Lane l's three doubles at base + i[l] for four lanes, transposed into
// x, y, z.
inline void load3x4(const double* base, const std::int32_t* i, __m256d (&xyz)[3]) {
  const __m256d r0 = load_row3(base + i[0]);
  const __m256d r1 = load_row3(base + i[1]);
  const __m256d r2 = load_row3(base + i[2]);
  const __m256d r3 = load_row3(base + i[3]);
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1);  // x0 x1 z0 z1
  const __m256d t1 = _mm256_unpackhi_pd(r0, r1);  // y0 y1 .. ..
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3);  // x2 x3 z2 z3
  const __m256d t3 = _mm256_unpackhi_pd(r2, r3);  // y2 y3 .. ..
  xyz[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  xyz[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  xyz[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
}

struct Avx2Lanes {
  __m256 v;

  struct Mask {
    __m256 m;
    friend Mask operator&(const Mask& p, const Mask& q) { return {_mm256_and_ps(p.m, q.m)}; }
  };

  static Avx2Lanes splat(float x) { return {_mm256_set1_ps(x)}; }
  static Avx2Lanes load(const float* p) { return {_mm256_loadu_ps(p)}; }
  /// Three consecutive doubles per lane, in double: c[k][h] holds lanes
  /// 4h..4h+3 of component k.
  struct Double3 {
    __m256d c[3][2];
  };
  static void load3(const double* base, const std::int32_t* i, Double3& out) {
    for (int h = 0; h < 2; ++h) {
      __m256d xyz[3];
      load3x4(base, i + 4 * h, xyz);
      for (int k = 0; k < 3; ++k) out.c[k][h] = xyz[k];
    }
  }
  static Avx2Lanes to_float(const Double3& a, int k) {
    return {_mm256_set_m128(_mm256_cvtpd_ps(a.c[k][1]), _mm256_cvtpd_ps(a.c[k][0]))};
  }
  static Avx2Lanes diff(const Double3& a, const Double3& b, int k) {
    return {_mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(a.c[k][1], b.c[k][1])),
                            _mm256_cvtpd_ps(_mm256_sub_pd(a.c[k][0], b.c[k][0])))};
  }
  /// Floats 0-7 at base + i[l] of the eight lanes, transposed: out[f] =
  /// field f of the eight lanes (eight row loads).
  static void load_rows8(const float* base, const std::int32_t* i, Avx2Lanes (&out)[8]) {
    __m256 r[8];
    for (int l = 0; l < 8; ++l) r[l] = _mm256_loadu_ps(base + i[l]);
    __m256 t[8];
    for (int q = 0; q < 2; ++q) {
      t[4 * q + 0] = _mm256_unpacklo_ps(r[4 * q + 0], r[4 * q + 1]);
      t[4 * q + 1] = _mm256_unpackhi_ps(r[4 * q + 0], r[4 * q + 1]);
      t[4 * q + 2] = _mm256_unpacklo_ps(r[4 * q + 2], r[4 * q + 3]);
      t[4 * q + 3] = _mm256_unpackhi_ps(r[4 * q + 2], r[4 * q + 3]);
    }
    __m256 u[8];
    for (int q = 0; q < 2; ++q) {
      u[4 * q + 0] = _mm256_shuffle_ps(t[4 * q + 0], t[4 * q + 2], 0x44);
      u[4 * q + 1] = _mm256_shuffle_ps(t[4 * q + 0], t[4 * q + 2], 0xEE);
      u[4 * q + 2] = _mm256_shuffle_ps(t[4 * q + 1], t[4 * q + 3], 0x44);
      u[4 * q + 3] = _mm256_shuffle_ps(t[4 * q + 1], t[4 * q + 3], 0xEE);
    }
    for (int f = 0; f < 4; ++f) {
      out[f].v = _mm256_permute2f128_ps(u[f], u[f + 4], 0x20);
      out[f + 4].v = _mm256_permute2f128_ps(u[f], u[f + 4], 0x31);
    }
  }
  /// The first six floats at base + i[l] per lane (a face record; two more
  /// floats are read and dropped).
  static void load_six(const float* base, const std::int32_t* i, Avx2Lanes (&out)[6]) {
    Avx2Lanes all[8];
    load_rows8(base, i, all);
    for (int f = 0; f < 6; ++f) out[f] = all[f];
  }
  /// The twelve floats of each lane's record (out[f] = field f of the eight
  /// lanes): eight row loads of floats 0-7 and eight of floats 8-11,
  /// transposed (cheaper than twelve gathers).
  static void load_records(const float* base, const std::int32_t* rec, Avx2Lanes (&out)[12]) {
    Avx2Lanes first[8];
    load_rows8(base, rec, first);
    for (int f = 0; f < 8; ++f) out[f] = first[f];
    // Floats 8-11: lanes j and j + 4 share a register, then a 4x4
    // transpose inside each half.
    __m256 h[4];
    for (int j = 0; j < 4; ++j)
      h[j] = _mm256_set_m128(_mm_loadu_ps(base + rec[j + 4] + 8), _mm_loadu_ps(base + rec[j] + 8));
    const __m256 a0 = _mm256_unpacklo_ps(h[0], h[1]), a1 = _mm256_unpackhi_ps(h[0], h[1]);
    const __m256 a2 = _mm256_unpacklo_ps(h[2], h[3]), a3 = _mm256_unpackhi_ps(h[2], h[3]);
    out[8].v = _mm256_shuffle_ps(a0, a2, 0x44);
    out[9].v = _mm256_shuffle_ps(a0, a2, 0xEE);
    out[10].v = _mm256_shuffle_ps(a1, a3, 0x44);
    out[11].v = _mm256_shuffle_ps(a1, a3, 0xEE);
  }
  /// Each real lane's corner result into its slot: the four values
  /// transposed into one 16-byte store per lane, then the weight.
  static void store_slots(FitSlot* slots, const std::int32_t* slot, int count,
                          const Avx2Lanes (&v)[4], const Avx2Lanes& w) {
    const __m256 t0 = _mm256_unpacklo_ps(v[0].v, v[1].v), t1 = _mm256_unpackhi_ps(v[0].v, v[1].v);
    const __m256 t2 = _mm256_unpacklo_ps(v[2].v, v[3].v), t3 = _mm256_unpackhi_ps(v[2].v, v[3].v);
    const __m256 r[4] = {_mm256_shuffle_ps(t0, t2, 0x44), _mm256_shuffle_ps(t0, t2, 0xEE),
                         _mm256_shuffle_ps(t1, t3, 0x44), _mm256_shuffle_ps(t1, t3, 0xEE)};
    alignas(32) float wl[8];
    _mm256_store_ps(wl, w.v);
    for (int l = 0; l < count; ++l) {
      // Lane l of the four values: half l / 4 of r[l % 4].
      const __m128 q =
          l < 4 ? _mm256_castps256_ps128(r[l & 3]) : _mm256_extractf128_ps(r[l & 3], 1);
      float* s = slots[slot[l]].data();
      _mm_storeu_ps(s, q);
      s[4] = wl[l];
    }
  }
  friend Avx2Lanes operator+(const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_add_ps(a.v, b.v)};
  }
  friend Avx2Lanes operator-(const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_sub_ps(a.v, b.v)};
  }
  friend Avx2Lanes operator*(const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_mul_ps(a.v, b.v)};
  }
  friend Avx2Lanes operator/(const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_div_ps(a.v, b.v)};
  }
  friend Avx2Lanes sqrt(const Avx2Lanes& a) { return {_mm256_sqrt_ps(a.v)}; }
  /// a > b ? a : b, b where either is NaN (as the portable loop).
  friend Avx2Lanes max(const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_blendv_ps(b.v, a.v, _mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ))};
  }
  friend Mask greater(const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ)};
  }
  friend Avx2Lanes select(const Mask& m, const Avx2Lanes& a, const Avx2Lanes& b) {
    return {_mm256_blendv_ps(b.v, a.v, m.m)};
  }
};

}  // namespace

void fit_second_fundamental_forms_avx2(const FitArrays& a, std::size_t begin, std::size_t end) {
  fitk::fit_second_fundamental_forms<Avx2Lanes>(a, begin, end);
}

void fit_curvature_derivatives_avx2(const FitArrays& a, std::size_t begin, std::size_t end) {
  fitk::fit_curvature_derivatives<Avx2Lanes>(a, begin, end);
}

}  // namespace fabrica::detail
