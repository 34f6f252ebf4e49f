// Mesh validation: counts every defect that breaks curvature, feature lines
// or hatching (docs/algorithms.md §1 "Mesh hygiene"), without changing the mesh.
//
// Works on any indexed triangle mesh: open, multi-component, non-manifold,
// degenerate. Out-of-range indices or non-finite coordinates are the only
// inputs rejected (fabrica::InputError), because no count is meaningful then.
//
// Definitions (docs/validation.md has examples):
// - degenerate face: a repeated vertex index, or area <= 1e-12 x (mean edge
//   length)^2. Faces with a repeated index are otherwise ignored by the
//   topological counts below (they have no three distinct edges).
// - duplicate face: the same three vertices as an earlier face, in either
//   orientation (faces with a repeated index are never called duplicates).
// - components: faces connected through shared VERTICES (so two spheres
//   touching at one vertex are one component); unreferenced vertices belong
//   to none.
// - boundary edge: used by exactly one face; non-manifold edge: by three or
//   more. A boundary loop is a boundary cycle of the surface: at each vertex
//   the two boundary edges of the same fan of faces are joined (a bow-tie of
//   two triangles has two loops), so the count does not change when
//   non-manifold vertices are split.
// - non-manifold vertex: its faces form more than one fan (sets connected
//   through edges incident to the vertex): a bow-tie or pinch point.
// - consistently oriented: every edge with exactly two faces is used in
//   opposite directions by them.
// - outward: for closed, consistently oriented, edge-manifold meshes, whether
//   the normals of every edge-connected piece point out of the solid: positive
//   signed volume, or negative for a cavity wall (a piece nested inside an odd
//   number of other closed pieces, tested by ray parity).
// Units: lengths in the mesh's units (mm), areas in units^2, volume units^3.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"

namespace fabrica::io {

struct ValidateOptions {
  /// Count pairs of faces that intersect other than at a shared vertex or
  /// edge (CGAL, exact predicates). Needs an edge-manifold, orientable mesh
  /// without repeated-index faces; otherwise skipped with the reason in
  /// ValidationReport::self_intersections_skipped. O(F log F), ~1 s per 1M faces.
  bool self_intersections = false;
};

struct ValidationReport {
  std::size_t vertices = 0, faces = 0;
  std::size_t components = 0;         ///< vertex-connected pieces
  std::size_t boundary_loops = 0;     ///< chains of boundary edges (holes)
  std::size_t boundary_edges = 0;     ///< edges with one face
  std::size_t nonmanifold_edges = 0;  ///< edges with three or more faces
  std::size_t nonmanifold_vertices = 0;
  std::size_t degenerate_faces = 0;  ///< repeated index or (near) zero area
  std::size_t duplicate_faces = 0;   ///< same vertex set as an earlier face
  std::size_t unreferenced_vertices = 0;
  std::size_t inconsistent_edges = 0;  ///< two-face edges used in the same direction by both
  std::size_t edges = 0;               ///< distinct undirected edges
  /// Euler characteristic V - E + F over referenced vertices (genus of one
  /// closed component = (2 - chi) / 2).
  long long euler_characteristic = 0;

  bool consistently_oriented = true;  ///< inconsistent_edges == 0
  bool closed = false;                ///< faces and no boundary edges
  /// Only for closed, consistently oriented meshes without non-manifold
  /// edges: true when every edge-connected piece faces out of the solid
  /// (positive signed volume; negative for a nested cavity wall).
  std::optional<bool> outward;
  std::size_t inward_pieces = 0;  ///< closed pieces facing into the solid (when outward is set)
  /// Open pieces (consistently oriented, edge-manifold mesh) whose signed
  /// volume with every boundary loop capped by a fan to its centroid is
  /// negative: they face inward (a flat sheet, with no inside, never counts).
  std::size_t inward_open_pieces = 0;

  double signed_volume = 0.0;     ///< sum over faces (divergence theorem), units^3
  double area = 0.0;              ///< total face area, units^2
  double mean_edge_length = 0.0;  ///< over distinct edges
  BoundingBox bbox;               ///< of all vertices (also unreferenced)

  /// Only when requested and possible: pairs of faces that intersect.
  std::optional<std::size_t> self_intersecting_face_pairs;
  std::string self_intersections_skipped;  ///< why, when requested but not computed

  /// Human-readable one-liners, one per kind of defect (degenerate, duplicate,
  /// non-manifold, inconsistent or inward orientation, self-intersections).
  std::vector<std::string> problems;
  /// Facts worth knowing that are not defects: open boundary, several
  /// components, unreferenced vertices (kept so vertex i stays vertex i).
  std::vector<std::string> notes;

  /// No defect: `problems` is empty (notes do not count).
  bool clean() const { return problems.empty(); }
};

/// Validates `mesh`. Deterministic. Throws InputError when a face index is out
/// of range or a coordinate is not finite. Cost O(V + F) (~30 ms per 250k faces).
ValidationReport validate_mesh(const TriangleMesh& mesh, const ValidateOptions& options = {});

/// The report as a JSON object (keys = field names; optional fields null).
nlohmann::json to_json(const ValidationReport& report);

}  // namespace fabrica::io
