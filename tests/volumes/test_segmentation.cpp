// From a label map to a figure (issue 17, items 2 and 3): islands dropped,
// smoothing that removes the voxel staircase (measured by ridge and valley
// length per mm^2), an intensity image refused, DIR/scene.json written by
// `extract` and drawn by `render` with the focus framed, strict scene
// validation. Real data: the bundled TotalSegmentator sample.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/core/suggest.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/render/image.hpp"
#include "fabrica/render/scene.hpp"
#include "test_support.hpp"
#include "volume_test_util.hpp"

using namespace fabrica;
namespace fs = std::filesystem;

namespace {

constexpr int kAorta = 52;  // TotalSegmentator's label of the aorta

fs::path volumes() {
  return test::bundled_data() / "meshes" / "volumes";
}

using CliRun = test::CommandRun;

CliRun run_fabrica(const std::string& args, const fs::path& log) {
  return test::run_logged(std::string("\"") + FABRICA_EXE + "\" " + args, log);
}

// `fabrica extract` of the bundled sample into `out` with more options.
CliRun extract_sample(const fs::path& out, const std::string& options, const fs::path& log) {
  return run_fabrica("extract \"" + (volumes() / "totalseg_example_seg.nii.gz").string() +
                         "\" -o \"" + out.string() + "\" " + options,
                     log);
}

std::string quoted(const fs::path& p) {
  return "\"" + p.string() + "\"";
}

// Enclosed volume of every vertex-connected piece of a closed mesh (mm^3;
// negative for a cavity wall).
std::vector<double> piece_volumes(const TriangleMesh& mesh) {
  std::vector<std::int32_t> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Face& f : mesh.faces) {
    parent[find(f[1])] = find(f[0]);
    parent[find(f[2])] = find(f[0]);
  }
  std::map<std::int32_t, double> volume6;
  const Vec3 o = bounding_box(mesh.positions).center();
  for (const Face& f : mesh.faces)
    volume6[find(f[0])] +=
        (mesh.positions[f[0]] - o).dot((mesh.positions[f[1]] - o).cross(mesh.positions[f[2]] - o));
  std::vector<double> out;
  for (const auto& [root, v] : volume6) out.push_back(v / 6.0);
  return out;
}

double area(const TriangleMesh& mesh) {
  double a = 0.0;
  for (const Face& f : mesh.faces)
    a += 0.5 * (mesh.positions[f[1]] - mesh.positions[f[0]])
                   .cross(mesh.positions[f[2]] - mesh.positions[f[0]])
                   .norm();
  return a;
}

// Ridge plus valley ink (length times the strength the drawing fades them
// by) per mm^2 of surface, for lines where the surface bends more sharply
// than `min_curvature` (1/mm): the same absolute threshold for every mesh.
double ridge_valley_density(const TriangleMesh& mesh, double min_curvature) {
  Surface surface{TriangleMesh(mesh)};
  LineOptions o;
  o.feature_size = 1.0;  // thresholds in 1/mm
  o.ridge.threshold = o.valley.threshold = min_curvature;
  o.families = {LineFamily::ridge, LineFamily::valley};
  o.ridge.cull_backfaces = o.valley.cull_backfaces = false;  // every side of the vessel
  LineExtractor extractor(surface, o);
  // Ink: each segment's length times its strength (the fade the drawing uses).
  double ink = 0.0;
  for (const auto& soup : extractor.extract(Camera{}))
    for (const auto& seg : soup.resolved())
      ink += (seg.end[1].position - seg.end[0].position).norm() * 0.5 *
             (seg.end[0].strength + seg.end[1].strength);
  return ink / area(mesh);
}

TriangleMesh aorta(std::optional<int> smoothing) {
  io::ExtractOptions o;
  o.labels = {kAorta};
  o.smoothing_iterations = smoothing;
  auto surfaces =
      io::extract_surfaces(io::read_label_volume(volumes() / "totalseg_example_seg.nii.gz"), o);
  EXPECT_EQ(surfaces.size(), 1u);
  return surfaces.at(0).mesh;
}

}  // namespace

TEST(Segmentation, DefaultSmoothingRemovesTheVoxelStaircase) {
  const TriangleMesh raw_mesh = aorta(0);
  // Where the surface bends more sharply than a 10 mm radius: the voxel
  // steps (3 mm) and the vessel's real bends.
  const double raw = ridge_valley_density(raw_mesh, 0.1);
  const double smoothed = ridge_valley_density(aorta(std::nullopt), 0.1);  // the default
  std::printf("aorta ridge+valley length per mm^2: unsmoothed %.4f, default smoothing %.4f\n", raw,
              smoothed);
  RecordProperty("unsmoothed_per_mm2", std::to_string(raw));
  RecordProperty("smoothed_per_mm2", std::to_string(smoothed));
  EXPECT_GT(raw, 0.0);
  EXPECT_LT(smoothed, 0.5 * raw);
}

TEST(Segmentation, NoPieceBelowTheIslandThreshold) {
  const io::LabelVolume volume = io::read_label_volume(volumes() / "totalseg_example_seg.nii.gz");
  const Vec3 s = volume.geometry.spacing;
  const double voxel = s.x() * s.y() * s.z();
  constexpr std::size_t kIsland = 20;
  // A piece of n voxels, contoured through the voxel-edge midpoints,
  // encloses well over a quarter of n voxels.
  const double smallest = 0.25 * kIsland * voxel;
  auto small_pieces = [&](const std::vector<io::ExtractedSurface>& surfaces) {
    std::size_t n = 0;
    for (const auto& surface : surfaces)
      for (double v : piece_volumes(surface.mesh)) n += v > 0.0 && v < smallest;
    return n;
  };
  // Without smoothing the surfaces are the exact contours of the kept voxels
  // (smoothing shrinks thin structures such as ribs and cartilage, and may
  // pinch off specks, whatever the island threshold).
  io::ExtractOptions o;
  o.smoothing_iterations = 0;
  const std::size_t before = small_pieces(io::extract_surfaces(volume, o));
  o.min_island_voxels = kIsland;
  const auto filtered = io::extract_surfaces(volume, o);
  std::size_t removed = 0;
  for (const auto& surface : filtered) removed += surface.islands_removed;
  std::printf("pieces below %g mm^3: %zu without --min-island, %zu with; %zu islands removed\n",
              smallest, before, small_pieces(filtered), removed);
  EXPECT_GT(before, 0u);  // the sample has islands: the check can fail
  EXPECT_GT(removed, 0u);
  EXPECT_EQ(small_pieces(filtered), 0u);

  // --largest-component: one outer piece per label.
  o.min_island_voxels = 0;
  o.largest_component = true;
  for (const auto& surface : io::extract_surfaces(volume, o)) {
    if (surface.mesh.empty()) continue;
    const auto v = piece_volumes(surface.mesh);
    EXPECT_EQ(std::count_if(v.begin(), v.end(), [](double x) { return x > 0.0; }), 1)
        << surface.name;
  }
}

TEST(Segmentation, IntensityImageIsRefusedWithAHint) {
  const auto dir = test::temp_dir("seg-ct");
  const CliRun r = run_fabrica("extract " + quoted(volumes() / "totalseg_example_ct_sm.nii.gz") +
                                   " -o " + quoted(dir / "out"),
                               dir / "log.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("not a label map"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--iso"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
  // The library refuses it too, and --labels (values named on purpose) is let through.
  const io::LabelVolume ct = io::read_label_volume(volumes() / "totalseg_example_ct_sm.nii.gz");
  EXPECT_THROW(io::extract_surfaces(ct), InputError);
}

TEST(Segmentation, ExtractWritesASceneThatRendersWithTheFocusFramed) {
  const auto dir = test::temp_dir("seg-scene");
  const fs::path out = dir / "organs";
  CliRun r = extract_sample(out, "--focus aorta --min-island 20", dir / "extract.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(out / "scene.json")) << r.output;

  std::ifstream scene_file(out / "scene.json");
  const nlohmann::json scene = nlohmann::json::parse(scene_file);
  std::ifstream manifest_file(out / "surfaces.json");
  const nlohmann::json manifest = nlohmann::json::parse(manifest_file);
  ASSERT_EQ(scene["structures"].size(), manifest["surfaces"].size());
  std::size_t focus = 0;
  std::vector<nlohmann::json> colors;
  for (const auto& s : scene["structures"]) {
    EXPECT_TRUE(fs::path(s["mesh"].get<std::string>()).is_relative());
    EXPECT_TRUE(fs::exists(out / s["mesh"].get<std::string>()));
    if (s["role"] == "focus") {
      ++focus;
      EXPECT_EQ(s["name"], "aorta");
      const auto c = render::anatomical_color("aorta");
      EXPECT_NEAR(s["color"][0].get<double>(), c->r, 1e-6);
    } else {
      EXPECT_EQ(s["role"], "context");
      colors.push_back(s["color"]);
    }
  }
  EXPECT_EQ(focus, 1u);
  std::sort(colors.begin(), colors.end());
  EXPECT_GT(std::unique(colors.begin(), colors.end()) - colors.begin(), 5);  // not one pale blue

  // Render it from another folder: the mesh paths resolve against the scene's.
  const int width = 800, height = 600;
  auto render = [&](const std::string& extra, const std::string& name) {
    return run_fabrica("render " + quoted(out / "scene.json") + " -o " +
                           quoted(dir / (name + ".png")) + " --size 800x600 --save-camera " +
                           quoted(dir / (name + ".json")) + " " + extra,
                       dir / (name + ".txt"));
  };
  r = render("", "focus");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const CliRun all = render("--frame all", "all");
  ASSERT_EQ(all.exit_code, 0) << all.output;

  // The focus's projected extent along the picture's shorter side (height).
  const TriangleMesh aorta_mesh = io::read_mesh(out / "aorta.stl").mesh;
  auto projected_height = [&](const std::string& name) {
    const Camera camera = read_camera(dir / (name + ".json"));
    double lo = 1e300, hi = -1e300;
    for (const Vec3& p : aorta_mesh.positions) {
      const double y = project(camera, p).pixel.y();
      lo = std::min(lo, y);
      hi = std::max(hi, y);
    }
    return hi - lo;
  };
  const double framed = projected_height("focus") / std::min(width, height);
  const double whole = projected_height("all") / std::min(width, height);
  // And in the picture: the extent of the aorta's red (opaque, shaded) pixels.
  const render::Image image = render::read_png(dir / "focus.png");
  ASSERT_EQ(image.width, width);
  int top = height, bottom = -1;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const auto p = image.pixel(x, y);
      if (p[0] > 60 && p[0] > 2 * p[1] + 10 && p[0] > 2 * p[2] + 10) {
        top = std::min(top, y);
        bottom = std::max(bottom, y);
      }
    }
  const double red = bottom >= top ? static_cast<double>(bottom - top + 1) / height : 0.0;
  std::printf(
      "aorta height / shorter side: framed on the focus %.2f (red pixels %.2f), "
      "framing everything %.2f\n",
      framed, red, whole);
  EXPECT_GE(framed, 0.4);
  EXPECT_GE(red, 0.4);
  EXPECT_LE(framed, 1.0);
  EXPECT_GT(framed, whole);
}

TEST(Segmentation, CliContextMeshesKeepTheirOwnColours) {
  const auto dir = test::temp_dir("seg-context");
  const fs::path out = dir / "organs";
  CliRun r = extract_sample(out, "--labels 5,52,1", dir / "extract.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = run_fabrica("render " + quoted(out / "aorta.stl") + " --context " +
                      quoted(out / "liver.stl") + " --context " + quoted(out / "spleen.stl") +
                      " -o " + quoted(dir / "a.png") + " --size 200x200 --save-scene " +
                      quoted(dir / "saved.json"),
                  dir / "render.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const render::SceneSpec saved = render::read_scene_spec(dir / "saved.json");
  ASSERT_EQ(saved.structures.size(), 3u);
  EXPECT_NEAR(saved.structures[1].style.color.r, render::anatomical_color("liver")->r, 1e-6);
  EXPECT_NEAR(saved.structures[2].style.color.g, render::anatomical_color("spleen")->g, 1e-6);
  EXPECT_NE(saved.structures[1].style.color.g, saved.structures[2].style.color.g);
}

// ------------------------------------------------------- strict scenes ----

namespace {

std::string scene_error(const std::string& text) {
  try {
    render::scene_spec_from_json(nlohmann::json::parse(text), "/tmp", "s.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SceneValidation, UnknownKeysNameTheirPathAndTheClosestKey) {
  std::string e = scene_error(R"({"structures": [{"mesh": "a.stl", "colour": [1, 0, 0]}]})");
  EXPECT_NE(e.find("structures[0].colour"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'color'"), std::string::npos) << e;
  e = scene_error(R"({"structures": [{"mesh": "a.stl"}, {"mesh": "b.stl", "opacty": 0.5}]})");
  EXPECT_NE(e.find("structures[1].opacty"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'opacity'"), std::string::npos) << e;
  e = scene_error(R"({"veiw": "anterior", "structures": [{"mesh": "a.stl"}]})");
  EXPECT_NE(e.find("did you mean 'view'"), std::string::npos) << e;
  e = scene_error(R"({"camera": {"eye": [0, 0, 1], "fov": 30}, "structures": [{"mesh": "a"}]})");
  EXPECT_NE(e.find("camera.fov"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'fov_deg'"), std::string::npos) << e;
  e = scene_error(R"({"structures": [{"mesh": "a.stl", "zzzz": 1}]})");
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
  EXPECT_EQ(e.find("did you mean"), std::string::npos) << e;  // nothing close
}

TEST(SceneValidation, WrongTypesAndValuesNameTheirPath) {
  std::string e = scene_error(R"({"structures": [{"mesh": "a.stl", "opacity": "0.5"}]})");
  EXPECT_NE(e.find("structures[0].opacity must be a number (got string)"), std::string::npos) << e;
  e = scene_error(R"({"transparent": "yes", "structures": [{"mesh": "a.stl"}]})");
  EXPECT_NE(e.find("transparent must be true or false"), std::string::npos) << e;
  e = scene_error(R"({"structures": [{"mesh": "a.stl", "role": "focsu"}]})");
  EXPECT_NE(e.find("structures[0].role"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'focus'"), std::string::npos) << e;
  e = scene_error(R"({"structures": [{"mesh": "a.stl", "lines": ["contour", "valey"]}]})");
  EXPECT_NE(e.find("structures[0].lines[1]"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'valley'"), std::string::npos) << e;
  e = scene_error(R"({"frame": "focus", "structures": [{"mesh": "a.stl"}]})");
  EXPECT_EQ(e, "");
}

TEST(SceneValidation, RenderExits2OnAMisspeltKey) {
  const auto dir = test::temp_dir("seg-strict");
  std::ofstream(dir / "scene.json")
      << R"({"structures": [{"mesh": "a.stl", "colour": [1, 0, 0]}]})";
  const CliRun r = run_fabrica(
      "render " + quoted(dir / "scene.json") + " -o " + quoted(dir / "a.png"), dir / "log.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("structures[0].colour: unknown key (did you mean 'color'?)"),
            std::string::npos)
      << r.output;
}

TEST(Suggest, ClosestNames) {
  EXPECT_EQ(edit_distance("veiw", "view"), 1u);
  EXPECT_EQ(edit_distance("colour", "color"), 1u);
  EXPECT_EQ(closest_name("anteriour", {"anterior", "posterior"}), "anterior");
  EXPECT_EQ(closest_name("xyz", {"anterior", "posterior"}), "");
  EXPECT_EQ(did_you_mean("ridges", {"ridge", "valley"}), " (did you mean 'ridge'?)");
}

// ------------------------------------------------------- CLI manners ----

TEST(SegmentationCli, InfoReportsAnInwardOpenTubeAndLinesTurnsIt) {
  const auto dir = test::temp_dir("seg-open");
  // The aorta with its two ends cut off (faces beyond planes across its long
  // axis dropped) and every face flipped: an inward open tube.
  TriangleMesh tube =
      io::read_mesh(test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.stl")
          .mesh;  // the file's faces point inward already
  const BoundingBox box = bounding_box(tube.positions);
  const double lo = box.min.z() + 0.15 * (box.max.z() - box.min.z());
  const double hi = box.max.z() - 0.15 * (box.max.z() - box.min.z());
  std::vector<Face> kept;
  for (const Face& f : tube.faces)
    if (std::all_of(f.begin(), f.end(), [&](std::int32_t v) {
          return tube.positions[v].z() > lo && tube.positions[v].z() < hi;
        }))
      kept.push_back(f);
  tube.faces = kept;
  io::write_mesh(tube, dir / "tube.obj");

  CliRun r = run_fabrica("info " + quoted(dir / "tube.obj"), dir / "info.txt");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("open piece points inward"), std::string::npos) << r.output;
  r = run_fabrica("info " + quoted(dir / "tube.obj") + " --repair", dir / "repair.txt");
  EXPECT_NE(r.output.find("1 open piece turned outward"), std::string::npos) << r.output;
  // lines: prepared (turned, reported) by default, kept with --keep-orientation.
  r = run_fabrica("lines " + quoted(dir / "tube.obj") + " -o " + quoted(dir / "a.svg"),
                  dir / "lines.txt");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("open piece turned outward"), std::string::npos) << r.output;
  r = run_fabrica(
      "lines " + quoted(dir / "tube.obj") + " --keep-orientation -o " + quoted(dir / "b.svg"),
      dir / "keep.txt");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("flipped"), std::string::npos) << r.output;
}

TEST(SegmentationCli, InfoSmoothTakesTheStaircaseOff) {
  const auto dir = test::temp_dir("seg-info-smooth");
  const CliRun extracted = extract_sample(dir / "raw", "--labels 52 --smooth 0 -q", dir / "x.txt");
  ASSERT_EQ(extracted.exit_code, 0) << extracted.output;
  const CliRun r = run_fabrica(
      "info " + quoted(dir / "raw" / "aorta.stl") + " --smooth 60 -o " + quoted(dir / "smooth.stl"),
      dir / "info.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("smoothed (windowed sinc, 60 iterations"), std::string::npos) << r.output;
  const TriangleMesh raw = io::read_mesh(dir / "raw" / "aorta.stl").mesh;
  const TriangleMesh smooth = io::read_mesh(dir / "smooth.stl").mesh;
  EXPECT_EQ(smooth.face_count(), raw.face_count());
  EXPECT_LT(ridge_valley_density(smooth, 0.1), 0.5 * ridge_valley_density(raw, 0.1));
  const double v_raw = piece_volumes(raw).at(0), v_smooth = piece_volumes(smooth).at(0);
  EXPECT_NEAR(v_smooth, v_raw, 0.05 * v_raw);
}

TEST(SegmentationCli, DidYouMeanAndTheAssumedSpace) {
  const auto dir = test::temp_dir("seg-typos");
  const std::string mesh =
      quoted(test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.stl");
  const std::string sample = quoted(volumes() / "totalseg_example_seg.nii.gz");
  struct Case {
    std::string args;
    int exit_code;
    std::string expected;
  };
  const Case cases[] = {
      {"lines " + mesh + " --view anteriour -o " + quoted(dir / "a.svg"), 2,
       "did you mean 'anterior'"},
      {"render " + mesh + " --view postrior -o " + quoted(dir / "a.png"), 2,
       "did you mean 'posterior'"},
      {"lines " + mesh + " --types contour,sugestive -o " + quoted(dir / "b.svg"), 2,
       "did you mean 'suggestive'"},
      {"extract " + sample + " -o " + quoted(dir / "x") + " --focus aort", 2,
       "did you mean 'aorta'"},
      {"lines " + mesh + " --veiw anterior -o " + quoted(dir / "a.svg"), 2,
       "unknown option '--veiw' (did you mean '--view'?)"},
      {"lnies " + mesh, 2, "unknown command 'lnies' (did you mean 'lines'?)"},
      // An OFF file has no space tag: LPS is assumed, and said.
      {"lines " + quoted(test::bundled_data() / "meshes/anatomy/vessels/sofa_aneurysm3D_1.off") +
           " -o " + quoted(dir / "c.svg"),
       0, "has no coordinate-space tag: assumed LPS"},
  };
  for (const Case& c : cases) {
    const CliRun r = run_fabrica(c.args, dir / "log.txt");
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.args << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(dir / "x"));  // a bad --focus writes nothing
}

TEST(SegmentationCli, ProgressOnATerminalOnly) {
  if (std::system("command -v script > /dev/null 2>&1") != 0) GTEST_SKIP() << "no script(1)";
  const auto dir = test::temp_dir("seg-progress");
  const std::string extract = std::string("\"") + FABRICA_EXE + "\" extract " +
                              quoted(volumes() / "totalseg_example_seg.nii.gz") + " -o ";
  // script(1) gives the command a terminal.
  const auto tty = test::run_logged("script -qc '" + extract + quoted(dir / "a") + "' /dev/null",
                                    dir / "tty.txt");
  EXPECT_EQ(tty.exit_code, 0) << tty.output;
  EXPECT_NE(tty.output.find("41/41 labels"), std::string::npos) << tty.output;
  const CliRun plain =
      run_fabrica(extract.substr(extract.find("extract")) + quoted(dir / "b"), dir / "plain.txt");
  EXPECT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_EQ(plain.output.find("/41 labels"), std::string::npos) << plain.output;
}
