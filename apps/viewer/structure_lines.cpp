#include "structure_lines.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "fabrica/core/projector.hpp"
#include "fabrica/hatching/hatching.hpp"
#include "fabrica/render/draw.hpp"

namespace fabrica::viewer {

namespace {

/// How far chain vertex `p` (strength `s`) is off the drawn segment from
/// `a` to `b` (strengths `sa`, `sb`): its squared pixel distance to the
/// segment and its strength's distance to the one interpolated at its foot.
struct Offset {
  double distance2, strength;
};
Offset offset_from(const Vec2& a, const Vec2& b, float sa, float sb, const Vec2& p, float s) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return {(a + t * ab - p).squaredNorm(), std::fabs(static_cast<double>(s) - (sa + t * (sb - sa)))};
}

/// The offset as a multiple of the tolerances (> 1: the vertex must stay):
/// the pixel distance over `tolerance_px` or the strength's over
/// `strength_tolerance`, whichever is larger.
double merge_error(const Offset& o, double tolerance_px, double strength_tolerance) {
  return std::max(std::sqrt(o.distance2) / tolerance_px, o.strength / strength_tolerance);
}

/// Bounds below which an offset's merge_error is surely at most `worst`:
/// (worst * tolerance)^2 and worst * tolerance less a relative 1e-9, far
/// more than the rounding of the square root and the divisions (a few
/// units of 2^-53), so the test skips them without changing a decision.
/// Non-finite values fail it and take the exact path.
struct Bounds {
  double distance2, strength;
  Bounds(double worst, double tolerance_px, double strength_tolerance) {
    const double d = worst * tolerance_px;
    distance2 = d * d * (1.0 - 1e-9);
    strength = worst * strength_tolerance * (1.0 - 1e-9);
  }
  bool below(const Offset& o) const { return o.distance2 < distance2 && o.strength < strength; }
};

}  // namespace

std::size_t merge_collinear(LineSet& lines, const Camera& camera, double tolerance_px,
                            double strength_tolerance) {
  if (!(tolerance_px > 0.0) || !(strength_tolerance > 0.0)) return 0;
  const Projector project(camera);
  std::size_t removed = 0;
  // The chain of a polyline as flat arrays (pixel, strength, front of the
  // eye, kept), with the first vertex again at index n for a loop (its
  // closing edge), so the simplification reads them without wrapping.
  // Kept between calls: the lines worker merges every moving frame.
  thread_local std::vector<Vec2> pixel;
  thread_local std::vector<float> strength;
  thread_local std::vector<char> keep;
  thread_local std::vector<std::pair<std::size_t, std::size_t>> spans;
  for (Polyline& pl : lines.polylines) {
    const std::size_t n = pl.vertices.size();
    if (n < 3) continue;
    const std::size_t m = pl.closed ? n + 1 : n;
    pixel.resize(m);
    strength.resize(m);
    keep.assign(m, 0);
    keep[0] = keep[m - 1] = 1;
    // Ends, and every vertex not in front of the eye with its neighbours,
    // stay; each run between two kept vertices is simplified on its own
    // (Douglas-Peucker: keep the worst vertex while one is off by more than
    // the tolerances).
    for (std::size_t i = 0; i < n; ++i) {
      const LineVertex& v = pl.vertices[i];
      const ProjectedPoint q = project(v.position);
      pixel[i] = q.pixel;
      strength[i] = v.strength;
      if (!(q.depth > 0.0 && std::isfinite(q.pixel.x()) && std::isfinite(q.pixel.y()))) {
        keep[i] = 1;
        if (i > 0) keep[i - 1] = 1;
        if (i + 1 < m) keep[i + 1] = 1;
        if (i == 0 && m > n) keep[n] = keep[n - 1] = 1;  // the loop's vertex 0 again, at n
      }
    }
    if (m > n) {
      pixel[n] = pixel[0];
      strength[n] = strength[0];
    }
    spans.clear();
    for (std::size_t a = 0, b = 1; b < m; ++b)
      if (keep[b]) {
        if (b > a + 1) spans.emplace_back(a, b);
        a = b;
      }
    while (!spans.empty()) {
      const auto [a, b] = spans.back();
      spans.pop_back();
      const Vec2 pa = pixel[a], pb = pixel[b];
      const float sa = strength[a], sb = strength[b];
      double worst = 1.0;
      Bounds bounds(worst, tolerance_px, strength_tolerance);
      std::size_t at = 0;
      for (std::size_t k = a + 1; k < b; ++k) {
        const Offset o = offset_from(pa, pb, sa, sb, pixel[k], strength[k]);
        if (bounds.below(o)) continue;  // not worse than `worst`
        const double e = merge_error(o, tolerance_px, strength_tolerance);
        if (e > worst) {
          worst = e;
          bounds = Bounds(worst, tolerance_px, strength_tolerance);
          at = k;
        }
      }
      if (at == 0) continue;  // every vertex between a and b goes
      keep[at] = 1;
      if (at > a + 1) spans.emplace_back(a, at);
      if (b > at + 1) spans.emplace_back(at, b);
    }
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) kept += keep[i] ? 1 : 0;
    if (kept == n || (pl.closed && kept < 3)) continue;
    // In place, in order (the vector keeps its storage).
    std::size_t w = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (keep[i]) pl.vertices[w++] = pl.vertices[i];
    pl.vertices.resize(w);
    removed += n - kept;
    pl.edge_faces.clear();
  }
  return removed;
}

LineSet structure_lines(LineDrawer& drawer, const render::StructureStyle& style,
                        const LineOptions& thresholds, const Camera& camera,
                        std::optional<double> apparent_min_ndotv) {
  DrawLinesOptions options = render::structure_line_options(style, thresholds);
  if (options.lines.families.empty()) return {};
  options.lines.apparent.min_ndotv = apparent_min_ndotv;
  drawer.set_options(options);
  return drawer.draw(camera).lines;
}

render::PolylineLayer structure_hatching(const Surface& surface, const Camera& camera,
                                         double width) {
  hatching::HatchingOptions options;
  options.stroke_width_px = width;
  const hatching::StrokeSet strokes = hatching::hatch(surface, camera, options);
  render::PolylineLayer layer;
  layer.name = "hatching";
  layer.style.width = width;
  layer.style.contour_width_factor = 1.0;
  layer.style.taper = 0.0;
  layer.style.fade_by_strength = false;
  for (const hatching::Stroke& stroke : strokes.strokes) {
    std::vector<Vec3> points;
    points.reserve(stroke.vertices.size());
    for (const hatching::StrokeVertex& v : stroke.vertices) points.push_back(v.position);
    layer.polylines.push_back(std::move(points));
  }
  return layer;
}

std::optional<double> moving_apparent_min_ndotv(const render::RenderMesh& mesh, render::Role role,
                                                const render::StructureStyle& style,
                                                const Camera& camera) {
  if (role != render::Role::focus || !(style.opacity >= 0.999) || !mesh.closed_outward ||
      style.lines.hidden != render::HiddenLines::omit || !(mesh.radius > 0.0))
    return std::nullopt;
  // Every point of the sphere beyond the near plane (which clip_planes
  // puts at the scene's sphere or the camera's own near distance) and, in
  // perspective, the eye outside it.
  const double front = (mesh.center - camera.eye).dot(camera.forward()) - mesh.radius;
  if (!(front > std::max(camera.near_plane, 0.0))) return std::nullopt;
  return kMovingApparentMinNdotv;
}

int moving_level(const render::RenderMesh& full, const std::vector<MovingLevel>& levels,
                 const Camera& camera) {
  if (levels.empty() || camera.height <= 0) return -1;
  const double t = std::tan(camera.fov_deg * M_PI / 360.0);
  double half_mm = 0.0;  // half the picture's height in mm at the mesh's centre
  if (camera.projection == Projection::orthographic) {
    half_mm = (camera.center - camera.eye).norm() * t;
  } else {
    const double depth = (full.center - camera.eye).dot(camera.forward());
    if (depth <= full.radius) return -1;  // near or around the eye
    half_mm = depth * t;
  }
  if (!(half_mm > 0.0)) return -1;
  const double px_per_mm = 0.5 * camera.height / half_mm;
  int chosen = -1;
  for (std::size_t i = 0; i < levels.size(); ++i)
    if (levels[i].mesh->mean_edge_length * px_per_mm <= kMovingEdgePx) chosen = static_cast<int>(i);
  return chosen;
}

}  // namespace fabrica::viewer
