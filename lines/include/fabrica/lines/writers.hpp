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

/// Layered SVG: one <g> per layer in the given order (later layers drawn
/// over earlier ones), an Inkscape layer (inkscape:groupmode="layer",
/// inkscape:label = name) with data-name, data-role, its stroke colour and
/// stroke-opacity; inside it one <g data-family="..."> per line family in
/// draw_order(). Paths are written as svg_string() writes them. A layer
/// without lines keeps its (empty) group.
std::string layered_svg_string(const std::vector<LineLayer>& layers, const Camera& camera);
void write_layered_svg(const std::filesystem::path& path, const std::vector<LineLayer>& layers,
                       const Camera& camera);
/// The same strokes as PDF, each layer in its colour and opacity (no PDF
/// layers). Error(unavailable) without cairo.
void write_layered_pdf(const std::filesystem::path& path, const std::vector<LineLayer>& layers,
                       const Camera& camera);

/// `extra` (camera, parameters...) is merged into the top-level object.
nlohmann::json lines_to_json(const LineSet& lines, const nlohmann::json& extra = {});
void write_lines_json(const std::filesystem::path& path, const LineSet& lines,
                      const nlohmann::json& extra = {});

}  // namespace fabrica
