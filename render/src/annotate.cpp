#include "fabrica/render/annotate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "fabrica/lines/visibility.hpp"
#include "stroke_font.hpp"

namespace fabrica::render {

double pixels_per_mm(const Camera& camera, double depth) {
  const double half_h = std::tan(0.5 * camera.fov_deg * 3.14159265358979323846 / 180.0);
  const double seen = camera.projection == Projection::orthographic
                          ? (camera.center - camera.eye).norm() * half_h
                          : depth * half_h;
  return seen > 0.0 ? 0.5 * camera.height / seen : 0.0;
}

std::vector<int> structure_map(const SceneSurfaces& scene, const Camera& camera) {
  const std::size_t n = static_cast<std::size_t>(camera.width) * camera.height;
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> best_opaque(n, inf), best_ghost(n, inf);
  std::vector<int> opaque(n, -1), ghost(n, -1);
  DepthBuffer depth;
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
    render_depth(scene.surfaces[i]->mesh(), camera, depth);
    const bool is_opaque = scene.spec.structures[i].style.opacity >= 0.999;
    std::vector<float>& best = is_opaque ? best_opaque : best_ghost;
    std::vector<int>& owner = is_opaque ? opaque : ghost;
    for (std::size_t p = 0; p < n; ++p)
      if (depth.depth[p] < best[p]) {
        best[p] = depth.depth[p];
        owner[p] = static_cast<int>(i);
      }
  }
  for (std::size_t p = 0; p < n; ++p)
    if (opaque[p] < 0) opaque[p] = ghost[p];
  return opaque;
}

namespace {

struct Box {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  Box grown(double d) const { return {x0 - d, y0 - d, x1 + d, y1 + d}; }
  bool overlaps(const Box& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
  double w() const { return x1 - x0; }
  double h() const { return y1 - y0; }
};

// The structure map on a grid of at most kGridSide pixels a side (the
// picture scaled by `scale`), with a summed-area table of its covered
// pixels for box queries.
constexpr int kGridSide = 2048;
struct Grid {
  int w = 0, h = 0;
  double scale = 1.0;  // grid pixels per picture pixel
  Camera camera;       // the picture's camera at the grid's size
  std::vector<int> owner;
  std::vector<long long> sat;  // (w+1) x (h+1)

  // Covered grid pixels in the picture-pixel box b (every grid pixel b touches).
  long long covered(const Box& b) const {
    const int gx0 = std::clamp(static_cast<int>(std::floor(b.x0 * scale)), 0, w);
    const int gy0 = std::clamp(static_cast<int>(std::floor(b.y0 * scale)), 0, h);
    const int gx1 = std::clamp(static_cast<int>(std::ceil(b.x1 * scale)), 0, w);
    const int gy1 = std::clamp(static_cast<int>(std::ceil(b.y1 * scale)), 0, h);
    auto at = [&](int x, int y) { return sat[static_cast<std::size_t>(y) * (w + 1) + x]; };
    return at(gx1, gy1) - at(gx0, gy1) - at(gx1, gy0) + at(gx0, gy0);
  }
};

Grid make_grid(const SceneSurfaces& scene, const Camera& camera) {
  Grid g;
  g.scale = std::min(1.0, static_cast<double>(kGridSide) / std::max(camera.width, camera.height));
  Camera c = camera;
  c.width = std::max(1, static_cast<int>(std::lround(camera.width * g.scale)));
  c.height = std::max(1, static_cast<int>(std::lround(camera.height * g.scale)));
  g.w = c.width;
  g.h = c.height;
  g.scale = static_cast<double>(g.h) / camera.height;
  g.camera = c;
  g.owner = structure_map(scene, c);
  g.sat.assign(static_cast<std::size_t>(g.w + 1) * (g.h + 1), 0);
  for (int y = 0; y < g.h; ++y) {
    long long row = 0;
    for (int x = 0; x < g.w; ++x) {
      row += g.owner[static_cast<std::size_t>(y) * g.w + x] >= 0 ? 1 : 0;
      g.sat[static_cast<std::size_t>(y + 1) * (g.w + 1) + x + 1] =
          g.sat[static_cast<std::size_t>(y) * (g.w + 1) + x + 1] + row;
    }
  }
  return g;
}

// Chamfer (3-4) distance of every pixel of a w × h label map to the edge of
// its region (a pixel whose 4-neighbour has another label, or the edge of
// the map); docs/algorithms.md §13 step 2.
std::vector<float> region_depth(const std::vector<int>& labels, int w, int h) {
  const float big = 1e30f;
  std::vector<float> d(labels.size(), big);
  auto id = [&](int x, int y) { return static_cast<std::size_t>(y) * w + x; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int o = labels[id(x, y)];
      const bool edge = x == 0 || y == 0 || x == w - 1 || y == h - 1 || labels[id(x - 1, y)] != o ||
                        labels[id(x + 1, y)] != o || labels[id(x, y - 1)] != o ||
                        labels[id(x, y + 1)] != o;
      if (edge) d[id(x, y)] = 0.0f;
    }
  auto relax = [&](int x, int y, int dx, int dy, float cost) {
    const int nx = x + dx, ny = y + dy;
    if (nx < 0 || ny < 0 || nx >= w || ny >= h) return;
    d[id(x, y)] = std::min(d[id(x, y)], d[id(nx, ny)] + cost);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      relax(x, y, -1, 0, 3.0f);
      relax(x, y, 0, -1, 3.0f);
      relax(x, y, -1, -1, 4.0f);
      relax(x, y, 1, -1, 4.0f);
    }
  for (int y = h - 1; y >= 0; --y)
    for (int x = w - 1; x >= 0; --x) {
      relax(x, y, 1, 0, 3.0f);
      relax(x, y, 0, 1, 3.0f);
      relax(x, y, 1, 1, 4.0f);
      relax(x, y, -1, 1, 4.0f);
    }
  return d;
}

// Segments ab and cd cross (proper intersection or touching).
bool segments_cross(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  auto orient = [](Vec2 p, Vec2 q, Vec2 r) {
    const double v = (q.x() - p.x()) * (r.y() - p.y()) - (q.y() - p.y()) * (r.x() - p.x());
    return (v > 1e-9) - (v < -1e-9);
  };
  auto on = [](Vec2 p, Vec2 q, Vec2 r) {  // r on segment pq, given collinear
    return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  return (o1 == 0 && on(a, b, c)) || (o2 == 0 && on(a, b, d)) || (o3 == 0 && on(c, d, a)) ||
         (o4 == 0 && on(c, d, b));
}

double point_segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 d = b - a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * d)).norm();
}

// Distance between segments ab and cd (0 when they cross).
double segment_distance(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  if (segments_cross(a, b, c, d)) return 0.0;
  return std::min({point_segment_distance(a, c, d), point_segment_distance(b, c, d),
                   point_segment_distance(c, a, b), point_segment_distance(d, a, b)});
}

// Segment ab passes through box b (Liang-Barsky clipping).
bool segment_hits_box(Vec2 a, Vec2 b, const Box& box) {
  double t0 = 0.0, t1 = 1.0;
  const double dx = b.x() - a.x(), dy = b.y() - a.y();
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a.x() - box.x0, box.x1 - a.x(), a.y() - box.y0, box.y1 - a.y()};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0.0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
    if (t0 > t1) return false;
  }
  return true;
}

OverlayItem path_item(std::string role, std::string name, std::vector<Vec2> points, bool closed,
                      std::string stroke, double width, std::string fill = {}) {
  OverlayItem it;
  it.kind = OverlayItem::Kind::path;
  it.role = std::move(role);
  it.name = std::move(name);
  it.points = std::move(points);
  it.closed = closed;
  it.stroke = std::move(stroke);
  it.stroke_width = width;
  it.fill = std::move(fill);
  return it;
}

OverlayItem text_item(std::string role, std::string name, const std::string& text, Vec2 origin,
                      double size, const std::string& color = "#111111") {
  OverlayItem it;
  it.kind = OverlayItem::Kind::text;
  it.role = std::move(role);
  it.name = std::move(name);
  it.text = text;
  it.position = origin;
  it.font_size = size;
  it.text_width = detail::text_width(text, size);
  it.box[0] = origin.x();
  it.box[1] = origin.y() - detail::kFontAscent * size;
  it.box[2] = it.text_width;
  it.box[3] = (detail::kFontAscent + detail::kFontDescent) * size;
  it.text_color = color;
  it.glyph_strokes = detail::text_strokes(text, origin, size);
  it.glyph_stroke_width = detail::text_stroke_width(size);
  return it;
}

std::vector<Vec2> rect(const Box& b) {
  return {{b.x0, b.y0}, {b.x1, b.y0}, {b.x1, b.y1}, {b.x0, b.y1}};
}

// The text box of height `h`, width `w` whose side faces the anchor and
// touches P, for a ray leaving the anchor in direction (cx, cy).
Box box_at(Vec2 p, double cx, double cy, double w, double h) {
  if (cx > 0.35) return {p.x(), p.y() - 0.5 * h, p.x() + w, p.y() + 0.5 * h};
  if (cx < -0.35) return {p.x() - w, p.y() - 0.5 * h, p.x(), p.y() + 0.5 * h};
  if (cy < 0.0) return {p.x() - 0.5 * w, p.y() - h, p.x() + 0.5 * w, p.y()};
  return {p.x() - 0.5 * w, p.y(), p.x() + 0.5 * w, p.y() + h};
}

// The largest length 1, 2 or 5 × 10^k mm that is at most `max_mm`.
double nice_length(double max_mm) {
  if (!(max_mm > 0.0)) return 0.0;
  const double p = std::pow(10.0, std::floor(std::log10(max_mm)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= max_mm) return m * p;
  return p;
}

std::string format_mm(double mm) {
  char buf[48];
  if (mm >= 1.0)
    std::snprintf(buf, sizeof buf, "%.0f mm", mm);
  else
    std::snprintf(buf, sizeof buf, "%g mm", mm);
  return buf;
}

std::string display_name(const StructureSpec& s) {
  if (!s.label.empty()) return s.label;
  std::string t = s.name;
  std::replace(t.begin(), t.end(), '_', ' ');
  return t;
}

}  // namespace

Annotation annotate_scene(const SceneSurfaces& scene, const Camera& camera,
                          const AnnotationSpec& options) {
  Annotation out;
  if (!options.any() || scene.surfaces.empty()) return out;
  const double unit = std::min(camera.width, camera.height) / 1024.0;
  const double font = std::max(4.0, options.font_size * unit);
  out.font_px = font;
  const double pad = std::max(3.0, 0.35 * font);  // free space around texts and boxes
  const double margin = 0.8 * font;               // from the picture's edges
  const double ink = std::max(1.0, font / 12.0);  // leader and frame width
  const Grid grid = make_grid(scene, camera);
  const Box picture{0.0, 0.0, static_cast<double>(camera.width),
                    static_cast<double>(camera.height)};
  std::vector<Box> taken;  // legend, scale bar, marker, placed labels (grown by pad)

  // Corner blocks (legend, scale bar, orientation marker): each in the free
  // corner whose box covers the fewest structure pixels; fixed order on ties.
  std::array<bool, 4> corner_used{};
  auto place_corner = [&](double w, double h) {
    const Box candidates[4] = {
        {margin, camera.height - margin - h, margin + w, camera.height - margin},
        {camera.width - margin - w, camera.height - margin - h, camera.width - margin,
         camera.height - margin},
        {margin, margin, margin + w, margin + h},
        {camera.width - margin - w, margin, camera.width - margin, margin + h}};
    int best = -1;
    long long best_cover = 0;
    for (int k = 0; k < 4; ++k) {
      if (corner_used[k]) continue;
      const long long c = grid.covered(candidates[k]);
      if (best < 0 || c < best_cover) best = k, best_cover = c;
    }
    corner_used[best] = true;
    taken.push_back(candidates[best].grown(pad));
    return candidates[best];
  };

  // Scale bar: the longest 1/2/5 × 10^k mm at most a fifth of the width, at
  // the focus depth for a perspective camera.
  std::vector<OverlayItem> corner_items;
  if (options.scale_bar) {
    const Vec3 target = 0.5 * ((scene.has_focus ? scene.focus_box : scene.box).min +
                               (scene.has_focus ? scene.focus_box : scene.box).max);
    const double depth = (target - camera.eye).dot(camera.forward());
    out.px_per_mm = pixels_per_mm(camera, depth);
    out.scale_at_focus_depth = camera.projection == Projection::perspective;
    if (out.px_per_mm > 0.0) {
      out.scale_bar_mm = nice_length(0.2 * camera.width / out.px_per_mm);
      const double len = out.scale_bar_mm * out.px_per_mm;
      const std::string label = format_mm(out.scale_bar_mm);
      const double tw = detail::text_width(label, font);
      const double w = std::max(len, tw), tick = 0.4 * font;
      const double h = (detail::kFontAscent + detail::kFontDescent) * font + 0.3 * font + tick;
      const Box b = place_corner(w, h);
      const double x0 = b.x0 + 0.5 * (w - len), y = b.y1 - 0.5 * tick;
      corner_items.push_back(path_item("scale-bar", format_mm(out.scale_bar_mm),
                                       {{x0, y}, {x0 + len, y}}, false, "#111111", 1.5 * ink));
      corner_items.push_back(path_item("scale-bar-tick", "",
                                       {{x0, y - 0.5 * tick}, {x0, y + 0.5 * tick}}, false,
                                       "#111111", ink));
      corner_items.push_back(path_item("scale-bar-tick", "",
                                       {{x0 + len, y - 0.5 * tick}, {x0 + len, y + 0.5 * tick}},
                                       false, "#111111", ink));
      corner_items.push_back(text_item(
          "scale-bar-text", "", label,
          {b.x0 + 0.5 * (w - tw), y - 0.5 * tick - 0.3 * font - detail::kFontDescent * font},
          font));
    }
  }

  // Orientation marker: the patient axes (LPS: +x left, +y posterior, +z
  // superior; RAS: +x right, +y anterior) as seen by the camera; an axis
  // along the view (shorter than 0.3 on screen) is left out.
  if (options.orientation) {
    const double r = 2.2 * font, letter = 0.9 * font;
    const double side = 2.0 * (r + 1.2 * letter);
    const Box b = place_corner(side, side);
    const Vec2 c(0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1));
    const bool ras = scene.space == Space::ras;
    const struct {
      Vec3 dir;
      const char* plus;
      const char* minus;
    } axes[3] = {{Vec3(1, 0, 0), ras ? "R" : "L", ras ? "L" : "R"},
                 {Vec3(0, 1, 0), ras ? "A" : "P", ras ? "P" : "A"},
                 {Vec3(0, 0, 1), "S", "I"}};
    const Vec3 right = camera.right(), up = camera.true_up();
    for (const auto& axis : axes) {
      const Vec2 s(axis.dir.dot(right), -axis.dir.dot(up));
      if (s.norm() < 0.3) continue;
      for (int sign : {1, -1}) {
        const Vec2 tip = c + sign * r * s;
        const char* name = sign > 0 ? axis.plus : axis.minus;
        corner_items.push_back(
            path_item("orientation-axis", name, {c, tip}, false, "#333333", ink));
        const double tw = detail::text_width(name, letter);
        const Vec2 centre = c + sign * (r + 0.7 * letter) * s.normalized() * std::max(1.0, 1.0);
        corner_items.push_back(
            text_item("orientation", name, name,
                      {centre.x() - 0.5 * tw,
                       centre.y() + 0.5 * (detail::kFontAscent - detail::kFontDescent) * letter -
                           0.04 * letter},
                      letter));
      }
    }
  }

  // Legend: a swatch in the structure's colour and its name per structure
  // (scene order), "(focus)" after focus structures, and the scale bar's
  // depth for a perspective camera.
  if (options.legend) {
    std::vector<std::string> lines;
    for (const auto& s : scene.spec.structures)
      lines.push_back(display_name(s) + (s.role == Role::focus ? " (focus)" : ""));
    if (options.scale_bar && out.scale_at_focus_depth && out.scale_bar_mm > 0.0)
      lines.push_back("scale at focus depth (perspective)");
    // 0.85 font sizes, smaller when the legend would not fit the picture.
    double tw1 = 0.0;  // widest line at size 1
    for (const auto& l : lines) tw1 = std::max(tw1, detail::text_width(l, 1.0));
    const double fit_h = (camera.height - 2.0 * margin) / (0.6 + 1.45 * lines.size());
    const double fit_w = (camera.width - 2.0 * margin) / (2.6 + tw1);
    const double size = std::max(1.0, std::min({0.85 * font, fit_h, fit_w}));
    const double row = 1.45 * size, sw = 0.9 * size;
    const double tw = tw1 * size;
    const double w = 0.6 * size + sw + 0.5 * size + tw + 0.6 * size;
    const double h = 0.6 * size + row * lines.size();
    const Box b = place_corner(w, h);
    OverlayItem frame =
        path_item("legend-frame", "", rect(b), true, "#777777", 0.6 * ink, "#ffffff");
    frame.opacity = 0.9;
    out.overlay.items.push_back(frame);
    for (std::size_t k = 0; k < lines.size(); ++k) {
      const double y = b.y0 + 0.3 * size + row * (k + 0.5);
      double x = b.x0 + 0.6 * size;
      if (k < scene.spec.structures.size()) {
        const StructureSpec& s = scene.spec.structures[k];
        out.overlay.items.push_back(path_item("legend-swatch", s.name,
                                              rect({x, y - 0.5 * sw, x + sw, y + 0.5 * sw}), true,
                                              "#555555", 0.5 * ink, to_hex(s.style.color)));
        x += sw + 0.5 * size;
      }
      out.overlay.items.push_back(text_item(
          "legend-text", k < scene.spec.structures.size() ? scene.spec.structures[k].name : "",
          lines[k],
          {x, y + 0.5 * (detail::kFontAscent - detail::kFontDescent) * size - 0.04 * size}, size));
    }
  }
  for (auto& it : corner_items) out.overlay.items.push_back(std::move(it));

  // Labels (docs/algorithms.md §13 step 3): each anchored where its structure is shown, at the
  // pixel deepest inside that region; the text at the nearest free place along 16 rays from the
  // anchor (distance first, then the rays in a fixed order: sideways before up and down), outside
  // every silhouette, clear of the other texts and blocks, its leader crossing no other leader or
  // text.
  if (options.labels) {
    const std::vector<float> inside = region_depth(grid.owner, grid.w, grid.h);
    // Where a structure is nowhere in front (a ghosted one behind another
    // ghosted one): the pixels where it is seen through ghosted structures
    // only, none opaque in front of it.
    auto seen_through = [&](std::size_t i) {
      DepthBuffer mine, opaque;
      render_depth(scene.surfaces[i]->mesh(), grid.camera, mine);
      std::vector<int> mask(grid.owner.size(), 0);
      for (std::size_t p = 0; p < mask.size(); ++p) {
        const int o = grid.owner[p];
        const bool opaque_in_front =
            o >= 0 && scene.spec.structures[static_cast<std::size_t>(o)].style.opacity >= 0.999;
        mask[p] = std::isfinite(mine.depth[p]) && !opaque_in_front ? 1 : 0;
      }
      return mask;
    };
    std::vector<std::size_t> order;
    for (Role role : {Role::focus, Role::context})
      for (std::size_t i = 0; i < scene.spec.structures.size(); ++i)
        if (scene.spec.structures[i].role == role && scene.spec.structures[i].show_label)
          order.push_back(i);
    // A leader crosses no opaque (focus) structure but its own.
    auto crosses_opaque = [&](Vec2 a, Vec2 b, std::size_t own) {
      const int steps = static_cast<int>(std::ceil((b - a).norm() * grid.scale)) + 1;
      for (int k = 0; k <= steps; ++k) {
        const Vec2 p = (a + (b - a) * (static_cast<double>(k) / steps)) * grid.scale;
        const int x = std::clamp(static_cast<int>(p.x()), 0, grid.w - 1);
        const int y = std::clamp(static_cast<int>(p.y()), 0, grid.h - 1);
        const int o = grid.owner[static_cast<std::size_t>(y) * grid.w + x];
        if (o >= 0 && o != static_cast<int>(own) &&
            scene.spec.structures[static_cast<std::size_t>(o)].style.opacity >= 0.999)
          return true;
      }
      return false;
    };
    std::vector<std::pair<Vec2, Vec2>> leaders;
    std::vector<Box> label_boxes;
    static const double kAngles[16] = {0,   180,  22.5, 157.5, -22.5, -157.5, 45, 135,
                                       -45, -135, 67.5, 112.5, -67.5, -112.5, 90, -90};
    for (std::size_t i : order) {
      const StructureSpec& s = scene.spec.structures[i];
      const std::string text = display_name(s);
      // The anchor: the grid pixel of this structure farthest from its region's edge.
      std::size_t best = grid.owner.size();
      for (std::size_t p = 0; p < grid.owner.size(); ++p)
        if (grid.owner[p] == static_cast<int>(i) &&
            (best == grid.owner.size() || inside[p] > inside[best]))
          best = p;
      if (best == grid.owner.size()) {
        const std::vector<int> mask = seen_through(i);
        const std::vector<float> depth = region_depth(mask, grid.w, grid.h);
        for (std::size_t p = 0; p < mask.size(); ++p)
          if (mask[p] && (best == mask.size() || depth[p] > depth[best])) best = p;
      }
      if (best == grid.owner.size()) {
        out.skipped.push_back(s.name + ": not visible in this view");
        continue;
      }
      const Vec2 anchor((static_cast<double>(best % grid.w) + 0.5) / grid.scale,
                        (static_cast<double>(best / grid.w) + 0.5) / grid.scale);
      const double tw = detail::text_width(text, font);
      const double th = (detail::kFontAscent + detail::kFontDescent) * font;
      bool placed = false;
      const double max_r = std::hypot(camera.width, camera.height);
      for (double r = 1.5 * font; r < max_r && !placed; r += 0.5 * font) {
        for (double deg : kAngles) {
          const double a = deg * 3.14159265358979323846 / 180.0;
          const double cx = std::cos(a), cy = -std::sin(a);  // y down: positive angles go up
          const Vec2 p = anchor + r * Vec2(cx, cy);
          const Box b = box_at(p, cx, cy, tw, th);
          const Box padded = b.grown(pad);
          if (b.x0 < margin || b.y0 < margin || b.x1 > picture.x1 - margin ||
              b.y1 > picture.y1 - margin)
            continue;
          if (grid.covered(padded) > 0) continue;
          if (std::any_of(taken.begin(), taken.end(),
                          [&](const Box& t) { return t.overlaps(padded); }))
            continue;
          const Vec2 end(std::clamp(anchor.x(), b.x0, b.x1), std::clamp(anchor.y(), b.y0, b.y1));
          const Vec2 gap =
              (end - anchor).norm() > 0.0 ? Vec2((end - anchor).normalized()) : Vec2(0, 0);
          const Vec2 leader_end = end - 0.25 * font * gap;
          bool clear = true;
          for (const auto& l : leaders)
            if (segment_distance(anchor, leader_end, l.first, l.second) < pad ||
                segment_hits_box(l.first, l.second, padded))
              clear = false;
          for (const Box& t : taken)
            if (clear && segment_hits_box(anchor, leader_end, t)) clear = false;
          if (clear && crosses_opaque(anchor, leader_end, i)) clear = false;
          if (!clear) continue;
          PlacedLabel label;
          label.structure = i;
          label.text = text;
          label.anchor = anchor;
          label.leader_end = leader_end;
          label.box[0] = b.x0;
          label.box[1] = b.y0;
          label.box[2] = b.w();
          label.box[3] = b.h();
          out.labels.push_back(label);
          leaders.emplace_back(anchor, leader_end);
          taken.push_back(padded);
          placed = true;
          break;
        }
      }
      if (!placed) out.skipped.push_back(s.name + ": no free place outside the silhouettes");
    }
    for (const PlacedLabel& l : out.labels) {
      const std::string& name = scene.spec.structures[l.structure].name;
      out.overlay.items.push_back(
          path_item("leader", name, {l.anchor, l.leader_end}, false, "#222222", ink));
      std::vector<Vec2> dot;
      for (int k = 0; k < 12; ++k) {
        const double a = k * 2.0 * 3.14159265358979323846 / 12.0;
        dot.push_back(l.anchor + 0.22 * font * Vec2(std::cos(a), std::sin(a)));
      }
      out.overlay.items.push_back(
          path_item("anchor", name, dot, true, "#ffffff", 0.5 * ink, "#222222"));
      out.overlay.items.push_back(text_item(
          "label", name, l.text, {l.box[0], l.box[1] + detail::kFontAscent * font}, font));
    }
  }
  return out;
}

namespace {

// Straight-alpha "over" of colour (r, g, b) at coverage a onto pixel px.
void blend(std::uint8_t* px, double r, double g, double b, double a) {
  if (a <= 0.0) return;
  const double da = px[3] / 255.0;
  const double oa = a + da * (1.0 - a);
  if (oa <= 0.0) return;
  const double src[3] = {r, g, b};
  for (int c = 0; c < 3; ++c) {
    const double v = (src[c] * a + px[c] / 255.0 * da * (1.0 - a)) / oa;
    px[c] = static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
  }
  px[3] = static_cast<std::uint8_t>(std::lround(std::clamp(oa, 0.0, 1.0) * 255.0));
}

void rgb(const std::string& hex, double& r, double& g, double& b) {
  unsigned v = 0;
  if (hex.size() == 7) std::sscanf(hex.c_str() + 1, "%06x", &v);
  r = ((v >> 16) & 0xff) / 255.0;
  g = ((v >> 8) & 0xff) / 255.0;
  b = (v & 0xff) / 255.0;
}

// Coverage of a set of strokes of width `width` (max over the segments, so
// joints are not blended twice) and of a filled polygon, in the item's box.
struct Coverage {
  int x0 = 0, y0 = 0, w = 0, h = 0;
  std::vector<float> a;
  Coverage(const Image& image, double bx0, double by0, double bx1, double by1) {
    x0 = std::clamp(static_cast<int>(std::floor(bx0)) - 1, 0, image.width);
    y0 = std::clamp(static_cast<int>(std::floor(by0)) - 1, 0, image.height);
    const int x1 = std::clamp(static_cast<int>(std::ceil(bx1)) + 1, 0, image.width);
    const int y1 = std::clamp(static_cast<int>(std::ceil(by1)) + 1, 0, image.height);
    w = std::max(0, x1 - x0);
    h = std::max(0, y1 - y0);
    a.assign(static_cast<std::size_t>(w) * h, 0.0f);
  }
  void stroke(Vec2 p, Vec2 q, double width) {
    const double half = 0.5 * std::max(width, 1.0);
    const double weight = std::min(width, 1.0);  // thinner than a pixel: fainter
    const Vec2 d = q - p;
    const double len2 = d.squaredNorm();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec2 c(x0 + x + 0.5, y0 + y + 0.5);
        const double t = len2 > 0.0 ? std::clamp((c - p).dot(d) / len2, 0.0, 1.0) : 0.0;
        const double dist = (c - (p + t * d)).norm();
        const double v = std::clamp(half + 0.5 - dist, 0.0, 1.0) * weight;
        float& cell = a[static_cast<std::size_t>(y) * w + x];
        cell = std::max(cell, static_cast<float>(v));
      }
  }
  void fill(const std::vector<Vec2>& poly) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec2 c(x0 + x + 0.5, y0 + y + 0.5);
        bool in = false;
        for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++)
          if ((poly[i].y() > c.y()) != (poly[j].y() > c.y()) &&
              c.x() < (poly[j].x() - poly[i].x()) * (c.y() - poly[i].y()) /
                              (poly[j].y() - poly[i].y()) +
                          poly[i].x())
            in = !in;
        if (in) a[static_cast<std::size_t>(y) * w + x] = 1.0f;
      }
  }
  void apply(Image& image, const std::string& hex, double opacity) const {
    double r, g, b;
    rgb(hex, r, g, b);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float v = a[static_cast<std::size_t>(y) * w + x];
        if (v > 0.0f) blend(image.pixel(x0 + x, y0 + y), r, g, b, v * opacity);
      }
  }
};

template <class Lines>
void bounds(const Lines& lines, double grow, double& x0, double& y0, double& x1, double& y1) {
  x0 = y0 = std::numeric_limits<double>::infinity();
  x1 = y1 = -x0;
  for (const auto& line : lines)
    for (const Vec2& p : line) {
      x0 = std::min(x0, p.x() - grow);
      y0 = std::min(y0, p.y() - grow);
      x1 = std::max(x1, p.x() + grow);
      y1 = std::max(y1, p.y() + grow);
    }
}

void stroke_lines(Coverage& cov, const std::vector<Vec2>& line, bool closed, double width) {
  if (line.size() == 1) cov.stroke(line[0], line[0], width);
  for (std::size_t k = 0; k + 1 < line.size(); ++k) cov.stroke(line[k], line[k + 1], width);
  if (closed && line.size() > 2) cov.stroke(line.back(), line.front(), width);
}

}  // namespace

void draw_annotation(Image& image, const VectorOverlay& overlay) {
  for (const OverlayItem& it : overlay.items) {
    double x0, y0, x1, y1;
    if (it.kind == OverlayItem::Kind::text) {
      bounds(it.glyph_strokes, it.glyph_stroke_width + 1.0, x0, y0, x1, y1);
      if (!(x1 > x0)) continue;
      Coverage cov(image, x0, y0, x1, y1);
      for (const auto& line : it.glyph_strokes)
        stroke_lines(cov, line, false, it.glyph_stroke_width);
      cov.apply(image, it.text_color, it.opacity);
      continue;
    }
    bounds(std::vector<std::vector<Vec2>>{it.points}, it.stroke_width + 1.0, x0, y0, x1, y1);
    if (!(x1 > x0) && !(y1 > y0)) continue;
    if (!it.fill.empty() && it.points.size() >= 3) {
      Coverage cov(image, x0, y0, x1, y1);
      cov.fill(it.points);
      cov.apply(image, it.fill, it.opacity);
    }
    if (!it.stroke.empty()) {
      Coverage cov(image, x0, y0, x1, y1);
      stroke_lines(cov, it.points, it.closed, it.stroke_width);
      cov.apply(image, it.stroke, it.opacity);
    }
  }
}

}  // namespace fabrica::render
