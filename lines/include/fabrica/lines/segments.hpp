// Raw feature-line output: a soup of straight segments per line family, each
// inside one triangle, before chaining. Every endpoint remembers where it lies
// on the mesh (a Topology edge, a vertex, the face centroid where three
// crossings are joined, or inside the face where a test function clipped the
// segment), so chaining can join segments by identity instead of by
// coordinates (docs/algorithms.md §11).
//
// The record is lean (40 bytes, docs/algorithms.md §11 "lean segment
// record"): an end stores only its element and, on an edge, the fraction t
// along it; its barycentric coordinates and position are recomputed from the
// mesh (SegmentGeometry) with the operations the kernels use, so they have
// the bits the kernels computed. Interior ends (test-function clips) keep
// two barycentric coordinates as floats.
//
// Positions are in the mesh's units (mm). Strength is the fade value in
// [0,1] (docs/algorithms.md §0 step 4): 1 = fully drawn.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/core/surface_point.hpp"
#include "fabrica/core/types.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica {

/// Where a segment endpoint lies on the mesh.
enum class EndKind : std::uint8_t {
  edge,      ///< on mesh edge `element` (Topology edge id)
  vertex,    ///< at mesh vertex `element` (boundaries, creases, mesh-edge contours)
  centroid,  ///< at the centroid of the segment's face (three-crossing join); element = face
  interior,  ///< inside the face (a test-function clip point): never joined
};

/// One end of a LineSegment (its kind is LineSegment::kind[i]).
struct SegmentEnd {
  /// edge: the fraction from the edge's lower vertex (Topology::edge(e)[0])
  /// to its higher one, barycentrics 1 - t and t; interior: `bary`.
  union {
    double t = 0.0;
    float bary[2];  ///< interior: the coordinates of face corners 0 and 1
  };
  std::int32_t element = -1;  ///< edge, vertex or face id, by kind; -1 for interior
  float strength = 1.0f;
};

struct LineSegment {
  std::int32_t face = -1;
  EndKind kind[2] = {EndKind::interior, EndKind::interior};
  SegmentEnd end[2];
};
static_assert(sizeof(LineSegment) == 40);

/// An end of a segment with its place on the mesh recomputed: face +
/// barycentrics, position, and the record's element, kind and strength.
struct ResolvedEnd {
  SurfacePoint anchor;
  Vec3 position = Vec3::Zero();
  std::int32_t element = -1;
  EndKind kind = EndKind::interior;
  float strength = 1.0f;
};

/// A segment with both ends resolved (for tools and tests; the pipeline
/// reads the lean records).
struct ResolvedSegment {
  std::int32_t face = -1;
  ResolvedEnd end[2];
};

/// Recomputes ends' barycentrics and positions from the mesh: on an edge
/// (1 - t) p_lo + t p_hi per component, at a vertex its position, at the
/// centroid (p0 + p1 + p2) / 3 per component, inside the face the
/// barycentric combination of the corners. Holds pointers into the
/// Surface (which must outlive it).
class SegmentGeometry {
 public:
  explicit SegmentGeometry(const Surface& surface);

  SurfacePoint anchor(const LineSegment& s, int i) const;
  Vec3 position(const LineSegment& s, int i) const;
  ResolvedEnd resolve(const LineSegment& s, int i) const;
  /// anchor() and position() of end i at once, with one look-up of its
  /// edge, vertex or face (the same values, bit for bit): chaining's per
  /// polyline vertex path, inline.
  void locate(const LineSegment& s, int i, SurfacePoint& anchor, Vec3& position) const;

  /// Sets end i of s to an interior point of its face with
  /// barycentrics `bary` (the stored precision: float).
  static void set_interior(LineSegment& s, int i, const double bary[3]);

 private:
  const Face* faces_;
  const Vec3* pos_;
  const Topology* topo_;
};

inline void SegmentGeometry::locate(const LineSegment& s, int i, SurfacePoint& anchor,
                                    Vec3& position) const {
  const SegmentEnd& e = s.end[i];
  const Face& f = faces_[static_cast<std::size_t>(s.face)];
  anchor.face = s.face;
  Vec3& b = anchor.bary;
  switch (s.kind[i]) {
    case EndKind::edge: {
      // 1 - t at the edge's lower vertex, t at its higher one (t wins
      // where both are the same corner), 0 at the third corner.
      // The edge's ends (lower vertex first, as Topology::edge has them)
      // from the face, whose edge opposite corner k it is: no read of the
      // topology's edge list, which a one-shot drawing frees
      // (Surface::release_topology_edges).
      const std::int32_t* const fe = topo_->face_edge_row(static_cast<std::size_t>(s.face));
      const int k = fe[0] == e.element ? 0 : fe[1] == e.element ? 1 : 2;
      const auto [a, c] = Topology::corners_after(f, k);
      const std::array<std::int32_t, 2> ev =
          fe[k] == e.element ? std::array<std::int32_t, 2>{std::min(a, c), std::max(a, c)}
                             : topo_->edge(static_cast<std::size_t>(e.element));
      const double t = e.t, u = 1.0 - t;
      for (int k = 0; k < 3; ++k) b[k] = f[k] == ev[1] ? t : f[k] == ev[0] ? u : 0.0;
      const Vec3 &p = pos_[ev[0]], &q = pos_[ev[1]];
      position = Vec3(u * p[0] + t * q[0], u * p[1] + t * q[1], u * p[2] + t * q[2]);
      return;
    }
    case EndKind::vertex:
      for (int k = 0; k < 3; ++k) b[k] = f[k] == e.element ? 1.0 : 0.0;
      position = pos_[static_cast<std::size_t>(e.element)];
      return;
    case EndKind::centroid: {
      b = Vec3::Constant(1.0 / 3.0);
      const Vec3 &p = pos_[f[0]], &q = pos_[f[1]], &r = pos_[f[2]];
      position =
          Vec3((p[0] + q[0] + r[0]) / 3.0, (p[1] + q[1] + r[1]) / 3.0, (p[2] + q[2] + r[2]) / 3.0);
      return;
    }
    case EndKind::interior: {
      const double b0 = e.bary[0], b1 = e.bary[1];
      b = Vec3(b0, b1, 1.0 - b0 - b1);
      break;
    }
    default:  // not a kind: no barycentrics (the combination below is 0)
      b = Vec3::Zero();
      break;
  }
  position = b[0] * pos_[f[0]] + b[1] * pos_[f[1]] + b[2] * pos_[f[2]];
}

/// All segments of one family, in a deterministic order (by face, then
/// extraction order inside the face) at any thread count. `surface` is the
/// mesh the ends refer to (it must outlive the soup's use).
struct SegmentSoup {
  LineFamily family = LineFamily::contour;
  const Surface* surface = nullptr;
  std::vector<LineSegment> segments;

  double total_length() const;
  /// The geometry of the ends (throws an internal Error when the soup has
  /// segments but no surface).
  SegmentGeometry geometry() const;
  /// The segments with their ends resolved, in order.
  std::vector<ResolvedSegment> resolved() const;
};

}  // namespace fabrica
