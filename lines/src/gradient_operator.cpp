// GradientOperator::apply: the per-view sparse product ∇f = G f used by the
// illumination fields (PELs, Laplacian lines). Built in precompute.cpp.
#include "fabrica/lines/precompute.hpp"
#include "parallel.hpp"

namespace fabrica {

void GradientOperator::apply(const std::vector<double>& f, std::vector<Vec3>& out) const {
  const std::size_t nv = offset.empty() ? 0 : offset.size() - 1;
  out.resize(nv);
  detail::parallel_range(
      nv,
      [&](std::size_t i) {
        double x = 0.0, y = 0.0, z = 0.0;
        for (auto k = static_cast<std::size_t>(offset[i]);
             k < static_cast<std::size_t>(offset[i + 1]); ++k) {
          const double v = f[static_cast<std::size_t>(column[k])];
          x += coeff[3 * k] * v;
          y += coeff[3 * k + 1] * v;
          z += coeff[3 * k + 2] * v;
        }
        out[i] = Vec3(x, y, z);
      },
      4096);
}

}  // namespace fabrica
