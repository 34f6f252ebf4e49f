// First-order discrete differential geometry on triangle meshes
// (docs/algorithms.md §1): face normals and areas, vertex normals (area, angle or
// Max 1999 weights), mixed Voronoi corner and vertex areas (Meyer, Desbrun,
// Schröder & Barr 2002, or trimesh2's clipped variant), gradients of
// piecewise-linear per-vertex fields, covariant derivatives, the minimal
// rotation between tangent planes, edge-length statistics and a bounding
// sphere.
//
// Units: lengths in mm (the mesh's units), areas in mm², gradients of a field
// f in [f]/mm. Normals point outward for counter-clockwise faces.
// Degenerate faces (zero area, repeated vertex) get a zero normal, zero
// gradient and contribute nothing to vertex quantities; vertices without a
// usable face get zeros (never NaN).
#pragma once

#include <span>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

struct FaceNormalsAndAreas {
  std::vector<Vec3> normals;  ///< unit, zero for degenerate faces
  std::vector<double> areas;  ///< mm²
};

/// Unit face normals n_T = (p1-p0)x(p2-p0)/|.| and areas A_T = |.|/2.
FaceNormalsAndAreas face_normals_and_areas(const TriangleMesh& mesh);

/// Per face, the area of each corner's part of the triangle (sums to A_T).
/// Degenerate faces split their (tiny) area equally.
std::vector<Vec3> mixed_voronoi_corner_areas(const TriangleMesh& mesh,
                                             MixedAreaScheme scheme = MixedAreaScheme::clipped);

/// Per vertex, the sum of its corner areas (isolated vertices: 0).
std::vector<double> vertex_areas_from_corners(const Topology& topology,
                                              const std::vector<Vec3>& corner_areas);

/// Unit vertex normals: normalised weighted sum of incident unit face
/// normals. Zero where no non-degenerate face touches the vertex or the
/// weighted normals cancel.
std::vector<Vec3> vertex_normals(const TriangleMesh& mesh, const Topology& topology,
                                 NormalWeighting weighting = NormalWeighting::max);

/// Minimal rotation, about from x to, taking a vector tangent to the plane
/// with unit normal `from` into the plane with unit normal `to` (R_{T->i}
/// of docs/algorithms.md §1). Falls back to projection when the normals are
/// opposite.
Vec3 rotate_to_tangent_plane(const Vec3& x, const Vec3& from, const Vec3& to);

/// Gradient of the piecewise-linear field `field` (one value per vertex) on
/// face f: (1/2A) sum_k f_k (n_T x e_k), e_k the CCW edge opposite corner k.
/// Zero for degenerate faces. Precondition: field.size() == vertex_count().
Vec3 face_gradient(const Surface& surface, std::size_t face, std::span<const double> field);

/// face_gradient for every face. Throws InputError if the field has the
/// wrong size.
std::vector<Vec3> face_gradients(const Surface& surface, std::span<const double> field);

/// Per-vertex gradient: corner-area weighted mean of the incident face
/// gradients, each rotated into the vertex tangent plane with the minimal
/// rotation. Zero at invalid vertices. Throws InputError on a size mismatch.
std::vector<Vec3> vertex_gradients(const Surface& surface, std::span<const double> field);

/// Covariant derivative D_w f = <grad f, w> at each vertex, with the vertex
/// gradient above and one tangent vector w per vertex. Throws InputError on
/// a size mismatch.
std::vector<double> covariant_derivative(const Surface& surface, std::span<const double> field,
                                         std::span<const Vec3> directions);

struct BoundingSphere {
  Vec3 center = Vec3::Zero();
  double radius = 0.0;
};

/// An enclosing sphere of all points (Ritter 1990, followed by an exact
/// growth pass so every point is inside): deterministic, within a few
/// percent of the minimal radius. Empty input gives radius 0 at the origin.
BoundingSphere bounding_sphere(const std::vector<Vec3>& points);

struct EdgeLengthStatistics {
  double median = 0.0;  ///< element n/2 (0-based) of the sorted lengths
  double mean = 0.0;
  double min = 0.0;
  double max = 0.0;
};

/// Statistics over the undirected edges of the mesh (each edge once).
EdgeLengthStatistics edge_length_statistics(const TriangleMesh& mesh, const Topology& topology);

}  // namespace fabrica
