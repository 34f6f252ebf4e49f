#include "fabrica/lines/style.hpp"

#include <algorithm>
#include <cmath>

namespace fabrica {

std::vector<LineFamily> draw_order() {
  return {LineFamily::demarcating, LineFamily::laplacian,  LineFamily::pel,
          LineFamily::highlight,   LineFamily::valley,     LineFamily::ridge,
          LineFamily::apparent,    LineFamily::suggestive, LineFamily::crease,
          LineFamily::boundary,    LineFamily::contour};
}

const char* family_color(LineFamily family) {
  switch (family) {
    case LineFamily::contour:
      return "#000000";
    case LineFamily::boundary:
      return "#000000";
    case LineFamily::crease:
      return "#202020";
    case LineFamily::suggestive:
      return "#000000";
    case LineFamily::highlight:
      return "#9a9a9a";
    case LineFamily::ridge:
      return "#8c1c13";
    case LineFamily::valley:
      return "#1b4f8a";
    case LineFamily::apparent:
      return "#000000";
    case LineFamily::pel:
      return "#000000";
    case LineFamily::laplacian:
      return "#000000";
    case LineFamily::demarcating:
      return "#3d5a1e";
  }
  return "#000000";
}

namespace {

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

}  // namespace

std::vector<StrokePiece> stroke_pieces(const LineSet& lines, const Camera& camera,
                                       const LineStyle& style) {
  std::vector<StrokePiece> out;
  const double scale = std::min(camera.width, camera.height) / std::max(style.reference_size, 1.0);
  for (LineFamily fam : draw_order()) {
    const bool thick = fam == LineFamily::contour || fam == LineFamily::boundary;
    const double base = style.width_px * scale * (thick ? style.contour_factor : 1.0);
    for (const auto& pl : lines.polylines) {
      if (pl.family != fam) continue;
      const std::size_t n = pl.vertices.size();
      if (n < 2) continue;
      const std::size_t edges = pl.closed ? n : n - 1;
      std::vector<Vec2> px(n);
      for (std::size_t i = 0; i < n; ++i) px[i] = project(camera, pl.vertices[i].position).pixel;
      // Arc length in pixels for the taper.
      std::vector<double> s(n + 1, 0.0);
      for (std::size_t i = 0; i < edges; ++i) s[i + 1] = s[i] + (px[(i + 1) % n] - px[i]).norm();
      const double total = s[edges];
      const double taper_len =
          (!pl.closed && style.taper_fraction > 0.0)
              ? std::min(style.taper_fraction * total, style.taper_max_px * scale)
              : 0.0;
      auto width_at = [&](std::size_t i, double arc) {
        double w = base;
        if (style.width_from_strength)
          w *= style.min_width_fraction +
               (1.0 - style.min_width_fraction) * std::clamp<double>(pl.vertices[i].strength, 0, 1);
        if (taper_len > 0.0) {
          const double d = std::min(arc, total - arc);
          w *= 0.3 + 0.7 * smoothstep(d / taper_len);
        }
        return w;
      };
      auto opacity_at = [&](std::size_t i) {
        return style.opacity_from_strength ? std::clamp<double>(pl.vertices[i].strength, 0, 1)
                                           : 1.0;
      };
      // Each edge gets the mean width/opacity of its ends, quantised; runs of
      // edges with equal (hidden, width, opacity) become one piece.
      StrokePiece cur;
      bool open = false;
      auto flush = [&]() {
        if (open && cur.points.size() >= 2) out.push_back(cur);
        open = false;
      };
      for (std::size_t i = 0; i < edges; ++i) {
        const std::size_t j = (i + 1) % n;
        const bool hidden = !pl.vertices[i].visible;
        if (hidden && style.hidden == HiddenLines::omit) {
          flush();
          continue;
        }
        double w = 0.5 * (width_at(i, s[i]) + width_at(j, s[i + 1]));
        double o = 0.5 * (opacity_at(i) + opacity_at(j));
        w = std::max(0.05, std::round(w * 20.0) / 20.0);
        o = std::round(o * 20.0) / 20.0;
        if (hidden) o *= style.hidden_opacity;
        if (!open || cur.hidden != hidden || cur.width != w || cur.opacity != o) {
          flush();
          cur = StrokePiece{};
          cur.family = fam;
          cur.hidden = hidden;
          cur.width = w;
          cur.opacity = o;
          cur.points.push_back(px[i]);
          open = true;
        }
        cur.points.push_back(px[j]);
      }
      // A loop drawn as a single piece is closed.
      if (open && pl.closed && cur.points.size() == edges + 1) {
        cur.points.pop_back();
        cur.closed = true;
      }
      flush();
    }
  }
  return out;
}

}  // namespace fabrica
