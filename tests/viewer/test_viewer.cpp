// fabrica-viewer end to end: each test writes a script, runs the real
// program in its window under `xvfb-run -a`, and checks what it produced
// (pixels, the saved scene, the frame log, exit codes and messages).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "bad_meshes.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/render/image.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace fabrica;

namespace {

struct Outcome {
  int code = -1;
  std::string err;
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A word of a shell command line.
std::string shell_quote(const std::string& s) {
  return "'" + s + "'";
}

/// A path in a viewer script.
std::string quote(const std::string& s) {
  return "\"" + s + "\"";
}

/// Runs a shell command line with stderr captured.
Outcome run(const std::string& command, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const std::string line = command + " </dev/null >" + shell_quote((dir / "stdout.txt").string()) +
                           " 2>" + shell_quote(err.string());
  const int status = std::system(line.c_str());
  Outcome r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  r.err = read_text(err);
  return r;
}

/// The viewer on a fresh X server, window `size`, running `script`. The X
/// authority file lives in the test's folder: xvfb-run's own temporary
/// folder sometimes fails to be removed (exit 5) while other servers run.
Outcome run_viewer(const fs::path& dir, const std::string& script, const std::string& size,
                   const std::string& extra = "") {
  const fs::path path = dir / "script.txt";
  std::ofstream(path) << script;
  return run(std::string(XVFB_RUN) + " -a -f " + shell_quote((dir / "Xauthority").string()) +
                 " -s '-screen 0 1600x1200x24' " + shell_quote(FABRICA_VIEWER_EXE) + " --size " +
                 size + " --script " + shell_quote(path.string()) + " " + extra,
             dir);
}

fs::path volume() {
  return test::bundled_data() / "meshes" / "volumes" / "totalseg_example_seg.nii.gz";
}

/// Pixels onto which the interior voxels of `label` project (interior: all
/// six neighbours carry the label, so the pixel lies inside the surface's
/// silhouette).
std::vector<std::pair<int, int>> label_pixels(int label, const Camera& camera) {
  const io::LabelVolume v = io::read_label_volume(volume());
  const auto& g = v.geometry;
  const auto& map = v.layers.at(0);
  auto at = [&](int i, int j, int k) {
    return map[static_cast<std::size_t>(i) +
               static_cast<std::size_t>(g.dims[0]) *
                   (static_cast<std::size_t>(j) + static_cast<std::size_t>(g.dims[1]) * k)];
  };
  std::vector<std::pair<int, int>> out;
  for (int k = 1; k + 1 < g.dims[2]; ++k)
    for (int j = 1; j + 1 < g.dims[1]; ++j)
      for (int i = 1; i + 1 < g.dims[0]; ++i) {
        if (at(i, j, k) != label || at(i - 1, j, k) != label || at(i + 1, j, k) != label ||
            at(i, j - 1, k) != label || at(i, j + 1, k) != label || at(i, j, k - 1) != label ||
            at(i, j, k + 1) != label)
          continue;
        const auto p = project(camera, g.index_to_patient(Vec3(i, j, k)));
        const int x = static_cast<int>(p.pixel.x()), y = static_cast<int>(p.pixel.y());
        if (x >= 0 && y >= 0 && x < camera.width && y < camera.height) out.emplace_back(x, y);
      }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

fs::path work_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = test::temp_dir(std::string("viewer-") + info->name());
  fs::create_directories(dir);
  return dir;
}

/// Two 800x600 window pictures compared right of the Structures panel and
/// above the HUD: the largest channel difference, and the fraction of
/// pixels differing by more than 8.
std::pair<int, double> differ(const render::Image& a, const render::Image& b) {
  int most = 0, over = 0, count = 0;
  for (int y = 40; y < 520; ++y)
    for (int x = 380; x < 800; ++x, ++count) {
      int m = 0;
      for (int c = 0; c < 3; ++c) m = std::max(m, std::abs(a.pixel(x, y)[c] - b.pixel(x, y)[c]));
      most = std::max(most, m);
      over += m > 8;
    }
  return {most, double(over) / count};
}

}  // namespace

// Focus one label of the bundled label volume, anterior view: the focus is
// drawn where the volume puts it and opaque, the context ghosted; the saved
// scene through `fabrica render` gives the same pixels; the frame log has one
// row per frame and the lines are never more than one frame old.
TEST(Viewer, LabelVolumeFocusAndContext) {
  const fs::path dir = work_dir();
  const std::string script =
      "# label volume, focus the liver (label 5), anterior view\n"
      "open " +
      quote(volume().string()) +
      "\n"
      "wait\n"
      "focus liver\n"
      "view anterior\n"
      "orbit 20 6\n"
      "view anterior\n"
      "wait\n"
      "screenshot " +
      quote((dir / "view.png").string()) +
      " 400x300\n"
      "screenshot " +
      quote((dir / "alpha.png").string()) +
      " 400x300 transparent\n"
      "save-scene " +
      quote((dir / "scene.json").string()) +
      "\n"
      "export-svg " +
      quote((dir / "lines.svg").string()) +
      "\n"
      "export-svg " +
      quote((dir / "lines.pdf").string()) +
      "\n"
      "quit\n";
  const Outcome r = run_viewer(dir, script, "640x400",
                               "--frame-log " + shell_quote((dir / "frames.csv").string()));
  ASSERT_EQ(r.code, 0) << r.err;

  // The scene: liver is the one focus, the camera is the window's.
  const auto scene = nlohmann::json::parse(read_text(dir / "scene.json"));
  int focus = 0;
  for (const auto& s : scene["structures"]) {
    if (s["role"] == "focus") {
      ++focus;
      EXPECT_EQ(s["name"], "liver");
    }
  }
  EXPECT_EQ(focus, 1);
  EXPECT_GT(scene["structures"].size(), 20u);
  Camera camera = camera_from_json(scene["camera"]);
  camera.width = 400;
  camera.height = 300;

  // Focus where the volume says, and opaque: the pixels of the liver's
  // interior voxels are fully covered in the transparent export.
  const render::Image alpha = render::read_png(dir / "alpha.png");
  const auto liver = label_pixels(5, camera);
  ASSERT_GT(liver.size(), 500u);
  std::vector<bool> in_liver(400 * 300, false);
  std::size_t opaque = 0;
  for (auto [x, y] : liver) {
    if (alpha.pixel(x, y)[3] == 255) ++opaque;
    for (int dy = -3; dy <= 3; ++dy)
      for (int dx = -3; dx <= 3; ++dx)
        if (x + dx >= 0 && x + dx < 400 && y + dy >= 0 && y + dy < 300)
          in_liver[static_cast<std::size_t>((y + dy) * 400 + x + dx)] = true;
  }
  EXPECT_GT(static_cast<double>(opaque) / liver.size(), 0.97);
  // The context (covered pixels away from the liver) is ghosted: partly
  // transparent for the most part.
  std::size_t context = 0, context_opaque = 0;
  for (int y = 0; y < 300; ++y)
    for (int x = 0; x < 400; ++x) {
      const int a = alpha.pixel(x, y)[3];
      if (a == 0 || in_liver[static_cast<std::size_t>(y * 400 + x)]) continue;
      ++context;
      if (a == 255) ++context_opaque;
    }
  std::printf("liver interior pixels %zu, opaque %zu; context pixels %zu, opaque %zu\n",
              liver.size(), opaque, context, context_opaque);
  ASSERT_GT(context, 5000u);
  EXPECT_LT(static_cast<double>(context_opaque) / context, 0.05)
      << context_opaque << " of " << context << " context pixels opaque";

  // In the visible image the liver is shaded in its own colour, not white.
  const render::Image view = render::read_png(dir / "view.png");
  double lightness = 0.0;
  for (auto [x, y] : liver) {
    const auto* p = view.pixel(x, y);
    lightness += (p[0] + p[1] + p[2]) / 3.0;
  }
  std::printf("mean lightness over the liver %.1f\n", lightness / liver.size());
  EXPECT_LT(lightness / liver.size(), 235.0);

  // One renderer: `fabrica render` on the saved scene, same size, same pixels.
  const Outcome cli =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "scene.json").string()) +
              " --size 400x300 -q -o " + shell_quote((dir / "cli.png").string()),
          dir);
  ASSERT_EQ(cli.code, 0) << cli.err;
  const render::Image from_cli = render::read_png(dir / "cli.png");
  const auto diff = render::compare_images(view, from_cli, 0);
  EXPECT_TRUE(diff.same_size);
  EXPECT_EQ(diff.max_abs, 0) << "mean " << diff.mean_abs << ", fraction " << diff.fraction_over;

  EXPECT_NE(read_text(dir / "lines.svg").find("<path"), std::string::npos);
  // One drawing path for the lines too: `fabrica render --svg` of the saved
  // scene at the window's size writes the same SVG, byte for byte (layers,
  // styles, CPU visibility).
  const Outcome svg =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "scene.json").string()) +
              " --size 640x400 -q -o " + shell_quote((dir / "cli640.png").string()) + " --svg " +
              shell_quote((dir / "cli.svg").string()),
          dir);
  ASSERT_EQ(svg.code, 0) << svg.err;
  const std::string viewer_svg = read_text(dir / "lines.svg"), cli_svg = read_text(dir / "cli.svg");
  EXPECT_NE(viewer_svg.find("inkscape:label=\"liver\""), std::string::npos);
  EXPECT_NE(viewer_svg.find("data-role=\"focus\""), std::string::npos);
  EXPECT_TRUE(viewer_svg == cli_svg)
      << "the viewer's SVG (" << viewer_svg.size() << " bytes) differs from fabrica render --svg ("
      << cli_svg.size() << " bytes)";
  EXPECT_EQ(read_text(dir / "lines.pdf").rfind("%PDF", 0), 0u);

  // Frame log: a header, then one row per frame, numbered 1, 2, 3, ...;
  // the orbit alone draws 6 frames; lines never more than one frame old.
  std::ifstream log(dir / "frames.csv");
  std::string line;
  std::getline(log, line);
  EXPECT_EQ(line, "frame,ms_frame,ms_gpu_submit,ms_lines,lines_age_frames");
  std::uint64_t expected = 1;
  while (std::getline(log, line)) {
    std::stringstream row(line);
    std::string cell;
    std::vector<std::string> cells;
    while (std::getline(row, cell, ',')) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 5u) << line;
    EXPECT_EQ(std::stoull(cells[0]), expected++);
    EXPECT_LE(std::stoi(cells[4]), 1) << line;
    for (std::size_t c = 1; c < 4; ++c) EXPECT_GE(std::stod(cells[c]), 0.0) << line;
  }
  EXPECT_GE(expected, 8u);
  const std::string frames_said = "frames: " + std::to_string(expected - 1);
  EXPECT_NE(r.err.find(frames_said), std::string::npos) << r.err;
}

// Click-to-focus through the GPU id buffer: a click on the liver's pixel
// makes the liver the focus.
TEST(Viewer, ClickPicksTheStructureUnderTheCursor) {
  const fs::path dir = work_dir();
  // The window's anterior camera first, to know where the liver is.
  const std::string first = "open " + quote(volume().string()) +
                            "\nwait\nview anterior\nsave-camera " +
                            quote((dir / "camera.json").string()) + "\n";
  const Outcome r1 = run_viewer(dir, first, "480x360");
  ASSERT_EQ(r1.code, 0) << r1.err;
  const Camera camera = read_camera(dir / "camera.json");
  ASSERT_EQ(camera.width, 480);
  const auto liver = label_pixels(5, camera);
  ASSERT_FALSE(liver.empty());
  double sx = 0, sy = 0;
  for (auto [x, y] : liver) sx += x, sy += y;
  // The interior pixel nearest the centroid.
  auto target = liver.front();
  double best = 1e30;
  for (auto [x, y] : liver) {
    const double d = std::hypot(x - sx / liver.size(), y - sy / liver.size());
    if (d < best) best = d, target = {x, y};
  }
  const std::string second = "open " + quote(volume().string()) +
                             "\nwait\nfocus spleen\nview anterior\nwait\nclick " +
                             std::to_string(target.first) + " " + std::to_string(target.second) +
                             "\nsave-scene " + quote((dir / "scene.json").string()) + "\n";
  const Outcome r2 = run_viewer(dir, second, "480x360");
  ASSERT_EQ(r2.code, 0) << r2.err;
  const auto scene = nlohmann::json::parse(read_text(dir / "scene.json"));
  for (const auto& s : scene["structures"])
    EXPECT_EQ(s["role"] == "focus", s["name"] == "liver") << s["name"];
  const std::string out = read_text(dir / "stdout.txt");
  EXPECT_NE(out.find(": liver at "), std::string::npos) << out;

  // Measure mode: two clicks on the liver, their distance in mm.
  const auto far = liver.back();
  const std::string third =
      "open " + quote(volume().string()) + "\nwait\nview anterior\nmeasure on\nclick " +
      std::to_string(target.first) + " " + std::to_string(target.second) + "\nclick " +
      std::to_string(far.first) + " " + std::to_string(far.second) + "\n";
  const Outcome r3 = run_viewer(dir, third, "480x360");
  ASSERT_EQ(r3.code, 0) << r3.err;
  const std::string measured = read_text(dir / "stdout.txt");
  const auto at = measured.find("distance ");
  ASSERT_NE(at, std::string::npos) << measured;
  const double mm = std::stod(measured.substr(at + 9));
  // Pixels apart times the mm per pixel at the liver's depth, roughly.
  const double px = std::hypot(far.first - target.first, far.second - target.second);
  const double mm_per_px = 2.0 * (camera.center - camera.eye).norm() *
                           std::tan(camera.fov_deg * M_PI / 360.0) / camera.height;
  EXPECT_GT(mm, 0.5 * px * mm_per_px) << measured;
  EXPECT_LT(mm, 2.0 * px * mm_per_px) << measured;
}

// A file that cannot be read: the error is shown (panel and stderr, the
// CLI's one-line message) and the session goes on.
TEST(Viewer, BadFileLeavesTheSessionRunning) {
  const fs::path dir = work_dir();
  std::ofstream(dir / "broken.stl") << "solid nothing\nendsolid\n";
  const fs::path mesh = test::bundled_data() / "meshes" / "classic" / "c3d_igea.ply";
  // Then an animated view change ends exactly where the jump goes.
  const std::string script =
      "open " + quote((dir / "broken.stl").string()) + "\nwait\nopen " + quote(mesh.string()) +
      "\nwait\nscreenshot " + quote((dir / "after.png").string()) +
      " 200x150\nview left animate\nscreenshot " + quote((dir / "animated.png").string()) +
      " 200x150\nview anterior\nview left\nscreenshot " + quote((dir / "jumped.png").string()) +
      " 200x150\nset c3d_igea hybrid=true lines=contour,apparent\nscreenshot " +
      quote((dir / "hybrid.png").string()) + " 200x150\nsave-scene " +
      quote((dir / "hybrid.json").string()) + "\n";
  const Outcome r = run_viewer(dir, script, "320x240");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("broken.stl"), std::string::npos) << r.err;
  const render::Image after = render::read_png(dir / "after.png");
  std::size_t drawn = 0;
  for (int y = 0; y < after.height; ++y)
    for (int x = 0; x < after.width; ++x)
      if (after.pixel(x, y)[0] < 250) ++drawn;
  EXPECT_GT(drawn, 1000u);
  const auto diff = render::compare_images(render::read_png(dir / "animated.png"),
                                           render::read_png(dir / "jumped.png"), 0);
  EXPECT_EQ(diff.max_abs, 0);
  EXPECT_GT(render::compare_images(after, render::read_png(dir / "jumped.png"), 0).max_abs, 0);

  // The hybrid GPU apparent ridges, too, are drawn as `fabrica render` draws them.
  const Outcome cli =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "hybrid.json").string()) +
              " --size 200x150 -q -o " + shell_quote((dir / "cli.png").string()),
          dir);
  ASSERT_EQ(cli.code, 0) << cli.err;
  const render::Image hybrid = render::read_png(dir / "hybrid.png");
  EXPECT_EQ(render::compare_images(hybrid, render::read_png(dir / "cli.png"), 0).max_abs, 0);
  EXPECT_GT(render::compare_images(hybrid, render::read_png(dir / "jumped.png"), 0).max_abs, 0);
}

// Every malformed-file kind the CLI refuses (tests/support/bad_meshes.hpp),
// opened one after the other: each gives its one-line message naming the
// file, nothing hangs (a FIFO among them) or crashes, and a good mesh opened
// after them is drawn (issue 15: "viewer open").
TEST(Viewer, EveryMalformedMeshIsRefusedAndTheSessionGoesOn) {
  const fs::path dir = work_dir();
  std::string script;
  std::vector<fs::path> bad;
  for (const auto& name : test::bad_mesh_names()) {
    const fs::path case_dir = dir / "in" / name;
    fs::create_directories(case_dir);
    bad.push_back(test::bad_mesh(name).make(case_dir));
    script += "open " + quote(bad.back().string()) + "\nwait\n";
  }
  const fs::path good = dir / "good.obj";
  test::write_bytes(good, test::kTetraObj);
  script += "open " + quote(good.string()) + "\nwait\nview anterior\nscreenshot " +
            quote((dir / "after.png").string()) + " 200x150\n";
  const Outcome r = run_viewer(dir, script, "320x240");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const fs::path& b : bad)
    EXPECT_NE(r.err.find(b.string()), std::string::npos) << "no message names " << b << "\n"
                                                         << r.err;
  const render::Image after = render::read_png(dir / "after.png");
  std::size_t drawn = 0;
  for (int y = 0; y < after.height; ++y)
    for (int x = 0; x < after.width; ++x)
      if (after.pixel(x, y)[0] < 250) ++drawn;
  EXPECT_GT(drawn, 100u);
}

// Script errors stop with exit 2 and the line number.
TEST(Viewer, ScriptErrorsNameTheLine) {
  const fs::path dir = work_dir();
  Outcome r = run_viewer(dir, "# comment\n\nfly-to mars\n", "320x240");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("script.txt:3: unknown command \"fly-to\""), std::string::npos) << r.err;
  r = run_viewer(dir, "orbit ten 5\n", "320x240");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("script.txt:1:"), std::string::npos) << r.err;
  r = run_viewer(dir, "open " + quote(volume().string()) + "\nfocus nothing_here\n", "320x240");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("script.txt:2: no structure named"), std::string::npos) << r.err;
}

// A label volume without names takes them (and colours) from a label table
// beside it: NAME.txt with `VALUE NAME R G B` lines.
TEST(Viewer, LabelTableBesideTheVolumeNamesTheStructures) {
  const fs::path dir = work_dir();
  const int n = 12;
  std::string voxels(static_cast<std::size_t>(n * n * n), '\0');
  for (int k = 3; k < 9; ++k)
    for (int j = 3; j < 9; ++j)
      for (int i = 3; i < 9; ++i) voxels[static_cast<std::size_t>(i + n * (j + n * k))] = 3;
  std::ofstream(dir / "block.nrrd", std::ios::binary)
      << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 12 12\nencoding: raw\n"
         "space: left-posterior-superior\nspace directions: (2,0,0) (0,2,0) (0,0,2)\n"
         "space origin: (0,0,0)\n\n"
      << voxels;
  std::ofstream(dir / "block.txt") << "# value name r g b\n3 cube 255 0 0\n";
  const Outcome r =
      run_viewer(dir,
                 "open " + quote((dir / "block.nrrd").string()) + "\nfocus cube\nsave-scene " +
                     quote((dir / "scene.json").string()) + "\n",
                 "320x240");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto scene = nlohmann::json::parse(read_text(dir / "scene.json"));
  ASSERT_EQ(scene["structures"].size(), 1u);
  EXPECT_EQ(scene["structures"][0]["name"], "cube");
  EXPECT_EQ(scene["structures"][0]["role"], "focus");
  EXPECT_EQ(scene["structures"][0]["color"], nlohmann::json::parse("[1.0, 0.0, 0.0, 1.0]"));
}

// The clipping plane (issue 18, item 4): `clip anterior 0` removes the
// context anterior of the liver's centre, so the pixels over the liver
// change; the focus is never clipped; a plane beyond the whole scene changes
// nothing; the saved scene keeps the plane and `fabrica render` draws the
// same pixels; a bad orientation stops the script with its line number.
TEST(Viewer, ClippingPlaneRemovesTheContextInFront) {
  const fs::path dir = work_dir();
  auto shot = [&](const std::string& name) {
    return "screenshot " + quote((dir / name).string()) + " 400x300\n";
  };
  const std::string script =
      "open " + quote(volume().string()) + "\nwait\nfocus liver\nview anterior\nwait\n" +
      shot("plain.png") + "clip anterior 0\nwait\n" + shot("clip.png") + "save-scene " +
      quote((dir / "scene.json").string()) + "\nclip anterior 5000\nwait\n" + shot("far.png") +
      "clip off\nwait\n" + shot("off.png") + "clip sideways 2\n";
  const Outcome r = run_viewer(dir, script, "640x400");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(":17: clip: unknown orientation \"sideways\""), std::string::npos) << r.err;

  const auto scene = nlohmann::json::parse(read_text(dir / "scene.json"));
  ASSERT_TRUE(scene.contains("clip")) << scene.dump();
  Camera camera = camera_from_json(scene["camera"]);
  camera.width = 400;
  camera.height = 300;
  const render::Image plain = render::read_png(dir / "plain.png");
  const render::Image clip = render::read_png(dir / "clip.png");
  // A plane beyond the scene, and no plane: the picture without clipping.
  EXPECT_EQ(render::compare_images(plain, render::read_png(dir / "far.png"), 0).max_abs, 0);
  EXPECT_EQ(render::compare_images(plain, render::read_png(dir / "off.png"), 0).max_abs, 0);
  // Over the liver, ghosted context in front of it is gone: its pixels change.
  const auto liver = label_pixels(5, camera);
  ASSERT_GT(liver.size(), 500u);
  std::size_t changed = 0;
  for (auto [x, y] : liver) {
    const auto *a = plain.pixel(x, y), *b = clip.pixel(x, y);
    if (std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]) > 6) ++changed;
  }
  std::printf("liver pixels %zu, changed by the clip %zu\n", liver.size(), changed);
  EXPECT_GT(changed, liver.size() / 20);
  // One renderer: the saved scene (with its plane) through `fabrica render`.
  const Outcome cli =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "scene.json").string()) +
              " --size 400x300 -q -o " + shell_quote((dir / "cli.png").string()),
          dir);
  ASSERT_EQ(cli.code, 0) << cli.err;
  EXPECT_EQ(render::compare_images(clip, render::read_png(dir / "cli.png"), 0).max_abs, 0);
}

// A ghosted context of more than 2 x 12k faces (the igea as context) is
// drawn from its level of detail while the camera turns and from the full
// mesh once it stops: the window during the orbit differs from the still
// window only a little (the coarse ghost), the still window after `wait` is
// the full picture again, and the export after an orbit is pixel-identical
// to `fabrica render` of the saved scene (the full meshes).
TEST(Viewer, GhostedContextIsCoarseOnlyWhileTheCameraMoves) {
  const fs::path dir = work_dir();
  const fs::path classic = test::bundled_data() / "meshes" / "classic";
  const std::string script = "open " + quote((classic / "libigl_bunny.off").string()) + "\n" +
                             "open " + quote((classic / "c3d_igea.ply").string()) + "\n" +
                             "wait\nfocus libigl_bunny\ncontext c3d_igea\n"
                             "set c3d_igea opacity=0.4\nview anterior\nwait\n"
                             "screenshot-window " +
                             quote((dir / "still0.png").string()) + "\n" +
                             "orbit 360 4\n"
                             "screenshot-window " +
                             quote((dir / "moving.png").string()) + "\n" +
                             "wait\n"
                             "screenshot-window " +
                             quote((dir / "still.png").string()) + "\n" + "screenshot " +
                             quote((dir / "view.png").string()) + "\n" + "save-scene " +
                             quote((dir / "scene.json").string()) + "\nquit\n";
  const Outcome r = run_viewer(dir, script, "800x600");
  ASSERT_EQ(r.code, 0) << r.err;
  const render::Image still0 = render::read_png(dir / "still0.png");
  const render::Image moving = render::read_png(dir / "moving.png");
  const render::Image still = render::read_png(dir / "still.png");
  // A full turn: the same camera before and after, the same still picture.
  EXPECT_EQ(differ(still0, still).first, 0);
  const auto [most, fraction] = differ(moving, still);
  EXPECT_GT(most, 0) << "the ghost was not drawn coarse while moving";
  EXPECT_LT(fraction, 0.05) << "the coarse ghost should look like the full one";
  const Outcome cli =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "scene.json").string()) +
              " --size 800x600 -q -o " + shell_quote((dir / "cli.png").string()),
          dir);
  ASSERT_EQ(cli.code, 0) << cli.err;
  const auto same = render::compare_images(render::read_png(dir / "view.png"),
                                           render::read_png(dir / "cli.png"), 0);
  EXPECT_EQ(same.max_abs, 0) << "mean " << same.mean_abs;
}

// While the camera moves the opaque igea (268k faces) is drawn from a
// coarser copy that fits the pixels (docs/algorithms.md §16), its lines from
// the full mesh, or with `moving-lines coarse` from that copy: the moving
// picture differs from the still one but stays close to it (closer with the
// full lines); the still picture after the motion is the full one again, and
// the export is pixel-identical to `fabrica render`.
TEST(Viewer, OpaqueFocusIsCoarseOnlyWhileTheCameraMoves) {
  const fs::path dir = work_dir();
  const fs::path classic = test::bundled_data() / "meshes" / "classic";
  auto window = [&](const std::string& name) {
    return "screenshot-window " + quote((dir / name).string()) + "\n";
  };
  const std::string script =
      "open " + quote((classic / "c3d_igea.ply").string()) + "\n" +
      "wait\nfocus c3d_igea\nset c3d_igea lines=contour,suggestive,apparent\n"
      "view anterior\nwait\n" +
      window("still0.png") + "orbit 360 4\n" + window("moving.png") + "wait\n" +
      window("still.png") + "moving-lines coarse\norbit 360 4\n" + window("coarse.png") + "wait\n" +
      window("still2.png") + "screenshot " + quote((dir / "view.png").string()) + "\n" +
      "save-scene " + quote((dir / "scene.json").string()) + "\nquit\n";
  const Outcome r = run_viewer(dir, script, "800x600");
  ASSERT_EQ(r.code, 0) << r.err;
  auto png = [&](const std::string& name) { return render::read_png(dir / name); };
  const render::Image still = png("still.png");
  EXPECT_EQ(differ(png("still0.png"), still).first, 0);
  EXPECT_EQ(differ(png("still2.png"), still).first, 0);
  const auto [most, fraction] = differ(png("moving.png"), still);
  EXPECT_GT(most, 0) << "the focus was not drawn coarse while moving";
  EXPECT_LT(fraction, 0.08) << "the coarse focus should look like the full one";  // 0.052
  const double coarse_fraction = differ(png("coarse.png"), still).second;
  EXPECT_GT(coarse_fraction, fraction) << "the lines did not come from the coarse copy";
  EXPECT_LT(coarse_fraction, 0.15);  // 0.086
  const Outcome cli =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "scene.json").string()) +
              " --size 800x600 -q -o " + shell_quote((dir / "cli.png").string()),
          dir);
  ASSERT_EQ(cli.code, 0) << cli.err;
  const auto same = render::compare_images(png("view.png"), png("cli.png"), 0);
  EXPECT_EQ(same.max_abs, 0) << "mean " << same.mean_abs;
}

// The cutaway (issue 18, item 4): the aorta seen from behind with opaque
// vertebrae in front of it. `cutaway on` shows the aorta through them (its
// colour at its centre pixel, absent without the cutaway); pixels far from
// the aorta do not change; `cutaway off` gives the first picture back; the
// saved scene keeps the cutaway and `fabrica render` draws the same
// pixels; a bad value stops the script with its line number.
TEST(Viewer, CutawayShowsTheFocusThroughTheContext) {
  const fs::path dir = work_dir();
  auto shot = [&](const std::string& name) {
    return "screenshot " + quote((dir / name).string()) + " 400x300\n";
  };
  std::string script = "open " + quote(volume().string()) + "\nwait\nfocus aorta\n";
  for (const char* bone : {"vertebrae_T11", "vertebrae_T12", "vertebrae_L1", "vertebrae_L2",
                           "autochthon_left", "autochthon_right"})
    script += "set " + std::string(bone) + " opacity=1\n";
  script += "view posterior\nwait\n" + shot("plain.png") + "cutaway on 12 8\nwait\n" +
            shot("cut.png") + "save-scene " + quote((dir / "scene.json").string()) +
            "\ncutaway off\nwait\n" + shot("off.png") + "cutaway rim=true margin_px=30\n" +
            "cutaway on wide\n";
  const Outcome r = run_viewer(dir, script, "640x400");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(":21: cutaway MARGIN_PX must be a number (got \"wide\")"), std::string::npos)
      << r.err;

  const auto scene = nlohmann::json::parse(read_text(dir / "scene.json"));
  ASSERT_TRUE(scene.contains("cutaway")) << scene.dump();
  EXPECT_TRUE(scene["cutaway"]["enabled"].get<bool>());
  EXPECT_EQ(scene["cutaway"]["margin_px"].get<double>(), 12.0);
  Camera camera = camera_from_json(scene["camera"]);
  camera.width = 400;
  camera.height = 300;
  const render::Image plain = render::read_png(dir / "plain.png");
  const render::Image cut = render::read_png(dir / "cut.png");
  EXPECT_EQ(render::compare_images(plain, render::read_png(dir / "off.png"), 0).max_abs, 0);
  // The aorta's interior pixels: its colour (from the volume's label
  // table: each channel 0 or 1) with the cutaway, shaded.
  const auto aorta = label_pixels(52, camera);
  ASSERT_GT(aorta.size(), 100u);
  nlohmann::json colour;
  for (const auto& st : scene["structures"])
    if (st["name"] == "aorta") colour = st["color"];
  ASSERT_TRUE(colour.is_array()) << scene.dump();
  auto red = [&](const std::uint8_t* p) {  // "shows the aorta's colour"
    for (int k = 0; k < 3; ++k)
      if (colour[k].get<double>() > 0.5 ? p[k] < 80 : p[k] > 40) return false;
    return true;
  };
  std::size_t red_plain = 0, red_cut = 0;
  double sx = 0, sy = 0;
  for (auto [x, y] : aorta) {
    red_plain += red(plain.pixel(x, y));
    red_cut += red(cut.pixel(x, y));
    sx += x, sy += y;
  }
  std::printf("aorta pixels %zu, its colour without the cutaway %zu, with %zu\n", aorta.size(),
              red_plain, red_cut);
  EXPECT_GT(red_cut, aorta.size() * 9 / 10);
  EXPECT_LT(red_plain, aorta.size() / 2);
  auto centre = aorta.front();
  double best = 1e30;
  for (auto [x, y] : aorta) {
    const double d = std::hypot(x - sx / aorta.size(), y - sy / aorta.size());
    if (d < best) best = d, centre = {x, y};
  }
  EXPECT_TRUE(red(cut.pixel(centre.first, centre.second)));
  EXPECT_FALSE(red(plain.pixel(centre.first, centre.second)));
  // Far from the aorta (30 px: margin + fade at this size are 6 px) the
  // picture is unchanged.
  std::vector<bool> near(400 * 300, false);
  for (auto [x, y] : aorta)
    for (int dy = -30; dy <= 30; ++dy)
      for (int dx = -30; dx <= 30; ++dx)
        if (x + dx >= 0 && x + dx < 400 && y + dy >= 0 && y + dy < 300)
          near[static_cast<std::size_t>((y + dy) * 400 + x + dx)] = true;
  std::size_t far = 0, far_changed = 0;
  for (int y = 0; y < 300; ++y)
    for (int x = 0; x < 400; ++x) {
      if (near[static_cast<std::size_t>(y * 400 + x)]) continue;
      ++far;
      const auto *a = plain.pixel(x, y), *b = cut.pixel(x, y);
      far_changed += a[0] != b[0] || a[1] != b[1] || a[2] != b[2] || a[3] != b[3];
    }
  EXPECT_GT(far, 40000u);
  EXPECT_EQ(far_changed, 0u);
  // One renderer: the saved scene (with its cutaway) through `fabrica render`.
  const Outcome cli =
      run(shell_quote(FABRICA_EXE) + " render " + shell_quote((dir / "scene.json").string()) +
              " --size 400x300 -q -o " + shell_quote((dir / "cli.png").string()),
          dir);
  ASSERT_EQ(cli.code, 0) << cli.err;
  EXPECT_EQ(render::compare_images(cut, render::read_png(dir / "cli.png"), 0).max_abs, 0);
}
