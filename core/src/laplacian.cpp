#include "fabrica/core/laplacian.hpp"

#include <string>

#include "curvature_internal.hpp"
#include "fabrica/core/error.hpp"
#include "geometry_kernels.hpp"

namespace fabrica {

std::vector<double> cotan_edge_weights(const Surface& surface) {
  const TriangleMesh& mesh = surface.mesh();
  const Topology& topo = surface.topology();
  const std::size_t nf = mesh.faces.size();
  // Per face, half the cotangent at each corner (0 for degenerate faces).
  std::vector<Vec3> half_cot(nf);
  detail::parallel_chunks(nf, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const auto t = detail::triangle_shape(mesh, mesh.faces[f]);
      if (t.degenerate) {
        half_cot[f].setZero();
        continue;
      }
      // cot at corner k = (a.b)/|a x b|, a and b the edges leaving corner k.
      for (int k = 0; k < 3; ++k)
        half_cot[f][k] = -0.5 * t.e[(k + 1) % 3].dot(t.e[(k + 2) % 3]) / t.twice_area;
    }
  });
  const std::size_t ne = topo.edge_count();
  std::vector<double> w(ne, 0.0);
  detail::parallel_chunks(ne, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t e = begin; e < end; ++e) {
      double s = 0.0;
      for (const auto f : topo.edge_faces(e))
        for (int k = 0; k < 3; ++k)
          if (topo.face_edge(static_cast<std::size_t>(f), k) == static_cast<std::int32_t>(e))
            s += half_cot[f][k];
      w[e] = s;
    }
  });
  return w;
}

Eigen::SparseMatrix<double> cotan_laplacian_matrix(const Surface& surface) {
  const Topology& topo = surface.topology();
  const std::vector<double> w = cotan_edge_weights(surface);
  const auto nv = static_cast<Eigen::Index>(surface.vertex_count());
  Eigen::SparseMatrix<double> L(nv, nv);
  Eigen::VectorXi nnz(nv);
  for (Eigen::Index v = 0; v < nv; ++v)
    nnz[v] = static_cast<int>(topo.vertex_neighbors(static_cast<std::size_t>(v)).size()) + 1;
  L.reserve(nnz);
  // Column v (= row v, symmetric): neighbours in increasing order, diagonal
  // summed in that same order.
  for (Eigen::Index v = 0; v < nv; ++v) {
    const auto nb = topo.vertex_neighbors(static_cast<std::size_t>(v));
    double diag = 0.0;
    bool diag_done = false;
    for (std::size_t i = 0; i < nb.size(); ++i) {
      if (!diag_done && nb[i] > v) {
        L.insert(v, v) = 0.0;
        diag_done = true;
      }
      const double wi =
          w[static_cast<std::size_t>(topo.vertex_edge(static_cast<std::size_t>(v), i))];
      L.insert(nb[i], v) = wi;
      diag -= wi;
    }
    if (!diag_done) L.insert(v, v) = 0.0;
    L.coeffRef(v, v) = diag;
  }
  L.makeCompressed();
  return L;
}

Eigen::SparseMatrix<double> mass_matrix(const Surface& surface) {
  const auto& a = surface.vertex_areas();
  const auto nv = static_cast<Eigen::Index>(a.size());
  Eigen::SparseMatrix<double> M(nv, nv);
  M.reserve(Eigen::VectorXi::Constant(nv, 1));
  for (Eigen::Index v = 0; v < nv; ++v) M.insert(v, v) = a[static_cast<std::size_t>(v)];
  M.makeCompressed();
  return M;
}

CotanLaplacian::CotanLaplacian(const Surface& surface)
    : surface_(&surface), weights_(cotan_edge_weights(surface)) {}

std::vector<double> CotanLaplacian::apply_weak(std::span<const double> x) const {
  const std::size_t nv = surface_->vertex_count();
  if (x.size() != nv)
    throw InputError("CotanLaplacian: the field has " + std::to_string(x.size()) +
                     " values but the surface has " + std::to_string(nv) + " vertices");
  const Topology& topo = surface_->topology();
  std::vector<double> y(nv);
  detail::parallel_chunks(nv, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const auto nb = topo.vertex_neighbors(v);
      double s = 0.0;
      for (std::size_t i = 0; i < nb.size(); ++i)
        s += weights_[static_cast<std::size_t>(topo.vertex_edge(v, i))] * (x[nb[i]] - x[v]);
      y[v] = s;
    }
  });
  return y;
}

std::vector<double> CotanLaplacian::apply(std::span<const double> x) const {
  std::vector<double> y = apply_weak(x);
  const auto& a = surface_->vertex_areas();
  for (std::size_t v = 0; v < y.size(); ++v) y[v] = a[v] > 0.0 ? y[v] / a[v] : 0.0;
  return y;
}

}  // namespace fabrica
