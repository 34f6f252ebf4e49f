// More line-engine tests (issue 3 "Must show"): hidden-line removal with one
// sphere in front of another, SVG parsed by a real XML parser (pugixml), PDF
// output, .seg round trip, and bit-identical output at 1 and 2 threads on a
// real aneurysm mesh.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <pugixml.hpp>
#include <sstream>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/seg_io.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/lines/writers.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

Camera camera_at(const Vec3& eye, int size = 512) {
  Camera c;
  c.eye = eye;
  c.center = Vec3::Zero();
  c.up = Vec3::UnitY();
  c.fov_deg = 40.0;
  c.width = c.height = size;
  return c;
}

TriangleMesh translated(TriangleMesh m, const Vec3& t) {
  for (auto& p : m.positions) p += t;
  return m;
}

TriangleMesh merged(const TriangleMesh& a, const TriangleMesh& b) {
  TriangleMesh m = a;
  const auto off = static_cast<std::int32_t>(a.positions.size());
  m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
  for (Face f : b.faces) {
    for (auto& i : f) i += off;
    m.faces.push_back(f);
  }
  return m;
}

// Two spheres: a front one (radius 1 at the origin) and a larger one behind
// it, shifted sideways so that its contour ring passes behind the front
// sphere on one side only.
struct TwoSpheres {
  Vec3 front_center = Vec3::Zero(), back_center = Vec3(1.0, 0.0, -4.0);
  double front_r = 1.0, back_r = 1.5;
  Vec3 eye = Vec3(0.0, 0.0, 10.0);
  TriangleMesh mesh() const {
    return merged(translated(test::make_icosphere(front_r, 5), front_center),
                  translated(test::make_icosphere(back_r, 5), back_center));
  }
  /// Angle (radians) between the ray to p and the ray to the front sphere's
  /// centre, minus the front sphere's angular radius: < 0 inside its disk.
  double angle_outside_front(const Vec3& p) const {
    const Vec3 a = (p - eye).normalized(), c = (front_center - eye);
    const double ang = std::acos(std::clamp(a.dot(c.normalized()), -1.0, 1.0));
    return ang - std::asin(front_r / c.norm());
  }
};

LineSet lines_for(const Surface& s, const Camera& cam, std::vector<LineFamily> fams,
                  double feature_size = 0.05) {
  LineOptions o;
  o.families = std::move(fams);
  o.feature_size = feature_size;
  LineExtractor ex(s, o);
  return chain_segments(ex.extract(cam));
}

}  // namespace

TEST(LinesVisibility, BackSphereContourIsHiddenWhereTheFrontSphereCoversIt) {
  const TwoSpheres scene;
  Surface surface(scene.mesh());
  const Camera cam = camera_at(scene.eye);
  LineSet lines = lines_for(surface, cam, {LineFamily::contour});
  compute_visibility(lines, surface, cam);

  // One pixel subtends about fov/size radians; stay a few pixels away from
  // the front sphere's outline, where the 3x3 window legitimately decides
  // either way.
  const double px = (40.0 * M_PI / 180.0) / cam.height, margin = 4.0 * px;
  std::size_t back_hidden = 0, back_visible = 0, front = 0, checked = 0;
  for (const auto& p : lines.polylines) {
    ASSERT_EQ(p.family, LineFamily::contour);
    for (const auto& v : p.vertices) {
      const double d_front = (v.position - scene.front_center).norm();
      const double d_back = (v.position - scene.back_center).norm();
      if (std::abs(d_front - scene.front_r) < 0.02) {
        EXPECT_TRUE(v.visible) << "front sphere contour hidden at " << v.position.transpose();
        ++front;
        continue;
      }
      ASSERT_LT(std::abs(d_back - scene.back_r), 0.03) << "contour point on neither sphere";
      const double out = scene.angle_outside_front(v.position);
      if (std::abs(out) < margin) continue;
      ++checked;
      const bool covered = out < 0.0;
      EXPECT_EQ(v.visible, !covered) << "back contour at " << v.position.transpose()
                                     << (covered ? " should be hidden" : " should be visible");
      (v.visible ? back_visible : back_hidden)++;
    }
  }
  EXPECT_GT(front, 50u);
  EXPECT_GT(checked, 100u);
  // Both states occur on the back sphere's ring: partial occlusion.
  EXPECT_GT(back_hidden, 20u);
  EXPECT_GT(back_visible, 50u);

  // With the spheres side by side nothing is hidden.
  Surface apart(merged(test::make_icosphere(1.0, 4),
                       translated(test::make_icosphere(1.0, 4), Vec3(3.0, 0.0, 0.0))));
  const Camera cam2 = camera_at(Vec3(1.5, 0.0, 12.0));
  LineSet lines2 = lines_for(apart, cam2, {LineFamily::contour});
  compute_visibility(lines2, apart, cam2);
  ASSERT_FALSE(lines2.polylines.empty());
  for (const auto& p : lines2.polylines)
    for (const auto& v : p.vertices) EXPECT_TRUE(v.visible);
}

namespace {

struct SvgSummary {
  std::string view_box;
  std::vector<std::string> groups;  // id of each <g>, in order
  std::map<std::string, int> visible_paths, hidden_paths;
};

SvgSummary parse_svg(const std::string& text) {
  pugi::xml_document doc;
  const auto r = doc.load_string(text.c_str());
  EXPECT_TRUE(r) << "SVG is not well-formed XML: " << r.description();
  SvgSummary s;
  const auto svg = doc.child("svg");
  EXPECT_TRUE(svg) << "no <svg> root";
  s.view_box = svg.attribute("viewBox").value();
  for (auto g : svg.children("g")) {
    const std::string id = g.attribute("id").value();
    EXPECT_EQ(id, g.attribute("class").value());
    s.groups.push_back(id);
    for (auto e : g.children()) {
      const std::string name = e.name();
      EXPECT_TRUE(name == "path" || name == "polyline") << "unexpected <" << name << ">";
      if (name == "path") {
        EXPECT_GT(std::strlen(e.attribute("d").value()), 6u);
        EXPECT_EQ(e.attribute("d").value()[0], 'M');
      } else {
        EXPECT_GT(std::strlen(e.attribute("points").value()), 6u);
      }
      const bool hidden = std::string(e.attribute("class").value()) == "hidden";
      if (hidden) {
        EXPECT_TRUE(e.attribute("stroke-dasharray")) << "hidden line not dashed";
      }
      (hidden ? s.hidden_paths : s.visible_paths)[id]++;
    }
  }
  return s;
}

}  // namespace

TEST(LinesSvg, ParsesWithOneGroupPerFamilyAndOmitsOrDashesHiddenLines) {
  const TwoSpheres scene;
  Surface surface(scene.mesh());
  Camera cam = camera_at(scene.eye);
  cam.width = 640;
  cam.height = 480;
  LineOptions o;
  o.families = {LineFamily::contour, LineFamily::ridge};
  o.feature_size = 0.05;
  o.ridge.threshold = 0.0;  // a sphere has no real ridges; keep what the noise gives
  LineExtractor ex(surface, o);
  LineSet lines = chain_segments(ex.extract(cam));
  compute_visibility(lines, surface, cam);

  LineStyle style;
  SvgSummary omit = parse_svg(svg_string(lines, cam, style));
  EXPECT_EQ(omit.view_box, "0 0 640 480");
  ASSERT_FALSE(omit.groups.empty());
  // Every group is a known family, at most once.
  std::map<std::string, int> seen;
  for (const auto& g : omit.groups) {
    EXPECT_TRUE(parse_family(g).has_value()) << "group " << g << " is not a family name";
    EXPECT_EQ(++seen[g], 1) << "family " << g << " has two groups";
  }
  ASSERT_EQ(seen.count("contour"), 1u);
  EXPECT_GE(omit.visible_paths.at("contour"), 2);
  EXPECT_TRUE(omit.hidden_paths.empty()) << "hidden lines drawn with --hidden omit";

  style.hidden = HiddenLines::dashed;
  SvgSummary dashed = parse_svg(svg_string(lines, cam, style));
  EXPECT_EQ(dashed.view_box, omit.view_box);
  EXPECT_GE(dashed.hidden_paths["contour"], 1) << "the covered part of the back contour";
  EXPECT_EQ(dashed.visible_paths["contour"], omit.visible_paths["contour"]);

  // The file written atomically is the same text.
  const auto dir = test::temp_dir("lines_more_svg");
  write_svg(dir / "out.svg", lines, cam, style);
  std::ifstream in(dir / "out.svg", std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), svg_string(lines, cam, style));
}

TEST(LinesPdf, StartsWithPdfHeaderAndHoldsTheStrokes) {
  if (!pdf_available()) GTEST_SKIP() << "built without cairo";
  const TwoSpheres scene;
  Surface surface(scene.mesh());
  const Camera cam = camera_at(scene.eye);
  LineSet lines = lines_for(surface, cam, {LineFamily::contour});
  compute_visibility(lines, surface, cam);
  const auto dir = test::temp_dir("lines_more_pdf");
  write_pdf(dir / "out.pdf", lines, cam);
  std::ifstream in(dir / "out.pdf", std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string pdf = ss.str();
  ASSERT_GE(pdf.size(), 1000u);
  EXPECT_EQ(pdf.substr(0, 5), "%PDF-");
  EXPECT_NE(pdf.find("%%EOF"), std::string::npos);
  // An empty drawing is much smaller than the two contour rings.
  write_pdf(dir / "empty.pdf", LineSet{}, cam);
  EXPECT_GT(pdf.size(), std::filesystem::file_size(dir / "empty.pdf") + 500);
}

TEST(LinesSeg, WrittenFilesReadBackWithTheSameCounts) {
  Surface torus(test::make_torus(2.0, 0.7, 120, 48, 0.05));
  const Camera cam = camera_at(Vec3(0.3, -6.0, 3.0));
  LineOptions o;
  o.families = all_families();
  o.feature_size = 0.3;
  LineExtractor ex(torus, o);
  const auto soups = ex.extract(cam);
  const auto dir = test::temp_dir("lines_more_seg");
  const nlohmann::json header = {{"eye", {0.3, -6.0, 3.0}}, {"note", "test"}};

  // Raw soups.
  write_seg(dir / "soups.seg", header, soups);
  const SegFile raw = read_seg_file(dir / "soups.seg");
  EXPECT_EQ(raw.header.at("note"), "test");
  std::size_t total = 0;
  for (const auto& s : soups) {
    total += s.segments.size();
    const SegGroup* g = raw.find(family_name(s.family));
    if (s.segments.empty()) {
      EXPECT_TRUE(g == nullptr || g->segments.empty());
      continue;
    }
    ASSERT_NE(g, nullptr) << family_name(s.family);
    ASSERT_EQ(g->segments.size(), s.segments.size()) << family_name(s.family);
    // 7 significant digits: positions within 1e-6 relative.
    const auto pos = segment_positions(s);
    for (std::size_t i = 0; i < pos.size(); ++i)
      for (int k = 0; k < 2; ++k) EXPECT_LT((g->segments[i][k] - pos[i][k]).norm(), 1e-5);
  }
  EXPECT_GT(total, 100u);

  // Chained lines: one segment per polyline edge (closing edges included).
  LineSet lines = chain_segments(soups);
  write_seg(dir / "lines.seg", header, lines, /*visible_only=*/false);
  const SegFile chained = read_seg_file(dir / "lines.seg");
  std::map<std::string, std::size_t> edges;
  for (const auto& p : lines.polylines)
    edges[family_name(p.family)] += p.vertices.size() - (p.closed ? 0 : 1);
  for (const auto& [name, n] : edges) {
    const SegGroup* g = chained.find(name);
    ASSERT_NE(g, nullptr) << name;
    EXPECT_EQ(g->segments.size(), n) << name;
  }
}

namespace {

struct RunOutput {
  std::vector<SegmentSoup> soups;  // their surface is gone: read `resolved`
  std::vector<std::vector<ResolvedSegment>> resolved;
  LineSet lines;
  std::string svg;
};

RunOutput run_with_threads(int threads, const TriangleMesh& mesh) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  Surface surface(mesh);  // geometry recomputed under this thread count
  const Camera cam = anatomical_camera(AnatomicalView::anterior, bounding_box(mesh.positions),
                                       mesh.space, 800, 600);
  LineOptions o;
  o.families = all_families();
  LineExtractor ex(surface, o);
  RunOutput r;
  r.soups = ex.extract(cam);
  for (const auto& s : r.soups) r.resolved.push_back(s.resolved());
  ChainOptions co;
  co.camera = cam;
  co.min_length_px = 2.0;
  r.lines = chain_segments(r.soups, co);
  compute_visibility(r.lines, surface, cam);
  r.svg = svg_string(r.lines, cam);
  return r;
}

bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}
bool same_bits(const Vec3& a, const Vec3& b) {
  return same_bits(a.x(), b.x()) && same_bits(a.y(), b.y()) && same_bits(a.z(), b.z());
}

}  // namespace

TEST(LinesDeterminism, SameSegmentsAndLinesAtOneAndTwoThreads) {
  const auto path = test::bundled_data() / "meshes/anatomy/vessels/sofa_aneurysm3D_1.off";
  TriangleMesh mesh = io::read_mesh(path).mesh;
  const RunOutput one = run_with_threads(1, mesh);
  const RunOutput two = run_with_threads(2, mesh);

  ASSERT_EQ(one.soups.size(), two.soups.size());
  std::size_t total = 0;
  for (std::size_t s = 0; s < one.soups.size(); ++s) {
    const auto &a = one.resolved[s], &b = two.resolved[s];
    ASSERT_EQ(a.size(), b.size()) << family_name(one.soups[s].family);
    total += a.size();
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a[i].face, b[i].face);
      for (int k = 0; k < 2; ++k) {
        const auto &ea = a[i].end[k], &eb = b[i].end[k];
        ASSERT_TRUE(same_bits(ea.position, eb.position))
            << family_name(one.soups[s].family) << " segment " << i;
        ASSERT_EQ(ea.element, eb.element);
        ASSERT_EQ(ea.kind, eb.kind);
        ASSERT_EQ(std::memcmp(&ea.strength, &eb.strength, sizeof(float)), 0);
        ASSERT_EQ(ea.anchor.face, eb.anchor.face);
      }
    }
  }
  EXPECT_GT(total, 1000u);

  ASSERT_EQ(one.lines.polylines.size(), two.lines.polylines.size());
  for (std::size_t p = 0; p < one.lines.polylines.size(); ++p) {
    const auto &a = one.lines.polylines[p], &b = two.lines.polylines[p];
    ASSERT_EQ(a.family, b.family);
    ASSERT_EQ(a.closed, b.closed);
    ASSERT_EQ(a.vertices.size(), b.vertices.size());
    for (std::size_t i = 0; i < a.vertices.size(); ++i) {
      ASSERT_TRUE(same_bits(a.vertices[i].position, b.vertices[i].position));
      ASSERT_EQ(a.vertices[i].visible, b.vertices[i].visible);
    }
  }
  EXPECT_EQ(one.svg, two.svg);
}
