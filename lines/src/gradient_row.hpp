// Private to fabrica::lines: one row of the per-vertex gradient operator,
// ∇f_i = Σ_k coeff[k] f[column[k]] over k in [offset[i], offset[i+1])
// (precompute.hpp). Float coefficients, double accumulation, in row order:
// every caller (GradientOperator::apply, the sparse illumination fields)
// gets the same bits for the same row.
#pragma once

#include <cstddef>

#include "fabrica/core/types.hpp"
#include "fabrica/lines/precompute.hpp"

namespace fabrica::detail {

inline Vec3 gradient_row(const GradientOperator& g, std::size_t i, const double* f) {
  double x = 0.0, y = 0.0, z = 0.0;
  const std::int32_t* col = g.column.data();
  const float* c = g.coeff.data();
  for (auto k = static_cast<std::size_t>(g.offset[i]);
       k < static_cast<std::size_t>(g.offset[i + 1]); ++k) {
    const double v = f[static_cast<std::size_t>(col[k])];
    x += c[3 * k] * v;
    y += c[3 * k + 1] * v;
    z += c[3 * k + 2] * v;
  }
  return Vec3(x, y, z);
}

}  // namespace fabrica::detail
