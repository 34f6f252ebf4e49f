// Drawing: Lambert and toon shading against the analytic sphere, lines as
// quads whose width scales with the image, hidden-line modes, weighted
// blended transparency, the stage-1 buffer of the hybrid method against the
// analytic q1 of a sphere, its stage 2 against the plain filter on the CPU,
// and scene JSON round trips.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <set>

#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/render/renderer.hpp"
#include "render_test_util.hpp"

namespace fr = fabrica::render;
using fabrica::Camera;
using fabrica::Vec3;

namespace {

using fabrica::test::renderer;

fr::Structure sphere_structure(double radius = 10.0, fr::Role role = fr::Role::focus) {
  fr::Structure s;
  s.name = "sphere";
  s.role = role;
  s.mesh = fabrica::test::sphere_render_mesh(radius, 5);
  s.style = fr::default_style(role);
  s.style.color = {1.0f, 1.0f, 1.0f, 1.0f};
  s.style.ambient = 0.0;
  return s;
}

// Orthographic camera seeing a square of side 2 * half mm.
Camera ortho_camera(int size, double half) {
  Camera c = fabrica::test::front_camera(size, size, 100.0, true);
  c.fov_deg = 2.0 * std::atan(half / 100.0) * 180.0 / M_PI;
  return c;
}

fabrica::Polyline straight_line(const Vec3& a, const Vec3& b, int n = 16) {
  fabrica::Polyline pl;
  pl.family = fabrica::LineFamily::ridge;
  for (int i = 0; i <= n; ++i) {
    fabrica::LineVertex v;
    v.position = a + (b - a) * (double(i) / n);
    pl.vertices.push_back(v);
  }
  return pl;
}

// Sum over a column of the ink (1 - luminance) in pixels: a line's width.
double ink_across(const fr::Image& img, int x) {
  double sum = 0.0;
  for (int y = 0; y < img.height; ++y) {
    const auto* p = img.pixel(x, y);
    sum += 1.0 - (p[0] + p[1] + p[2]) / (3.0 * 255.0);
  }
  return sum;
}

// A blue ghost (radius 10, opacity 0.25, no lines) and a red opaque focus
// (radius 5) inside it, in that order, over `background`.
fr::Scene ghost_over_focus(const fr::Color& background) {
  fr::Scene scene;
  fr::Structure focus = sphere_structure(5.0);
  focus.style.color = {1.0f, 0.0f, 0.0f, 1.0f};
  fr::Structure ghost = sphere_structure(10.0, fr::Role::context);
  ghost.style.color = {0.0f, 0.0f, 1.0f, 1.0f};
  ghost.style.opacity = 0.25;
  ghost.style.families.clear();
  scene.structures = {ghost, focus};
  scene.background = background;
  return scene;
}

// A sphere drawn with `shading` whose lines (every family, untapered,
// `width` pixels at the reference size) the test adds to
// structures[0].lines.
fr::Scene sphere_with_lines(fr::Shading shading, double width) {
  fr::Scene scene;
  scene.structures.push_back(sphere_structure());
  scene.structures[0].style.shading = shading;
  scene.structures[0].style.families.clear();  // draw every family
  scene.structures[0].style.lines.width = width;
  scene.structures[0].style.lines.taper = 0.0;
  return scene;
}

}  // namespace

TEST(RenderDrawing, LambertSphereMatchesAnalyticProfile) {
  fr::Scene scene;
  scene.structures.push_back(sphere_structure());
  scene.background = {0.0f, 0.0f, 0.0f, 1.0f};
  const int size = 400;
  const double half = 12.5;  // mm seen from the centre to the edge
  const fr::Image img = renderer().render(scene, ortho_camera(size, half));
  int checked = 0;
  double worst = 0.0;
  for (int y = 0; y < size; y += 7) {
    for (int x = 0; x < size; x += 7) {
      const double px = (x + 0.5 - size / 2.0) * (2.0 * half / size);
      const double py = (y + 0.5 - size / 2.0) * (2.0 * half / size);
      const double rho = std::hypot(px, py) / 10.0;
      if (rho > 0.95) continue;
      const double expected = 255.0 * std::sqrt(1.0 - rho * rho);  // n.l of a sphere, headlight
      const double got = img.pixel(x, y)[0];
      worst = std::max(worst, std::abs(got - expected));
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_LE(worst, 3.0);  // 8-bit rounding plus interpolated normals of a subdivision-5 icosphere
  EXPECT_EQ(img.pixel(0, 0)[0], 0);
}

TEST(RenderDrawing, ToonShadingHasTheRequestedBands) {
  fr::Scene scene;
  scene.structures.push_back(sphere_structure());
  scene.structures[0].style.shading = fr::Shading::toon;
  scene.structures[0].style.toon_levels = 3;
  scene.background = {0.0f, 0.0f, 0.0f, 1.0f};
  const fr::Image img = renderer().render(scene, ortho_camera(200, 12.5));
  std::set<int> values;
  for (int y = 20; y < 180; ++y)
    for (int x = 20; x < 180; ++x) {
      const double rho = std::hypot(x + 0.5 - 100, y + 0.5 - 100) * 0.125 / 10.0;
      if (rho < 0.97) values.insert(img.pixel(x, y)[0]);
    }
  EXPECT_TRUE(values.count(255));
  EXPECT_TRUE(values.count(170));
  EXPECT_TRUE(values.count(85));
  for (int v : values) EXPECT_TRUE(v == 85 || v == 170 || v == 255) << v;
}

// Tight line quads (RenderOptions::tight_line_quads, the viewer while the
// camera moves): an untapered straight run gives the same pixels to a level
// (the quads end where the anti-aliased edge's coverage is zero); tapered
// (the quad's width changes along it) and on a polygonal circle (sharp
// joins every 10 degrees; a closed line is never tapered) very few pixels
// differ, and the ink across the lines is the same.
TEST(RenderDrawing, TightLineQuadsDrawTheSameLines) {
  fr::Scene scene = sphere_with_lines(fr::Shading::none, 12.0);  // 3 px at 256
  auto& ls = scene.structures[0].style.lines;
  auto& lines = scene.structures[0].lines.polylines;
  lines.push_back(straight_line(Vec3(-8, 0, 11), Vec3(8, 0, 11)));
  lines.push_back(straight_line(Vec3(-8, -6, 11), Vec3(8, -5, 11)));
  const Camera camera = ortho_camera(256, 12.5);
  fr::RenderOptions tight;
  tight.tight_line_quads = true;
  const fr::Image loose_straight = renderer().render(scene, camera);
  const fr::Image tight_straight = renderer().render(scene, camera, tight);
  EXPECT_LE(fr::compare_images(loose_straight, tight_straight, 1).max_abs, 1);
  EXPECT_NEAR(ink_across(tight_straight, 128), 6.0, 0.3);  // two lines of 3 px
  ls.taper = 0.3;
  const fr::Image loose_tapered = renderer().render(scene, camera);
  const fr::Image tight_tapered = renderer().render(scene, camera, tight);
  const fr::ImageDifference t = fr::compare_images(loose_tapered, tight_tapered, 16);
  EXPECT_LE(t.fraction_over, 0.002) << t.max_abs;
  for (int x : {60, 128})  // near an end (thinner: x from 46 to 210) and in the middle
    EXPECT_NEAR(ink_across(tight_tapered, x), ink_across(loose_tapered, x), 0.1) << x;
  ls.taper = 0.0;
  fabrica::Polyline circle;
  circle.family = fabrica::LineFamily::ridge;
  circle.closed = true;
  for (int i = 0; i < 36; ++i) {
    fabrica::LineVertex v;
    v.position = Vec3(6 * std::cos(i * M_PI / 18), 6 * std::sin(i * M_PI / 18), 11);
    circle.vertices.push_back(v);
  }
  lines = {circle};
  const fr::Image loose = renderer().render(scene, camera);
  const fr::Image tight_circle = renderer().render(scene, camera, tight);
  const fr::ImageDifference d = fr::compare_images(loose, tight_circle, 16);
  EXPECT_GT(ink_across(loose, 128), 5.0);  // the circle crosses the middle column twice
  EXPECT_NEAR(ink_across(tight_circle, 128), ink_across(loose, 128), 0.1);
  EXPECT_LE(d.fraction_over, 0.002) << d.max_abs;
}

TEST(RenderDrawing, LineWidthScalesWithImageSize) {
  // 8 pixels at the 1024-pixel reference.
  fr::Scene scene = sphere_with_lines(fr::Shading::none, 8.0);
  scene.structures[0].lines.polylines.push_back(straight_line(Vec3(-8, 0, 11), Vec3(8, 0, 11)));
  double widths[3];
  const int sizes[3] = {256, 1024, 2048};
  for (int i = 0; i < 3; ++i)
    widths[i] = ink_across(renderer().render(scene, ortho_camera(sizes[i], 12.5)), sizes[i] / 2);
  EXPECT_NEAR(widths[0], 2.0, 0.2);
  EXPECT_NEAR(widths[1], 8.0, 0.3);
  EXPECT_NEAR(widths[2], 16.0, 0.5);
  // Fixed pixel widths when asked.
  fr::RenderOptions fixed;
  fixed.scale_lines_with_image = false;
  EXPECT_NEAR(ink_across(renderer().render(scene, ortho_camera(256, 12.5), fixed), 128), 8.0, 0.3);
  EXPECT_NEAR(ink_across(renderer().render(scene, ortho_camera(2048, 12.5), fixed), 1024), 8.0,
              0.3);
}

TEST(RenderDrawing, FadeByStrengthAndTaper) {
  fr::Scene scene = sphere_with_lines(fr::Shading::none, 8.0);
  auto pl = straight_line(Vec3(-8, 0, 11), Vec3(8, 0, 11));
  for (auto& v : pl.vertices) v.strength = 0.5f;
  scene.structures[0].lines.polylines.push_back(pl);
  const double faded = ink_across(renderer().render(scene, ortho_camera(512, 12.5)), 256);
  EXPECT_NEAR(faded, 0.5 * 4.0, 0.2);  // half the ink of a 4-pixel line
  scene.structures[0].style.lines.taper = 0.3;
  scene.structures[0].style.lines.fade_by_strength = false;
  const fr::Image tapered = renderer().render(scene, ortho_camera(512, 12.5));
  // Near the ends (5% of the length) the line is thinner than in the middle.
  const int x_end = static_cast<int>(256 - 0.9 * 8.0 / 12.5 * 256);
  EXPECT_LT(ink_across(tapered, x_end), 0.7 * ink_across(tapered, 256));
}

TEST(RenderDrawing, HiddenLinesOmittedDashedOrShown) {
  fr::Scene scene = sphere_with_lines(fr::Shading::flat, 6.0);
  auto& ls = scene.structures[0].style.lines;
  // Behind the sphere (z = -11), crossing it: hidden where |x| < 10.
  scene.structures[0].lines.polylines.push_back(
      straight_line(Vec3(-4, 0, -11), Vec3(4, 0, -11), 64));
  double ink[3];
  for (auto mode : {fr::HiddenLines::omit, fr::HiddenLines::dashed, fr::HiddenLines::show}) {
    ls.hidden = mode;
    const fr::Image img = renderer().render(scene, ortho_camera(512, 12.5));
    double sum = 0.0;
    for (int x = 150; x < 362; ++x) sum += ink_across(img, x);
    ink[static_cast<int>(mode)] = sum;
  }
  EXPECT_LT(ink[0], 1.0);
  EXPECT_GT(ink[2], 100.0);
  EXPECT_GT(ink[1], 0.3 * ink[2]);
  EXPECT_LT(ink[1], 0.7 * ink[2]);
}

TEST(RenderDrawing, GhostedContextBlendsOverFocusInAnyOrder) {
  fr::Scene scene = ghost_over_focus({0.0f, 0.0f, 0.0f, 1.0f});
  const fr::Image a = renderer().render(scene, ortho_camera(200, 12.5));
  std::swap(scene.structures[0], scene.structures[1]);
  const fr::Image b = renderer().render(scene, ortho_camera(200, 12.5));
  EXPECT_LE(fr::compare_images(a, b, 1).max_abs, 1);  // order independent
  // Centre: one ghost layer (its back is hidden by the focus) over the red focus.
  const auto* c = a.pixel(100, 100);
  EXPECT_NEAR(c[0], 0.75 * 255, 3);
  EXPECT_NEAR(c[2], 0.25 * 255, 3);
  // Outside the focus, inside the ghost: two ghost layers over black.
  const double rho = 7.5 / 10.0;
  const double lambert = std::sqrt(1 - rho * rho);
  const auto* g = a.pixel(100 + 60, 100);  // 60 px = 7.5 mm
  const double coverage = 1.0 - 0.75 * 0.75;
  EXPECT_NEAR(g[2], 255.0 * coverage * lambert, 6);
  EXPECT_EQ(g[0], 0);
}

TEST(RenderDrawing, HybridStageOneMatchesAnalyticSphere) {
  // Sphere: Q = k P^-1, so q1 (largest eigenvalue of Q^T Q) = k^2 / cos^2(theta),
  // and t1 is the radial screen direction.
  auto mesh = fabrica::test::sphere_render_mesh(10.0, 5);
  fr::HybridOptions o;
  o.tau = std::log2(0.25 * 100.0);  // q = 0.25 at the centre (k^2 = 0.01)
  o.float_target = false;
  const int size = 400;
  const fr::Image buf = renderer().render_hybrid_buffer(mesh, ortho_camera(size, 12.5), o);
  for (double rho : {0.0, 0.3, 0.5, 0.7}) {
    const int x = static_cast<int>(size / 2 + rho * 10.0 / 12.5 * size / 2);
    const auto* p = buf.pixel(x, size / 2);
    const double expected = 0.25 / (1.0 - rho * rho);
    EXPECT_NEAR(p[0] / 255.0, expected, 0.012) << "rho " << rho;
    EXPECT_EQ(p[3], 255);
    if (rho > 0.2) {
      EXPECT_GT(p[1], 245) << "t1 should be +x on the right half: " << int(p[1]) << " "
                           << int(p[2]);
      EXPECT_NEAR(p[2], 128, 4);
    }
  }
  EXPECT_EQ(buf.pixel(2, 2)[3], 0);  // background
}

TEST(RenderDrawing, HybridSphereHasOnlyTheOutline) {
  // A sphere has no apparent ridges but its contour (q1 -> infinity).
  auto mesh = fabrica::test::sphere_render_mesh(10.0, 5);
  const int size = 300;
  for (int variant = 0; variant < 4; ++variant) {
    fr::HybridOptions o;
    o.tau = std::log2(100.0 * 0.25);
    o.per_fragment = variant == 1;
    o.sign_free = variant == 2;
    o.float_target = variant == 3;
    const fr::Image img = renderer().render_hybrid(mesh, ortho_camera(size, 12.5), o);
    std::size_t ink_inside = 0, ink_ring = 0;
    std::set<int> sectors;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        if (img.pixel(x, y)[0] > 128) continue;
        const double dx = x + 0.5 - size / 2.0, dy = y + 0.5 - size / 2.0;
        const double rho = std::hypot(dx, dy) * (25.0 / size) / 10.0;
        if (rho < 0.85)
          ++ink_inside;
        else if (rho < 1.05) {
          ++ink_ring;
          sectors.insert(static_cast<int>((std::atan2(dy, dx) + M_PI) / (2 * M_PI) * 36) % 36);
        }
      }
    EXPECT_EQ(ink_inside, 0u) << "variant " << variant;
    EXPECT_GT(ink_ring, 300u) << "variant " << variant;
    EXPECT_EQ(sectors.size(), 36u) << "variant " << variant << ": the outline is closed";
  }
}

// Stage 2 on the CPU from the stage-1 buffer (8-bit target): the filter of
// ar_stage2.frag without any shortcut, for HybridStageTwoMatchesCpuFilter.
// Returns the red channel render_hybrid writes over white (255 = no ink).
int cpu_stage_two(const fr::Image& buf, int x, int y, const fr::HybridOptions& o) {
  const auto* c = buf.pixel(x, y);
  if (c[3] < 128) return 255;
  const float lambda = static_cast<float>(o.lambda), threshold = static_cast<float>(o.threshold);
  float v = (8.0f + 8.0f * lambda) * (c[0] / 255.0f);
  if (lambda >= -0.5f && v <= threshold) return 255;
  float tx = 2.0f * (c[1] / 255.0f - 0.5f), ty = 2.0f * (c[2] / 255.0f - 0.5f);
  if (tx == 0.0f && ty == 0.0f) return 255;
  if (o.sign_free) {
    const float phi = 0.5f * std::atan2(ty, tx);
    tx = std::cos(phi);
    ty = std::sin(phi);
  }
  const float b = 0.92387953251080f, a = 0.70710678118655f;
  int dx = -1, dy = 1;
  if (std::abs(tx) > b)
    dx = 1, dy = 0;
  else if (std::abs(a * tx + a * ty) > b)
    dx = 1, dy = 1;
  else if (std::abs(ty) > b)
    dx = 0, dy = 1;
  // GL offsets (y up) on an image stored top row first.
  auto q = [&](int ox, int oy) { return buf.pixel(x + ox, y - oy)[0] / 255.0f; };
  const float h = q(-1, 0) + q(1, 0), vert = q(0, 1) + q(0, -1);
  const float diag = q(1, 1) + q(-1, -1), anti = q(-1, 1) + q(1, -1);
  const float C = dy == 0    ? h + 0.5f * (diag + anti)
                  : dx == 0  ? vert + 0.5f * (diag + anti)
                  : dx == dy ? diag + 0.5f * (h + vert)
                             : anti + 0.5f * (h + vert);
  v -= (h + vert + diag + anti) + 2.0f * lambda * C;
  if (v <= threshold) return 255;
  const float ink = o.fade ? std::min(v, 1.0f) : 1.0f;
  return static_cast<int>(std::lround(255.0 * (1.0 - ink)));
}

TEST(RenderDrawing, HybridStageTwoMatchesCpuFilter) {
  // The renderer filters only the pixels its mask pass marks (renderer.cpp,
  // hybrid_stage2); the image must equal the plain filter applied to every
  // pixel of the stage-1 buffer. A torus in perspective has contours, ridges
  // inside and pixels on both sides of every early test.
  auto mesh = fabrica::test::torus_render_mesh(1.0, 0.35, 96, 48);
  Camera cam = fabrica::test::front_camera(256, 256, 5.0);
  cam.eye = Vec3(0.0, -4.0, 5.5);
  for (int variant = 0; variant < 5; ++variant) {
    fr::HybridOptions o;
    if (variant == 1) o.lambda = 0.0, o.threshold = 0.05;
    if (variant == 2) o.lambda = -0.75;  // no early bound: every covered pixel is filtered
    if (variant == 3) o.fade = false, o.sign_free = true;
    if (variant == 4) o.tau = 0.0, o.threshold = 0.1;
    const fr::Image buf = renderer().render_hybrid_buffer(mesh, cam, o);
    const fr::Image img = renderer().render_hybrid(mesh, cam, o);
    std::size_t inked = 0, differ = 0, grey = 0;
    for (int y = 1; y + 1 < img.height; ++y)
      for (int x = 1; x + 1 < img.width; ++x) {
        const int expected = cpu_stage_two(buf, x, y, o);
        const int actual = img.pixel(x, y)[0];
        if (expected < 255) ++inked;
        if (expected > 0 && expected < 255) ++grey;
        if (std::abs(expected - actual) > 1) ++differ;
      }
    // Float rounding (FMA, conversions) may move a pixel across the
    // threshold; a pixel the mask lost would differ by its whole ink.
    EXPECT_GT(inked, 400u) << "variant " << variant;
    if (o.fade && variant < 3) {
      EXPECT_GT(grey, 40u) << "variant " << variant << ": faded ink";
    }
    EXPECT_LE(differ, inked / 500 + 2)
        << "variant " << variant << ": " << differ << " of " << inked << " inked pixels differ";
  }
}

TEST(RenderScene, JsonRoundTrip) {
  fr::SceneSpec spec;
  fr::StructureSpec a;
  a.name = "liver";
  a.mesh = "/data/liver.stl";
  a.role = fr::Role::focus;
  a.style = fr::default_style(fr::Role::focus);
  a.style.hybrid_apparent_ridges = true;
  a.style.lines.hidden = fr::HiddenLines::dashed;
  fr::StructureSpec b;
  b.name = "skin";
  b.mesh = "/data/skin.stl";
  b.role = fr::Role::context;
  b.style = fr::default_style(fr::Role::context);
  b.space = fabrica::Space::ras;
  spec.structures = {a, b};
  spec.view = fabrica::AnatomicalView::anterior;
  spec.transparent = true;
  fr::ClipPlane clip;
  clip.point = fabrica::Vec3(1.0 / 3.0, -2.5, 1e-7);
  clip.normal = fabrica::Vec3(0.0, -1.0, 0.25);
  spec.clip = clip;
  const auto dir = fabrica::test::temp_dir("render_scene_json");
  fr::write_scene_spec(spec, dir / "scene.json");
  const fr::SceneSpec back = fr::read_scene_spec(dir / "scene.json");
  ASSERT_EQ(back.structures.size(), 2u);
  EXPECT_EQ(back.structures[0].name, "liver");
  EXPECT_TRUE(back.structures[0].style.hybrid_apparent_ridges);
  EXPECT_EQ(back.structures[0].style.lines.hidden, fr::HiddenLines::dashed);
  EXPECT_EQ(back.structures[1].role, fr::Role::context);
  EXPECT_DOUBLE_EQ(back.structures[1].style.opacity, 0.25);
  EXPECT_EQ(back.structures[1].space, fabrica::Space::ras);
  EXPECT_EQ(back.structures[1].style.families, b.style.families);
  EXPECT_EQ(back.view, fabrica::AnatomicalView::anterior);
  EXPECT_TRUE(back.transparent);
  // The clipping plane comes back exactly (the viewer's export and
  // `fabrica render` must clip at the same place).
  ASSERT_TRUE(back.clip.has_value());
  EXPECT_EQ(back.clip->point, clip.point);
  EXPECT_EQ(back.clip->normal, clip.normal);
  EXPECT_TRUE(clip.keeps(clip.point + fabrica::Vec3(0.0, 1.0, 0.0)));
  EXPECT_FALSE(clip.keeps(clip.point + fabrica::Vec3(0.0, -1.0, 0.0)));
  for (const char* bad_clip :
       {R"({"point": [0, 0, 0], "normal": [0, 0, 0]})", R"({"point": [0, 0], "normal": [0, 0, 1]})",
        R"({"point": [0, 0, 0], "normal": [0, 0, 1], "offset": 2})"}) {
    nlohmann::json j = fr::scene_spec_to_json(spec);
    j["clip"] = nlohmann::json::parse(bad_clip);
    try {
      fr::scene_spec_from_json(j, dir, "my.json");
      ADD_FAILURE() << bad_clip;
    } catch (const fabrica::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("my.json: clip"), std::string::npos) << e.what();
    }
  }
  // Errors name the scene and the structure.
  nlohmann::json bad = {{"structures", {{{"mesh", "a.stl"}, {"role", "hero"}}}}};
  try {
    fr::scene_spec_from_json(bad, dir, "my.json");
    FAIL();
  } catch (const fabrica::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("my.json: structures[0]"), std::string::npos) << e.what();
  }
}

// Back-face culling (RenderMesh::closed_outward): a closed outward mesh is
// recognised, an open or inward one is not; culled, the picture is the one
// drawn without culling, also from inside the mesh (the near plane cuts it:
// no culling) and with a ghost in front.
TEST(RenderDrawing, BackFaceCullingOfClosedMeshesKeepsThePicture) {
  using fabrica::test::make_icosphere;
  const fabrica::TriangleMesh sphere = make_icosphere(10.0, 4);
  std::vector<Vec3> normals;
  for (const Vec3& p : sphere.positions) normals.push_back(p.normalized());
  EXPECT_TRUE(fr::make_render_mesh(sphere, normals).closed_outward);
  fabrica::TriangleMesh open = sphere;
  open.faces.pop_back();
  EXPECT_FALSE(fr::make_render_mesh(open, normals).closed_outward);
  fabrica::TriangleMesh inward = sphere;
  for (auto& f : inward.faces) std::swap(f[1], f[2]);
  EXPECT_FALSE(fr::make_render_mesh(inward, normals).closed_outward);
  fabrica::TriangleMesh one_flipped = sphere;
  std::swap(one_flipped.faces[7][1], one_flipped.faces[7][2]);
  EXPECT_FALSE(fr::make_render_mesh(one_flipped, normals).closed_outward);

  auto closed = std::make_shared<fr::RenderMesh>(fr::make_render_mesh(sphere, normals));
  auto unmarked = std::make_shared<fr::RenderMesh>(*closed);
  unmarked->closed_outward = false;      // the same mesh, never culled
  for (double distance : {60.0, 5.0}) {  // outside; inside the sphere
    Camera camera = fabrica::test::front_camera(160, 120, distance, false, 60.0);
    fr::Scene a, b;
    fr::Structure s = sphere_structure();
    s.style.color = {1.0f, 0.0f, 0.0f, 1.0f};
    fr::Structure ghost = sphere_structure(4.0, fr::Role::context);
    s.mesh = closed;
    a.structures = {s, ghost};
    s.mesh = unmarked;
    b.structures = {s, ghost};
    const fr::Image ia = renderer().render(a, camera), ib = renderer().render(b, camera);
    EXPECT_EQ(fr::compare_images(ia, ib, 0).max_abs, 0) << "camera at " << distance;
    // The sphere covers the middle, the background the corner (outside).
    EXPECT_LT(ia.pixel(80, 60)[1], 250);
    if (distance > 20.0) {
      EXPECT_EQ(ia.pixel(2, 2)[1], 255);
    }
  }
}

// A render mesh from a mesh alone (a moving level's, no topology): unit
// normals along the sphere's radius (within the facets' tilt), the same as
// the Surface's to a few degrees, positions and indices as given, and the
// same bounding sphere and closedness.
TEST(RenderMeshLod, NormalsFromTheMeshAloneFollowTheSurface) {
  const fabrica::TriangleMesh sphere = fabrica::test::make_icosphere(10.0, 4);
  const fabrica::Surface surface(sphere);
  const fr::RenderMesh alone = fr::make_render_mesh(sphere);
  const fr::RenderMesh from_surface = fr::make_render_mesh(surface, false);
  ASSERT_EQ(alone.normals.size(), 3 * sphere.positions.size());
  EXPECT_EQ(alone.positions, from_surface.positions);
  EXPECT_EQ(alone.indices, from_surface.indices);
  EXPECT_EQ(alone.closed_outward, from_surface.closed_outward);
  EXPECT_TRUE(alone.closed_outward);
  EXPECT_DOUBLE_EQ(alone.radius, from_surface.radius);
  EXPECT_DOUBLE_EQ(alone.mean_edge_length, from_surface.mean_edge_length);
  for (std::size_t i = 0; i < sphere.positions.size(); ++i) {
    const Vec3 n(alone.normals[3 * i], alone.normals[3 * i + 1], alone.normals[3 * i + 2]);
    const Vec3 m(from_surface.normals[3 * i], from_surface.normals[3 * i + 1],
                 from_surface.normals[3 * i + 2]);
    EXPECT_NEAR(n.norm(), 1.0, 1e-6) << i;
    EXPECT_GT(n.dot(sphere.positions[i].normalized()), std::cos(2.0 * M_PI / 180.0)) << i;
    EXPECT_GT(n.dot(m), std::cos(2.0 * M_PI / 180.0)) << i;
  }
  // A vertex no face uses: a zero normal, not NaN.
  fabrica::TriangleMesh extra = sphere;
  extra.positions.push_back(Vec3(50, 0, 0));
  const fr::RenderMesh with_extra = fr::make_render_mesh(extra);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(with_extra.normals[with_extra.normals.size() - 3 + c], 0.0f);
}

// Level of detail (render::cluster_simplify): about the asked number of
// faces, vertices on the surface within a cell, the same output every time,
// the input itself when it is small enough.
TEST(RenderMeshLod, ClusterSimplifyKeepsTheShapeWithFewerFaces) {
  const fabrica::TriangleMesh sphere = fabrica::test::make_icosphere(10.0, 5);  // 20,480 faces
  ASSERT_EQ(sphere.faces.size(), 20480u);
  const fabrica::TriangleMesh coarse = fr::cluster_simplify(sphere, 2000);
  EXPECT_LE(coarse.faces.size(), 2500u);
  EXPECT_GE(coarse.faces.size(), 1000u);
  // Cells of about sqrt(3 A / 2000) = 3.4 mm: a mean of points within a
  // cell lies inside the sphere by less than the cell's sagitta.
  for (const Vec3& p : coarse.positions) {
    EXPECT_LE(p.norm(), 10.0 + 1e-9);
    EXPECT_GE(p.norm(), 9.0);
  }
  std::size_t outward = 0;
  for (const auto& f : coarse.faces) {
    EXPECT_NE(f[0], f[1]);
    EXPECT_NE(f[1], f[2]);
    EXPECT_NE(f[0], f[2]);
    const Vec3 &a = coarse.positions[f[0]], &b = coarse.positions[f[1]],
               &c = coarse.positions[f[2]];
    if ((b - a).cross(c - a).dot(a + b + c) > 0.0) ++outward;
  }
  // Orientation kept, but for the few sliver faces clustering folds over.
  EXPECT_GE(outward, coarse.faces.size() * 99 / 100);
  const fabrica::TriangleMesh again = fr::cluster_simplify(sphere, 2000);
  EXPECT_EQ(again.faces, coarse.faces);
  EXPECT_EQ(again.positions, coarse.positions);
  EXPECT_EQ(fr::cluster_simplify(sphere, 30000).faces, sphere.faces);
}

// Half-resolution ghosts (RenderOptions::ghosts_half_resolution, the
// viewer while the camera moves): the transparency pass at half the
// resolution in each axis, composited bilinearly, stays close to the full
// picture: mean |difference| <= 1.5 levels of 255, at most 5 % of the
// pixels off by more than 16 levels (a band of 2 pixels along the ghost's
// silhouette and the focus's edge, where a half pixel straddles two
// surfaces: 2 x 2 pi (80 + 40) px = 3.8 % of 200 x 200; measured 3.1 %,
// mean 1.2), and inside the ghost, away from edges, within 3 levels. Off,
// nothing changes; a picture of several tiles ignores it.
// The passes scissored to where structures can be (the ghosts'
// transparency and composite, the hybrid ridges) bound a mesh by its
// vertices' box (RenderMesh::box_min/box_max, set by make_render_mesh),
// tighter than its sphere's cube for a flat ghost seen obliquely: the same
// pixels as with the sphere's bound, with a hybrid focus too. At half
// resolution depth A is copied down only around that rectangle, and which
// of each 2x2 pixels' depths a nearest 2:1 copy takes may differ with the
// copied rectangle (its sample points fall on texel edges): a few pixels
// along the focus's outline under the ghost differ, no more.
TEST(RenderDrawing, BoxBoundsDrawTheSamePixelsAsSphereBounds) {
  const auto flat = std::make_shared<fr::RenderMesh>(*fabrica::test::sphere_render_mesh(10.0, 4));
  for (std::size_t i = 1; i < flat->positions.size(); i += 3) flat->positions[i] *= 0.3f;
  flat->box_min.y() *= 0.3;
  flat->box_max.y() *= 0.3;
  ASSERT_LT(flat->box_max.y(), 3.01);
  const auto unbounded = std::make_shared<fr::RenderMesh>(*flat);
  unbounded->box_min = Vec3::Constant(1.0);
  unbounded->box_max = Vec3::Constant(-1.0);
  fr::Scene scene = ghost_over_focus({1.0f, 1.0f, 1.0f, 1.0f});
  scene.structures[1].style.hybrid_apparent_ridges = true;
  Camera camera = ortho_camera(160, 12.5);
  camera.eye = Vec3(0, 60, 80);  // from above and in front: the flat ghost's box is low
  for (bool half : {false, true}) {
    fr::RenderOptions options;
    options.ghosts_half_resolution = half;
    scene.structures[0].mesh = flat;
    const fr::Image boxed = renderer().render(scene, camera, options);
    scene.structures[0].mesh = unbounded;
    const fr::Image sphered = renderer().render(scene, camera, options);
    const fr::ImageDifference d = fr::compare_images(boxed, sphered, 16);
    if (!half)
      EXPECT_EQ(d.max_abs, 0);
    else
      EXPECT_LE(d.fraction_over, 0.01) << d.max_abs;  // measured 0.6 %
  }
}

TEST(RenderDrawing, HalfResolutionGhostsStayCloseToTheFullPicture) {
  fr::Scene scene = ghost_over_focus({1.0f, 1.0f, 1.0f, 1.0f});
  fr::Structure& ghost = scene.structures[0];
  for (int size : {200, 201}) {  // even and odd: the last half pixel covers one
    const Camera camera = ortho_camera(size, 12.5);
    const fr::Image full = renderer().render(scene, camera);
    fr::RenderOptions half_options;
    half_options.ghosts_half_resolution = true;
    const fr::Image half = renderer().render(scene, camera, half_options);
    const fr::ImageDifference d = fr::compare_images(full, half, 16);
    EXPECT_GT(d.max_abs, 0) << size;  // it was drawn at half resolution
    EXPECT_LE(d.mean_abs, 1.5) << size;
    EXPECT_LE(d.fraction_over, 0.05) << size;
    // Inside the ghost, away from edges: the same colour to a few levels.
    for (const auto& [x, y] : {std::pair{size / 2, size / 2}, std::pair{size / 2 + 60, size / 2}}) {
      const auto *a = full.pixel(x, y), *b = half.pixel(x, y);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 3) << size << " " << x << "," << y;
    }
    // Off (the still picture, exports): the same picture as before.
    EXPECT_EQ(fr::compare_images(full, renderer().render(scene, camera, {}), 0).max_abs, 0);
  }
  // The ghost's lines are tested against its depth at half resolution: a
  // line in front of it (z = 10.5, above the centre) is drawn, one behind
  // the focus (z = -11, below it) omitted, as in the full picture.
  ghost.style.lines.hidden = fr::HiddenLines::omit;
  ghost.style.lines.width = 20.0;  // about 4 px at 200 px
  ghost.style.lines.color = {0.0f, 0.0f, 0.0f, 1.0f};
  ghost.style.lines.fade_by_strength = false;
  ghost.style.lines.taper = 0.0;
  // A third line, beside the focus (y = 7) inside the ghost (z = 0), is
  // behind the ghost's own front (z = 7.1 there): hidden by the ghost's
  // depth, which the transparency pass draws itself where the driver has
  // per-buffer blend equations (OpenGL 4.0, llvmpipe; else a depth pass).
  ghost.lines.polylines = {straight_line(Vec3(-4, 3, 10.5), Vec3(4, 3, 10.5), 64),
                           straight_line(Vec3(-4, -3, -11), Vec3(4, -3, -11), 64)};
  {
    const Camera camera = ortho_camera(200, 12.5);
    fr::RenderOptions half_options;
    half_options.ghosts_half_resolution = true;
    const fr::Image full_two = renderer().render(scene, camera);
    const fr::Image half_two = renderer().render(scene, camera, half_options);
    ghost.lines.polylines.push_back(straight_line(Vec3(-3, 7, 0), Vec3(3, 7, 0), 64));
    const fr::Image full = renderer().render(scene, camera);
    const fr::Image half = renderer().render(scene, camera, half_options);
    const int front = 100 + 24, behind = 100 - 24;  // 3 mm = 24 px above and below the centre
    const int inside = 100 + 56;                    // 7 mm above the centre
    for (const auto& [img, two] : {std::pair{&full, &full_two}, std::pair{&half, &half_two}}) {
      EXPECT_LT(img->pixel(100, img->height - 1 - front)[0], 60);    // line: dark
      EXPECT_GT(img->pixel(100, img->height - 1 - behind)[0], 120);  // no line: the red focus
      // The third line is not drawn: the same pixels as without it.
      EXPECT_EQ(fr::compare_images(*img, *two, 0).max_abs, 0);
      EXPECT_GT(img->pixel(100, img->height - 1 - inside)[2], 120);  // the ghost's blue
    }
    EXPECT_LE(fr::compare_images(full, half, 16).fraction_over, 0.05);
  }
  // Several tiles: ignored, the same as the full picture in tiles.
  fr::RenderOptions tiled;
  tiled.max_tile_size = 96;
  const Camera camera = ortho_camera(200, 12.5);
  const fr::Image full_tiled = renderer().render(scene, camera, tiled);
  tiled.ghosts_half_resolution = true;
  EXPECT_EQ(fr::compare_images(full_tiled, renderer().render(scene, camera, tiled), 0).max_abs, 0);
}
