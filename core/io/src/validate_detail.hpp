// Private helpers shared by validate.cpp, repair.cpp and the CGAL
// self-intersection translation unit. Not installed, not part of the API.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/topology.hpp"

namespace fabrica::io::detail {

/// Union-find over indices 0..n-1 (parent[i] == i at the start): the root
/// of i's set, with path halving.
std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t i);
/// Joins the sets of a and b; the lower root index becomes the root, so the
/// labels do not depend on the order of the unions.
void unite(std::vector<std::int32_t>& parent, std::int32_t a, std::int32_t b);

/// "1 face", "3 faces".
std::string plural(std::size_t n, const char* one, const char* many);

/// Area below this fraction of (mean edge length)^2 counts as zero.
inline constexpr double kDegenerateAreaFraction = 1e-12;

/// Whether two faces use the same three vertex indices (in any order).
inline bool same_vertex_set(Face a, Face b) {
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  return a == b;
}

inline bool has_repeated_index(const Face& f) {
  return f[0] == f[1] || f[1] == f[2] || f[2] == f[0];
}

/// Topology of the faces WITHOUT a repeated vertex index (those have no three
/// distinct edges and would confuse every fan and orientation walk). Face ids
/// of the topology are "proper" ids; original_face maps them back.
class ProperTopology {
 public:
  explicit ProperTopology(const TriangleMesh& mesh);

  const std::vector<Face>& faces() const { return filtered_ ? filtered_faces_ : *mesh_faces_; }
  /// Mesh face id of proper face f.
  std::int32_t original_face(std::size_t f) const {
    return filtered_ ? original_face_[f] : static_cast<std::int32_t>(f);
  }
  std::size_t repeated_index_faces() const { return repeated_index_faces_; }
  const Topology& topology() const { return topology_; }
  /// Follows proper face f turned from `corners` (a, b, c) to (a, c, b)
  /// (Topology::reverse_face), so this still describes the mesh.
  void reverse_face(std::size_t f, const Face& corners) {
    topology_.reverse_face(f, corners);
    if (filtered_) std::swap(filtered_faces_[f][1], filtered_faces_[f][2]);
  }
  /// Topology(mesh) of the mesh this was built from, when no face was left
  /// out (no repeated-index face); moved out, so this object is spent.
  std::optional<Topology> release_mesh_topology() {
    if (filtered_) return std::nullopt;
    return std::move(topology_);
  }

 private:
  const std::vector<Face>* mesh_faces_;
  bool filtered_ = false;
  std::vector<Face> filtered_faces_;
  std::vector<std::int32_t> original_face_;
  std::size_t repeated_index_faces_ = 0;
  Topology topology_;
};

/// Mean length of the distinct edges (0 when there are none).
double mean_edge_length(const Topology& topology, const std::vector<Vec3>& positions);

/// Index (0..2) of the corner opposite edge e in face f, or -1.
inline int corner_opposite(const Topology& topology, std::size_t f, std::int32_t e) {
  for (int k = 0; k < 3; ++k)
    if (topology.face_edge(f, k) == e) return k;
  return -1;
}

/// Vertex at which face f's directed edge opposite corner k starts.
inline std::int32_t edge_start(const Face& f, int k) {
  return f[(k + 1) % 3];
}

/// Fans around vertex v: fan label (0, 1, ...) of each entry of
/// topology.vertex_faces(v), numbered in order of their lowest face; returns
/// the number of fans. Faces are connected through any edge incident to v, or
/// with manifold_edges_only through edges with exactly two faces.
int vertex_fans(const Topology& topology, std::size_t v, std::vector<int>& fan_of_entry,
                bool manifold_edges_only = false);

/// Edge-connected pieces: faces joined through edges with exactly two faces.
/// Returns the piece of each face, numbered in order of the lowest face.
std::vector<std::int32_t> manifold_pieces(const Topology& topology, std::size_t& piece_count);

/// Six times the signed volume contribution of a triangle about `origin`.
inline double signed_volume6(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& origin) {
  return (a - origin).dot((b - origin).cross(c - origin));
}

/// Orientation of an open piece: its signed volume with every boundary loop
/// capped virtually by a fan to the loop's centroid (so the capped piece is
/// closed and its volume does not depend on the origin), and its area.
struct CappedVolume {
  double volume6 = 0.0;  ///< six times the capped signed volume (> 0: outward)
  double area = 0.0;
  std::size_t loops = 0;  ///< boundary loops capped
  /// The capped volume is too small against the area for a side to exist
  /// (a flat or nearly flat sheet): |volume| < kFlatSheetRatio * area^1.5.
  bool ambiguous() const;
};
inline constexpr double kFlatSheetRatio = 1e-3;

/// Capped volume of every piece (see CappedVolume; `piece` gives the piece of
/// each proper face, numbered 0..piece_count-1). Faces with flip[f] set count
/// as reversed (flip may be null). Boundary loops: boundary edges joined at
/// shared vertices.
std::vector<CappedVolume> capped_piece_volumes(const Topology& topology,
                                               const std::vector<Vec3>& positions,
                                               const std::vector<Face>& faces,
                                               const std::vector<std::int32_t>& piece,
                                               std::size_t piece_count,
                                               const std::vector<std::uint8_t>* flip = nullptr);

/// How many other closed pieces enclose each closed piece (0 for open ones):
/// piece A is inside piece B when A's bounding box lies in B's and each of A's
/// six extreme vertices (min/max x, y, z) is inside B by ray parity. A piece
/// at odd depth is a cavity wall: its normals point into the cavity, i.e. out
/// of the solid, so its signed volume should be negative. `piece` gives the
/// piece of every face of `faces`.
std::vector<int> nesting_depths(const std::vector<Vec3>& positions, const std::vector<Face>& faces,
                                const std::vector<std::int32_t>& piece,
                                const std::vector<std::uint8_t>& piece_closed);

/// Pairs of faces that intersect other than at a shared vertex or edge, by
/// CGAL (exact predicates). The mesh must be consistently oriented, without
/// repeated-index faces, non-manifold edges or non-manifold vertices; returns
/// nullopt with `why_not` set when CGAL cannot represent it.
std::optional<std::size_t> count_self_intersecting_face_pairs(const TriangleMesh& mesh,
                                                              std::string& why_not);

}  // namespace fabrica::io::detail
