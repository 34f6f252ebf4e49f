// Vector output of a LineSet (docs/algorithms.md §11.6), all written atomically
// (core/atomic_file.hpp):
//  - SVG: real paths, one <g> per family (id and class = family name, in
//    draw_order()), viewBox in pixels, transparent background, two decimals,
//    deterministic order; hidden lines omitted or dashed (class "hidden").
//  - PDF (cairo): the same strokes as vector paths.
//  - JSON: every polyline with family, closed flag and its vertices' anchors
//    (face + barycentric), positions, strengths and visibility.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/lines/style.hpp"

namespace fabrica {

/// SVG text (for tests and embedding).
std::string svg_string(const LineSet& lines, const Camera& camera, const LineStyle& style = {});
void write_svg(const std::filesystem::path& path, const LineSet& lines, const Camera& camera,
               const LineStyle& style = {});
/// Throws Error(unavailable) when fabrica was built without cairo.
void write_pdf(const std::filesystem::path& path, const LineSet& lines, const Camera& camera,
               const LineStyle& style = {});
bool pdf_available();

/// One layer of a layered drawing (a scene's structure): its own name, role,
/// stroke colour and opacity, styling and lines.
struct LineLayer {
  std::string name;
  std::string role;               ///< written as data-role when not empty
  std::string color = "#000000";  ///< stroke colour of every family, "#rrggbb"
  double opacity = 1.0;           ///< group opacity (stroke-opacity), [0,1]
  double dash = 4.0;              ///< dashed hidden lines: dash and gap, reference pixels
  LineStyle style;
  LineSet lines;
};

/// One element of an overlay drawn over the layers (the annotation of
/// render/annotate.hpp: labels, leaders, legend, scale bar, orientation
/// marker), in pixels (x right, y down).
struct OverlayItem {
  enum class Kind { path, text };
  Kind kind = Kind::path;
  std::string role;  ///< data-role (e.g. "label", "leader", "scale-bar")
  std::string name;  ///< data-name (e.g. the structure's name), may be empty
  double opacity = 1.0;
  // Kind::path
  std::vector<Vec2> points;
  bool closed = false;
  std::string stroke = "#000000";  ///< "#rrggbb", empty: no stroke
  double stroke_width = 1.0;
  std::string fill;  ///< "#rrggbb", empty: no fill
  // Kind::text: `text` on the baseline from `position` (left end), fitted
  // to `text_width`; `box` = x, y (top-left), width, height of its ink.
  std::string text;
  Vec2 position = Vec2::Zero();
  double font_size = 12.0;
  double text_width = 0.0;
  double box[4] = {0, 0, 0, 0};
  std::string text_color = "#000000";
  /// The same text as strokes of fabrica's stroke font (pixels), for
  /// outputs without real text (PNG, PDF).
  std::vector<std::vector<Vec2>> glyph_strokes;
  double glyph_stroke_width = 1.0;
};

/// Items drawn in order over every layer, as one more layer named `name`.
struct VectorOverlay {
  std::string name = "annotation";
  std::vector<OverlayItem> items;
};

/// Layered SVG: one <g> per layer in the given order (later layers drawn
/// over earlier ones), an Inkscape layer (inkscape:groupmode="layer",
/// inkscape:label = name) with data-name, data-role, its stroke colour and
/// stroke-opacity; inside it one <g data-family="..."> per line family in
/// draw_order(). Paths are written as svg_string() writes them. A layer
/// without lines keeps its (empty) group. An `overlay` is written last as
/// one more Inkscape layer (id = its name, data-role="annotation"): paths as
/// <path>, texts as real <text> elements (selectable, textLength fitted to
/// the item's width, data-box with its box).
std::string layered_svg_string(const std::vector<LineLayer>& layers, const Camera& camera,
                               const VectorOverlay* overlay = nullptr);
void write_layered_svg(const std::filesystem::path& path, const std::vector<LineLayer>& layers,
                       const Camera& camera, const VectorOverlay* overlay = nullptr);
/// The same strokes as PDF, each layer in its colour and opacity, then the
/// overlay (texts as their glyph strokes). No PDF layers (optional content
/// groups): cairo has no API for them (docs/rendering.md).
/// Error(unavailable) without cairo.
void write_layered_pdf(const std::filesystem::path& path, const std::vector<LineLayer>& layers,
                       const Camera& camera, const VectorOverlay* overlay = nullptr);

/// `extra` (camera, parameters...) is merged into the top-level object.
nlohmann::json lines_to_json(const LineSet& lines, const nlohmann::json& extra = {});
void write_lines_json(const std::filesystem::path& path, const LineSet& lines,
                      const nlohmann::json& extra = {});

}  // namespace fabrica
