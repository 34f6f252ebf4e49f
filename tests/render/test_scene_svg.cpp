// The scene's vector output (issue 17, item 4): render::write_scene_svg keeps
// one layer per structure (role, per-family groups, the structure's line
// colour), focus over context, and shows the same lines as the PNG.
#include <gtest/gtest.h>

#include <pugixml.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/render/draw.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
namespace fr = fabrica::render;
using fabrica::Camera;

namespace {

fs::path scene_path() {
  return fs::path(FABRICA_SOURCE_DIR) / "data" / "aneurysm-scene.json";
}

std::string hex(const fr::Color& c) {
  char buf[8];
  auto b = [](float v) { return static_cast<int>(std::lround(v * 255.0)); };
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", b(c.r), b(c.g), b(c.b));
  return buf;
}

/// The scene's anterior view, 256x256.
Camera small_camera(const fr::SceneSurfaces& scene, fr::Frame frame) {
  Camera cam = fr::view_camera(scene, fabrica::AnatomicalView::anterior, frame);
  cam.width = cam.height = 256;
  return cam;
}

struct Rendered {
  fr::RenderedScene picture;
  std::string svg;
};

std::optional<Rendered> render(const fr::SceneSurfaces& scene, const Camera& cam) {
  Rendered r;
  try {
    r.picture = fr::render_scene(scene, cam);
  } catch (const fabrica::Error& e) {
    if (e.kind() == fabrica::ErrorKind::unavailable) return std::nullopt;
    throw;
  }
  r.svg = fabrica::layered_svg_string(fr::vector_layers(scene, r.picture.scene, cam), cam);
  return r;
}

/// Points along every path of `group` (0.5 px apart) whose effective
/// opacity (the group's times the path's) is at least `min_opacity`.
std::vector<fabrica::Vec2> path_points(const pugi::xml_node& group, double min_opacity) {
  std::vector<fabrica::Vec2> out;
  const double group_opacity = group.attribute("stroke-opacity").as_double(1.0);
  for (const auto& x : group.select_nodes(".//path")) {
    const pugi::xml_node path = x.node();
    const double o = path.attribute("stroke-opacity").as_double(group_opacity);
    if (o < min_opacity) continue;
    std::string d = path.attribute("d").value();
    const bool closed = !d.empty() && d.back() == 'Z';
    for (char& c : d)
      if (c == 'M' || c == 'L' || c == 'Z') c = ' ';
    std::istringstream in(d);
    std::vector<fabrica::Vec2> v;
    double px, py;
    while (in >> px >> py) v.emplace_back(px, py);
    if (closed && v.size() > 1) v.push_back(v.front());
    for (std::size_t i = 0; i + 1 < v.size(); ++i) {
      const double len = (v[i + 1] - v[i]).norm();
      const int steps = std::max(1, static_cast<int>(len / 0.5));
      for (int s = 0; s < steps; ++s) out.push_back(v[i] + (v[i + 1] - v[i]) * (double(s) / steps));
    }
    if (!v.empty()) out.push_back(v.back());
  }
  return out;
}

/// Pixels where two pictures differ (any channel by more than 12).
std::vector<char> difference_mask(const fr::Image& a, const fr::Image& b) {
  std::vector<char> mask(static_cast<std::size_t>(a.width) * a.height, 0);
  for (std::size_t i = 0; i < mask.size(); ++i)
    for (int c = 0; c < 4; ++c)
      if (std::abs(int(a.rgba[4 * i + c]) - int(b.rgba[4 * i + c])) > 12) mask[i] = 1;
  return mask;
}

bool near_mask(const std::vector<char>& mask, int w, int h, fabrica::Vec2 p, int r) {
  const int cx = static_cast<int>(std::floor(p.x())), cy = static_cast<int>(std::floor(p.y()));
  for (int y = cy - r; y <= cy + r; ++y)
    for (int x = cx - r; x <= cx + r; ++x)
      if (x >= 0 && y >= 0 && x < w && y < h && mask[static_cast<std::size_t>(y) * w + x])
        return true;
  return false;
}

}  // namespace

TEST(SceneSvg, OneLayerPerStructureInItsStyleFocusOverContext) {
  if (!fs::exists(scene_path())) GTEST_SKIP() << scene_path() << " not present";
  const fr::SceneSurfaces scene = fr::load_scene(fr::read_scene_spec(scene_path()));
  const Camera cam = small_camera(scene, fr::default_frame(scene.spec, scene.spec.frame));
  const auto r = render(scene, cam);
  if (!r) GTEST_SKIP() << "no headless GL context";

  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_string(r->svg.c_str())) << r->svg.substr(0, 200);
  std::vector<pugi::xml_node> groups;
  for (pugi::xml_node g : doc.child("svg").children("g")) groups.push_back(g);
  ASSERT_EQ(groups.size(), scene.spec.structures.size());

  bool seen_focus = false;
  for (const pugi::xml_node& g : groups) {
    const std::string name = g.attribute("inkscape:label").value();
    const fr::StructureSpec* spec = nullptr;
    for (const auto& s : scene.spec.structures)
      if (s.name == name) spec = &s;
    ASSERT_NE(spec, nullptr) << "layer " << name << " is no structure of the scene";
    EXPECT_EQ(std::string(g.attribute("data-role").value()), fr::to_string(spec->role)) << name;
    // Context layers all come before the focus layers (drawn under them).
    if (spec->role == fr::Role::focus)
      seen_focus = true;
    else
      EXPECT_FALSE(seen_focus) << "context layer " << name << " after a focus layer";
    EXPECT_EQ(std::string(g.attribute("stroke").value()), hex(spec->style.lines.color)) << name;
    EXPECT_NEAR(g.attribute("stroke-opacity").as_double(), spec->style.lines.color.a, 0.006);
    // One group per drawn family, each family of the structure's style.
    std::map<std::string, int> families;
    for (pugi::xml_node f : g.children("g")) {
      const std::string fam = f.attribute("data-family").value();
      ++families[fam];
      bool in_style = false;
      for (auto lf : spec->style.families) in_style = in_style || fam == fabrica::family_name(lf);
      EXPECT_TRUE(in_style) << name << ": family " << fam;
      EXPECT_FALSE(f.child("path").empty()) << name << ": empty family group " << fam;
      for (pugi::xml_node p : f.children("path"))
        EXPECT_TRUE(p.attribute("stroke").empty()) << "a path overrides its layer's colour";
    }
    EXPECT_EQ(families["contour"], 1) << name;  // both structures draw contours here
    for (const auto& [fam, n] : families) EXPECT_EQ(n, 1) << name << ": " << fam;
  }
  EXPECT_TRUE(seen_focus);
  // The scene has a context structure in a colour of its own.
  EXPECT_NE(r->svg.find("data-role=\"context\""), std::string::npos);
  EXPECT_NE(r->svg.find("stroke=\"#404d66\""), std::string::npos);
}

TEST(SceneSvg, PngAndSvgShowTheSameLines) {
  if (!fs::exists(scene_path())) GTEST_SKIP() << scene_path() << " not present";
  const fr::SceneSurfaces scene = fr::load_scene(fr::read_scene_spec(scene_path()));
  const Camera cam = small_camera(scene, fr::default_frame(scene.spec, scene.spec.frame));
  const auto full = render(scene, cam);
  if (!full) GTEST_SKIP() << "no headless GL context";
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_string(full->svg.c_str()));

  for (std::size_t k = 0; k < scene.spec.structures.size(); ++k) {
    const std::string name = scene.spec.structures[k].name;
    // The PNG's lines of structure k: what changes when k draws none.
    fr::SceneSurfaces without = scene;
    without.spec.structures[k].style.families.clear();
    const auto other = render(without, cam);
    ASSERT_TRUE(other);
    const auto mask = difference_mask(full->picture.image, other->picture.image);
    std::size_t drawn = 0;
    for (char m : mask) drawn += m;

    const pugi::xml_node g =
        doc.child("svg").find_child_by_attribute("g", "inkscape:label", name.c_str());
    ASSERT_FALSE(g.empty()) << name;
    const auto points = path_points(g, 0.2);
    EXPECT_GT(drawn, 50u) << name << ": no lines in the PNG";
    ASSERT_GT(points.size(), 50u) << name << ": no lines in the SVG";
    // Where the SVG draws k's lines, the PNG has them too...
    std::size_t hits = 0;
    for (const auto& p : points) hits += near_mask(mask, cam.width, cam.height, p, 2);
    EXPECT_GT(double(hits) / points.size(), 0.9) << name;
    // ...and where the PNG has them, so does the SVG.
    std::vector<char> svg_mask(mask.size(), 0);
    for (const auto& p : path_points(g, 0.0)) {
      const int x = static_cast<int>(p.x()), y = static_cast<int>(p.y());
      if (x >= 0 && y >= 0 && x < cam.width && y < cam.height)
        svg_mask[static_cast<std::size_t>(y) * cam.width + x] = 1;
    }
    std::size_t covered = 0;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x)
        if (mask[static_cast<std::size_t>(y) * cam.width + x])
          covered += near_mask(svg_mask, cam.width, cam.height, {x + 0.5, y + 0.5}, 2);
    EXPECT_GT(double(covered) / drawn, 0.85) << name;
    std::printf("%s: %zu PNG line pixels, %zu SVG points, %.3f / %.3f agree\n", name.c_str(), drawn,
                points.size(), double(hits) / points.size(), double(covered) / drawn);
  }
}

TEST(SceneSvg, HiddenLinesFollowEachStructuresStyle) {
  if (!fs::exists(scene_path())) GTEST_SKIP() << scene_path() << " not present";
  fr::SceneSpec spec = fr::read_scene_spec(scene_path());
  std::map<std::string, std::size_t> hidden_paths, all_paths;
  for (fr::HiddenLines mode :
       {fr::HiddenLines::omit, fr::HiddenLines::dashed, fr::HiddenLines::show}) {
    for (auto& s : spec.structures)
      s.style.lines.hidden = s.role == fr::Role::focus ? mode : fr::HiddenLines::omit;
    const fr::SceneSurfaces scene = fr::load_scene(spec);
    const Camera cam = small_camera(scene, fr::Frame::all);
    const auto r = render(scene, cam);
    if (!r) GTEST_SKIP() << "no headless GL context";
    pugi::xml_document doc;
    ASSERT_TRUE(doc.load_string(r->svg.c_str()));
    for (pugi::xml_node g : doc.child("svg").children("g")) {
      const std::string key =
          std::string(fr::to_string(mode)) + "/" + g.attribute("data-role").value();
      for (const auto& x : g.select_nodes(".//path")) {
        ++all_paths[key];
        if (std::string(x.node().attribute("class").value()) == "hidden") {
          ++hidden_paths[key];
          // Dashed for "dashed", solid for "show"; fainter either way.
          EXPECT_EQ(x.node().attribute("stroke-dasharray").empty(), mode == fr::HiddenLines::show);
          EXPECT_LT(x.node().attribute("stroke-opacity").as_double(1.0), 0.5);
        }
      }
    }
  }
  // The aneurysm's back and the apparent ridges behind it: dashed only when asked.
  EXPECT_EQ(hidden_paths["omit/focus"], 0u);
  EXPECT_GT(hidden_paths["dashed/focus"], 0u);
  EXPECT_GT(hidden_paths["show/focus"], 0u);
  EXPECT_GT(all_paths["show/focus"], all_paths["omit/focus"]);
  // The context keeps its own style (omit) whatever the focus does.
  EXPECT_EQ(hidden_paths["dashed/context"], 0u);
}
