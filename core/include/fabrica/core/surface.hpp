// Surface: a triangle mesh plus its lazily computed, cached, view-independent
// geometry (normals, mixed Voronoi areas, principal curvatures and the
// curvature-derivative tensor, feature size).
//
// Conventions (docs/conventions.md, docs/algorithms.md §0–2):
//  - normals point outward for an outward-oriented mesh (CCW faces);
//  - shape operator S = D n (derivative of the outward normal): a sphere of
//    radius R has k1 = k2 = +1/R (convex positive);
//  - principal curvatures are ordered by absolute value, |k1| >= |k2|
//    (as trimesh2/rtsc), e2 = n x e1;
//  - curvature derivative (a, b, c, d) = C(e1,e1,e1), C(e1,e1,e2),
//    C(e1,e2,e2), C(e2,e2,e2) in the principal frame of each vertex.
//
// Every accessor computes on first use and caches; the cache is thread-safe
// (several threads may ask at once). Results are bit-identical at any
// thread count. Method, accuracy and the CSV of `fabrica geometry`:
// docs/geometry.md; speed: docs/PERFORMANCE.md. While curvature is computed the Surface holds
// scratch (20-byte float fit slots for the corners of the vertices of one step of faces and of
// those spread over several steps, 12 bytes of slot indices and, in the normal pass, 24 of weights
// per face, 48 per vertex), released once the derivatives exist. Vertices where a
// quantity is undefined (isolated vertices, vertices whose faces are all degenerate) are marked
// invalid in `valid` and hold zeros, never NaN.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/topology.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

/// Weights for averaging face normals to vertex normals (docs/algorithms.md §1).
enum class NormalWeighting {
  area,   ///< face area
  angle,  ///< interior angle at the vertex (Thürmer & Wüthrich)
  max,    ///< Max (1999): sin(angle) / (|e_a| |e_b|); the default, as trimesh2
};

/// How a triangle's area is split among its corners (docs/algorithms.md §1).
enum class MixedAreaScheme {
  /// trimesh2's variant (the default, so that curvature agrees with rtsc):
  /// Voronoi cells clipped to the triangle. Acute triangles: exact Voronoi
  /// areas from the circumcentre's barycentric weights; obtuse triangles:
  /// each acute corner gets the right triangle cut off by the perpendicular
  /// bisector of its edge to the obtuse corner, the obtuse corner the rest.
  clipped,
  /// Meyer et al. 2002: Voronoi areas for non-obtuse triangles, otherwise
  /// A/2 to the obtuse corner and A/4 to the others.
  meyer,
};

struct SurfaceOptions {
  NormalWeighting normal_weighting = NormalWeighting::max;
  MixedAreaScheme mixed_areas = MixedAreaScheme::clipped;
  /// Passes of rtsc-style smoothing of the curvature tensor (0 = none),
  /// docs/algorithms.md §2.7.
  int curvature_smoothing_passes = 0;
  /// Gaussian width of that smoothing in multiples of the median edge length.
  double curvature_smoothing_sigma = 1.0;
  /// Passes of smoothing applied to the curvature-derivative tensor.
  int derivative_smoothing_passes = 0;
};

/// Per-vertex principal curvatures and directions (structure of arrays).
struct PrincipalCurvatures {
  std::vector<double> k1, k2;  ///< |k1| >= |k2|, 1/mm
  std::vector<Vec3> e1, e2;    ///< unit tangent directions, e2 = n x e1
  std::vector<std::uint8_t> valid;
  double mean(std::size_t v) const { return 0.5 * (k1[v] + k2[v]); }
  double gaussian(std::size_t v) const { return k1[v] * k2[v]; }
};

/// Per-vertex curvature-derivative tensor in the principal frame, 1/mm².
struct CurvatureDerivatives {
  std::vector<double> a, b, c, d;
  std::vector<std::uint8_t> valid;
};

class Surface {
 public:
  /// Takes the mesh as is (validate and repair it first if needed). Throws
  /// InputError if indices are out of range or coordinates are not finite.
  explicit Surface(TriangleMesh mesh, SurfaceOptions options = {});
  /// The same Surface, given the mesh's Topology already built, so that it is
  /// not built again (the preparation builds it: PreparedMesh::topology,
  /// fabrica::to_surface, io::prepare_for_lines with a topology_out). It must
  /// be Topology(mesh) of this very mesh (same vertices, same faces in the
  /// same corner order); everything computed is then bit-identical to the
  /// Surface that builds its own. Throws InputError, as the constructor above
  /// does, and when the topology's vertex or face count differs from the
  /// mesh's or, at a sample of faces (up to 64, evenly spaced), its face
  /// edges do not join the face's corners (a cheap check, not a full one).
  Surface(TriangleMesh mesh, Topology topology, SurfaceOptions options = {});
  ~Surface();
  /// A moved-from Surface may only be destroyed or assigned to.
  Surface(Surface&&) noexcept;
  Surface& operator=(Surface&&) noexcept;
  Surface(const Surface&) = delete;
  Surface& operator=(const Surface&) = delete;

  const TriangleMesh& mesh() const { return mesh_; }
  const std::vector<Vec3>& positions() const { return mesh_.positions; }
  const std::vector<Face>& faces() const { return mesh_.faces; }
  std::size_t vertex_count() const { return mesh_.positions.size(); }
  std::size_t face_count() const { return mesh_.faces.size(); }
  const SurfaceOptions& options() const { return options_; }

  const Topology& topology() const;
  /// Frees the topology's edge pairs (Topology::release_edges: rebuilt on
  /// the first call that reads them), for a Surface drawn once whose
  /// readers do not ask for them (`fabrica lines`); the edge-length
  /// statistics are computed first. Not to be called while another thread
  /// reads this Surface.
  void release_topology_edges() const;

  /// Unit face normals (zero for degenerate faces) and face areas.
  const std::vector<Vec3>& face_normals() const;
  const std::vector<double>& face_areas() const;
  /// Unit vertex normals with options().normal_weighting; zero where invalid.
  const std::vector<Vec3>& vertex_normals() const;
  /// Per face, the mixed Voronoi area of each corner (sums to the face area).
  const std::vector<Vec3>& corner_areas() const;
  /// Per vertex, the mixed Voronoi area (sum of its corner areas).
  const std::vector<double>& vertex_areas() const;
  const PrincipalCurvatures& curvature() const;
  const CurvatureDerivatives& curvature_derivatives() const;
  /// rtsc's feature size (docs/algorithms.md §2.6), deterministic.
  double feature_size() const;
  /// Median edge length (trimesh2's feature_size()).
  double median_edge_length() const;
  /// Mean edge length.
  double mean_edge_length() const;
  /// Bounding sphere (approximate, enclosing every vertex).
  Vec3 bounding_sphere_center() const;
  double bounding_sphere_radius() const;

  /// Computes every cached quantity now (normals, areas, curvature,
  /// curvature derivatives, feature size), in parallel.
  void precompute() const;

  /// Lets the Surface free the face quantities (face normals, face areas,
  /// corner areas: 56 bytes per face) that it computed on its own as
  /// inputs of the curvature fits, once the curvature derivatives exist
  /// (at once if they do, else when they are done), for a single-use
  /// Surface whose later work does not read them (the one-shot
  /// draw_lines). Arrays that a caller obtained from face_normals(),
  /// face_areas() or corner_areas() are never freed, so
  /// no reference is invalidated; after the release, these accessors
  /// compute them again.
  void release_face_quantities() const;

 private:
  struct Cache;
  static void free_face_quantities(Cache& c);
  TriangleMesh mesh_;
  SurfaceOptions options_;
  std::unique_ptr<Cache> cache_;
};

}  // namespace fabrica
