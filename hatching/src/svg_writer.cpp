// SVG writer for shading strokes; see the header.
#include "fabrica/hatching/svg_writer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"

namespace fabrica::hatching {
namespace {

double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  if (!(len2 > 0.0)) return (p - a).norm();
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

void simplify_range(const std::vector<Vec2>& points, std::size_t first, std::size_t last,
                    double tolerance, std::vector<std::uint8_t>& keep) {
  // Iterative (explicit stack) so long strokes cannot overflow the call stack.
  std::vector<std::pair<std::size_t, std::size_t>> stack{{first, last}};
  while (!stack.empty()) {
    const auto [lo, hi] = stack.back();
    stack.pop_back();
    if (hi <= lo + 1) continue;
    double worst = -1.0;
    std::size_t at = lo;
    for (std::size_t k = lo + 1; k < hi; ++k) {
      const double d = segment_distance(points[k], points[lo], points[hi]);
      if (d > worst) {
        worst = d;
        at = k;
      }
    }
    if (worst > tolerance) {
      keep[at] = 1;
      stack.push_back({lo, at});
      stack.push_back({at, hi});
    }
  }
}

/// Appends a path: absolute start, then relative steps between coordinates
/// rounded on the output grid (so rounding never accumulates).
void append_path(std::string& out, const std::vector<Vec2>& points, int decimals,
                 const std::string& attributes = {}) {
  const double scale = std::pow(10.0, decimals);
  auto q = [&](double v) { return static_cast<long long>(std::llround(v * scale)); };
  const unsigned long long unit = static_cast<unsigned long long>(std::llround(scale));
  auto number = [&](long long v) {
    const bool negative = v < 0;
    const unsigned long long a = static_cast<unsigned long long>(negative ? -v : v);
    unsigned long long frac = a % unit;
    int digits = decimals;
    while (digits > 0 && frac % 10 == 0) {
      frac /= 10;
      --digits;
    }
    std::string text = negative ? "-" : "";
    text += std::to_string(a / unit);
    if (digits > 0) {
      std::string f = std::to_string(frac);
      text += '.';
      text.append(static_cast<std::size_t>(digits) - f.size(), '0');
      text += f;
    }
    return text;
  };
  long long px = q(points[0].x()), py = q(points[0].y());
  out += "<path ";
  out += attributes;
  out += "d=\"M";
  out += number(px);
  out += ' ';
  out += number(py);
  bool any = false;
  for (std::size_t k = 1; k < points.size(); ++k) {
    const long long x = q(points[k].x()), y = q(points[k].y());
    if (x == px && y == py) continue;
    out += any ? ' ' : 'l';
    out += number(x - px);
    out += ' ';
    out += number(y - py);
    any = true;
    px = x;
    py = y;
  }
  if (!any) out += "h0";  // a dot: still drawn with a round cap
  out += "\"/>\n";
}

std::string fixed(double v, int decimals = 2) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  return buffer;
}

}  // namespace

std::vector<WeightedRun> weighted_runs(const Stroke& stroke, int levels) {
  std::vector<WeightedRun> runs;
  const std::size_t n = stroke.vertices.size();
  if (n == 0) return runs;
  levels = std::max(levels, 1);
  auto quantise = [&](std::size_t k) {
    const double w = 0.5 * (stroke.vertices[k].weight + stroke.vertices[k + 1].weight);
    return std::clamp(std::ceil(w * levels - 1e-9) / levels, 1.0 / levels, 1.0);
  };
  if (n == 1) return {WeightedRun{std::clamp(stroke.vertices[0].weight, 0.0, 1.0), 0, 0}};
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double w = quantise(k);
    if (!runs.empty() && runs.back().weight == w)
      runs.back().last = k + 1;
    else
      runs.push_back(WeightedRun{w, k, k + 1});
  }
  return runs;
}

std::vector<Vec2> simplify_polyline(const std::vector<Vec2>& points, double tolerance) {
  if (points.size() <= 2 || !(tolerance > 0.0)) return points;
  std::vector<std::uint8_t> keep(points.size(), 0);
  keep.front() = keep.back() = 1;
  simplify_range(points, 0, points.size() - 1, tolerance, keep);
  std::vector<Vec2> result;
  for (std::size_t k = 0; k < points.size(); ++k)
    if (keep[k]) result.push_back(points[k]);
  return result;
}

std::string hatching_svg(const StrokeSet& strokes, const SvgStyle& style,
                         const std::vector<SvgLayer>& layers) {
  const int decimals = std::clamp(style.decimals, 0, 6);
  std::string out;
  out += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(strokes.width) +
         "\" height=\"" + std::to_string(strokes.height) + "\" viewBox=\"0 0 " +
         std::to_string(strokes.width) + " " + std::to_string(strokes.height) + "\">\n";
  if (style.background) out += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  const std::string common = "fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\"";
  out += "<g class=\"hatching\" " + common + " stroke=\"" + style.stroke_color +
         "\" stroke-width=\"" + fixed(style.stroke_width_px) + "\">\n";
  std::vector<Vec2> points;
  for (const Stroke& stroke : strokes.strokes) {
    // Runs of one style weight (ConFIS); shading strokes are a single run of 1.
    for (const WeightedRun& run : weighted_runs(stroke)) {
      points.clear();
      for (std::size_t k = run.first; k <= run.last; ++k)
        points.push_back(stroke.vertices[k].pixel);
      if (points.empty()) continue;
      const std::string attributes =
          run.weight == 1.0 ? std::string()
                            : "stroke-width=\"" + fixed(run.weight * style.stroke_width_px, 3) +
                                  "\" stroke-opacity=\"" + fixed(run.weight, 3) + "\" ";
      append_path(out, simplify_polyline(points, style.simplify_px), decimals, attributes);
    }
  }
  out += "</g>\n";
  if (style.draw_ridges && !strokes.ridges.empty()) {
    out += "<g class=\"intensity-ridges\" " + common + " stroke=\"" + style.ridge_color +
           "\" stroke-width=\"" + fixed(style.stroke_width_px) + "\">\n";
    for (const auto& seg : strokes.ridges) append_path(out, {seg[0].pixel, seg[1].pixel}, decimals);
    out += "</g>\n";
  }
  for (const SvgLayer& layer : layers) {
    out += "<g class=\"" + layer.name + "\" " + common + " stroke=\"" + layer.color +
           "\" stroke-width=\"" + fixed(layer.width_px) + "\">\n";
    for (const auto& line : layer.polylines)
      if (!line.empty()) append_path(out, simplify_polyline(line, style.simplify_px), decimals);
    out += "</g>\n";
  }
  out += "</svg>\n";
  return out;
}

void write_hatching_svg(const std::filesystem::path& path, const StrokeSet& strokes,
                        const SvgStyle& style, const std::vector<SvgLayer>& layers) {
  const std::string text = hatching_svg(strokes, style, layers);
  write_file_atomically(path, [&](std::ostream& os) {
    os.write(text.data(), static_cast<std::streamsize>(text.size()));
  });
}

}  // namespace fabrica::hatching
