// StrokeSet: shading strokes as polylines anchored on the surface, the output
// of hatching (Singh & Schaefer 2010). Each vertex is a SurfacePoint (face +
// barycentric coordinates, as LineSet's LineVertex) with its 3D position
// (mm), its image position (pixels, x right, y down) for the camera the
// strokes were made for, and the diffuse intensity there.
//
// Vertex order: from the dark end (traced along −∇I, where strokes emanate
// from intensity valleys and silhouettes) to the bright end (along +∇I).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fabrica/core/surface_point.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica::hatching {

/// Why a stroke stopped at one end.
enum class StrokeEnd : std::uint8_t {
  threshold,      ///< intensity above the threshold
  extremum,       ///< the field turns back across an edge (intensity valley / ridge), or vanishes
  boundary,       ///< a mesh boundary (or non-manifold) edge
  back_facing,    ///< the surface turns away from the viewer (interpolated n·v = 0)
  occluded,       ///< hidden behind nearer surface (depth buffer)
  length,         ///< the length limit
  proximity,      ///< too close to an earlier stroke or an intensity ridge (proximity grid)
  outside_image,  ///< left the image
  step_limit,     ///< safety limit on faces crossed (should not happen)
  region,         ///< ConFIS: left the contour margin and the feature regions
};
inline constexpr int kStrokeEndCount = 10;
const char* to_string(StrokeEnd end);

struct StrokeVertex {
  SurfacePoint anchor;
  Vec3 position = Vec3::Zero();  ///< mm
  Vec2 pixel = Vec2::Zero();     ///< image position
  double intensity = 0.0;        ///< I (unclamped) at the vertex; ConFIS: n·v
  /// Style weight in [0, 1] scaling the stroke's width and opacity there:
  /// 1 for shading strokes; ConFIS: how deep inside its masks the point is.
  double weight = 1.0;
};

struct Stroke {
  std::vector<StrokeVertex> vertices;          ///< dark end first
  std::size_t seed_vertex = 0;                 ///< index of the seed point in `vertices`
  int seed_level = 0;                          ///< proximity-grid level the seed came from
  StrokeEnd dark_end = StrokeEnd::extremum;    ///< why tracing along −∇I stopped
  StrokeEnd bright_end = StrokeEnd::extremum;  ///< why tracing along +∇I stopped
  double length_px = 0.0;                      ///< image-space length
};

struct HatchingStats {
  std::size_t candidates = 0;      ///< lattice points looked at
  std::size_t seeds = 0;           ///< seeds traced
  std::size_t short_strokes = 0;   ///< traced but shorter than the minimum length (dropped)
  std::size_t ridge_segments = 0;  ///< intensity-ridge segments detected
  std::array<std::size_t, kStrokeEndCount> ends{};  ///< stroke ends by reason (kept strokes)
};

struct StrokeSet {
  int width = 0, height = 0;  ///< image size the strokes were made for
  int grid_depth = 0, seed_depth = 0;
  std::vector<Stroke> strokes;  ///< in the order they were made (coarse seeds first)
  /// Visible intensity-ridge segments (for inspection; empty when ridge
  /// removal is off).
  std::vector<std::array<StrokeVertex, 2>> ridges;
  HatchingStats stats;
};

}  // namespace fabrica::hatching
