// The viewer's line merging while the camera moves (merge_collinear in
// apps/viewer/structure_lines.cpp): the merged polylines are drawn within
// the tolerance of the extracted ones, keep their ends, and are never joined.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/projector.hpp"
#include "structure_lines.hpp"

using namespace fabrica;
using fabrica::viewer::merge_collinear;
using fabrica::viewer::moving_level;
using fabrica::viewer::MovingLevel;

namespace {

Camera test_camera() {
  Camera c;
  c.eye = Vec3(0.0, 0.0, 10.0);
  c.center = Vec3::Zero();
  c.width = 1280;
  c.height = 800;
  return c;
}

/// The point of the plane z = 0 seen at `pixel`.
Vec3 at_pixel(const Camera& c, double x, double y) {
  Vec3 origin, direction;
  Projector(c).ray(Vec2(x, y), origin, direction);
  return origin + direction * (-origin.z() / direction.z());
}

Polyline polyline_through(const Camera& c, const std::vector<Vec2>& pixels,
                          const std::vector<float>& strengths = {}) {
  Polyline pl;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    LineVertex v;
    v.position = at_pixel(c, pixels[i].x(), pixels[i].y());
    v.strength = strengths.empty() ? 1.0f : strengths[i];
    pl.vertices.push_back(v);
  }
  for (std::size_t i = 0; i + 1 < pixels.size(); ++i) pl.edge_faces.push_back(int(i));
  return pl;
}

std::vector<Vec2> pixels_of(const Camera& c, const Polyline& pl) {
  const Projector project(c);
  std::vector<Vec2> out;
  for (const LineVertex& v : pl.vertices) out.push_back(project(v.position).pixel);
  if (pl.closed && !out.empty()) out.push_back(out.front());
  return out;
}

double to_segment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0.0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

double to_chain(const Vec2& p, const std::vector<Vec2>& chain) {
  double d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < chain.size(); ++i)
    d = std::min(d, to_segment(p, chain[i], chain[i + 1]));
  return d;
}

/// Largest distance between the two drawn chains, both ways, sampling every
/// segment at 20 points.
double hausdorff(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  double worst = 0.0;
  for (const auto* pair : {&a, &b}) {
    const auto& from = *pair;
    const auto& to = pair == &a ? b : a;
    for (std::size_t i = 0; i + 1 < from.size(); ++i)
      for (int k = 0; k <= 20; ++k)
        worst = std::max(worst, to_chain(from[i] + (from[i + 1] - from[i]) * (k / 20.0), to));
  }
  return worst;
}

}  // namespace

TEST(ViewerLines, MergedPolylineStaysWithinHalfAPixelAndKeepsItsEnds) {
  const Camera c = test_camera();
  // A wiggly curve: a sine of 60 px amplitude sampled every ~2 px, with
  // a sub-pixel zigzag on top (what the merge removes).
  std::vector<Vec2> pixels;
  for (int i = 0; i <= 400; ++i)
    pixels.emplace_back(200.0 + 2.0 * i, 400.0 + 60.0 * std::sin(i * 0.02) + (i % 2 ? 0.2 : -0.2));
  LineSet lines;
  lines.polylines.push_back(polyline_through(c, pixels));
  const Polyline original = lines.polylines.front();
  const std::size_t removed = merge_collinear(lines, c, 0.5, 0.1);
  ASSERT_EQ(lines.polylines.size(), 1u);
  const Polyline& merged = lines.polylines.front();
  EXPECT_EQ(removed, original.vertices.size() - merged.vertices.size());
  EXPECT_LT(merged.vertices.size(), original.vertices.size() / 4);  // it does merge
  EXPECT_GT(merged.vertices.size(), 2u);                            // the sine stays a curve
  EXPECT_EQ(merged.vertices.front().position, original.vertices.front().position);
  EXPECT_EQ(merged.vertices.back().position, original.vertices.back().position);
  EXPECT_TRUE(merged.edge_faces.empty());
  // Every kept vertex is one of the original's, in order.
  std::size_t j = 0;
  for (const LineVertex& v : merged.vertices) {
    while (j < original.vertices.size() && original.vertices[j].position != v.position) ++j;
    ASSERT_LT(j, original.vertices.size());
  }
  EXPECT_LE(hausdorff(pixels_of(c, original), pixels_of(c, merged)), 0.5 + 1e-9);
  // A tighter tolerance keeps more, and still holds.
  LineSet tight;
  tight.polylines.push_back(original);
  merge_collinear(tight, c, 0.25, 0.1);
  EXPECT_GT(tight.polylines.front().vertices.size(), merged.vertices.size());
  EXPECT_LE(hausdorff(pixels_of(c, original), pixels_of(c, tight.polylines.front())), 0.25 + 1e-9);
}

TEST(ViewerLines, MergeKeepsCornersStrengthChangesAndGaps) {
  const Camera c = test_camera();
  // An L: the corner stays, the straight legs lose their inner vertices.
  std::vector<Vec2> l;
  for (int i = 0; i <= 10; ++i) l.emplace_back(100.0 + 10.0 * i, 100.0);
  for (int i = 1; i <= 10; ++i) l.emplace_back(200.0, 100.0 + 10.0 * i);
  // Two straight polylines end to end with a gap of 5 px between them: not joined.
  std::vector<Vec2> a, b;
  for (int i = 0; i <= 10; ++i) a.emplace_back(300.0 + 10.0 * i, 500.0);
  for (int i = 0; i <= 10; ++i) b.emplace_back(405.0 + 10.0 * i, 500.0);
  // A straight line whose strength jumps from 1 to 0.2 in the middle.
  std::vector<Vec2> s;
  std::vector<float> strengths;
  for (int i = 0; i <= 10; ++i) {
    s.emplace_back(600.0 + 10.0 * i, 300.0);
    strengths.push_back(i < 5 ? 1.0f : 0.2f);
  }
  LineSet lines;
  lines.polylines.push_back(polyline_through(c, l));
  lines.polylines.push_back(polyline_through(c, a));
  lines.polylines.push_back(polyline_through(c, b));
  lines.polylines.push_back(polyline_through(c, s, strengths));
  merge_collinear(lines, c, 0.5, 0.1);
  ASSERT_EQ(lines.polylines.size(), 4u);
  const auto corner = pixels_of(c, lines.polylines[0]);
  ASSERT_EQ(corner.size(), 3u);
  EXPECT_LT((corner[1] - Vec2(200.0, 100.0)).norm(), 1e-6);
  for (int k : {1, 2}) {
    const auto p = pixels_of(c, lines.polylines[k]);
    ASSERT_EQ(p.size(), 2u);  // each its own segment: the 5 px between them stay empty
    EXPECT_LT((p.front() - (k == 1 ? a.front() : b.front())).norm(), 1e-6);
    EXPECT_LT((p.back() - (k == 1 ? a.back() : b.back())).norm(), 1e-6);
  }
  // The strength step keeps the vertices on both sides of it.
  const Polyline& st = lines.polylines[3];
  EXPECT_EQ(st.vertices.size(), 4u);
  // Without the strength test (a huge tolerance) the line is one segment.
  LineSet loose;
  loose.polylines.push_back(polyline_through(c, s, strengths));
  merge_collinear(loose, c, 0.5, 10.0);
  EXPECT_EQ(loose.polylines.front().vertices.size(), 2u);
}

TEST(ViewerLines, MergeKeepsLoopsClosedAndPointsBehindTheEye) {
  const Camera c = test_camera();
  // A circle of 100 px radius in 360 vertices: a closed polygon of far fewer.
  std::vector<Vec2> circle;
  for (int i = 0; i < 360; ++i)
    circle.emplace_back(640.0 + 100.0 * std::cos(i * M_PI / 180.0),
                        400.0 + 100.0 * std::sin(i * M_PI / 180.0));
  LineSet lines;
  Polyline loop = polyline_through(c, circle);
  loop.closed = true;
  lines.polylines.push_back(loop);
  // A tiny loop inside half a pixel: left as it is (a loop needs 3 vertices).
  std::vector<Vec2> dot;
  for (int i = 0; i < 8; ++i)
    dot.emplace_back(100.0 + 0.1 * std::cos(i * M_PI / 4.0),
                     100.0 + 0.1 * std::sin(i * M_PI / 4.0));
  Polyline tiny = polyline_through(c, dot);
  tiny.closed = true;
  lines.polylines.push_back(tiny);
  // A straight line in space that passes behind the eye: the vertices behind
  // it and their neighbours stay.
  Polyline through;
  for (int i = 0; i <= 20; ++i) {
    LineVertex v;
    v.position = Vec3(0.5, 0.0, -5.0 + 1.0 * i);  // z from -5 to 15, the eye at z = 10
    through.vertices.push_back(v);
  }
  lines.polylines.push_back(through);
  merge_collinear(lines, c, 0.5, 0.1);
  const Polyline& merged = lines.polylines[0];
  EXPECT_TRUE(merged.closed);
  EXPECT_GE(merged.vertices.size(), 3u);
  EXPECT_LT(merged.vertices.size(), 100u);
  EXPECT_LE(hausdorff(pixels_of(c, loop), pixels_of(c, merged)), 0.5 + 1e-9);
  EXPECT_EQ(lines.polylines[1].vertices.size(), dot.size());
  const Projector project(c);
  const Polyline& t = lines.polylines[2];
  const int count = static_cast<int>(through.vertices.size());
  int checked = 0;
  for (int i = 0; i < count; ++i) {
    bool near_behind = false;
    for (int k = std::max(0, i - 1); k <= std::min(count - 1, i + 1); ++k)
      near_behind = near_behind || project(through.vertices[k].position).depth <= 0.0;
    if (!near_behind) continue;
    ++checked;
    EXPECT_TRUE(std::any_of(
        t.vertices.begin(), t.vertices.end(),
        [&](const LineVertex& v) { return v.position == through.vertices[i].position; }))
        << "vertex " << i;
  }
  EXPECT_GT(checked, 0);
  EXPECT_LT(t.vertices.size(), through.vertices.size());  // the part in front merges
  // No tolerance: nothing changes.
  LineSet same;
  same.polylines.push_back(loop);
  EXPECT_EQ(merge_collinear(same, c, 0.0, 0.1), 0u);
  EXPECT_EQ(same.polylines.front().vertices.size(), loop.vertices.size());
}

namespace {

// merge_collinear as first written (session 13): the modulo-indexed chain,
// merge_error with its square root and divisions for every vertex, a new
// vertex array. The current one must give the same polylines bit for bit.
double reference_error(const Vec2& a, const Vec2& b, float sa, float sb, const Vec2& p, float s,
                       double tolerance_px, double strength_tolerance) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  const double distance = (a + t * ab - p).norm();
  const double strength = std::fabs(static_cast<double>(s) - (sa + t * (sb - sa)));
  return std::max(distance / tolerance_px, strength / strength_tolerance);
}

std::size_t reference_merge(LineSet& lines, const Camera& camera, double tolerance_px,
                            double strength_tolerance) {
  const Projector project(camera);
  std::size_t removed = 0;
  for (Polyline& pl : lines.polylines) {
    const std::size_t n = pl.vertices.size();
    if (n < 3) continue;
    const std::size_t m = pl.closed ? n + 1 : n;
    std::vector<Vec2> pixel(n);
    std::vector<char> front(n), keep(m, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const ProjectedPoint q = project(pl.vertices[i].position);
      pixel[i] = q.pixel;
      front[i] = q.depth > 0.0 && std::isfinite(q.pixel.x()) && std::isfinite(q.pixel.y());
    }
    keep[0] = keep[m - 1] = 1;
    for (std::size_t i = 0; i < m; ++i)
      if (!front[i % n]) {
        keep[i] = 1;
        if (i > 0) keep[i - 1] = 1;
        if (i + 1 < m) keep[i + 1] = 1;
      }
    std::vector<std::pair<std::size_t, std::size_t>> spans;
    for (std::size_t a = 0, b = 1; b < m; ++b)
      if (keep[b]) {
        if (b > a + 1) spans.emplace_back(a, b);
        a = b;
      }
    while (!spans.empty()) {
      const auto [a, b] = spans.back();
      spans.pop_back();
      double worst = 1.0;
      std::size_t at = 0;
      for (std::size_t k = a + 1; k < b; ++k) {
        const double e = reference_error(
            pixel[a % n], pixel[b % n], pl.vertices[a % n].strength, pl.vertices[b % n].strength,
            pixel[k % n], pl.vertices[k % n].strength, tolerance_px, strength_tolerance);
        if (e > worst) {
          worst = e;
          at = k;
        }
      }
      if (at == 0) continue;
      keep[at] = 1;
      if (at > a + 1) spans.emplace_back(a, at);
      if (b > at + 1) spans.emplace_back(at, b);
    }
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) kept += keep[i] ? 1 : 0;
    if (kept == n || (pl.closed && kept < 3)) continue;
    std::vector<LineVertex> vertices;
    for (std::size_t i = 0; i < n; ++i)
      if (keep[i]) vertices.push_back(pl.vertices[i]);
    removed += n - kept;
    pl.vertices = std::move(vertices);
    pl.edge_faces.clear();
  }
  return removed;
}

bool same_vertex(const LineVertex& a, const LineVertex& b) {
  return a.anchor.face == b.anchor.face &&
         std::memcmp(a.anchor.bary.data(), b.anchor.bary.data(), 24) == 0 &&
         std::memcmp(a.position.data(), b.position.data(), 24) == 0 &&
         std::memcmp(&a.strength, &b.strength, 4) == 0 && a.visible == b.visible;
}

}  // namespace

TEST(ViewerLines, MergeGivesTheFirstImplementationsPolylinesBitForBit) {
  // Random wiggly polylines (steps of a few pixels, sideways jitter around
  // the tolerance, strength steps around theirs), open and closed, some
  // crossing the eye's plane, at several tolerances: the optimised merge
  // (flat arrays, exact bounds before the square root) keeps exactly the
  // vertices the first one kept.
  const Camera c = test_camera();
  std::mt19937 rng(18);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  LineSet lines;
  for (int p = 0; p < 300; ++p) {
    std::vector<Vec2> pixels;
    std::vector<float> strengths;
    const int n = 3 + static_cast<int>(unit(rng) * 60.0);
    Vec2 at(100.0 + 1000.0 * unit(rng), 100.0 + 600.0 * unit(rng));
    double heading = 2.0 * M_PI * unit(rng);
    float strength = static_cast<float>(unit(rng));
    for (int i = 0; i < n; ++i) {
      pixels.push_back(at);
      strengths.push_back(strength);
      heading += 0.3 * (unit(rng) - 0.5);
      const double step = 0.5 + 4.0 * unit(rng), side = 1.2 * (unit(rng) - 0.5);
      at += step * Vec2(std::cos(heading), std::sin(heading)) +
            side * Vec2(-std::sin(heading), std::cos(heading));
      if (unit(rng) < 0.2)
        strength = std::clamp(strength + 0.3f * float(unit(rng) - 0.5), 0.f, 1.f);
    }
    Polyline pl = polyline_through(c, pixels, strengths);
    pl.closed = p % 3 == 0;
    if (p % 17 == 0)  // through the eye's plane (z = 10): points behind the eye
      for (std::size_t i = 0; i < pl.vertices.size(); i += 4) pl.vertices[i].position.z() += 12.0;
    lines.polylines.push_back(pl);
  }
  for (double tolerance : {0.25, 0.5, 1.0})
    for (double strength_tolerance : {0.05, 0.1, 10.0}) {
      LineSet mine = lines, first = lines;
      const std::size_t removed = merge_collinear(mine, c, tolerance, strength_tolerance);
      EXPECT_EQ(removed, reference_merge(first, c, tolerance, strength_tolerance));
      EXPECT_GT(removed, 0u);
      ASSERT_EQ(mine.polylines.size(), first.polylines.size());
      for (std::size_t i = 0; i < mine.polylines.size(); ++i) {
        const Polyline &a = mine.polylines[i], &b = first.polylines[i];
        EXPECT_EQ(a.closed, b.closed);
        EXPECT_EQ(a.edge_faces, b.edge_faces);
        ASSERT_EQ(a.vertices.size(), b.vertices.size()) << "polyline " << i;
        for (std::size_t k = 0; k < a.vertices.size(); ++k)
          ASSERT_TRUE(same_vertex(a.vertices[k], b.vertices[k]))
              << "polyline " << i << " vertex " << k;
      }
    }
}

namespace {

// A level of a mesh for moving_level: only its render mesh's mean edge
// length counts.
MovingLevel level_of_edge(double edge) {
  auto mesh = std::make_shared<render::RenderMesh>();
  mesh->mean_edge_length = edge;
  MovingLevel level;
  level.mesh = std::move(mesh);
  return level;
}

}  // namespace

// While the camera moves an opaque structure is drawn from the coarsest
// level whose edges are at most kMovingEdgePx pixels long at its centre:
// a finer one as the camera comes closer, the full mesh when none fits or
// the eye is inside the mesh's sphere.
TEST(ViewerLines, MovingLevelFitsItsEdgesToThePixels) {
  render::RenderMesh full;
  full.center = Vec3::Zero();
  full.radius = 1.0;
  // Levels of mean edge 0.01, 0.04 and 0.16 mm.
  const std::vector<MovingLevel> levels = {level_of_edge(0.01), level_of_edge(0.04),
                                           level_of_edge(0.16)};
  Camera c = test_camera();  // 800 pixels high, 40 degrees
  auto at_px_per_mm = [&](double px_per_mm) {
    c.eye = Vec3(0.0, 0.0, 400.0 / (px_per_mm * std::tan(20.0 * M_PI / 180.0)));
    return moving_level(full, levels, c);
  };
  ASSERT_EQ(fabrica::viewer::kMovingEdgePx, 7.0);  // the pixel figures below
  EXPECT_EQ(at_px_per_mm(20.0), 2);                // 0.16 mm: 3.2 px
  EXPECT_EQ(at_px_per_mm(43.5), 2);                // 0.16 mm: 6.96 px
  EXPECT_EQ(at_px_per_mm(44.0), 1);                // 0.16 mm: 7.04 px; 0.04 mm: 1.76 px
  EXPECT_EQ(at_px_per_mm(174.0), 1);               // 0.04 mm: 6.96 px
  EXPECT_EQ(at_px_per_mm(176.0), 0);               // 0.04 mm: 7.04 px
  EXPECT_EQ(at_px_per_mm(1000.0), -1);             // 0.01 mm: 10 px
  EXPECT_EQ(moving_level(full, {}, c), -1);
  c.eye = Vec3(0.0, 0.0, 0.5);  // inside the bounding sphere
  EXPECT_EQ(moving_level(full, levels, c), -1);
  c.projection = Projection::orthographic;  // the height seen at the centre
  c.eye = Vec3(0.0, 0.0, 400.0 / (20.0 * std::tan(20.0 * M_PI / 180.0)));
  EXPECT_EQ(moving_level(full, levels, c), 2);
}

// While the camera moves, the apparent ridges of a structure that hides its
// own back are looked for only on faces not turned far from the eye
// (ApparentOptions::min_ndotv): an opaque focus whose mesh is closed and
// outward, hidden lines omitted, its sphere wholly beyond the eye and the
// near plane; any one of these missing, everywhere.
TEST(ViewerLines, MovingApparentRidgesSkipTheBackOnlyWhereItIsHidden) {
  using fabrica::viewer::kMovingApparentMinNdotv;
  using fabrica::viewer::moving_apparent_min_ndotv;
  render::RenderMesh mesh;
  mesh.center = Vec3::Zero();
  mesh.radius = 1.0;
  mesh.closed_outward = true;
  render::StructureStyle style;
  style.opacity = 1.0;
  const Camera c = test_camera();  // eye 10 mm away on +z
  const std::optional<double> limit = kMovingApparentMinNdotv;
  EXPECT_LT(kMovingApparentMinNdotv, 0.0);
  EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::focus, style, c), limit);
  EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::context, style, c), std::nullopt);
  render::StructureStyle ghost = style;
  ghost.opacity = 0.5;
  EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::focus, ghost, c), std::nullopt);
  for (const auto hidden : {render::HiddenLines::dashed, render::HiddenLines::show}) {
    render::StructureStyle shown = style;
    shown.lines.hidden = hidden;
    EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::focus, shown, c), std::nullopt);
  }
  render::RenderMesh open = mesh;
  open.closed_outward = false;
  EXPECT_EQ(moving_apparent_min_ndotv(open, render::Role::focus, style, c), std::nullopt);
  Camera inside = c;
  inside.eye = Vec3(0.0, 0.0, 0.5);
  EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::focus, style, inside), std::nullopt);
  Camera near = c;
  near.near_plane = 9.5;  // cuts the sphere (its front is 9 mm away)
  EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::focus, style, near), std::nullopt);
  near.near_plane = 8.5;
  EXPECT_EQ(moving_apparent_min_ndotv(mesh, render::Role::focus, style, near), limit);
}
