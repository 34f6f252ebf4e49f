// GradientOperator::apply: the per-view sparse product ∇f = G f used by the
// illumination fields (PELs, Laplacian lines). Built in precompute.cpp.
#include "gradient_row.hpp"
#include "parallel.hpp"

namespace fabrica {

void GradientOperator::apply(const std::vector<double>& f, std::vector<Vec3>& out) const {
  const std::size_t nv = offset.empty() ? 0 : offset.size() - 1;
  out.resize(nv);
  detail::parallel_range(
      nv, [&](std::size_t i) { out[i] = detail::gradient_row(*this, i, f.data()); }, 4096);
}

}  // namespace fabrica
