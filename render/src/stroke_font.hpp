// fabrica's stroke font (issue 17, item 5): capitals, digits and a little
// punctuation drawn as polylines on a 4 x 6 grid, lower case as small
// capitals. The annotation draws its text with it in PNG and PDF (no font
// file, identical on every machine); the SVG carries real <text> fitted to
// the same box (docs/rendering.md, docs/algorithms.md §13).
#pragma once

#include <string_view>
#include <vector>

#include "fabrica/core/types.hpp"

namespace fabrica::render::detail {

/// Heights of the font's box in units of the font size: ascent above the
/// baseline (capitals reach 0.72) and descent below it.
inline constexpr double kFontAscent = 0.80;
inline constexpr double kFontDescent = 0.16;

/// Advance width of `text` at `size` pixels (the ink's width: no spacing
/// after the last character).
double text_width(std::string_view text, double size);
/// The strokes of `text` with its baseline's left end at `origin`, y down.
std::vector<std::vector<Vec2>> text_strokes(std::string_view text, Vec2 origin, double size);
/// Stroke width the text is drawn with at `size`.
inline double text_stroke_width(double size) {
  return 0.085 * size;
}

}  // namespace fabrica::render::detail
