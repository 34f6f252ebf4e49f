// Private to fabrica::lines: one row of the per-vertex gradient operator,
// ∇f_i = Σ_k coeff[k] f[column[k]] over k in [offset[i], offset[i+1])
// (precompute.hpp). Float coefficients, double accumulation, in row order:
// every caller (GradientOperator::apply, the sparse illumination fields)
// gets the same bits for the same row. Where the CPU has AVX2 the three
// components are accumulated in one 256-bit vector (the same products and
// sums per component, in the same order: the same bits).
#pragma once

#include <algorithm>
#include <cstddef>

#include "fabrica/core/types.hpp"
#include "fabrica/lines/precompute.hpp"
#include "simd_avx2.hpp"

namespace fabrica::detail {

// Entries [k, e) of a row, one component at a time.
inline Vec3 gradient_row_tail(const GradientOperator& g, std::size_t k, std::size_t e,
                              const double* f, double x, double y, double z) {
  const std::int32_t* col = g.column.data();
  const float* c = g.coeff.data();
  for (; k < e; ++k) {
    const double v = f[static_cast<std::size_t>(col[k])];
    x += c[3 * k] * v;
    y += c[3 * k + 1] * v;
    z += c[3 * k + 2] * v;
  }
  return Vec3(x, y, z);
}

#if defined(FABRICA_LINES_AVX2)
/// Rows i and i + 1 at once (out[0], out[1]): each row's products and sums
/// in its own order, as gradient_row_avx2, but the two accumulation chains
/// interleaved so their addition latencies overlap.
[[gnu::target("avx2")]] inline void gradient_rows2_avx2(const GradientOperator& g, std::size_t i,
                                                        const double* f, Vec3* out) {
  const std::int32_t* col = g.column.data();
  const float* c = g.coeff.data();
  const std::size_t last = g.coeff.size() / 3 - 1;  // see gradient_row_avx2
  std::size_t ka = static_cast<std::size_t>(g.offset[i]);
  std::size_t kb = static_cast<std::size_t>(g.offset[i + 1]);
  const std::size_t ea = kb, eb = static_cast<std::size_t>(g.offset[i + 2]);
  const std::size_t ea4 = std::min(ea, last), eb4 = std::min(eb, last);
  __m256d acc_a = _mm256_setzero_pd(), acc_b = _mm256_setzero_pd();
  const std::size_t both = std::min(ea4 - std::min(ka, ea4), eb4 - std::min(kb, eb4));
  for (std::size_t n = 0; n < both; ++n, ++ka, ++kb) {
    const __m256d va = _mm256_broadcast_sd(f + col[ka]);
    const __m256d vb = _mm256_broadcast_sd(f + col[kb]);
    acc_a = _mm256_add_pd(acc_a, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * ka)), va));
    acc_b = _mm256_add_pd(acc_b, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * kb)), vb));
  }
  for (; ka < ea4; ++ka)
    acc_a = _mm256_add_pd(acc_a, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * ka)),
                                               _mm256_broadcast_sd(f + col[ka])));
  for (; kb < eb4; ++kb)
    acc_b = _mm256_add_pd(acc_b, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * kb)),
                                               _mm256_broadcast_sd(f + col[kb])));
  alignas(32) double ra[4], rb[4];
  _mm256_store_pd(ra, acc_a);
  _mm256_store_pd(rb, acc_b);
  out[0] = gradient_row_tail(g, ka, ea, f, ra[0], ra[1], ra[2]);
  out[1] = gradient_row_tail(g, kb, eb, f, rb[0], rb[1], rb[2]);
}

[[gnu::target("avx2")]] inline Vec3 gradient_row_avx2(const GradientOperator& g, std::size_t i,
                                                      const double* f) {
  const std::int32_t* col = g.column.data();
  const float* c = g.coeff.data();
  std::size_t k = static_cast<std::size_t>(g.offset[i]);
  const std::size_t e = static_cast<std::size_t>(g.offset[i + 1]);
  // Four floats are read per entry (its x, y, z and the next entry's x,
  // whose product lands in the unused lane): not for the array's last entry.
  const std::size_t e4 = std::min(e, g.coeff.size() / 3 - 1);
  __m256d acc = _mm256_setzero_pd();
  for (; k < e4; ++k) {
    const __m256d v = _mm256_broadcast_sd(f + col[k]);
    acc = _mm256_add_pd(acc, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * k)), v));
  }
  alignas(32) double r[4];
  _mm256_store_pd(r, acc);
  return gradient_row_tail(g, k, e, f, r[0], r[1], r[2]);
}
#endif

inline Vec3 gradient_row(const GradientOperator& g, std::size_t i, const double* f) {
#if defined(FABRICA_LINES_AVX2)
  if (cpu_has_avx2()) return gradient_row_avx2(g, i, f);
#endif
  return gradient_row_tail(g, static_cast<std::size_t>(g.offset[i]),
                           static_cast<std::size_t>(g.offset[i + 1]), f, 0.0, 0.0, 0.0);
}

}  // namespace fabrica::detail
