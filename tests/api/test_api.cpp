// The one-call pipelines (issue 16): the library draws exactly what the CLI
// writes for the same mesh, camera and options; options are validated with
// the CLI's messages; meshes convert to and from plain arrays without copies.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fabrica/fabrica.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace fabrica;

namespace {

fs::path liver() {
  return test::bundled_data() / "meshes" / "anatomy" / "liver" / "sofa_liver_coarse.obj";
}

int run_fabrica(const std::vector<std::string>& args) {
  std::string cmd = "'" + std::string(FABRICA_EXE) + "'";
  for (const auto& a : args) cmd += " '" + a + "'";
  cmd += " > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

Camera anterior(const TriangleMesh& mesh, int w = 1024, int h = 1024) {
  return anatomical_camera(AnatomicalView::anterior, bounding_box(mesh.positions), mesh.space, w,
                           h);
}

/// `mesh` with every face turned over (normals pointing inward).
TriangleMesh inverted(TriangleMesh mesh) {
  for (Face& f : mesh.faces) std::swap(f[1], f[2]);
  return mesh;
}

}  // namespace

TEST(Api, DrawLinesEqualsLinesJson) {
  const fs::path dir = test::temp_dir("api_lines");
  const fs::path out = dir / "x.json";
  ASSERT_EQ(run_fabrica({"lines", liver().string(), "--types", "contour,suggestive,apparent,ridge",
                         "--smooth", "2", "-q", "-o", out.string()}),
            0);
  const nlohmann::json cli = nlohmann::json::parse(slurp(out));

  PreparedMesh prepared = prepare_mesh(liver());
  const Camera camera = anterior(prepared.mesh);
  const Surface surface(std::move(prepared.mesh));
  DrawLinesOptions options;
  options.lines.families = {LineFamily::contour, LineFamily::suggestive, LineFamily::apparent,
                            LineFamily::ridge};
  options.smooth = 2;
  const LineDrawing drawing = draw_lines(surface, camera, options);
  ASSERT_GT(drawing.lines.polylines.size(), 5u);
  ASSERT_GT(drawing.segment_count(), 0u);
  nlohmann::json header = drawing_header(drawing, surface, camera, options);
  header["mesh"] = liver().filename().string();
  header["source"] = "fabrica lines";
  // Same bytes as the file (dump(1) is what write_lines_json writes).
  EXPECT_EQ(lines_to_json(drawing.lines, header).dump(1) + "\n", slurp(out));
  EXPECT_EQ(cli["segments"]["contour"].get<std::size_t>(), drawing.segments[0].second);
}

TEST(Api, LineDrawerReusedForManyCamerasEqualsFreshDrawings) {
  PreparedMesh prepared = prepare_mesh(liver());
  const Surface surface(std::move(prepared.mesh));
  DrawLinesOptions options;
  options.lines.families = {LineFamily::contour, LineFamily::apparent};
  LineDrawer drawer(surface, options);
  for (AnatomicalView v :
       {AnatomicalView::anterior, AnatomicalView::left, AnatomicalView::superior}) {
    const Camera camera = anatomical_camera(v, bounding_box(surface.positions()), Space::lps);
    const LineDrawing a = drawer.draw(camera);
    const LineDrawing b = draw_lines(surface, camera, options);
    EXPECT_EQ(lines_to_json(a.lines).dump(), lines_to_json(b.lines).dump());
    EXPECT_GT(a.lines.polylines.size(), 0u);
  }
}

TEST(Api, DrawHatchingEqualsHatchSvg) {
  const fs::path dir = test::temp_dir("api_hatch");
  const fs::path out = dir / "x.svg";
  ASSERT_EQ(run_fabrica({"hatch", liver().string(), "--size", "400x300", "--light", "view:1,1,1",
                         "-q", "-o", out.string()}),
            0);
  PreparedMesh prepared = prepare_mesh(liver());
  const Camera camera = anterior(prepared.mesh, 400, 300);
  const Surface surface(std::move(prepared.mesh));
  DrawHatchingOptions options;
  options.light = "view:1,1,1";
  const hatching::StrokeSet strokes = draw_hatching(surface, camera, options);
  EXPECT_GT(strokes.strokes.size(), 10u);
  EXPECT_EQ(hatching::hatching_svg(strokes), slurp(out));
}

// Issue 21: the one-call API's method confis gives what `fabrica hatch
// --method confis` writes, and the method names parse with a did-you-mean.
TEST(Api, DrawHatchingConfisEqualsHatchSvg) {
  const fs::path dir = test::temp_dir("api_confis");
  const fs::path out = dir / "x.svg";
  ASSERT_EQ(run_fabrica({"hatch", liver().string(), "--size", "400x300", "--method", "confis",
                         "--spacing", "4", "--convex-threshold", "0.05", "-q", "-o", out.string()}),
            0);
  PreparedMesh prepared = prepare_mesh(liver());
  const Camera camera = anterior(prepared.mesh, 400, 300);
  const Surface surface(std::move(prepared.mesh));
  DrawHatchingOptions options;
  options.method = parse_hatching_method("ConFIS");
  options.confis.spacing_px = 4.0;
  options.confis.feature_regions.convex_threshold = 0.05;
  const hatching::StrokeSet strokes = draw_hatching(surface, camera, options);
  EXPECT_GT(strokes.strokes.size(), 5u);
  EXPECT_EQ(hatching::hatching_svg(strokes), slurp(out));
  EXPECT_EQ(parse_hatching_method("shading"), HatchingMethod::shading);
  try {
    parse_hatching_method("shadnig");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'shading'"), std::string::npos) << e.what();
  }
}

TEST(Api, HatchOrientsInwardMeshesAsLinesDoes) {
  // The drift issue 16 names: `hatch` now prepares the mesh as `lines` does,
  // so an inward-facing copy hatches exactly like the outward original.
  const fs::path dir = test::temp_dir("api_hatch_inward");
  const TriangleMesh original = io::read_mesh(liver()).mesh;
  io::write_mesh(original, dir / "out.off");
  io::write_mesh(inverted(original), dir / "in.off");
  for (const char* name : {"out", "in"})
    ASSERT_EQ(run_fabrica({"hatch", (dir / (std::string(name) + ".off")).string(), "--size",
                           "300x300", "-q", "-o", (dir / (std::string(name) + ".svg")).string()}),
              0);
  EXPECT_EQ(slurp(dir / "out.svg"), slurp(dir / "in.svg"));
  // --keep-orientation keeps the old behaviour: the inward copy differs.
  ASSERT_EQ(run_fabrica({"hatch", (dir / "in.off").string(), "--size", "300x300",
                         "--keep-orientation", "-q", "-o", (dir / "kept.svg").string()}),
            0);
  EXPECT_NE(slurp(dir / "out.svg"), slurp(dir / "kept.svg"));
}

TEST(Api, PrepareMeshOrientsAndReports) {
  const TriangleMesh original = io::read_mesh(liver()).mesh;
  const PreparedMesh p = prepare_mesh(inverted(original));
  EXPECT_EQ(p.mesh.positions, original.positions);
  EXPECT_GE(p.repair.components_reversed, 1u);
  ASSERT_FALSE(p.messages().empty());
  PrepareOptions keep;
  keep.orient = false;
  EXPECT_EQ(prepare_mesh(inverted(original), keep).mesh.faces, inverted(original).faces);
  // Keeping the orientation still welds exact duplicates (docs/validation.md): the second
  // triangle's copies of vertices 1 and 2 become 1 and 2, vertex i stays vertex i.
  TriangleMesh split;
  split.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  split.faces = {{0, 1, 2}, {3, 5, 4}};
  const PreparedMesh welded = prepare_mesh(split, keep);
  EXPECT_EQ(welded.mesh.faces, (std::vector<Face>{{0, 1, 2}, {1, 5, 2}}));
  EXPECT_EQ(welded.mesh.positions.size(), 6u);
  EXPECT_EQ(welded.repair.welded_vertices, 2u);
  EXPECT_THROW(prepare_mesh(TriangleMesh{}), InputError);
  EXPECT_THROW(prepare_mesh(test::bundled_data() / "no-such-mesh.obj"), InputError);
}

TEST(Api, OptionValidationThrowsInputError) {
  const Surface surface(test::make_icosphere(1.0, 2));
  const Camera camera;
  auto message = [&](const DrawLinesOptions& o) {
    try {
      draw_lines(surface, camera, o);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  DrawLinesOptions o;
  o.lines.ridge.threshold = -1.0;
  EXPECT_EQ(message(o), "--ridge-threshold must be a non-negative number");
  o = {};
  o.lines.apparent.threshold = std::nan("");
  EXPECT_EQ(message(o), "--apparent-threshold must be a non-negative number");
  o = {};
  o.lines.feature_size = -2.0;
  EXPECT_EQ(message(o), "--feature-size must be a positive length in mesh units");
  o = {};
  o.smooth = -1;
  EXPECT_EQ(message(o), "--smooth must be >= 0 (iterations; 0 = off)");
  o = {};
  o.min_length_px = -1.0;
  EXPECT_THROW(validate(o), InputError);

  DrawHatchingOptions h;
  h.hatching.ridges.min_angle_deg = 180.0;
  EXPECT_THROW(draw_hatching(surface, camera, h), InputError);
  h = {};
  h.light = "sideways";
  EXPECT_THROW(draw_hatching(surface, camera, h), InputError);
  h.light = "dir:0,0,0";
  EXPECT_THROW(draw_hatching(surface, camera, h), InputError);
  h = {};
  h.method = HatchingMethod::confis;
  h.confis.spacing_px = -1.0;
  EXPECT_THROW(draw_hatching(surface, camera, h), InputError);
  h.confis = {};
  h.confis.contour_margin = 2.0;
  EXPECT_THROW(validate(h), InputError);
}

TEST(Api, MeshArraysAreViewsAndRoundTrip) {
  TriangleMesh mesh = test::make_icosphere(2.0, 1);
  auto V = vertex_matrix(mesh);
  auto F = face_matrix(mesh);
  EXPECT_EQ(V.data(), mesh.positions.front().data());  // a view, not a copy
  EXPECT_EQ(F.data(), mesh.faces.front().data());
  EXPECT_EQ(V.rows(), static_cast<Eigen::Index>(mesh.vertex_count()));
  EXPECT_EQ(V(3, 1), mesh.positions[3].y());
  EXPECT_EQ(F(5, 2), mesh.faces[5][2]);
  V(0, 0) = 7.0;
  EXPECT_EQ(mesh.positions[0].x(), 7.0);

  const Eigen::MatrixXd Vd = V;  // column-major libigl-style copies
  const Eigen::MatrixXi Fi = F.cast<int>();
  const TriangleMesh back = mesh_from_arrays(Vd, Fi, Space::ras);
  EXPECT_EQ(back.positions, mesh.positions);
  EXPECT_EQ(back.faces, mesh.faces);
  EXPECT_EQ(back.space, Space::ras);

  Eigen::MatrixXi bad = Fi;
  bad(0, 0) = static_cast<int>(mesh.vertex_count());
  EXPECT_THROW(mesh_from_arrays(Vd, bad), InputError);
  EXPECT_THROW(mesh_from_arrays(Eigen::MatrixXd(4, 2), Fi), InputError);
  Eigen::MatrixXd nan = Vd;
  nan(1, 1) = std::nan("");
  EXPECT_THROW(mesh_from_arrays(nan, Fi), InputError);
}
