// The cutaway (issue 18, item 4; docs/algorithms.md §15): context in front
// of the focus is removed near the focus's footprint, with a margin and a
// fade, for opaque and ghosted context; pixels outside its reach are
// unchanged; tiled and untiled agree; the scene JSON keys are strict.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "fabrica/core/error.hpp"
#include "fabrica/core/projector.hpp"
#include "fabrica/render/draw.hpp"
#include "fabrica/render/renderer.hpp"
#include "render_test_util.hpp"

namespace fr = fabrica::render;
using fabrica::Camera;
using fabrica::Vec3;

namespace {

using fabrica::test::renderer;

// 200 x 200 orthographic view of a 25 mm square: 8 px per mm; line
// reference size 200, so the cutaway's pixels are the picture's.
constexpr int kSize = 200;
constexpr double kPxPerMm = kSize / 25.0;
Camera camera() {
  Camera c = fabrica::test::front_camera(kSize, kSize, 100.0, true);
  c.fov_deg = 2.0 * std::atan(12.5 / 100.0) * 180.0 / M_PI;
  return c;
}
fr::RenderOptions options() {
  fr::RenderOptions o;
  o.line_reference_size = kSize;
  return o;
}

fr::Structure sphere(double radius, fr::Role role, fr::Color color) {
  fr::Structure s;
  s.name = role == fr::Role::focus ? "focus" : "context";
  s.role = role;
  s.mesh = fabrica::test::sphere_render_mesh(radius, 5);
  s.style = fr::default_style(role);
  s.style.color = color;
  s.style.opacity = 1.0;
  s.style.ambient = 0.0;
  s.style.families.clear();
  return s;
}

// A square facing the eye at height z (side 24 mm, 8 x 8 cells), flat shaded.
fr::Structure plane(double z, fr::Color color) {
  fabrica::TriangleMesh mesh;
  const int n = 8;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      mesh.positions.emplace_back(-12.0 + 24.0 * i / n, -12.0 + 24.0 * j / n, z);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i;
      mesh.faces.push_back({a, a + 1, a + n + 2});
      mesh.faces.push_back({a, a + n + 2, a + n + 1});
    }
  fr::Structure s;
  s.name = "plane";
  s.role = fr::Role::context;
  s.mesh = std::make_shared<fr::RenderMesh>(
      fr::make_render_mesh(mesh, std::vector<Vec3>(mesh.positions.size(), Vec3::UnitZ())));
  s.style = fr::default_style(fr::Role::context);
  s.style.shading = fr::Shading::flat;
  s.style.color = color;
  s.style.opacity = 1.0;
  s.style.families.clear();
  return s;
}

const fr::Color kRed{1.0f, 0.0f, 0.0f, 1.0f}, kBlue{0.0f, 0.0f, 1.0f, 1.0f};

fr::Scene scene_of(std::vector<fr::Structure> structures, bool cut, double margin = 12.0,
                   double fade = 8.0) {
  fr::Scene scene;
  scene.structures = std::move(structures);
  scene.background = {0.0f, 0.0f, 0.0f, 1.0f};
  scene.cutaway.enabled = cut;
  scene.cutaway.margin_px = margin;
  scene.cutaway.fade_px = fade;
  return scene;
}

}  // namespace

// A focus sphere (r 5 mm, red) inside an opaque context sphere (r 10 mm,
// blue): without the cutaway the centre is blue, with it the focus shows,
// drawn as without any context; pixels beyond margin + fade are unchanged.
TEST(RenderCutaway, OpaqueContextSphereShowsTheFocus) {
  const auto focus = sphere(5.0, fr::Role::focus, kRed);
  const auto context = sphere(10.0, fr::Role::context, kBlue);
  const fr::Image off = renderer().render(scene_of({context, focus}, false), camera(), options());
  const fr::Image on = renderer().render(scene_of({context, focus}, true), camera(), options());
  const fr::Image alone = renderer().render(scene_of({focus}, false), camera(), options());
  const int c = kSize / 2;
  EXPECT_EQ(off.pixel(c, c)[0], 0);  // the context hides the focus
  EXPECT_GT(off.pixel(c, c)[2], 200);
  EXPECT_GT(on.pixel(c, c)[0], 200);  // the focus shows through the cut
  EXPECT_EQ(on.pixel(c, c)[2], 0);
  // Inside the focus's footprint the picture is the focus alone.
  const double focus_px = 5.0 * kPxPerMm;  // 40 px
  int inside = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      if (std::hypot(x + 0.5 - c, y + 0.5 - c) > focus_px - 2.0) continue;
      ++inside;
      for (int k = 0; k < 4; ++k)
        ASSERT_EQ(on.pixel(x, y)[k], alone.pixel(x, y)[k]) << x << "," << y;
    }
  EXPECT_GT(inside, 4000);
  // Beyond the reach (40 + 12 + 8 px and a pixel of JFA rounding): unchanged.
  int outside = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      if (std::hypot(x + 0.5 - c, y + 0.5 - c) < focus_px + 20.0 + 1.5) continue;
      ++outside;
      for (int k = 0; k < 4; ++k) ASSERT_EQ(on.pixel(x, y)[k], off.pixel(x, y)[k]) << x << "," << y;
    }
  EXPECT_GT(outside, 20000);
  // Within the margin, outside the focus: the context's back half (behind
  // the focus's front) is kept, so the ring is the context, shaded as its
  // inside: blue, no red.
  const auto* ring = on.pixel(c + static_cast<int>(focus_px) + 6, c);
  EXPECT_EQ(ring[0], 0);
  EXPECT_GT(ring[2], 0);
}

// A ghosted context sphere: the same cut (its front is removed, its back
// behind the focus is hidden by it), so the centre is the focus alone.
TEST(RenderCutaway, GhostedContextIsCutToo) {
  const auto focus = sphere(5.0, fr::Role::focus, kRed);
  auto context = sphere(10.0, fr::Role::context, kBlue);
  context.style.opacity = 0.3;
  const fr::Image off = renderer().render(scene_of({context, focus}, false), camera(), options());
  const fr::Image on = renderer().render(scene_of({context, focus}, true), camera(), options());
  const fr::Image alone = renderer().render(scene_of({focus}, false), camera(), options());
  const int c = kSize / 2;
  EXPECT_GT(off.pixel(c, c)[2], 40);  // a blue veil over the focus
  for (int k = 0; k < 4; ++k) EXPECT_EQ(on.pixel(c, c)[k], alone.pixel(c, c)[k]);
}

// A flat blue plane in front of the focus over a black background: the
// plane's brightness across the cut's border is its opacity there, 0 up to
// the margin, rising monotonically over the fade as the smoothstep of
// cutaway_keep (within a pixel of the distance field), 1 beyond.
TEST(RenderCutaway, FadeIsMonotoneAcrossTheMargin) {
  const auto focus = sphere(5.0, fr::Role::focus, kRed);
  const auto front = plane(8.0, kBlue);
  const double margin = 12.0, fade = 8.0;
  const fr::Image on =
      renderer().render(scene_of({front, focus}, true, margin, fade), camera(), options());
  const int c = kSize / 2;
  const double edge = 5.0 * kPxPerMm;  // the focus's silhouette, 40 px from the centre
  fr::Cutaway cut;
  cut.margin_px = margin;
  cut.fade_px = fade;
  int previous = -1;
  double worst = 0.0;
  for (int x = c; x < c + 90; ++x) {  // the plane ends 96 px from the centre
    const auto* p = on.pixel(x, c);
    const double d = x + 0.5 - c - edge;   // distance from the silhouette
    if (d > 1.0) EXPECT_EQ(p[0], 0) << x;  // no focus: the plane or black
    if (d > 0.0) {
      EXPECT_GE(p[2], previous) << "not monotone at x = " << x;
      previous = p[2];
    }
    if (d > 1.0 && d < margin - 1.0) EXPECT_EQ(p[2], 0) << x;
    if (d > margin + fade + 1.0) EXPECT_EQ(p[2], 255) << x;
    // The distance field measures to the nearest focus pixel centre: within a pixel.
    if (d > 0.0) {
      const double lo = 255.0 * fr::cutaway_keep(cut, d - 1.0);
      const double hi = 255.0 * fr::cutaway_keep(cut, d + 1.0);
      worst = std::max({worst, lo - 2.0 - p[2], p[2] - hi - 2.0});
    }
  }
  EXPECT_LE(worst, 0.0);
  // Part way through the fade: partly there.
  const auto* mid = on.pixel(static_cast<int>(c + edge + margin + fade / 2), c);
  EXPECT_GT(mid[2], 60);
  EXPECT_LT(mid[2], 200);
}

// The rim: a dark line along the outer border of the cut, on the context.
TEST(RenderCutaway, RimIsDrawnOnTheContextAtTheBorder) {
  const auto focus = sphere(5.0, fr::Role::focus, kRed);
  auto front = plane(8.0, {1.0f, 1.0f, 1.0f, 1.0f});
  fr::Scene scene = scene_of({front, focus}, true, 12.0, 0.0);
  scene.cutaway.rim = true;
  scene.cutaway.rim_color = {0.0f, 0.0f, 0.0f, 1.0f};
  const fr::Image img = renderer().render(scene, camera(), options());
  const int c = kSize / 2;
  const int border = c + 40 + 12;  // silhouette + margin
  int darkest = 255;
  for (int x = border - 1; x <= border + 3; ++x)
    darkest = std::min<int>(darkest, img.pixel(x, c)[1]);
  EXPECT_LT(darkest, 64);
  EXPECT_EQ(img.pixel(border + 8, c)[1], 255);  // the plane beyond the rim
}

// Tiles: each tile's distance field sees the focus within reach (wider
// tile margins), so a tiled picture equals the untiled one.
TEST(RenderCutaway, TiledEqualsUntiled) {
  const auto focus = sphere(5.0, fr::Role::focus, kRed);
  const auto context = sphere(10.0, fr::Role::context, kBlue);
  fr::Scene scene = scene_of({context, focus}, true);
  scene.cutaway.rim = true;
  const fr::Image whole = renderer().render(scene, camera(), options());
  fr::RenderOptions tiled = options();
  tiled.max_tile_size = 96;
  const fr::Image parts = renderer().render(scene, camera(), tiled);
  EXPECT_EQ(fr::compare_images(whole, parts, 0).max_abs, 0);
}

// Scene JSON: the keys round-trip; bad values and unknown keys name the
// path; disabled with default values writes nothing.
TEST(RenderCutaway, SceneKeys) {
  fr::SceneSpec spec;
  fr::StructureSpec a;
  a.name = "focus";
  a.mesh = "/data/focus.stl";
  spec.structures = {a};
  EXPECT_FALSE(fr::scene_spec_to_json(spec).contains("cutaway"));
  spec.cutaway.enabled = true;
  spec.cutaway.margin_px = 20.5;
  spec.cutaway.fade_px = 0.0;
  spec.cutaway.rim = true;
  spec.cutaway.rim_color = {0.5f, 0.25f, 0.0f, 1.0f};
  const nlohmann::json j = fr::scene_spec_to_json(spec);
  ASSERT_TRUE(j.contains("cutaway"));
  const fr::SceneSpec back = fr::scene_spec_from_json(j, "/", "my.json");
  EXPECT_TRUE(back.cutaway.enabled);
  EXPECT_EQ(back.cutaway.margin_px, 20.5);
  EXPECT_EQ(back.cutaway.fade_px, 0.0);
  EXPECT_TRUE(back.cutaway.rim);
  EXPECT_EQ(fr::to_hex(back.cutaway.rim_color), "#804000");
  for (const char* bad : {R"({"enabled": 1})", R"({"margin_px": -1})", R"({"fade_px": 1000})",
                          R"({"margin_px": "12"})", R"({"margn_px": 12})", R"([true])",
                          R"({"rim_color": [2, 0, 0]})"}) {
    nlohmann::json k = j;
    k["cutaway"] = nlohmann::json::parse(bad);
    try {
      fr::scene_spec_from_json(k, "/", "my.json");
      ADD_FAILURE() << bad;
    } catch (const fabrica::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("my.json: cutaway"), std::string::npos) << e.what();
    }
  }
  // The smoothstep: 0 up to the margin, 1 from margin + fade, monotone between.
  fr::Cutaway c;
  c.margin_px = 10.0;
  c.fade_px = 4.0;
  EXPECT_EQ(fr::cutaway_keep(c, 10.0), 0.0);
  EXPECT_EQ(fr::cutaway_keep(c, 14.0), 1.0);
  EXPECT_DOUBLE_EQ(fr::cutaway_keep(c, 12.0), 0.5);
  EXPECT_EQ(fr::cutaway_keep(c, 6.0, 2.0), 0.0);  // 6 px <= the 20 px margin
  EXPECT_DOUBLE_EQ(fr::cutaway_keep(c, 24.0, 2.0), 0.5);
}

// Vector output: a context line across the front of the context sphere
// loses its part over the focus and the margin (where the cutaway keeps
// less than half), the rest stays; the focus's line, hidden by the opaque
// context without the cutaway, is visible through the cut.
TEST(RenderCutaway, VectorLinesAreCutToo) {
  fr::SceneSurfaces scene;
  fr::StructureSpec context, focus;
  context.name = "context";
  context.role = fr::Role::context;
  context.style = fr::default_style(fr::Role::context);
  context.style.opacity = 1.0;
  focus.name = "focus";
  focus.role = fr::Role::focus;
  focus.style = fr::default_style(fr::Role::focus);
  scene.add(context,
            std::make_shared<const fabrica::Surface>(fabrica::test::make_icosphere(10, 4)));
  scene.add(focus, std::make_shared<const fabrica::Surface>(fabrica::test::make_icosphere(5, 4)));
  const Camera cam = camera();
  fr::Scene drawn = fr::build_scene(scene, cam);
  // A line over the context's front (z = 9.9 mm at x = 0, on the sphere
  // near the middle row) and one over the focus's front (z = 4.9 mm).
  auto across = [](double r, double z_front) {
    fabrica::Polyline pl;
    pl.family = fabrica::LineFamily::ridge;
    for (int i = -40; i <= 40; ++i) {
      const double x = r * 0.9 * i / 40.0;
      fabrica::LineVertex v;
      v.position = Vec3(x, 0.0, std::sqrt(std::max(0.0, z_front * z_front - x * x)));
      pl.vertices.push_back(v);
    }
    return pl;
  };
  drawn.structures[0].lines.polylines = {across(10.0, 9.95)};
  drawn.structures[1].lines.polylines = {across(5.0, 4.95)};
  drawn.structures[0].style.families.clear();
  drawn.structures[1].style.families.clear();
  auto visible_x = [&](const fabrica::LineSet& ls) {
    std::vector<double> xs;
    const fabrica::Projector proj(cam);
    for (const auto& pl : ls.polylines)
      for (const auto& v : pl.vertices)
        if (v.visible) xs.push_back(proj(v.position).pixel.x() - kSize / 2.0);
    return xs;
  };
  const auto off = fr::vector_layers(scene, drawn, cam, kSize);
  drawn.cutaway.enabled = true;
  const auto on = fr::vector_layers(scene, drawn, cam, kSize);
  ASSERT_EQ(off.size(), 2u);
  ASSERT_EQ(on.size(), 2u);
  EXPECT_EQ(off[0].role, "context");
  EXPECT_EQ(visible_x(off[0].lines).size(), 81u);  // the whole context line
  EXPECT_TRUE(visible_x(off[1].lines).empty());    // the focus hidden by the context
  // With the cutaway: the context line outside 40 px + margin + fade / 2
  // (where the smoothstep passes 0.5), within a pixel and a vertex spacing.
  const auto cut = visible_x(on[0].lines);
  EXPECT_GT(cut.size(), 10u);
  EXPECT_LT(cut.size(), 40u);
  for (double x : cut) EXPECT_GT(std::abs(x), 40.0 + 12.0 + 4.0 - 1.5) << x;
  EXPECT_EQ(visible_x(on[1].lines).size(), 81u);  // the focus line, all of it
}
