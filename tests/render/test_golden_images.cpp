// Golden-image tests (issue 4): fixed scenes rendered headless (EGL or
// OSMesa, llvmpipe here) at small sizes and compared with the PNGs in
// tests/render/golden/. Scenes: the bundled aneurysm (anterior) with Lambert
// shading and contours; the aneurysm toon-shaded from the left; the bundled
// focus-and-context scene data/aneurysm-scene.json; hybrid apparent ridges
// (seed 000) on the gfxmorph femur; an analytic torus on a transparent
// background (alpha checked too).
//
// Tolerance: a pixel differs when some channel (RGBA, 0..255) differs by more
// than kChannelTolerance (4); an image matches when at most
// kMaxDifferingFraction (0.02 %) of its pixels differ. Measured on llvmpipe
// (Mesa 22.3): run-to-run, EGL versus OSMesa, LP_NUM_THREADS=1 or 4 and
// LP_NATIVE_VECTOR_WIDTH=128 all give bit-identical images (0 pixels differ),
// so the limits only leave room for rounding on another Mesa build. Small real
// changes fail: contours 20 % wider (1.4 % of pixels over 4), toon colour +5
// levels (4.5 %), context opacity 0.25 -> 0.3 (7.7 %), camera 0.4 % farther
// (0.55 %), hybrid threshold 0.2 -> 0.22 (0.044 %). The goldens are llvmpipe
// images: on another renderer (a real GPU through EGL) the comparison is
// skipped. docs/rendering.md, "Golden images".
//
// On a mismatch the actual image and a diff image (differing pixels red,
// others grey) are written to <build>/Testing/golden-output/ and their paths
// printed. FABRICA_REGENERATE_GOLDENS=1 writes the goldens instead of
// comparing (scripts/regenerate-goldens).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/render/renderer.hpp"
#include "render_test_util.hpp"
#include "test_support.hpp"

namespace fr = fabrica::render;
namespace fs = std::filesystem;
using fabrica::AnatomicalView;
using fabrica::Camera;
using fabrica::LineFamily;

namespace {

constexpr int kChannelTolerance = 4;              // per channel, 0..255
constexpr double kMaxDifferingFraction = 0.0002;  // of the pixels (0.02 %: 13 px at 256 x 256)

using fabrica::test::renderer;

bool regenerating() {
  const char* v = std::getenv("FABRICA_REGENERATE_GOLDENS");
  return v != nullptr && std::string(v) != "" && std::string(v) != "0";
}

fs::path golden_dir() {
  return fs::path(FABRICA_SOURCE_DIR) / "tests" / "render" / "golden";
}
fs::path output_dir() {
  return fs::path(FABRICA_BINARY_DIR) / "Testing" / "golden-output";
}

// Differing pixels red, the rest the actual image's luminance faded to grey.
fr::Image diff_image(const fr::Image& a, const fr::Image& b) {
  fr::Image d(a.width, a.height);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const auto* p = a.pixel(x, y);
      const auto* q = b.pixel(x, y);
      int m = 0;
      for (int c = 0; c < 4; ++c) m = std::max(m, std::abs(int(p[c]) - int(q[c])));
      auto* o = d.pixel(x, y);
      if (m > kChannelTolerance) {
        o[0] = 255, o[1] = 0, o[2] = 0;
      } else {
        const int l = (p[0] + p[1] + p[2]) / 3;
        o[0] = o[1] = o[2] = static_cast<std::uint8_t>(192 + l / 4);
      }
      o[3] = 255;
    }
  return d;
}

void check_golden(const fr::Image& actual, const std::string& name) {
  // The goldens are llvmpipe's pictures; a real GPU (EGL picks one when present)
  // rasterises differently. FABRICA_GL_BACKEND=osmesa forces llvmpipe.
  if (renderer().context().renderer().find("llvmpipe") == std::string::npos)
    GTEST_SKIP() << "goldens are llvmpipe images; this context is "
                 << renderer().context().renderer() << " (set FABRICA_GL_BACKEND=osmesa)";
  const fs::path golden = golden_dir() / (name + ".png");
  if (regenerating()) {
    fr::write_png(actual, golden);
    std::printf("[golden] wrote %s (%s)\n", golden.c_str(),
                fr::to_string(renderer().context().backend()));
    return;
  }
  ASSERT_TRUE(fs::exists(golden)) << golden << " is missing: run scripts/regenerate-goldens";
  const fr::Image expected = fr::read_png(golden);
  const fr::ImageDifference d = fr::compare_images(actual, expected, kChannelTolerance);
  const double any = fr::compare_images(actual, expected, 0).fraction_over;
  std::printf(
      "[golden] %s (%s): max |diff| %d, mean %.5f, pixels differing: %.4f %% at all, "
      "%.4f %% by more than %d\n",
      name.c_str(), fr::to_string(renderer().context().backend()), d.max_abs, d.mean_abs,
      100.0 * any, 100.0 * d.fraction_over, kChannelTolerance);
  const bool ok = d.same_size && d.fraction_over <= kMaxDifferingFraction;
  if (!ok) {
    fs::create_directories(output_dir());
    const std::string tag = name + "-" + fr::to_string(renderer().context().backend());
    const fs::path actual_path = output_dir() / (tag + "-actual.png");
    fr::write_png(actual, actual_path);
    std::string diff_note;
    if (d.same_size) {
      const fs::path diff_path = output_dir() / (tag + "-diff.png");
      fr::write_png(diff_image(actual, expected), diff_path);
      diff_note = ", diff: " + diff_path.string();
    }
    ADD_FAILURE() << name << " differs from " << golden << ": "
                  << (d.same_size ? "" : "size differs; ") << 100.0 * d.fraction_over
                  << " % of pixels differ by more than " << kChannelTolerance << " (allowed "
                  << 100.0 * kMaxDifferingFraction << " %), max " << d.max_abs
                  << "\n  actual: " << actual_path.string() << diff_note
                  << "\n  if the change is intended: scripts/regenerate-goldens, and say why in "
                     "the commit message";
  }
}

struct Loaded {
  std::unique_ptr<fabrica::Surface> surface;
  fabrica::BoundingBox box;
  fabrica::Space space = fabrica::Space::lps;
};

Loaded load(const fs::path& path, std::optional<fabrica::Space> space = std::nullopt) {
  fabrica::io::ReadOptions ro;
  ro.space = space;
  auto file = fabrica::io::read_mesh(path, ro);
  fabrica::io::prepare_for_lines(file.mesh);
  Loaded l;
  l.box = fabrica::bounding_box(file.mesh.positions);
  l.space = file.mesh.space;
  l.surface = std::make_unique<fabrica::Surface>(std::move(file.mesh));
  return l;
}

// One structure from a surface: render mesh, object-space lines of `families`.
fr::Structure make_structure(const fabrica::Surface& surface, const Camera& camera, fr::Role role,
                             const fr::StructureStyle& style) {
  fr::Structure st;
  st.role = role;
  st.style = style;
  std::vector<LineFamily> families = style.families;
  if (style.hybrid_apparent_ridges)
    families.erase(std::remove(families.begin(), families.end(), LineFamily::apparent),
                   families.end());
  st.style.families = families;
  st.mesh =
      std::make_shared<fr::RenderMesh>(fr::make_render_mesh(surface, style.hybrid_apparent_ridges));
  if (!families.empty()) {
    fabrica::LineOptions lo;
    lo.families = families;
    fabrica::LineExtractor extractor(surface, lo);
    fabrica::ChainOptions chain;
    chain.camera = camera;
    chain.min_length_px = 3.0;
    st.lines = fabrica::chain_segments(extractor.extract(camera), chain);
  }
  return st;
}

fs::path aneurysm_path() {
  return fs::path(FABRICA_SOURCE_DIR) / "data" / "aneurysm.off";
}

}  // namespace

TEST(GoldenImages, AneurysmLambertContours) {
  const Loaded l = load(aneurysm_path());
  const Camera cam = fabrica::anatomical_camera(AnatomicalView::anterior, l.box, l.space, 256, 256);
  fr::StructureStyle style = fr::default_style(fr::Role::focus);
  style.shading = fr::Shading::lambert;
  style.families = {LineFamily::contour, LineFamily::boundary};
  fr::Scene scene;
  scene.structures.push_back(make_structure(*l.surface, cam, fr::Role::focus, style));
  fr::RenderOptions ro;
  ro.line_reference_size = 256.0;  // 2-px contours at this size
  check_golden(renderer().render(scene, cam, ro), "aneurysm-lambert-contours");
}

TEST(GoldenImages, AneurysmToon) {
  const Loaded l = load(aneurysm_path());
  const Camera cam = fabrica::anatomical_camera(AnatomicalView::left, l.box, l.space, 256, 256);
  fr::StructureStyle style = fr::default_style(fr::Role::focus);
  style.shading = fr::Shading::toon;
  style.toon_levels = 3;
  style.color = {0.55f, 0.75f, 0.95f, 1.0f};
  style.families = {LineFamily::contour};
  fr::Scene scene;
  scene.structures.push_back(make_structure(*l.surface, cam, fr::Role::focus, style));
  fr::RenderOptions ro;
  ro.line_reference_size = 256.0;
  check_golden(renderer().render(scene, cam, ro), "aneurysm-toon");
}

TEST(GoldenImages, FocusAndContextScene) {
  const fs::path scene_path = fs::path(FABRICA_SOURCE_DIR) / "data" / "aneurysm-scene.json";
  if (!fs::exists(scene_path)) GTEST_SKIP() << scene_path << " not present";
  const fr::SceneSpec spec = fr::read_scene_spec(scene_path);
  ASSERT_FALSE(spec.structures.empty());
  std::vector<Loaded> loaded;
  fabrica::BoundingBox box;
  for (const auto& s : spec.structures) {
    loaded.push_back(load(s.mesh, s.space));
    const auto& b = loaded.back().box;
    if (loaded.size() == 1) {
      box = b;
    } else {
      box.min = box.min.cwiseMin(b.min);
      box.max = box.max.cwiseMax(b.max);
    }
  }
  const Camera cam = fabrica::anatomical_camera(spec.view.value_or(AnatomicalView::anterior), box,
                                                loaded.front().space, 320, 240);
  fr::Scene scene;
  scene.background = spec.background;
  for (std::size_t i = 0; i < spec.structures.size(); ++i) {
    fr::Structure st =
        make_structure(*loaded[i].surface, cam, spec.structures[i].role, spec.structures[i].style);
    st.name = spec.structures[i].name;
    scene.structures.push_back(std::move(st));
  }
  fr::RenderOptions ro;
  ro.transparent_background = spec.transparent;
  check_golden(renderer().render(scene, cam, ro), "aneurysm-scene");
}

TEST(GoldenImages, FemurHybridApparentRidges) {
  const fs::path femur = fabrica::test::bundled_data() / "meshes/anatomy/bones/gfxmorph_femur.stl";
  if (!fs::exists(femur)) GTEST_SKIP() << femur << " not present";
  const Loaded l = load(femur);
  const Camera cam = fabrica::anatomical_camera(AnatomicalView::anterior, l.box, l.space, 240, 320);
  fr::StructureStyle style = fr::default_style(fr::Role::focus);
  style.shading = fr::Shading::lambert;
  style.families = {LineFamily::contour};
  style.hybrid_apparent_ridges = true;
  fr::Scene scene;
  scene.structures.push_back(make_structure(*l.surface, cam, fr::Role::focus, style));
  check_golden(renderer().render(scene, cam), "femur-hybrid-ridges");
}

TEST(GoldenImages, TorusTransparentBackground) {
  fr::Structure st;
  st.role = fr::Role::focus;
  st.style = fr::default_style(fr::Role::focus);
  st.style.shading = fr::Shading::lambert;
  st.style.color = {0.9f, 0.7f, 0.4f, 1.0f};
  st.style.families = {};
  st.style.hybrid_apparent_ridges = true;
  st.mesh = fabrica::test::torus_render_mesh(1.0, 0.35, 96, 48);
  Camera cam = fabrica::test::front_camera(256, 256, 5.0);
  cam.eye = fabrica::Vec3(0.0, -4.0, 5.5);
  fr::Scene scene;
  scene.structures.push_back(st);
  fr::RenderOptions ro;
  ro.transparent_background = true;
  const fr::Image img = renderer().render(scene, cam, ro);
  // Transparent corners, opaque torus: the alpha channel is part of the golden.
  EXPECT_EQ(img.pixel(0, 0)[3], 0);
  EXPECT_EQ(img.pixel(img.width / 2 + 80, img.height / 2)[3], 255);
  check_golden(img, "torus-transparent");
}
