// The per-face curvature fits (curvature_fit_kernel.hpp) with an AVX2 lane
// type: this file alone is compiled with -mavx2 (and -ffp-contract=off, no
// FMA), and curvature.cpp calls it only when the CPU has AVX2. Each lane
// operation is the IEEE single-precision operation the portable loop does,
// so both give the same bits.
#include <immintrin.h>

#include "curvature_fit_kernel.hpp"

namespace fabrica::detail {

namespace {

// The masked gathers with a zero source and a full mask (the unmasked
// intrinsics leave their source undefined, which GCC 12 warns about).
inline __m256d gather4(const double* base, __m128i i) {
  return _mm256_mask_i32gather_pd(_mm256_setzero_pd(), base, i,
                                  _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), 8);
}
inline __m256 gather8(const float* base, __m256i i) {
  return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, i,
                                  _mm256_castsi256_ps(_mm256_set1_epi32(-1)), 4);
}

struct Avx2Lanes {
  __m256 v;

  struct Mask {
    __m256 m;
    friend Mask operator&(const Mask& p, const Mask& q) { return {_mm256_and_ps(p.m, q.m)}; }
  };

  static Avx2Lanes splat(float x) { return {_mm256_set1_ps(x)}; }
  static Avx2Lanes load(const float* p) { return {_mm256_loadu_ps(p)}; }
  static Avx2Lanes from_double(const double* base, const std::int32_t* i) {
    const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(i));
    const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(i + 4));
    const __m128 a = _mm256_cvtpd_ps(gather4(base, lo));
    const __m128 b = _mm256_cvtpd_ps(gather4(base, hi));
    return {_mm256_set_m128(b, a)};
  }
  static Avx2Lanes diff_double(const double* base, const std::int32_t* i, const std::int32_t* j) {
    const __m128i ilo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(i));
    const __m128i ihi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(i + 4));
    const __m128i jlo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(j));
    const __m128i jhi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(j + 4));
    const __m128 a = _mm256_cvtpd_ps(_mm256_sub_pd(gather4(base, ilo), gather4(base, jlo)));
    const __m128 b = _mm256_cvtpd_ps(_mm256_sub_pd(gather4(base, ihi), gather4(base, jhi)));
    return {_mm256_set_m128(b, a)};
  }
  static Avx2Lanes gather(const float* base, const std::int32_t* i) {
    return {gather8(base, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(i)))};
  }
  void store(float* out) const { _mm256_storeu_ps(out, v); }
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
