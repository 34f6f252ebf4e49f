// Chaining (docs/algorithms.md §11.1–2): joins the segments of each family into
// polylines and closed loops by the identity of their endpoints (family +
// mesh edge, vertex, or face centroid), never by coordinates, then drops
// short chains. Endpoints shared by exactly two segments are joined; an
// endpoint shared by one or by three or more (branch points: centroid joins,
// non-manifold edges) ends its chains. Deterministic: chains start at the
// lowest-numbered free segment end, loops at their lowest segment.
#pragma once

#include <optional>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/lines/segments.hpp"

namespace fabrica {

struct ChainOptions {
  /// Drop chains shorter than this in space (mm); 0 keeps all.
  double min_length = 0.0;
  /// Drop chains whose projected length is below this many pixels (needs
  /// `camera`); 0 keeps all.
  double min_length_px = 0.0;
  std::optional<Camera> camera;
};

/// Chains one soup.
std::vector<Polyline> chain_segments(const SegmentSoup& soup, const ChainOptions& options = {});
/// Chains every soup, in order, into one LineSet.
LineSet chain_segments(const std::vector<SegmentSoup>& soups, const ChainOptions& options = {});

/// Projected length of a polyline in pixels.
double projected_length(const Polyline& polyline, const Camera& camera);

}  // namespace fabrica
