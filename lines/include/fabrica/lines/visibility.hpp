// Hidden-line removal for vector output (docs/algorithms.md §3.5 item 2, §11.3):
// the mesh is rasterised on the CPU into a depth buffer of linear eye depth
// at image resolution; each polyline is sampled every <= 1 px and a sample
// is visible when its depth <= (depth of the 3x3 pixels around it) + epsilon,
// where the window's depth is its MAXIMUM by default. The minimum (see
// docs/algorithms.md §3.5) hides interpolated contours: at a silhouette
// the surface in front of the contour point, one pixel inside, is nearer by
// about sqrt(2 r px) (r the radius of curvature, px the pixel size), far more
// than any sensible epsilon. With the maximum a sample is visible when some
// pixel of the window shows nothing nearer than it, so lines at silhouettes
// survive and lines behind other parts are hidden except within one pixel of
// the occluder's outline. Visibility switches only after `hysteresis` consecutive samples
// agree, and a vertex is inserted where it switches, so chains do not
// flicker. Deterministic at any thread count (depth uses min, which is
// order independent).
#pragma once

#include "fabrica/core/camera.hpp"
#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica {

struct VisibilityOptions {
  /// Depth tolerance in mm; <= 0 uses half the median edge length.
  double epsilon = 0.0;
  double sample_spacing_px = 1.0;
  int hysteresis = 2;  ///< consecutive samples needed to switch state
  /// Compare with the window's maximum (default) or minimum depth.
  bool window_minimum = false;
};

/// Sets LineVertex::visible on every polyline (inserting vertices where
/// visibility changes). Uses `depth` if given, otherwise renders one.
void compute_visibility(LineSet& lines, const Surface& surface, const Camera& camera,
                        const VisibilityOptions& options = {}, const DepthBuffer* depth = nullptr);

}  // namespace fabrica
