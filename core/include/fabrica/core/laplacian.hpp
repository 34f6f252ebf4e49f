// Cotangent Laplace–Beltrami operator (Pinkall & Polthier 1993; Meyer et al.
// 2002; docs/algorithms.md §1):
//   (Δf)_i = 1/A_i * sum_j w_ij (f_j - f_i),  w_ij = (cot α_ij + cot β_ij) / 2,
// with α, β the angles opposite edge ij (a boundary edge has one term; a
// non-manifold edge one term per face) and A_i the mixed Voronoi vertex
// area of the Surface. Sign: "div grad", negative semidefinite.
// Degenerate faces contribute nothing. Obtuse triangles give negative
// weights (the operator is then not monotone); that is accepted here.
//
// Two forms: Eigen sparse matrices (weak Laplacian L, symmetric, rows summing
// to zero, and the diagonal mass matrix M = diag(A_i), so Δ = M⁻¹ L), and a
// matrix-free operator for repeated application.
#pragma once

#include <Eigen/SparseCore>
#include <span>
#include <vector>

#include "fabrica/core/surface.hpp"

namespace fabrica {

/// Per edge of surface.topology(), the cotangent weight w_ij (1/1, unitless).
std::vector<double> cotan_edge_weights(const Surface& surface);

/// The weak cotan Laplacian L: L_ij = w_ij for edges, L_ii = -sum_j w_ij.
/// Symmetric, negative semidefinite, L * 1 = 0.
Eigen::SparseMatrix<double> cotan_laplacian_matrix(const Surface& surface);

/// The lumped mass matrix diag(A_i) with the Surface's mixed Voronoi areas.
Eigen::SparseMatrix<double> mass_matrix(const Surface& surface);

/// Matrix-free cotan Laplacian: keeps the edge weights and applies L or
/// M⁻¹ L in parallel (each output entry summed in a fixed order, so results
/// are identical at any thread count). Keeps a reference to `surface`.
class CotanLaplacian {
 public:
  explicit CotanLaplacian(const Surface& surface);
  /// y = L x (weak form, units [x] mm⁰). Throws InputError on size mismatch.
  std::vector<double> apply_weak(std::span<const double> x) const;
  /// y = M⁻¹ L x, the pointwise Laplacian ([x]/mm²); 0 where A_i = 0.
  std::vector<double> apply(std::span<const double> x) const;
  const std::vector<double>& edge_weights() const { return weights_; }

 private:
  const Surface* surface_;
  std::vector<double> weights_;
};

}  // namespace fabrica
