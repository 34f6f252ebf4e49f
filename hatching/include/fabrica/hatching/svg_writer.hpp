// SVG output of a StrokeSet: one <path> per stroke in image pixels (x right,
// y down, viewBox = the image), optional layers for intensity ridges (for
// inspection) and for feature lines drawn with the strokes. Written
// atomically; the text depends only on the inputs (fixed decimals, strokes in
// StrokeSet order), so repeated runs give identical files.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fabrica/core/types.hpp"
#include "fabrica/hatching/stroke_set.hpp"

namespace fabrica::hatching {

struct SvgStyle {
  double stroke_width_px = 1.0;
  std::string stroke_color = "#000000";
  bool background = true;  ///< white rectangle under everything
  bool draw_ridges = false;
  std::string ridge_color = "#d62728";
  int decimals = 2;          ///< coordinate precision
  double simplify_px = 0.2;  ///< Douglas–Peucker tolerance in pixels (0 = keep every vertex)
};

/// Extra polylines in image pixels drawn above the strokes (e.g. feature lines).
struct SvgLayer {
  std::string name;  ///< used as the group's class
  std::string color = "#000000";
  double width_px = 1.5;
  std::vector<std::vector<Vec2>> polylines;
};

/// The SVG document as text.
std::string hatching_svg(const StrokeSet& strokes, const SvgStyle& style = {},
                         const std::vector<SvgLayer>& layers = {});
/// Writes it atomically; OutputError if the file cannot be written.
void write_hatching_svg(const std::filesystem::path& path, const StrokeSet& strokes,
                        const SvgStyle& style = {}, const std::vector<SvgLayer>& layers = {});

/// A piece of a stroke drawn with one style weight (width and opacity
/// factor): vertices first..last (inclusive; neighbouring runs share their
/// end vertex).
struct WeightedRun {
  double weight = 1.0;
  std::size_t first = 0, last = 0;
};
/// Splits a stroke where its style weight, quantised per segment (the mean
/// of the segment's two vertices rounded up to a multiple of 1/levels),
/// changes. A stroke whose weights are all 1 (shading strokes) is one run.
std::vector<WeightedRun> weighted_runs(const Stroke& stroke, int levels = 8);

/// Douglas–Peucker simplification of an image polyline (keeps both ends).
std::vector<Vec2> simplify_polyline(const std::vector<Vec2>& points, double tolerance);

}  // namespace fabrica::hatching
