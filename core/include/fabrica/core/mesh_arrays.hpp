// TriangleMesh to and from plain arrays (issue 16): vertices as an n×3 matrix
// of doubles, faces as an m×3 matrix of 32-bit ints, row i = vertex/face i
// (the layout of libigl's V, F and of numpy's (n,3) arrays).
//
// To arrays costs nothing: TriangleMesh stores Vec3 and std::array<int32,3>
// contiguously, so vertex_matrix/face_matrix are row-major Eigen::Map views
// of its storage (valid while the mesh lives and is not resized). From
// arrays copies once into the mesh's own vectors (a TriangleMesh owns its
// storage); the values are checked like a file's (InputError naming `what`).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/core/mesh.hpp"

namespace fabrica {

using VertexMatrix = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using FaceMatrix = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 must be three packed doubles");
static_assert(sizeof(Face) == 3 * sizeof(std::int32_t), "Face must be three packed int32");

/// The mesh's vertices as an n×3 row-major view (no copy).
inline Eigen::Map<VertexMatrix> vertex_matrix(TriangleMesh& mesh) {
  return {mesh.positions.empty() ? nullptr : mesh.positions.front().data(),
          static_cast<Eigen::Index>(mesh.positions.size()), 3};
}
inline Eigen::Map<const VertexMatrix> vertex_matrix(const TriangleMesh& mesh) {
  return {mesh.positions.empty() ? nullptr : mesh.positions.front().data(),
          static_cast<Eigen::Index>(mesh.positions.size()), 3};
}
/// The mesh's faces as an m×3 row-major view (no copy).
inline Eigen::Map<FaceMatrix> face_matrix(TriangleMesh& mesh) {
  return {mesh.faces.empty() ? nullptr : mesh.faces.front().data(),
          static_cast<Eigen::Index>(mesh.faces.size()), 3};
}
inline Eigen::Map<const FaceMatrix> face_matrix(const TriangleMesh& mesh) {
  return {mesh.faces.empty() ? nullptr : mesh.faces.front().data(),
          static_cast<Eigen::Index>(mesh.faces.size()), 3};
}

/// A mesh from any n×3 vertex and m×3 integer face matrix (libigl's V, F, an
/// Eigen::Map over numpy memory, ...). Throws InputError naming `what` when
/// a matrix does not have three columns, a face index is out of range or a
/// coordinate is not finite.
template <typename DerivedV, typename DerivedF>
TriangleMesh mesh_from_arrays(const Eigen::MatrixBase<DerivedV>& V,
                              const Eigen::MatrixBase<DerivedF>& F, Space space = Space::lps,
                              const std::string& what = "mesh") {
  if (V.cols() != 3 || F.cols() != 3)
    throw InputError(what + ": vertices and faces must be n x 3 and m x 3 matrices (got " +
                     std::to_string(V.rows()) + " x " + std::to_string(V.cols()) + " and " +
                     std::to_string(F.rows()) + " x " + std::to_string(F.cols()) + ")");
  TriangleMesh mesh;
  mesh.space = space;
  mesh.positions.resize(static_cast<std::size_t>(V.rows()));
  vertex_matrix(mesh) = V.template cast<double>();
  mesh.faces.resize(static_cast<std::size_t>(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto index = F(f, k);
      if (index < 0 || static_cast<std::size_t>(index) >= mesh.positions.size())
        throw InputError(what + ": face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(static_cast<long long>(index)) + ", but there are " +
                         std::to_string(mesh.positions.size()) + " vertices");
      mesh.faces[static_cast<std::size_t>(f)][static_cast<std::size_t>(k)] =
          static_cast<std::int32_t>(index);
    }
  check_mesh_indices_and_values(mesh, what);
  return mesh;
}

}  // namespace fabrica
