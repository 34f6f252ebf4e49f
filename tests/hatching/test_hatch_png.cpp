// PNG output of hatching through the renderer. First the renderer's polyline
// layers on their own (render::Structure::polyline_layers: drawn at their own
// width and colour, not filtered by the structure's line families, hidden
// behind the surface like feature lines, under the feature lines). Then the
// command: `fabrica hatch -o x.png` has ink where the SVG of the same run has
// strokes (stroke vertices read from the SVG, no rasteriser involved), white
// paper or transparency around, and exit code 4 when no GL backend exists.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/render/render_mesh.hpp"
#include "fabrica/render/renderer.hpp"
#include "test_support.hpp"

namespace fr = fabrica::render;
namespace fs = std::filesystem;
using fabrica::Camera;
using fabrica::Vec2;
using fabrica::Vec3;

namespace {

// ----------------------------------------------------- renderer layers

// Orthographic camera at +z seeing a square of side 2 * half mm.
Camera ortho_camera(int size, double half) {
  Camera c;
  c.eye = Vec3(0.0, 0.0, 100.0);
  c.center = Vec3::Zero();
  c.up = Vec3::UnitY();
  c.projection = fabrica::Projection::orthographic;
  c.fov_deg = 2.0 * std::atan(half / 100.0) * 180.0 / M_PI;
  c.width = size;
  c.height = size;
  return c;
}

fr::Structure white_sphere() {
  const fabrica::TriangleMesh mesh = fabrica::test::make_icosphere(10.0, 4);
  std::vector<Vec3> normals;
  for (const Vec3& p : mesh.positions) normals.push_back(p.normalized());
  fr::Structure s;
  s.name = "sphere";
  s.mesh = std::make_shared<fr::RenderMesh>(fr::make_render_mesh(mesh, normals));
  s.style.shading = fr::Shading::flat;
  s.style.color = {1.0f, 1.0f, 1.0f, 1.0f};
  s.style.families = {fabrica::LineFamily::contour};  // feature lines: contours only
  return s;
}

std::vector<Vec3> segment(const Vec3& a, const Vec3& b, int n = 32) {
  std::vector<Vec3> points;
  for (int i = 0; i <= n; ++i) points.push_back(a + (b - a) * (double(i) / n));
  return points;
}

fr::LineStyle plain(double width, fr::Color color) {
  fr::LineStyle style;
  style.width = width;
  style.color = color;
  style.taper = 0.0;
  style.fade_by_strength = false;
  return style;
}

// Ink of one channel summed down column x: a line's width in pixels.
double ink_down(const fr::Image& img, int x, int channel) {
  double sum = 0.0;
  for (int y = 0; y < img.height; ++y) sum += 1.0 - img.pixel(x, y)[channel] / 255.0;
  return sum;
}

std::unique_ptr<fr::Renderer> make_renderer() {
  try {
    return std::make_unique<fr::Renderer>(fr::create_headless_context());
  } catch (const fabrica::Error&) {
    return nullptr;
  }
}

// ------------------------------------------------------------- command

fs::path aneurysm() {
  return fabrica::test::bundled_data() / "meshes" / "anatomy" / "vessels" / "sofa_aneurysm3D_1.off";
}

/// Runs the fabrica executable (arguments shell-quoted); returns its exit code.
int run_fabrica(const std::vector<std::string>& args, const std::string& env = "") {
  std::string cmd = env.empty() ? "" : "env " + env + " ";
  cmd += "'" + std::string(FABRICA_EXE) + "'";
  for (const auto& a : args) cmd += " '" + a + "'";
  cmd += " > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Every vertex of every path of the SVG's hatching group, in pixels
/// (paths are "M x y l dx dy dx dy ...").
std::vector<std::vector<Vec2>> svg_strokes(const fs::path& svg) {
  std::ifstream in(svg);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  const auto begin = s.find("<g class=\"hatching\"");
  const auto end = s.find("</g>", begin);
  std::vector<std::vector<Vec2>> strokes;
  if (begin == std::string::npos || end == std::string::npos) return strokes;
  const std::string group = s.substr(begin, end - begin);
  const std::regex path_re("d=\"M([^\"]*)\"");
  for (auto it = std::sregex_iterator(group.begin(), group.end(), path_re);
       it != std::sregex_iterator(); ++it) {
    std::string d = (*it)[1].str();
    for (char& c : d)
      if (c == 'l') c = ' ';
    std::istringstream nums(d);
    std::vector<Vec2> points;
    double x = 0.0, y = 0.0;
    if (!(nums >> x >> y)) continue;
    points.emplace_back(x, y);
    double dx = 0.0, dy = 0.0;
    while (nums >> dx >> dy) {
      x += dx;
      y += dy;
      points.emplace_back(x, y);
    }
    strokes.push_back(points);
  }
  return strokes;
}

/// Darkest luminance (0..255, weighted by alpha over white) in the 3x3
/// neighbourhood of pixel position p (SVG pixels: x right, y down, pixel
/// centres at +0.5).
int darkest_near(const fr::Image& img, const Vec2& p) {
  const int cx = static_cast<int>(std::floor(p.x())), cy = static_cast<int>(std::floor(p.y()));
  int darkest = 255;
  for (int y = cy - 1; y <= cy + 1; ++y)
    for (int x = cx - 1; x <= cx + 1; ++x) {
      if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
      const auto* q = img.pixel(x, y);
      const int lum = (q[0] + q[1] + q[2]) / 3;
      const int over_white = (lum * q[3] + 255 * (255 - q[3])) / 255;
      darkest = std::min(darkest, over_white);
    }
  return darkest;
}

std::size_t dark_pixels(const fr::Image& img) {
  std::size_t n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const auto* q = img.pixel(x, y);
      if (q[3] > 128 && (q[0] + q[1] + q[2]) / 3 < 128) ++n;
    }
  return n;
}

}  // namespace

TEST(RenderPolylineLayer, OwnWidthColourHiddenLinesAndOrder) {
  auto renderer = make_renderer();
  if (!renderer) GTEST_SKIP() << "no headless GL backend";
  fr::Scene scene;
  fr::Structure s = white_sphere();
  // A red layer in front of the sphere (z = 11) along y = 0, 6 px wide.
  s.polyline_layers.push_back({"red", plain(6.0, {1.0f, 0.0f, 0.0f, 1.0f}), {}});
  s.polyline_layers[0].polylines.push_back(segment(Vec3(-8, 0, 11), Vec3(8, 0, 11)));
  // A blue layer behind the sphere (z = -11), along y = 5: hidden.
  s.polyline_layers.push_back({"blue", plain(4.0, {0.0f, 0.0f, 1.0f, 1.0f}), {}});
  s.polyline_layers[1].polylines.push_back(segment(Vec3(-4, 5, -11), Vec3(4, 5, -11)));
  // A ridge feature line (filtered out by families = {contour}) along x = 0.
  fabrica::Polyline ridge;
  ridge.family = fabrica::LineFamily::ridge;
  for (const Vec3& p : segment(Vec3(0, -8, 11), Vec3(0, 8, 11))) {
    fabrica::LineVertex v;
    v.position = p;
    ridge.vertices.push_back(v);
  }
  s.lines.polylines.push_back(ridge);
  // A contour-family feature line crossing the red layer at x = 100 px: on top.
  fabrica::Polyline contour = ridge;
  contour.family = fabrica::LineFamily::contour;
  for (auto& v : contour.vertices) v.position.x() = -12.5 + 100.5 / 512.0 * 25.0;
  s.lines.polylines.push_back(contour);
  s.style.lines = plain(3.0, {0.0f, 0.0f, 0.0f, 1.0f});
  scene.structures.push_back(s);

  fr::RenderOptions options;
  options.scale_lines_with_image = false;  // widths in image pixels
  const fr::Image img = renderer->render(scene, ortho_camera(512, 12.5), options);
  // Red: full red, no green; 6 px of green ink across it.
  const auto* centre = img.pixel(256 + 40, 256);
  EXPECT_GT(centre[0], 240);
  EXPECT_LT(centre[1], 15);
  EXPECT_NEAR(ink_down(img, 256 + 40, 1), 6.0, 0.4);
  // The ridge at x = 0 is filtered out: nothing but the red layer down x = 256 + 40,
  // and the column x = 256 has the same 6 px only (no vertical ridge line).
  EXPECT_NEAR(ink_down(img, 256, 1), 6.0, 0.4);
  // The blue layer behind the sphere is hidden: no ink in the red channel on y = 5 mm.
  const int y_blue = static_cast<int>(256 - 5.0 / 25.0 * 512);
  double blue_ink = 0.0;
  for (int x = 200; x < 312; ++x) blue_ink += 1.0 - img.pixel(x, y_blue)[0] / 255.0;
  EXPECT_LT(blue_ink, 0.5);
  // ... and drawn when its style shows hidden lines (so it was there to hide).
  scene.structures[0].polyline_layers[1].style.hidden = fr::HiddenLines::show;
  scene.structures[0].polyline_layers[1].style.hidden_opacity = 1.0;
  const fr::Image shown = renderer->render(scene, ortho_camera(512, 12.5), options);
  double shown_ink = 0.0;
  for (int x = 200; x < 312; ++x) shown_ink += 1.0 - shown.pixel(x, y_blue)[0] / 255.0;
  EXPECT_GT(shown_ink, 0.8 * 112);
  // The contour feature line is drawn over the layer: black where they cross.
  const auto* cross = img.pixel(100, 256);
  EXPECT_LT(cross[0], 40) << "feature lines must be drawn above the polyline layers";
  // Corners: the white background.
  EXPECT_EQ(img.pixel(0, 0)[0], 255);
  EXPECT_EQ(img.pixel(0, 0)[3], 255);
}

TEST(RenderPolylineLayer, EmptyLayersDrawNothing) {
  auto renderer = make_renderer();
  if (!renderer) GTEST_SKIP() << "no headless GL backend";
  fr::Scene with, without;
  without.structures.push_back(white_sphere());
  with.structures.push_back(white_sphere());
  with.structures[0].polyline_layers.push_back({"empty", plain(3.0, {0, 0, 0, 1}), {}});
  with.structures[0].polyline_layers[0].polylines.push_back({Vec3(0, 0, 11)});  // one point
  const Camera camera = ortho_camera(128, 12.5);
  const fr::ImageDifference d =
      fr::compare_images(renderer->render(with, camera), renderer->render(without, camera), 0);
  EXPECT_TRUE(d.same_size);
  EXPECT_EQ(d.max_abs, 0);
}

TEST(HatchPng, InkWhereTheSvgHasStrokesAndWhitePaperAround) {
  const fs::path dir = fabrica::test::temp_dir("hatch_png_ink");
  const fs::path png = dir / "a.png", svg = dir / "a.svg";
  const std::vector<std::string> common{"hatch",  aneurysm().string(), "--view", "anterior",
                                        "--size", "600x600",           "-q"};
  auto with_output = [&](const fs::path& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = common;
    args.insert(args.end(), {"-o", out.string()});
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const int code = run_fabrica(with_output(png));
  if (code == 4) GTEST_SKIP() << "no headless GL backend";
  ASSERT_EQ(code, 0);
  ASSERT_EQ(run_fabrica(with_output(svg)), 0);
  // A complete PNG, nothing else left in the folder.
  std::ifstream in(png, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 1000u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(bytes.substr(bytes.size() - 8, 4), "IEND");
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 2u);

  const fr::Image img = fr::read_png(png);
  ASSERT_EQ(img.width, 600);
  ASSERT_EQ(img.height, 600);
  const auto strokes = svg_strokes(svg);
  ASSERT_GT(strokes.size(), 100u);
  // Every stroke's middle vertex and both ends: a dark pixel within one pixel.
  std::size_t checked = 0, dark = 0;
  for (const auto& s : strokes)
    for (const std::size_t i : {std::size_t{0}, s.size() / 2, s.size() - 1}) {
      ++checked;
      if (darkest_near(img, s[i]) < 128) ++dark;
    }
  const double fraction = double(dark) / double(checked);
  EXPECT_GT(fraction, 0.97) << dark << " of " << checked << " stroke points are dark";
  // Paper: the corners are white and opaque, and most of the image is white.
  for (const auto& [x, y] : {std::pair{0, 0}, {599, 0}, {0, 599}, {599, 599}}) {
    const auto* p = img.pixel(x, y);
    EXPECT_EQ(p[0], 255);
    EXPECT_EQ(p[1], 255);
    EXPECT_EQ(p[2], 255);
    EXPECT_EQ(p[3], 255);
  }
  const std::size_t ink = dark_pixels(img);
  EXPECT_GT(ink, 500u);
  EXPECT_LT(ink, std::size_t{600 * 600 / 10});

  // Feature lines add ink; --transparent leaves the paper transparent around.
  const fs::path lined = dir / "lined.png", clear = dir / "clear.png";
  ASSERT_EQ(run_fabrica(with_output(lined, {"--with-lines", "contour"})), 0);
  EXPECT_GT(dark_pixels(fr::read_png(lined)), ink + 200);
  ASSERT_EQ(run_fabrica(with_output(clear, {"--transparent"})), 0);
  const fr::Image transparent = fr::read_png(clear);
  EXPECT_EQ(transparent.pixel(0, 0)[3], 0);
  EXPECT_EQ(transparent.pixel(599, 599)[3], 0);
  std::size_t dark_clear = 0;
  for (const auto& s : strokes)
    if (darkest_near(transparent, s[s.size() / 2]) < 128) ++dark_clear;
  EXPECT_GT(double(dark_clear) / double(strokes.size()), 0.97);
  fs::remove_all(dir);
}

TEST(HatchPng, NoGlBackendExitsFourAndWritesNothing) {
  const fs::path dir = fabrica::test::temp_dir("hatch_png_no_gl");
  const fs::path png = dir / "a.png";
  // EGL forced, with glvnd given no vendor: the backend cannot be created.
  const int code = run_fabrica({"hatch", aneurysm().string(), "--size", "200x200", "-q", "-o",
                                png.string(), "--backend", "egl"},
                               "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent/egl_vendor.json");
  EXPECT_EQ(code, 4);
  EXPECT_FALSE(fs::exists(png));
  EXPECT_EQ(
      run_fabrica({"hatch", aneurysm().string(), "-q", "-o", png.string(), "--backend", "vulkan"}),
      2);
  fs::remove_all(dir);
}
