// RenderMesh: a triangle mesh as flat float arrays ready for upload, with
// optional per-vertex curvature for the hybrid apparent ridges (principal
// curvatures k1, k2 in 1/mm with |k1| >= |k2|, convex positive; unit
// principal directions e1, e2), and the scales the renderer needs (bounding
// sphere, mean edge length, feature size; all in mm).
#pragma once

#include <cstdint>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {
class Surface;
}

namespace fabrica::render {

struct RenderMesh {
  std::vector<float> positions;        ///< 3 per vertex
  std::vector<float> normals;          ///< 3 per vertex, unit
  std::vector<std::uint32_t> indices;  ///< 3 per triangle
  std::vector<float> k1, k2;           ///< optional: 1 per vertex
  std::vector<float> e1, e2;           ///< optional: 3 per vertex
  /// Optional, for surface LIC (lic.hpp, set_lic_field, LicField): 3 per
  /// vertex, the unit maximal-curvature line direction (either sign; zero:
  /// none); 1 per vertex, the feature level phi (>= 0 inside a feature
  /// region; the mask is clamp(phi, 0, 1), phi linear in a face).
  std::vector<float> lic_field, lic_level;
  Vec3 center = Vec3::Zero();  ///< bounding sphere
  double radius = 0.0;
  /// The vertices' axis-aligned bounding box (box_min > box_max: not known;
  /// the renderer then bounds the mesh by its sphere). The sphere's centre
  /// is the box's centre.
  Vec3 box_min = Vec3::Constant(1.0), box_max = Vec3::Constant(-1.0);
  double mean_edge_length = 0.0;
  double feature_size = 0.0;  ///< rtsc feature size (0 = unknown)
  /// Closed (every edge in exactly two faces), consistently oriented and
  /// facing outward (positive signed volume): seen from outside its faces
  /// wind counter-clockwise, and the renderer may cull its back faces where
  /// nothing cuts it open (a focus structure beyond the near plane;
  /// docs/algorithms.md §16).
  bool closed_outward = false;

  std::size_t vertex_count() const { return positions.size() / 3; }
  std::size_t triangle_count() const { return indices.size() / 3; }
  bool has_curvature() const { return k1.size() == vertex_count() && vertex_count() > 0; }
  bool has_lic_field() const {
    return lic_field.size() == 3 * vertex_count() && lic_level.size() == vertex_count() &&
           triangle_count() > 0;
  }
};

/// From a mesh and unit vertex normals (one per vertex). Throws InputError if
/// the sizes disagree or the mesh is empty.
RenderMesh make_render_mesh(const TriangleMesh& mesh, const std::vector<Vec3>& vertex_normals);

/// From a Surface: its vertex normals and, if `with_curvature`, its principal
/// curvatures and directions and feature size.
RenderMesh make_render_mesh(const Surface& surface, bool with_curvature);

/// From a mesh alone, without a topology or repair (a level of detail's):
/// vertex normals the normalised sums of the incident faces' area vectors
/// (zero where none or where they cancel).
RenderMesh make_render_mesh(const TriangleMesh& mesh);

/// A coarse copy of `mesh` with about `target_faces` faces (at most 25% more)
/// by vertex clustering on a uniform grid (docs/algorithms.md §16): the
/// viewer draws ghosted context with it while the camera moves. Returns `mesh` itself when it has
/// no more faces than that. Deterministic; unreferenced vertices are dropped.
TriangleMesh cluster_simplify(const TriangleMesh& mesh, std::size_t target_faces);

/// Sets the curvature arrays (sizes must match the vertex count).
void set_curvature(RenderMesh& mesh, const std::vector<double>& k1, const std::vector<double>& k2,
                   const std::vector<Vec3>& e1, const std::vector<Vec3>& e2);

}  // namespace fabrica::render
