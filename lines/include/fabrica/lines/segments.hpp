// Raw feature-line output: a soup of straight segments per line family, each
// inside one triangle, before chaining. Every endpoint remembers where it lies
// on the mesh (a Topology edge, a vertex, the face centroid where three
// crossings are joined, or inside the face where a test function clipped the
// segment), so chaining can join segments by identity instead of by
// coordinates (docs/algorithms.md §11).
//
// Positions are in the mesh's units (mm). Strength is the fade value in
// [0,1] (docs/algorithms.md §0 step 4): 1 = fully drawn.
#pragma once

#include <cstdint>
#include <vector>

#include "fabrica/core/surface_point.hpp"
#include "fabrica/core/types.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica {

/// Where a segment endpoint lies on the mesh.
enum class EndKind : std::uint8_t {
  edge,      ///< on mesh edge `element` (Topology edge id)
  vertex,    ///< at mesh vertex `element` (boundaries, creases, mesh-edge contours)
  centroid,  ///< at the centroid of the segment's face (three-crossing join)
  interior,  ///< inside the face (a test-function clip point): never joined
};

struct SegmentEnd {
  SurfacePoint anchor;  ///< face + barycentric coordinates
  Vec3 position = Vec3::Zero();
  std::int32_t element = -1;  ///< edge or vertex id, by `kind`; -1 otherwise
  EndKind kind = EndKind::interior;
  float strength = 1.0f;
};

struct LineSegment {
  std::int32_t face = -1;
  SegmentEnd end[2];
};

/// All segments of one family, in a deterministic order (by face, then
/// extraction order inside the face) at any thread count.
struct SegmentSoup {
  LineFamily family = LineFamily::contour;
  std::vector<LineSegment> segments;

  double total_length() const;
};

}  // namespace fabrica
