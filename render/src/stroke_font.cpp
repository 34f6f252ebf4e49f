#include "stroke_font.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <string>

namespace fabrica::render::detail {
namespace {

// Each glyph: polylines separated by '|', points "x,y" (grid units, y up
// from the baseline, capitals 6 high and 4 wide) separated by spaces.
const char* glyph(char c) {
  switch (c) {
    case 'A':
      return "0,0 2,6 4,0|0.7,2 3.3,2";
    case 'B':
      return "0,3 3,3 4,4 4,5 3,6 0,6 0,0 3,0 4,1 4,2 3,3";
    case 'C':
      return "4,5 3,6 1,6 0,5 0,1 1,0 3,0 4,1";
    case 'D':
      return "0,0 0,6 2,6 4,4 4,2 2,0 0,0";
    case 'E':
      return "4,6 0,6 0,0 4,0|0,3 3,3";
    case 'F':
      return "4,6 0,6 0,0|0,3 3,3";
    case 'G':
      return "4,5 3,6 1,6 0,5 0,1 1,0 3,0 4,1 4,3 2,3";
    case 'H':
      return "0,0 0,6|4,0 4,6|0,3 4,3";
    case 'I':
      return "1,6 3,6|2,6 2,0|1,0 3,0";
    case 'J':
      return "4,6 4,1 3,0 1,0 0,1";
    case 'K':
      return "0,0 0,6|4,6 0,2|1.3,3.3 4,0";
    case 'L':
      return "0,6 0,0 4,0";
    case 'M':
      return "0,0 0,6 2,3 4,6 4,0";
    case 'N':
      return "0,0 0,6 4,0 4,6";
    case 'O':
      return "1,0 0,1 0,5 1,6 3,6 4,5 4,1 3,0 1,0";
    case 'P':
      return "0,0 0,6 3,6 4,5 4,4 3,3 0,3";
    case 'Q':
      return "1,0 0,1 0,5 1,6 3,6 4,5 4,1 3,0 1,0|2.5,1.5 4,0";
    case 'R':
      return "0,0 0,6 3,6 4,5 4,4 3,3 0,3|2,3 4,0";
    case 'S':
      return "4,5 3,6 1,6 0,5 0,4 1,3 3,3 4,2 4,1 3,0 1,0 0,1";
    case 'T':
      return "0,6 4,6|2,6 2,0";
    case 'U':
      return "0,6 0,1 1,0 3,0 4,1 4,6";
    case 'V':
      return "0,6 2,0 4,6";
    case 'W':
      return "0,6 1,0 2,4 3,0 4,6";
    case 'X':
      return "0,0 4,6|0,6 4,0";
    case 'Y':
      return "0,6 2,3 4,6|2,3 2,0";
    case 'Z':
      return "0,6 4,6 0,0 4,0";
    case '0':
      return "1,0 0,1 0,5 1,6 3,6 4,5 4,1 3,0 1,0|1,1.5 3,4.5";
    case '1':
      return "1,5 2,6 2,0|1,0 3,0";
    case '2':
      return "0,5 1,6 3,6 4,5 4,4 0,0 4,0";
    case '3':
      return "0,5 1,6 3,6 4,5 4,4 3,3 1.5,3|3,3 4,2 4,1 3,0 1,0 0,1";
    case '4':
      return "3,0 3,6 0,2 4,2";
    case '5':
      return "4,6 0,6 0,3 3,3 4,2 4,1 3,0 1,0 0,1";
    case '6':
      return "3,6 1,6 0,5 0,1 1,0 3,0 4,1 4,2 3,3 0,3";
    case '7':
      return "0,6 4,6 1,0";
    case '8':
      return "1,3 0,4 0,5 1,6 3,6 4,5 4,4 3,3 1,3 0,2 0,1 1,0 3,0 4,1 4,2 3,3";
    case '9':
      return "1,0 3,0 4,1 4,5 3,6 1,6 0,5 0,4 1,3 4,3";
    case '-':
      return "1,3 3,3";
    case '_':
      return "0,-0.8 4,-0.8";
    case '.':
      return "1.8,0 2.2,0";
    case ',':
      return "2.2,0.4 1.6,-1";
    case ':':
      return "1.8,0.5 2.2,0.5|1.8,4 2.2,4";
    case '(':
      return "3,6.6 2,5.2 1.7,3 2,0.8 3,-0.6";
    case ')':
      return "1,6.6 2,5.2 2.3,3 2,0.8 1,-0.6";
    case '/':
      return "0.5,0 3.5,6";
    case '+':
      return "2,1 2,5|0,3 4,3";
    case '*':
      return "2,1.6 2,4.4|0.8,2.3 3.2,3.7|0.8,3.7 3.2,2.3";
    case '\'':
      return "2,6 2,4.5";
    case '"':
      return "1.4,6 1.4,4.5|2.6,6 2.6,4.5";
    case '=':
      return "0.5,2 3.5,2|0.5,4 3.5,4";
    case '&':
      return "4,0 1,4.5 1,5.5 1.6,6 2.4,6 3,5.5 3,4.8 0,2.2 0,1 1,0 2.4,0 4,2";
    case '#':
      return "1,0 1.6,6|2.6,0 3.2,6|0,2 4,2|0,4 4,4";
    case '%':
      return "0,0 4,6|0.6,5.4 0.6,4.6|3.4,1.4 3.4,0.6";
    case '[':
      return "3,6.6 2,6.6 2,-0.6 3,-0.6";
    case ']':
      return "1,6.6 2,6.6 2,-0.6 1,-0.6";
    case '<':
      return "4,5 0,3 4,1";
    case '>':
      return "0,5 4,3 0,1";
    case '?':
      return "0,5 1,6 3,6 4,5 4,4 2,2.5 2,1.5|1.8,0 2.2,0";
    case '!':
      return "2,6 2,1.5|1.8,0 2.2,0";
    default:
      return nullptr;
  }
}

constexpr double kUnit = 0.12;       // grid unit in font sizes: capitals 0.72 high
constexpr double kAdvance = 5.0;     // grid units per character (4 wide + 1 space)
constexpr double kSpace = 3.0;       // advance of a space
constexpr double kSmallCaps = 0.78;  // lower case: capitals at this scale
const char* const kUnknown = "0,0 0,6 4,6 4,0 0,0";

// One character of `text` (UTF-8: a multi-byte sequence is one unknown
// character), as the glyph to draw and its scale; advances `i`.
struct Char {
  const char* strokes;  // nullptr: a space
  double scale;
};
Char next_char(std::string_view text, std::size_t& i) {
  const auto c = static_cast<unsigned char>(text[i++]);
  if (c >= 0x80) {
    while (i < text.size() && (static_cast<unsigned char>(text[i]) & 0xC0) == 0x80) ++i;
    return {kUnknown, 1.0};
  }
  if (c == ' ' || c == '\t') return {nullptr, 1.0};
  if (std::islower(c)) return {glyph(static_cast<char>(std::toupper(c))), kSmallCaps};
  const char* g = glyph(static_cast<char>(c));
  return {g ? g : kUnknown, 1.0};
}

}  // namespace

double text_width(std::string_view text, double size) {
  double w = 0.0, last_gap = 0.0;
  for (std::size_t i = 0; i < text.size();) {
    const Char ch = next_char(text, i);
    w += ch.strokes ? kAdvance * ch.scale : kSpace;
    last_gap = ch.strokes ? 1.0 * ch.scale : kSpace;
  }
  return std::max(0.0, w - last_gap) * kUnit * size;
}

std::vector<std::vector<Vec2>> text_strokes(std::string_view text, Vec2 origin, double size) {
  std::vector<std::vector<Vec2>> out;
  const double u = kUnit * size;
  double x = 0.0;
  for (std::size_t i = 0; i < text.size();) {
    const Char ch = next_char(text, i);
    if (!ch.strokes) {
      x += kSpace;
      continue;
    }
    std::vector<Vec2> line;
    const char* p = ch.strokes;
    while (*p) {
      char* end = nullptr;
      const double gx = std::strtod(p, &end);
      p = end + 1;  // ','
      const double gy = std::strtod(p, &end);
      p = end;
      line.emplace_back(origin.x() + (x + gx * ch.scale) * u, origin.y() - gy * ch.scale * u);
      if (*p == '|' || *p == '\0') {
        out.push_back(std::move(line));
        line.clear();
      }
      if (*p) ++p;
    }
    x += kAdvance * ch.scale;
  }
  return out;
}

}  // namespace fabrica::render::detail
