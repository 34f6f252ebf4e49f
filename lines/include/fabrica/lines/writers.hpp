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

/// `extra` (camera, parameters...) is merged into the top-level object.
nlohmann::json lines_to_json(const LineSet& lines, const nlohmann::json& extra = {});
void write_lines_json(const std::filesystem::path& path, const LineSet& lines,
                      const nlohmann::json& extra = {});

}  // namespace fabrica
