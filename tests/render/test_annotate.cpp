// Annotation of a scene (issue 17, item 5), checked from the written SVG:
// labels clear of every silhouette (the CPU depth of all surfaces, and the
// rendered PNG when GL is there) and of each other, leaders that do not
// cross, anchors on pixels where their structure is in front, the scale
// bar's length against the camera's px/mm, the orientation marker's letters
// for the view, and byte-identical output.
#include <gtest/gtest.h>

#include <pugixml.hpp>

#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/render/annotate.hpp"
#include "test_support.hpp"

namespace fr = fabrica::render;
using fabrica::Camera;
using fabrica::Vec2;
using fabrica::Vec3;

namespace {

fabrica::TriangleMesh sphere(double r, const Vec3& at, fabrica::Space space) {
  fabrica::TriangleMesh m = fabrica::test::make_icosphere(r, 3);
  for (auto& p : m.positions) p += at;
  m.space = space;
  return m;
}

/// A focus sphere (r 10) at the origin, context spheres on the patient's
/// left (+x in LPS) and above (superior, +z).
fr::SceneSurfaces three_spheres(fabrica::Space space = fabrica::Space::lps) {
  fr::SceneSurfaces scene;
  const double left = space == fabrica::Space::lps ? 1.0 : -1.0;
  const struct {
    const char* name;
    double r;
    Vec3 at;
    fr::Role role;
  } parts[3] = {{"heart", 10.0, Vec3(0, 0, 0), fr::Role::focus},
                {"left_lung", 6.0, Vec3(24 * left, 0, 4), fr::Role::context},
                {"trachea", 4.0, Vec3(0, 0, 20), fr::Role::context}};
  for (const auto& p : parts) {
    fr::StructureSpec s;
    s.name = p.name;
    s.role = p.role;
    s.style = fr::default_style(p.role);
    scene.add(s, std::make_shared<const fabrica::Surface>(sphere(p.r, p.at, space)));
  }
  return scene;
}

fr::AnnotationSpec everything() {
  fr::AnnotationSpec a;
  a.labels = a.legend = a.scale_bar = a.orientation = true;
  return a;
}

Camera camera_of(const fr::SceneSurfaces& scene, fabrica::AnatomicalView view, int w = 480,
                 int h = 360) {
  Camera cam = fr::view_camera(scene, view, fr::Frame::all);
  cam.width = w;
  cam.height = h;
  return cam;
}

std::string svg_of(const fr::SceneSurfaces& scene, const Camera& cam, const fr::Annotation& a) {
  const fr::Scene drawn = fr::build_scene(scene, cam);
  return fabrica::layered_svg_string(fr::vector_layers(scene, drawn, cam), cam, &a.overlay);
}

struct Text {
  std::string role, name, text;
  double box[4];
  Vec2 centre() const { return {box[0] + 0.5 * box[2], box[1] + 0.5 * box[3]}; }
};
struct Path {
  std::string role, name;
  std::vector<Vec2> points;
};

struct Parsed {
  std::vector<Text> texts;
  std::vector<Path> paths;
  bool has_layer = false;
};

Parsed parse(const std::string& svg) {
  pugi::xml_document doc;
  EXPECT_TRUE(doc.load_string(svg.c_str()));
  Parsed out;
  const pugi::xml_node layer = doc.child("svg").find_child_by_attribute("g", "id", "annotation");
  out.has_layer = layer && std::string(layer.attribute("inkscape:groupmode").value()) == "layer" &&
                  layer == doc.child("svg").last_child();  // drawn over the structure layers
  for (pugi::xml_node n : layer.children()) {
    if (std::string(n.name()) == "text") {
      Text t;
      t.role = n.attribute("data-role").value();
      t.name = n.attribute("data-name").value();
      t.text = n.child_value();
      std::istringstream in(n.attribute("data-box").value());
      in >> t.box[0] >> t.box[1] >> t.box[2] >> t.box[3];
      out.texts.push_back(t);
    } else {
      Path p;
      p.role = n.attribute("data-role").value();
      p.name = n.attribute("data-name").value();
      std::string d = n.attribute("d").value();
      for (char& c : d)
        if (c == 'M' || c == 'L' || c == 'Z') c = ' ';
      std::istringstream in(d);
      double x, y;
      while (in >> x >> y) p.points.emplace_back(x, y);
      out.paths.push_back(p);
    }
  }
  return out;
}

std::vector<Text> with_role(const Parsed& p, const std::string& role) {
  std::vector<Text> out;
  for (const auto& t : p.texts)
    if (t.role == role) out.push_back(t);
  return out;
}

/// Depth of every surface of the scene together (CPU, independent of the
/// annotation's own structure map).
fabrica::DepthBuffer all_depth(const fr::SceneSurfaces& scene, const Camera& cam) {
  fabrica::TriangleMesh all;
  for (const auto& s : scene.surfaces) {
    const auto base = static_cast<std::int32_t>(all.positions.size());
    all.positions.insert(all.positions.end(), s->mesh().positions.begin(),
                         s->mesh().positions.end());
    for (const auto& f : s->mesh().faces)
      all.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  }
  return fabrica::render_depth(all, cam);
}

bool crosses(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  auto cross = [](Vec2 u, Vec2 v) { return u.x() * v.y() - u.y() * v.x(); };
  const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a);
  const double d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
  return d1 * d2 < 0.0 && d3 * d4 < 0.0;
}

}  // namespace

TEST(Annotate, LabelsAreClearOfEverySilhouetteAndOfEachOther) {
  const fr::SceneSurfaces scene = three_spheres();
  const Camera cam = camera_of(scene, fabrica::AnatomicalView::anterior);
  const fr::Annotation a = fr::annotate_scene(scene, cam, everything());
  EXPECT_TRUE(a.skipped.empty()) << a.skipped.front();
  const Parsed svg = parse(svg_of(scene, cam, a));
  ASSERT_TRUE(svg.has_layer);
  const auto labels = with_role(svg, "label");
  ASSERT_EQ(labels.size(), 3u);
  std::map<std::string, std::string> text_of;
  for (const auto& l : labels) text_of[l.name] = l.text;
  EXPECT_EQ(text_of["left_lung"], "left lung");  // '_' shown as a space
  // Masks: the CPU depth of every surface; and the rendered picture (every
  // pixel that differs from the white background) when GL is available.
  const fabrica::DepthBuffer depth = all_depth(scene, cam);
  std::optional<fr::Image> png;
  try {
    png = fr::render_scene(scene, cam).image;
  } catch (const fabrica::Error& e) {
    if (e.kind() != fabrica::ErrorKind::unavailable) throw;
  }
  for (const auto& l : labels) {
    for (int y = static_cast<int>(std::floor(l.box[1])); y < std::ceil(l.box[1] + l.box[3]); ++y)
      for (int x = static_cast<int>(std::floor(l.box[0])); x < std::ceil(l.box[0] + l.box[2]);
           ++x) {
        ASSERT_TRUE(x >= 0 && y >= 0 && x < cam.width && y < cam.height) << l.name;
        ASSERT_FALSE(std::isfinite(depth.at(x, y)))
            << l.name << " over a surface at " << x << "," << y;
        if (png) {
          const std::uint8_t* p = png->pixel(x, y);
          ASSERT_TRUE(p[0] == 255 && p[1] == 255 && p[2] == 255)
              << l.name << " over a drawn pixel at " << x << "," << y;
        }
      }
  }
  // No two texts (labels, legend, scale bar, marker letters) overlap.
  for (std::size_t i = 0; i < svg.texts.size(); ++i)
    for (std::size_t j = i + 1; j < svg.texts.size(); ++j) {
      const auto &s = svg.texts[i].box, &t = svg.texts[j].box;
      const bool overlap =
          s[0] < t[0] + t[2] && t[0] < s[0] + s[2] && s[1] < t[1] + t[3] && t[1] < s[1] + s[3];
      EXPECT_FALSE(overlap) << svg.texts[i].text << " / " << svg.texts[j].text;
    }
  // Leaders: one per label, none crossing another or another label's box.
  std::vector<Path> leaders;
  for (const auto& p : svg.paths)
    if (p.role == "leader") leaders.push_back(p);
  ASSERT_EQ(leaders.size(), labels.size());
  for (std::size_t i = 0; i < leaders.size(); ++i) {
    ASSERT_EQ(leaders[i].points.size(), 2u);
    for (std::size_t j = i + 1; j < leaders.size(); ++j)
      EXPECT_FALSE(crosses(leaders[i].points[0], leaders[i].points[1], leaders[j].points[0],
                           leaders[j].points[1]));
    for (const auto& l : labels) {
      if (l.name == leaders[i].name) continue;
      for (double t = 0.0; t <= 1.0; t += 0.01) {
        const Vec2 p = leaders[i].points[0] + t * (leaders[i].points[1] - leaders[i].points[0]);
        EXPECT_FALSE(p.x() > l.box[0] && p.x() < l.box[0] + l.box[2] && p.y() > l.box[1] &&
                     p.y() < l.box[1] + l.box[3])
            << leaders[i].name << "'s leader crosses " << l.name;
      }
    }
  }
}

TEST(Annotate, EachAnchorIsAPixelWhereItsStructureIsInFront) {
  const fr::SceneSurfaces scene = three_spheres();
  const Camera cam = camera_of(scene, fabrica::AnatomicalView::anterior);
  const fr::Annotation a = fr::annotate_scene(scene, cam, everything());
  const Parsed svg = parse(svg_of(scene, cam, a));
  const fabrica::DepthBuffer all = all_depth(scene, cam);
  int checked = 0;
  for (const auto& p : svg.paths) {
    if (p.role != "leader") continue;
    std::size_t i = 0;
    while (scene.spec.structures[i].name != p.name) ++i;
    const int x = static_cast<int>(p.points[0].x()), y = static_cast<int>(p.points[0].y());
    const fabrica::DepthBuffer own = fabrica::render_depth(scene.surfaces[i]->mesh(), cam);
    ASSERT_TRUE(std::isfinite(own.at(x, y))) << p.name << " does not cover its anchor";
    EXPECT_LE(own.at(x, y), all.at(x, y) + 1e-4) << p.name << " is behind another surface";
    // Near the middle of what is seen of it: several pixels from its edge.
    for (int dy = -3; dy <= 3; ++dy)
      for (int dx = -3; dx <= 3; ++dx) EXPECT_TRUE(std::isfinite(own.at(x + dx, y + dy)));
    ++checked;
  }
  EXPECT_EQ(checked, 3);
}

TEST(Annotate, ScaleBarLengthIsItsMillimetresTimesTheCameraScale) {
  const fr::SceneSurfaces scene = three_spheres();
  for (auto projection : {fabrica::Projection::perspective, fabrica::Projection::orthographic}) {
    Camera cam = camera_of(scene, fabrica::AnatomicalView::anterior, 640, 400);
    cam.projection = projection;
    const fr::Annotation a = fr::annotate_scene(scene, cam, everything());
    const Parsed svg = parse(svg_of(scene, cam, a));
    const Path* bar = nullptr;
    for (const auto& p : svg.paths)
      if (p.role == "scale-bar") bar = &p;
    ASSERT_NE(bar, nullptr);
    const auto text = with_role(svg, "scale-bar-text");
    ASSERT_EQ(text.size(), 1u);
    const double mm = std::stod(text[0].text);
    EXPECT_NE(text[0].text.find(" mm"), std::string::npos);
    // px/mm measured by projecting 10 mm across the view at the focus centre.
    const Vec3 c = 0.5 * (scene.focus_box.min + scene.focus_box.max);
    const double px_per_mm = (fabrica::project(cam, c + 5.0 * cam.right()).pixel -
                              fabrica::project(cam, c - 5.0 * cam.right()).pixel)
                                 .norm() /
                             10.0;
    const double length = (bar->points[1] - bar->points[0]).norm();
    EXPECT_NEAR(length, mm * px_per_mm, 1.0);
    EXPECT_LE(length, 0.2 * cam.width + 1e-9);
    EXPECT_GT(length, 0.2 * cam.width / 5.0 - 1e-9);  // 1-2-5: at least 2/5 of the room
    // The legend says when the scale holds at the focus depth only.
    bool says = false;
    for (const auto& t : with_role(svg, "legend-text"))
      says |= t.text.find("focus depth") != std::string::npos;
    EXPECT_EQ(says, projection == fabrica::Projection::perspective);
  }
}

TEST(Annotate, OrientationMarkerMatchesTheView) {
  // Anterior view: the patient's left on the screen's right, superior up;
  // posterior: left on the left; superior view: anterior up... whatever the
  // file's space (LPS or RAS).
  for (auto space : {fabrica::Space::lps, fabrica::Space::ras}) {
    const fr::SceneSurfaces scene = three_spheres(space);
    auto letters = [&](fabrica::AnatomicalView view) {
      const Camera cam = camera_of(scene, view);
      const Parsed svg = parse(svg_of(scene, cam, fr::annotate_scene(scene, cam, everything())));
      std::map<std::string, Vec2> at;
      for (const auto& t : with_role(svg, "orientation")) at[t.text] = t.centre();
      return at;
    };
    auto ant = letters(fabrica::AnatomicalView::anterior);
    ASSERT_EQ(ant.size(), 4u);  // L R S I; A/P along the view
    EXPECT_GT(ant["L"].x(), ant["R"].x() + 10);
    EXPECT_LT(ant["S"].y(), ant["I"].y() - 10);
    EXPECT_FALSE(ant.count("A"));
    auto post = letters(fabrica::AnatomicalView::posterior);
    EXPECT_LT(post["L"].x(), post["R"].x() - 10);
    EXPECT_LT(post["S"].y(), post["I"].y() - 10);
    auto left = letters(fabrica::AnatomicalView::left);  // from the patient's left
    EXPECT_GT(left["P"].x(), left["A"].x() + 10);
    EXPECT_FALSE(left.count("L"));
    auto sup = letters(fabrica::AnatomicalView::superior);
    ASSERT_TRUE(sup.count("A") && sup.count("L"));
    EXPECT_FALSE(sup.count("S"));
  }
}

TEST(Annotate, OutputIsDeterministicAndEmptyWhenOff) {
  const fr::SceneSurfaces scene = three_spheres();
  const Camera cam = camera_of(scene, fabrica::AnatomicalView::anterior);
  const fr::Annotation a = fr::annotate_scene(scene, cam, everything());
  const fr::Annotation b = fr::annotate_scene(scene, cam, everything());
  EXPECT_EQ(svg_of(scene, cam, a), svg_of(scene, cam, b));
  fr::Image ia(cam.width, cam.height), ib(cam.width, cam.height);
  fr::draw_annotation(ia, a.overlay);
  fr::draw_annotation(ib, b.overlay);
  EXPECT_EQ(ia.rgba, ib.rgba);
  EXPECT_NE(ia.rgba, fr::Image(cam.width, cam.height).rgba);  // something was drawn
  EXPECT_TRUE(fr::annotate_scene(scene, cam, fr::AnnotationSpec{}).overlay.items.empty());
  // Text scales with the picture.
  const fr::Annotation big = fr::annotate_scene(
      scene, camera_of(scene, fabrica::AnatomicalView::anterior, 960, 720), everything());
  EXPECT_NEAR(big.font_px, 2.0 * a.font_px, 1e-9);
}

TEST(Annotate, LabelKeyRenamesOrDropsALabel) {
  fr::SceneSurfaces scene = three_spheres();
  scene.spec.structures[1].label = "Left lung";
  scene.spec.structures[2].show_label = false;
  const Camera cam = camera_of(scene, fabrica::AnatomicalView::anterior);
  const Parsed svg = parse(svg_of(scene, cam, fr::annotate_scene(scene, cam, everything())));
  std::vector<std::string> texts;
  for (const auto& t : with_role(svg, "label")) texts.push_back(t.text);
  EXPECT_EQ(texts, (std::vector<std::string>{"heart", "Left lung"}));
  EXPECT_EQ(with_role(svg, "legend-text").size(), 4u);  // three structures + the depth note
}

TEST(Annotate, SceneKeysAreValidatedStrictly) {
  const auto parse_scene = [](const std::string& text) {
    return fr::scene_spec_from_json(nlohmann::json::parse(text), "/tmp", "s.json");
  };
  const fr::SceneSpec ok = parse_scene(
      R"({"annotation": {"labels": true, "scale_bar": true, "font_size": 24},
          "structures": [{"mesh": "a.stl", "label": "Aorta"}, {"mesh": "b.stl", "label": false}]})");
  EXPECT_TRUE(ok.annotation.labels && ok.annotation.scale_bar);
  EXPECT_FALSE(ok.annotation.legend || ok.annotation.orientation);
  EXPECT_EQ(ok.annotation.font_size, 24.0);
  EXPECT_EQ(ok.structures[0].label, "Aorta");
  EXPECT_FALSE(ok.structures[1].show_label);
  // Round trip through JSON.
  const fr::SceneSpec back =
      fr::scene_spec_from_json(fr::scene_spec_to_json(ok), "/tmp", "saved.json");
  EXPECT_EQ(back.structures[0].label, "Aorta");
  EXPECT_FALSE(back.structures[1].show_label);
  EXPECT_TRUE(back.annotation.labels && back.annotation.scale_bar && !back.annotation.legend);
  const std::pair<const char*, const char*> bad[] = {
      {R"({"annotation": {"lables": true}, "structures": [{"mesh": "a.stl"}]})",
       "annotation.lables: unknown key (did you mean 'labels'?)"},
      {R"({"anotation": {}, "structures": [{"mesh": "a.stl"}]})", "did you mean 'annotation'?"},
      {R"({"annotation": true, "structures": [{"mesh": "a.stl"}]})",
       "annotation must be an object"},
      {R"({"annotation": {"legend": 1}, "structures": [{"mesh": "a.stl"}]})",
       "annotation.legend must be true or false"},
      {R"({"annotation": {"font_size": 0}, "structures": [{"mesh": "a.stl"}]})",
       "annotation.font_size must be between"},
      {R"({"structures": [{"mesh": "a.stl", "label": 3}]})", "structures[0].label must be"},
      {R"({"structures": [{"mesh": "a.stl", "label": ""}]})", "structures[0].label must be"},
      {R"({"structures": [{"mesh": "a.stl", "lable": "x"}]})", "did you mean 'label'?"},
      {R"({"structures": [{"mesh": "a.stl", "label": "a\nb"}]})", "control characters"}};
  for (const auto& [text, message] : bad) {
    try {
      parse_scene(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const fabrica::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

TEST(Annotate, LegendShrinksToFitASmallPicture) {
  const fr::SceneSurfaces scene = three_spheres();
  const Camera cam = camera_of(scene, fabrica::AnatomicalView::anterior, 120, 60);
  fr::AnnotationSpec legend;
  legend.legend = legend.scale_bar = true;  // 4 rows: 3 structures and the depth note
  legend.font_size = 200.0;  // 11.7 px here: 4 rows at 0.85 of it would be 64 px high
  const Parsed svg = parse(svg_of(scene, cam, fr::annotate_scene(scene, cam, legend)));
  int frames = 0;
  for (const auto& p : svg.paths) {
    if (p.role != "legend-frame") continue;
    ++frames;
    for (const Vec2& q : p.points) {
      EXPECT_GE(q.x(), 0.0);
      EXPECT_GE(q.y(), 0.0);
      EXPECT_LE(q.x(), cam.width);
      EXPECT_LE(q.y(), cam.height);
    }
  }
  EXPECT_EQ(frames, 1);
}
