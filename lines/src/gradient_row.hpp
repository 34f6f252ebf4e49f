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
// Entries [k, e) added into acc (x, y, z in lanes 0-2): four floats are read
// per entry (its x, y, z and the next entry's x, whose product lands in the
// unused lane), so e must stay below the array's last entry (row_end4).
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d accumulate_avx2(
    const GradientOperator& g, std::size_t k, std::size_t e, const double* f, __m256d acc) {
  const std::int32_t* col = g.column.data();
  const float* c = g.coeff.data();
  for (; k < e; ++k)
    acc = _mm256_add_pd(acc, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * k)),
                                           _mm256_broadcast_sd(f + col[k])));
  return acc;
}

// The end of row i's entries that accumulate_avx2 may read (the rest, at
// most the array's last entry, goes to gradient_row_tail).
inline std::size_t row_end4(const GradientOperator& g, std::size_t i) {
  const std::size_t e = static_cast<std::size_t>(g.offset[i + 1]);
  return g.coeff.size() < 6 ? static_cast<std::size_t>(g.offset[i])
                            : std::min(e, g.coeff.size() / 3 - 1);
}

// The row from its accumulated head [offset[i], k) and the tail [k, end).
[[gnu::target("avx2"), gnu::always_inline]] inline Vec3 finish_row_avx2(
    const GradientOperator& g, std::size_t i, std::size_t k, const double* f, __m256d acc) {
  alignas(32) double r[4];
  _mm256_store_pd(r, acc);
  return gradient_row_tail(g, k, static_cast<std::size_t>(g.offset[i + 1]), f, r[0], r[1], r[2]);
}

/// Rows i and i + 1 at once (out[0], out[1]): each row's products and sums
/// in its own order, as gradient_row_avx2, but the two accumulation chains
/// interleaved so their addition latencies overlap.
[[gnu::target("avx2")]] inline void gradient_rows2_avx2(const GradientOperator& g, std::size_t i,
                                                        const double* f, Vec3* out) {
  const std::int32_t* col = g.column.data();
  const float* c = g.coeff.data();
  std::size_t ka = static_cast<std::size_t>(g.offset[i]);
  std::size_t kb = static_cast<std::size_t>(g.offset[i + 1]);
  const std::size_t ea4 = row_end4(g, i), eb4 = row_end4(g, i + 1);
  __m256d acc_a = _mm256_setzero_pd(), acc_b = _mm256_setzero_pd();
  const std::size_t both = std::min(ea4 - std::min(ka, ea4), eb4 - std::min(kb, eb4));
  for (std::size_t n = 0; n < both; ++n, ++ka, ++kb) {
    const __m256d va = _mm256_broadcast_sd(f + col[ka]);
    const __m256d vb = _mm256_broadcast_sd(f + col[kb]);
    acc_a = _mm256_add_pd(acc_a, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * ka)), va));
    acc_b = _mm256_add_pd(acc_b, _mm256_mul_pd(_mm256_cvtps_pd(_mm_loadu_ps(c + 3 * kb)), vb));
  }
  acc_a = accumulate_avx2(g, ka, std::max(ka, ea4), f, acc_a);
  acc_b = accumulate_avx2(g, kb, std::max(kb, eb4), f, acc_b);
  out[0] = finish_row_avx2(g, i, std::max(ka, ea4), f, acc_a);
  out[1] = finish_row_avx2(g, i + 1, std::max(kb, eb4), f, acc_b);
}

[[gnu::target("avx2")]] inline Vec3 gradient_row_avx2(const GradientOperator& g, std::size_t i,
                                                      const double* f) {
  const std::size_t k = static_cast<std::size_t>(g.offset[i]);
  const std::size_t e4 = std::max(k, row_end4(g, i));
  return finish_row_avx2(g, i, e4, f, accumulate_avx2(g, k, e4, f, _mm256_setzero_pd()));
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
