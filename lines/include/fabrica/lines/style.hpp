// Styling for vector output (docs/algorithms.md §11.5): strength -> width or
// opacity, tapered ends, thicker contours, and hidden lines omitted or
// dashed. Produces projected stroke pieces (pixel coordinates, y down) that
// the SVG and PDF writers draw as real vector paths. Widths are given for a
// 1024-pixel image and scale with min(width, height), so a figure looks the
// same at any resolution.
#pragma once

#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica {

/// omit: hidden parts dropped; dashed: drawn dashed at hidden_opacity;
/// solid: drawn solid at hidden_opacity (a scene's hidden "show").
enum class HiddenLines { omit, dashed, solid };

struct LineStyle {
  double width_px = 1.2;             ///< stroke width of interior lines at 1024 px
  double reference_size = 1024;      ///< image size at which width_px applies
  double contour_factor = 1.7;       ///< contours and boundaries are drawn thicker
  double min_width_fraction = 0.35;  ///< width at strength 0, as a fraction
  bool width_from_strength = true;
  bool opacity_from_strength = false;
  double taper_fraction = 0.15;  ///< of the chain length at each open end; 0 = none
  double taper_max_px = 12.0;    ///< taper length cap in pixels
  HiddenLines hidden = HiddenLines::omit;
  double hidden_opacity = 0.5;
};

/// One stroke with a constant width and opacity.
struct StrokePiece {
  LineFamily family = LineFamily::contour;
  bool hidden = false;
  bool closed = false;
  double width = 1.0;    ///< pixels
  double opacity = 1.0;  ///< [0,1]
  std::vector<Vec2> points;
};

/// Families in drawing order (contours last, on top).
std::vector<LineFamily> draw_order();
/// Stroke colour of a family as "#rrggbb".
const char* family_color(LineFamily family);

/// Pieces in draw_order(), then polyline order; deterministic.
std::vector<StrokePiece> stroke_pieces(const LineSet& lines, const Camera& camera,
                                       const LineStyle& style);

}  // namespace fabrica
