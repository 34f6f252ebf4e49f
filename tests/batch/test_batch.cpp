// End-to-end tests of `fabrica batch` (docs/batch.md) on bundled meshes: a
// manifest with one unreadable input makes every other item and reports the
// bad ones (exit 5); --jobs 1 and --jobs 2, three shards in separate folders,
// and a run killed with SIGKILL then resumed all give the same bytes as the
// full run, and the resumed run leaves finished items alone; an item is what
// its command makes by hand (also for volume labels and camera files); ten
// times the items do not grow a worker's memory; bad manifests fail before
// any work (exit 2) naming every problem by its JSON path.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sanitized.hpp"
#include "test_support.hpp"

extern char** environ;

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

/// Starts `fabrica ARGS...` with stdout and stderr into LOG; returns its pid.
pid_t start(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all = {FABRICA_EXE};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  pid_t pid = -1;
  EXPECT_EQ(posix_spawn(&pid, all[0].c_str(), &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

/// Waits for the child; its exit code (128 + signal when killed), and its peak
/// resident memory in KiB in `max_rss_kib` when given.
int wait_exit(pid_t pid, long* max_rss_kib = nullptr) {
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  if (max_rss_kib) *max_rss_kib = usage.ru_maxrss;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

struct Result {
  int code;
  std::string log;
};

Result fabrica(const std::vector<std::string>& args, const fs::path& log) {
  const int code = wait_exit(start(args, log));
  return {code, read_text(log)};
}

/// Every output below DIR (relative path -> bytes), without the reports and
/// the batch's own working files in DIR/.batch.
std::map<std::string, std::string> outputs(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string rel = e.path().lexically_relative(dir).string();
    if (!e.is_regular_file() || rel.starts_with(".batch") || rel.starts_with("batch-report"))
      continue;
    files[rel] = read_text(e.path());
  }
  return files;
}

/// A manifest over three bundled meshes (one glob) and a broken one, three
/// views (a preset and an orbit of two) and two styles (lines as SVG + JSON,
/// render as PNG + SVG) at 256x256: 4 x 3 x 2 = 24 items, 6 of them on the
/// broken input.
class Batch : public ::testing::Test {
 protected:
  static fs::path root, manifest, full;
  static Result full_run;

  static void SetUpTestSuite() {
    root = fabrica::test::temp_dir("batch");
    fs::create_directory_symlink(fabrica::test::bundled_data(), root / "data");
    write_text(root / "broken.off", "OFF\n3 1 0\n0 0 0\n1 0 nan\n");
    const json m = {{"inputs",
                     {{{"mesh", "data/meshes/anatomy/liver/sofa_liver_coarse.obj"}},
                      {{"mesh", "broken.off"}},
                      {{"glob", "data/meshes/anatomy/brain/vtkdata_mni-surface-mesh.o*"}},
                      {{"mesh", "data/meshes/anatomy/liver/sofa_liver2.obj"}, {"name", "liver"}}}},
                    {"views", {"anterior", {{"orbit", 2}, {"from", "left"}}}},
                    {"styles",
                     {{{"name", "lines"},
                       {"command", "lines"},
                       {"types", {"contour", "suggestive"}},
                       {"formats", {"svg", "json"}}},
                      {{"name", "shaded"},
                       {"command", "render"},
                       {"lines", {"contour"}},
                       {"formats", {"png", "svg"}}}}},
                    {"size", {256, 256}}};
    manifest = root / "manifest.json";
    write_text(manifest, m.dump(2));
    full = root / "full";
    full_run = fabrica({"batch", manifest.string(), "-o", full.string(), "--jobs", "2"},
                       root / "full.log");
  }
};
fs::path Batch::root, Batch::manifest, Batch::full;
Result Batch::full_run;

TEST_F(Batch, MakesEveryGoodItemAndReportsTheBadInput) {
  ASSERT_EQ(full_run.code, 5) << full_run.log;
  const json report = json::parse(read_text(full / "batch-report.json"));
  EXPECT_EQ(report["total_items"], 24);
  ASSERT_EQ(report["items"].size(), 24u);
  EXPECT_EQ(report["summary"]["made"], 18);
  EXPECT_EQ(report["summary"]["failed"], 6);
  for (std::size_t k = 0; k < 24; ++k) {
    const json& item = report["items"][k];
    EXPECT_EQ(item["index"], k);  // input-major: input = k / 6
    const bool bad = k / 6 == 1;
    EXPECT_EQ(item["input"], bad ? "broken"
                                 : (k / 6 == 0   ? "sofa_liver_coarse"
                                    : k / 6 == 2 ? "vtkdata_mni-surface-mesh"
                                                 : "liver"));
    EXPECT_EQ(item["status"], bad ? "failed" : "made") << item.dump();
    if (bad) {
      EXPECT_NE(item["reason"].get<std::string>().find("broken.off"), std::string::npos)
          << item.dump();
      EXPECT_EQ(item["reason"].get<std::string>().find('\n'), std::string::npos);
    }
    for (const auto& o : item["outputs"]) {
      EXPECT_EQ(fs::exists(full / o.get<std::string>()), !bad) << o;
      if (!bad) {
        const json meta = json::parse(read_text(full / (o.get<std::string>() + ".meta.json")));
        EXPECT_EQ(meta["item"], k);
        EXPECT_TRUE(meta["input"]["hash"].get<std::string>().starts_with("fnv1a64:"));
        EXPECT_EQ(meta["output"], o);
        EXPECT_FALSE(meta["commands"].empty());
      }
    }
  }
  // The names of the outputs, and a camera recorded for an orbit view.
  EXPECT_TRUE(fs::exists(full / "liver/shaded-orbit1.png"));
  EXPECT_TRUE(fs::exists(full / "liver/shaded-orbit1.svg"));
  EXPECT_TRUE(fs::exists(full / "sofa_liver_coarse/lines-anterior.json"));
  const json meta = json::parse(read_text(full / "liver/lines-orbit1.svg.meta.json"));
  EXPECT_TRUE(meta["view"]["camera"].contains("eye"));
  EXPECT_NE(full_run.log.find("failed"), std::string::npos);
}

TEST_F(Batch, ItemIsWhatTheCommandMakes) {
  ASSERT_EQ(full_run.code, 5) << full_run.log;
  const fs::path out = root / "single.svg";
  const auto r = fabrica(
      {"lines", (root / "data/meshes/anatomy/liver/sofa_liver2.obj").string(), "--view", "anterior",
       "--size", "256x256", "--types", "contour,suggestive", "--quiet", "-o", out.string()},
      root / "single.log");
  ASSERT_EQ(r.code, 0) << r.log;
  EXPECT_EQ(read_text(out), read_text(full / "liver/lines-anterior.svg"));
  // Later views of an input are drawn with the line precompute the worker
  // kept from its first (LoadedSurface::draw_lines): still the same bits as
  // one command, which computes it afresh. The item's recorded command, run alone:
  for (const std::string item : {"liver/lines-orbit1", "vtkdata_mni-surface-mesh/lines-orbit0"}) {
    const json meta = json::parse(read_text(full / (item + ".svg.meta.json")));
    std::vector<std::string> args = meta["commands"][0].get<std::vector<std::string>>();
    args.erase(args.begin());  // "fabrica"
    for (auto& a : args) {
      if (a.starts_with(".batch/")) a = (full / a).string();
      if (a.starts_with("data/")) a = (root / a).string();
    }
    const auto o = std::find(args.begin(), args.end(), "-o");
    ASSERT_NE(o, args.end());
    const fs::path alone = root / (fs::path(item).filename().string() + "-alone.svg");
    *(o + 1) = alone.string();
    const auto c = fabrica(args, root / "alone.log");
    ASSERT_EQ(c.code, 0) << c.log;
    EXPECT_EQ(read_text(alone), read_text(full / (item + ".svg"))) << item;
  }
  // A picture drawn by a worker's GL context after other items = a fresh command's.
  const auto p =
      fabrica({"render", (root / "data/meshes/anatomy/liver/sofa_liver2.obj").string(), "--view",
               "anterior", "--size", "256x256", "--lines", "contour", "--quiet", "-o",
               (root / "single.png").string(), "--svg", (root / "single-r.svg").string()},
              root / "single-render.log");
  ASSERT_EQ(p.code, 0) << p.log;
  EXPECT_EQ(read_text(root / "single.png"), read_text(full / "liver/shaded-anterior.png"));
  EXPECT_EQ(read_text(root / "single-r.svg"), read_text(full / "liver/shaded-anterior.svg"));
}

TEST_F(Batch, OneJobAndTwoJobsGiveTheSameBytes) {
  ASSERT_EQ(full_run.code, 5) << full_run.log;
  const fs::path one = root / "one";
  EXPECT_EQ(fabrica({"batch", manifest.string(), "-o", one.string(), "--jobs", "1", "--quiet"},
                    root / "one.log")
                .code,
            5);
  const auto a = outputs(full), b = outputs(one);
  EXPECT_EQ(a.size(), 18u * 2 * 2);  // two outputs per item, each with its .meta.json
  EXPECT_TRUE(a == b);
}

TEST_F(Batch, ShardsInSeparateFoldersMakeTheFullRun) {
  ASSERT_EQ(full_run.code, 5) << full_run.log;
  std::map<std::string, std::string> joined;
  std::vector<std::string> dirs;
  for (int i = 0; i < 3; ++i) {
    const fs::path dir = root / ("shard" + std::to_string(i));
    dirs.push_back(dir.string());
    const auto r = fabrica({"batch", manifest.string(), "-o", dir.string(), "--shard",
                            std::to_string(i) + "/3", "--jobs", "1"},
                           root / ("shard" + std::to_string(i) + ".log"));
    EXPECT_EQ(r.code, 5) << r.log;  // every shard has items of the broken input
    const json report =
        json::parse(read_text(dir / ("batch-report-" + std::to_string(i) + "-of-3.json")));
    EXPECT_EQ(report["items"].size(), 8u);
    for (const auto& item : report["items"]) EXPECT_EQ(item["index"].get<int>() % 3, i);
    for (auto& [k, v] : outputs(dir)) EXPECT_TRUE(joined.emplace(k, v).second) << k;
  }
  EXPECT_TRUE(joined == outputs(full));
  std::vector<std::string> merge = {"batch", "merge"};
  merge.insert(merge.end(), dirs.begin(), dirs.end());
  merge.insert(merge.end(), {"-o", (root / "merged.json").string()});
  EXPECT_EQ(fabrica(merge, root / "merge.log").code, 5);
  const json merged = json::parse(read_text(root / "merged.json"));
  const json single = json::parse(read_text(full / "batch-report.json"));
  EXPECT_EQ(merged["summary"]["made"], 18);
  EXPECT_EQ(merged["summary"]["failed"], 6);
  EXPECT_EQ(merged["summary"]["missing"], 0);
  for (std::size_t k = 0; k < 24; ++k) {
    EXPECT_EQ(merged["items"][k]["status"], single["items"][k]["status"]);
    EXPECT_EQ(merged["items"][k]["outputs"], single["items"][k]["outputs"]);
  }
  // Two shards only: the third's items are missing.
  EXPECT_EQ(fabrica({"batch", "merge", dirs[0], dirs[1], "-o", (root / "partial.json").string()},
                    root / "partial.log")
                .code,
            5);
  EXPECT_EQ(json::parse(read_text(root / "partial.json"))["summary"]["missing"], 8);
}

TEST_F(Batch, KilledRunResumesToTheSameBytesWithoutRedoingFinishedItems) {
  ASSERT_EQ(full_run.code, 5) << full_run.log;
  const fs::path dir = root / "killed";
  const pid_t pid =
      start({"batch", manifest.string(), "-o", dir.string(), "--jobs", "1"}, root / "killed.log");
  // Wait for a few finished items (the .meta.json of each of their outputs
  // is written last), then SIGKILL.
  auto finished = [&] {
    std::map<std::string, fs::file_time_type> done;
    if (!fs::exists(dir)) return done;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      const std::string name = e.path().string();
      if (!name.ends_with(".meta.json") || name.find("/.batch/") != std::string::npos) continue;
      json meta;
      try {
        meta = json::parse(read_text(e.path()));
      } catch (const json::exception&) {
        continue;
      }
      bool all = true;
      for (const auto& o : meta["outputs"])
        all = all && fs::exists(dir / (o.get<std::string>() + ".meta.json"));
      const fs::path out = name.substr(0, name.size() - 10);
      if (all) done[out.string()] = fs::last_write_time(out);
    }
    return done;
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (finished().size() < 6 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  kill(pid, SIGKILL);
  EXPECT_EQ(wait_exit(pid), 128 + SIGKILL) << "the run ended before it could be killed";
  const auto before = finished();
  ASSERT_GE(before.size(), 6u);
  EXPECT_FALSE(fs::exists(dir / "batch-report.json"));

  const auto r =
      fabrica({"batch", manifest.string(), "-o", dir.string(), "--jobs", "2", "--resume"},
              root / "resumed.log");
  EXPECT_EQ(r.code, 5) << r.log;
  const auto resumed = outputs(dir), expected = outputs(full);
  EXPECT_TRUE(resumed == expected);
  for (const auto& [file, bytes] : resumed)
    EXPECT_TRUE(expected.count(file) && expected.at(file) == bytes) << file;
  for (const auto& [file, bytes] : expected) EXPECT_TRUE(resumed.count(file)) << file;
  for (const auto& [file, time] : before) EXPECT_EQ(fs::last_write_time(file), time) << file;
  const json report = json::parse(read_text(dir / "batch-report.json"));
  EXPECT_GE(report["summary"]["skipped"].get<std::size_t>(), before.size() / 2);
  EXPECT_EQ(report["summary"]["failed"], 6);

  // A second resume redoes nothing but the failed items.
  EXPECT_EQ(fabrica({"batch", manifest.string(), "-o", dir.string(), "--resume", "--quiet"},
                    root / "again.log")
                .code,
            5);
  EXPECT_EQ(json::parse(read_text(dir / "batch-report.json"))["summary"]["skipped"], 18);
}

TEST_F(Batch, DryRunListsTheItemsAsCommandLines) {
  const auto r =
      fabrica({"batch", manifest.string(), "--dry-run", "--shard", "0/3"}, root / "dry.log");
  ASSERT_EQ(r.code, 0) << r.log;
  EXPECT_NE(r.log.find("# 8 item(s) of 24 (shard 0/3)"), std::string::npos) << r.log;
  EXPECT_NE(r.log.find("\n3\tfabrica render data/meshes/anatomy/liver/sofa_liver_coarse.obj"),
            std::string::npos)
      << r.log;
  EXPECT_NE(r.log.find("0\tfabrica lines data/meshes/anatomy/liver/sofa_liver_coarse.obj --view "
                       "anterior --size 256x256 --types contour,suggestive --quiet -o "
                       "sofa_liver_coarse/lines-anterior.svg"),
            std::string::npos)
      << r.log;
  EXPECT_FALSE(fs::exists(root / "out"));
}

TEST(BatchInputs, VolumeLabelsCameraFilesAndHatching) {
  const fs::path root = fabrica::test::temp_dir("batch-volume");
  fs::create_directory_symlink(fabrica::test::bundled_data(), root / "data");
  const std::string liver = (root / "data/meshes/anatomy/liver/sofa_liver_coarse.obj").string();
  ASSERT_EQ(fabrica({"render", liver, "--view", "left", "--size", "64x64", "--save-camera",
                     (root / "side.json").string(), "-o", (root / "side.png").string(), "--quiet"},
                    root / "camera.log")
                .code,
            0);
  write_text(root / "m.json",
             json({{"inputs",
                    {{{"volume", "data/meshes/volumes/totalseg_example_seg.nii.gz"},
                      {"labels", {2, 5}},
                      {"name", "seg"}},
                     {{"mesh", liver}, {"name", "liver"}}}},
                   {"views", {"anterior", {{"camera", "side.json"}}}},
                   {"styles",
                    {{{"command", "hatch"}, {"formats", {"svg"}}, {"threshold", 0.8}},
                     {{"command", "lines"}, {"types", "contour"}, {"formats", "seg"}}}},
                   {"size", {200, 200}}})
                 .dump());
  const auto r =
      fabrica({"batch", (root / "m.json").string(), "-o", (root / "out").string()}, root / "log");
  // The side camera suits the liver; it may see neither label: those items may fail.
  ASSERT_TRUE(r.code == 0 || r.code == 5) << r.log;
  for (const char* out : {"seg-label2/hatch-anterior.svg", "seg-label5/hatch-anterior.svg",
                          "seg-label2/lines-anterior.seg", "seg-label5/lines-anterior.seg",
                          "liver/lines-side.seg", "liver/hatch-side.svg"}) {
    ASSERT_TRUE(fs::exists(root / "out" / out)) << out << "\n" << r.log;
    const json meta = json::parse(read_text(root / "out" / (std::string(out) + ".meta.json")));
    if (std::string(out).starts_with("seg"))
      EXPECT_EQ(meta["input"]["label"], out[9] == '2' ? 2 : 5);
    else
      EXPECT_EQ(meta["view"]["camera"]["width"], 64);  // as in the file; --size sets the image
  }
  // Each item is what the command makes from the label surface (written as
  // `fabrica extract` would) or with the camera file.
  auto by_hand = [&](const std::string& mesh, const std::vector<std::string>& view,
                     const std::string& made) {
    std::vector<std::string> args = {"lines",   mesh,      "--size",
                                     "200x200", "--types", "contour",
                                     "--quiet", "-o",      (root / "by-hand.seg").string()};
    args.insert(args.begin() + 2, view.begin(), view.end());
    const auto x = fabrica(args, root / "hand.log");
    ASSERT_EQ(x.code, 0) << x.log;
    EXPECT_EQ(read_text(root / "by-hand.seg"), read_text(root / "out" / made));
  };
  by_hand((root / "out/.batch/volumes/seg-label5.ply").string(), {"--view", "anterior"},
          "seg-label5/lines-anterior.seg");
  by_hand(liver, {"--camera", (root / "side.json").string()}, "liver/lines-side.seg");
}

// Issue 21: a hatch style with "method": "confis" next to a shading one in
// the same worker gives what the commands make (the method's own options
// are reset between items).
TEST(BatchInputs, HatchStylesOfBothMethods) {
  const fs::path root = fabrica::test::temp_dir("batch-confis");
  const std::string liver =
      (fabrica::test::bundled_data() / "meshes/anatomy/liver/sofa_liver_coarse.obj").string();
  write_text(root / "m.json",
             json({{"inputs", {{{"mesh", liver}, {"name", "liver"}}}},
                   {"views", {"anterior"}},
                   {"styles",
                    {{{"name", "confis"},
                      {"command", "hatch"},
                      {"method", "confis"},
                      {"spacing", 5},
                      {"formats", {"svg"}}},
                     {{"name", "shading"}, {"command", "hatch"}, {"formats", {"svg"}}}}},
                   {"size", {200, 200}}})
                 .dump());
  const auto r =
      fabrica({"batch", (root / "m.json").string(), "-o", (root / "out").string(), "--jobs", "1"},
              root / "log");
  ASSERT_EQ(r.code, 0) << r.log;
  for (const auto& [style, extra] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"confis", {"--method", "confis", "--spacing", "5"}}, {"shading", {}}}) {
    std::vector<std::string> args = {"hatch",    liver,    "--view",
                                     "anterior", "--size", "200x200",
                                     "--quiet",  "-o",     (root / "x.svg").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto x = fabrica(args, root / "x.log");
    ASSERT_EQ(x.code, 0) << x.log;
    EXPECT_EQ(read_text(root / "x.svg"), read_text(root / "out/liver" / (style + "-anterior.svg")))
        << style;
  }
}

TEST(BatchMemory, TenTimesTheItemsInOneProcessDoNotGrowItsMemory) {
  // ASan keeps freed blocks in a quarantine (256 MB), so peak memory grows
  // with the work done whatever the program frees; LSan checks leaks there.
  if (fabrica::test::kSanitized) GTEST_SKIP() << "peak memory is not meaningful under ASan";
  const fs::path root = fabrica::test::temp_dir("batch-memory");
  fs::create_directory_symlink(fabrica::test::bundled_data(), root / "data");
  long rss[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    const int views = run == 0 ? 4 : 40;  // 8 and 80 items
    const fs::path m = root / (run == 0 ? "small.json" : "large.json");
    write_text(m, json({{"inputs", {"data/meshes/anatomy/liver/sofa_liver2.obj"}},
                        {"views", {{{"orbit", views}}}},
                        {"styles",
                         {{{"command", "lines"}, {"types", "contour,suggestive,ridge"}},
                          {{"command", "render"}, {"formats", {"png", "svg"}}}}},
                        {"size", {256, 256}}})
                      .dump());
    const pid_t pid = start({"batch", m.string(), "-o", (root / std::to_string(run)).string(),
                             "--jobs", "1", "--quiet"},
                            root / "log");
    ASSERT_EQ(wait_exit(pid, &rss[run]), 0) << read_text(root / "log");
  }
  EXPECT_LE(rss[1], rss[0] * 11 / 10) << "8 items: " << rss[0] << " KiB, 80 items: " << rss[1];
}

TEST(BatchManifest, EveryProblemIsReportedWithItsJsonPathBeforeAnyWork) {
  const fs::path root = fabrica::test::temp_dir("batch-bad");
  const json m = {
      {"inputs", {{{"mesh", "a.off"}, {"colour", "red"}}, {{"glob", "nothing/*.stl"}}}},
      {"views", {"anterior", "sideways", {{"orbit", 0}}}},
      {"styles",
       {{{"command", "lines"}, {"typez", "contour"}},
        {{"command", "lines"}, {"name", "l2"}, {"types", "contour,wiggles"}, {"smooth", "x"}},
        {{"command", "render"}, {"formats", {"svg"}}},
        {{"command", "paint"}},
        {{"command", "hatch"}, {"view", "left"}, {"draw-ridges", "yes"}}}},
      {"size", {0, 256}}};
  write_text(root / "m.json", m.dump());
  const auto r =
      fabrica({"batch", (root / "m.json").string(), "-o", (root / "out").string()}, root / "log");
  EXPECT_EQ(r.code, 2) << r.log;
  for (const char* path :
       {"inputs[0].colour", "inputs[1].glob", "views[1]", "views[2].orbit", "styles[0].typez",
        "styles[1].types", "styles[1].smooth", "styles[2].formats", "styles[3].command",
        "styles[4].view", "styles[4].draw-ridges", "size"})
    EXPECT_NE(r.log.find(std::string(path) + ": "), std::string::npos) << path << "\n" << r.log;
  EXPECT_FALSE(fs::exists(root / "out"));

  write_text(root / "not.json", "{\"inputs\": [");
  EXPECT_EQ(fabrica({"batch", (root / "not.json").string()}, root / "log2").code, 2);
  EXPECT_EQ(fabrica({"batch", (root / "m.json").string(), "--shard", "3/3"}, root / "log3").code,
            2);
}

TEST(BatchManifest, ShardAutoReadsTheSchedulersEnvironment) {
  const fs::path root = fabrica::test::temp_dir("batch-auto");
  fs::create_directory_symlink(fabrica::test::bundled_data(), root / "data");
  write_text(root / "m.json", json({{"inputs", {"data/meshes/anatomy/liver/sofa_liver_coarse.obj"}},
                                    {"views", {"anterior", "left", "right", "superior"}},
                                    {"styles", {{{"command", "lines"}}}}})
                                  .dump());
  auto dry = [&](const std::vector<std::pair<const char*, const char*>>& env,
                 std::vector<std::string> extra) {
    for (const auto& [k, v] : env) setenv(k, v, 1);
    std::vector<std::string> args = {"batch", (root / "m.json").string(), "--dry-run", "--shard",
                                     "auto"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = fabrica(args, root / "log");
    for (const auto& [k, v] : env) unsetenv(k);
    return r;
  };
  auto r = dry(
      {{"SLURM_ARRAY_TASK_ID", "5"}, {"SLURM_ARRAY_TASK_MIN", "4"}, {"SLURM_ARRAY_TASK_MAX", "6"}},
      {});
  EXPECT_EQ(r.code, 0) << r.log;
  EXPECT_NE(r.log.find("shard 1/3"), std::string::npos) << r.log;
  EXPECT_NE(r.log.find("\n1\tfabrica lines"), std::string::npos) << r.log;
  r = dry({{"JOB_COMPLETION_INDEX", "1"}}, {"--shard-count", "2"});
  EXPECT_NE(r.log.find("shard 1/2"), std::string::npos) << r.log;
  EXPECT_NE(r.log.find("\n3\tfabrica lines"), std::string::npos) << r.log;
  EXPECT_EQ(dry({{"JOB_COMPLETION_INDEX", "1"}}, {}).code, 2);
  EXPECT_EQ(dry({}, {}).code, 2);
}

}  // namespace

namespace {

Result run_fabrica(const std::vector<std::string>& args, const fs::path& log) {
  return fabrica(args, log);
}

/// A folder with copies of two bundled livers (a.obj, b.obj, c.obj, editable)
/// and a scene s.json: b the focus, c the context.
fs::path scene_folder(const std::string& name) {
  const fs::path root = fabrica::test::temp_dir(name);
  const fs::path liver = fabrica::test::bundled_data() / "meshes/anatomy/liver";
  fs::copy_file(liver / "sofa_liver_coarse.obj", root / "a.obj");
  fs::copy_file(liver / "sofa_liver_coarse.obj", root / "b.obj");
  fs::copy_file(liver / "sofa_liver2.obj", root / "c.obj");
  write_text(root / "s.json", json({{"structures",
                                     {{{"name", "b"}, {"mesh", "b.obj"}, {"role", "focus"}},
                                      {{"name", "c"}, {"mesh", "c.obj"}, {"role", "context"}}}}})
                                  .dump(2));
  return root;
}

json read_json(const fs::path& p) {
  return json::parse(read_text(p));
}

Eigen::Vector3d vec(const json& j) {
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

/// status of every item of a report, by "input/view/style".
std::map<std::string, std::string> statuses(const fs::path& report) {
  std::map<std::string, std::string> out;
  const json r = read_json(report);
  for (const auto& item : r["items"])
    out[item["input"].get<std::string>() + "/" + item["view"].get<std::string>() + "/" +
        item["style"].get<std::string>()] = item["status"].get<std::string>();
  return out;
}

}  // namespace

// Orbit views of a scene input (issue 19 with issue 17's scenes): the orbit
// turns about the first view's up axis through the scene's framing centre;
// step 0 is the command's own --view; lines, render --svg and hatch styles
// all draw the scene.
TEST(BatchScenes, OrbitOfASceneTurnsAboutItsFramingCentre) {
  const fs::path root = scene_folder("batch-scene-orbit");
  write_text(root / "m.json",
             json({{"inputs", {{{"scene", "s.json"}}}},
                   {"views", {{{"orbit", 4}, {"from", "left"}}}},
                   {"styles",
                    {{{"name", "lines"}, {"command", "lines"}},
                     {{"name", "shaded"}, {"command", "render"}, {"formats", {"png", "svg"}}},
                     {{"name", "hatch"}, {"command", "hatch"}}}},
                   {"size", {128, 96}}})
                 .dump());
  const auto r = run_fabrica({"batch", (root / "m.json").string(), "-o", (root / "out").string()},
                             root / "log");
  ASSERT_EQ(r.code, 0) << r.log;
  Eigen::Vector3d center0, offset0;
  for (int k = 0; k < 4; ++k) {
    const std::string view = "orbit" + std::to_string(k);
    // A scene's lines style writes render --svg's layers.
    EXPECT_EQ(read_text(root / "out/s" / ("lines-" + view + ".svg")),
              read_text(root / "out/s" / ("shaded-" + view + ".svg")))
        << view;
    EXPECT_TRUE(fs::exists(root / "out/s" / ("hatch-" + view + ".svg")));
    const json cam =
        read_json(root / "out/s" / ("lines-" + view + ".svg.meta.json"))["view"]["camera"];
    EXPECT_EQ(cam["width"], 128);
    EXPECT_EQ(cam["height"], 96);
    const Eigen::Vector3d center = vec(cam["center"]), offset = vec(cam["eye"]) - center;
    if (k == 0) {
      center0 = center;
      offset0 = offset;
      continue;
    }
    EXPECT_LT((center - center0).norm(), 1e-9 * offset0.norm());
    EXPECT_NEAR(offset.norm(), offset0.norm(), 1e-9 * offset0.norm());
    const double expected_cos = std::cos(k * M_PI / 2.0);
    EXPECT_NEAR(offset.dot(offset0) / offset0.squaredNorm(), expected_cos, 1e-9) << view;
  }
  // Step 0 is what `--view left` frames at the item's size.
  const auto by_hand = run_fabrica({"lines", (root / "s.json").string(), "--view", "left", "--size",
                                    "128x96", "--quiet", "-o", (root / "left.svg").string()},
                                   root / "hand.log");
  ASSERT_EQ(by_hand.code, 0) << by_hand.log;
  EXPECT_EQ(read_text(root / "left.svg"), read_text(root / "out/s/lines-orbit0.svg"));
  // The framing centre of a scene with focus and context is the focus's box centre.
  ASSERT_EQ(run_fabrica({"render", (root / "s.json").string(), "--view", "left", "--size", "128x96",
                         "--quiet", "-o", (root / "left.png").string(), "--save-camera",
                         (root / "left-camera.json").string()},
                        root / "hand.log")
                .code,
            0);
  EXPECT_LT((vec(read_json(root / "left-camera.json")["center"]) - center0).norm(), 1e-9);
}

// --resume re-makes exactly the items whose referenced files changed: a
// style's --context mesh, a camera view's file, a scene's mesh.
TEST(BatchResume, EditingAReferencedFileRemakesExactlyTheItemsThatUseIt) {
  const fs::path root = scene_folder("batch-resume-files");
  ASSERT_EQ(run_fabrica({"render", (root / "a.obj").string(), "--view", "left", "--size", "96x96",
                         "--quiet", "-o", (root / "cam.png").string(), "--save-camera",
                         (root / "cam.json").string()},
                        root / "cam.log")
                .code,
            0);
  write_text(root / "m.json",
             json({{"inputs", {{{"mesh", "a.obj"}}, {{"scene", "s.json"}}}},
                   {"views", {"anterior", {{"camera", "cam.json"}}}},
                   {"styles",
                    {{{"name", "plain"}, {"command", "lines"}, {"types", "contour"}},
                     {{"name", "ctx"},
                      {"command", "render"},
                      {"context", {"c.obj"}},
                      {"lines", "contour"}}}},
                   {"size", {96, 96}}})
                 .dump());
  const std::vector<std::string> run = {
      "batch", (root / "m.json").string(), "-o", (root / "out").string(), "--resume", "--jobs",
      "1"};
  auto check = [&](const std::set<std::string>& remade, const std::string& what) {
    const auto r = run_fabrica(run, root / "log");
    ASSERT_EQ(r.code, 0) << what << "\n" << r.log;
    const auto s = statuses(root / "out/batch-report.json");
    ASSERT_EQ(s.size(), 8u);
    for (const auto& [item, status] : s)
      EXPECT_EQ(status, remade.count(item) ? "made" : "skipped") << what << ": " << item;
  };
  const std::set<std::string> all = {"a/anterior/plain", "a/anterior/ctx",   "a/cam/plain",
                                     "a/cam/ctx",        "s/anterior/plain", "s/anterior/ctx",
                                     "s/cam/plain",      "s/cam/ctx"};
  check(all, "first run");
  check({}, "nothing changed");
  // The style's context mesh: every "ctx" item, and the scene's items (c is its context).
  std::ofstream(root / "c.obj", std::ios::app) << "# edited\n";
  check({"a/anterior/ctx", "a/cam/ctx", "s/anterior/plain", "s/anterior/ctx", "s/cam/plain",
         "s/cam/ctx"},
        "context mesh edited");
  // The camera file: every item of that view.
  json cam = read_json(root / "cam.json");
  cam["fov_deg"] = cam["fov_deg"].get<double>() + 3.0;
  write_text(root / "cam.json", cam.dump(2));
  check({"a/cam/plain", "a/cam/ctx", "s/cam/plain", "s/cam/ctx"}, "camera edited");
  // A mesh of the scene: the scene's items.
  std::ofstream(root / "b.obj", std::ios::app) << "# edited\n";
  check({"s/anterior/plain", "s/anterior/ctx", "s/cam/plain", "s/cam/ctx"}, "scene mesh edited");
  // The recorded hash is the file's.
  const json meta = read_json(root / "out/a/ctx-anterior.png.meta.json");
  ASSERT_EQ(meta["style"]["files"].size(), 1u);
  EXPECT_EQ(meta["style"]["files"][0]["path"], "c.obj");
}

// `lines` and `hatch` take a scene (issue 17, item 3).
TEST(SceneCommands, LinesDrawsRendersLayersAndHatchHatchesTheFocus) {
  const fs::path root = scene_folder("scene-commands");
  const std::string scene = (root / "s.json").string();
  auto run = [&](std::vector<std::string> args) { return run_fabrica(args, root / "log"); };
  ASSERT_EQ(
      run({"lines", scene, "--size", "160x120", "--quiet", "-o", (root / "l.svg").string()}).code,
      0);
  ASSERT_EQ(run({"render", scene, "--size", "160x120", "--quiet", "-o", (root / "r.png").string(),
                 "--svg", (root / "r.svg").string()})
                .code,
            0);
  EXPECT_EQ(read_text(root / "l.svg"), read_text(root / "r.svg"));
  const std::string svg = read_text(root / "l.svg");
  EXPECT_NE(svg.find("inkscape:label=\"b\""), std::string::npos);
  EXPECT_NE(svg.find("inkscape:label=\"c\""), std::string::npos);
  // Options of a single mesh's drawing, and outputs of one mesh's lines, are refused.
  auto refused = [&](std::vector<std::string> args, const std::string& says) {
    const auto r = run(args);
    EXPECT_EQ(r.code, 2) << r.log;
    EXPECT_NE(r.log.find(says), std::string::npos) << r.log;
  };
  refused({"lines", scene, "-o", (root / "l.seg").string()}, ".svg or .pdf");
  refused({"lines", scene, "--ridge-threshold", "0.2", "-o", (root / "x.svg").string()},
          "--ridge-threshold: only for a mesh input");

  // hatch: the focus (b) by default; "hatching" picks other structures.
  auto strokes = [&](const std::string& log) {
    const auto at = log.find(" strokes (");
    return at == std::string::npos ? -1 : std::stoi(log.substr(log.rfind(' ', at - 1) + 1));
  };
  const auto focus = run({"hatch", scene, "--size", "160x120", "-o", (root / "h.svg").string()});
  ASSERT_EQ(focus.code, 0) << focus.log;
  EXPECT_GT(strokes(focus.log), 0) << focus.log;
  const std::string hsvg = read_text(root / "h.svg");
  EXPECT_NE(hsvg.find("class=\"lines-b\""), std::string::npos);
  EXPECT_NE(hsvg.find("class=\"lines-c\""), std::string::npos);
  // The focus's strokes alone are those of hatching the focus mesh with the scene's camera.
  ASSERT_EQ(run({"render", scene, "--size", "160x120", "--quiet", "-o", (root / "c.png").string(),
                 "--save-camera", (root / "scene-cam.json").string()})
                .code,
            0);
  const auto alone = run({"hatch", (root / "b.obj").string(), "--camera",
                          (root / "scene-cam.json").string(), "-o", (root / "b.svg").string()});
  ASSERT_EQ(alone.code, 0) << alone.log;
  EXPECT_EQ(strokes(alone.log), strokes(focus.log));
  json s = read_json(root / "s.json");
  s["structures"][0]["hatching"] = false;
  s["structures"][1]["hatching"] = true;
  write_text(root / "s2.json", s.dump());
  const auto context = run({"hatch", (root / "s2.json").string(), "--size", "160x120", "-o",
                            (root / "h2.svg").string()});
  ASSERT_EQ(context.code, 0) << context.log;
  EXPECT_NE(strokes(context.log), strokes(focus.log));
  s["structures"][1]["hatching"] = false;
  write_text(root / "s3.json", s.dump());
  refused({"hatch", (root / "s3.json").string(), "-o", (root / "h3.svg").string()},
          "no structure to hatch");
  const auto png =
      run({"hatch", scene, "--size", "160x120", "--quiet", "-o", (root / "h.png").string()});
  EXPECT_EQ(png.code, 0) << png.log;
  EXPECT_TRUE(fs::exists(root / "h.png"));
}

// --view with --size frames for the requested size in every command (issue
// 16): a tall picture's view stands back by sin(half_v) / sin(half_h), with
// tan(half_h) = tan(half_v) * width / height (anatomical_camera).
TEST(SceneCommands, ViewsAreFramedAtTheRequestedSize) {
  const fs::path root = scene_folder("framing");
  auto distance = [&](const std::string& size, const std::string& command) {
    const fs::path cam = root / (command + size + ".json");
    std::vector<std::string> args = {
        command, (root / "a.obj").string(), "--view", "anterior", "--size", size, "--quiet"};
    if (command == "lines") {
      args.insert(args.end(), {"-o", cam.string()});
    } else {
      args.insert(args.end(), {"-o", (root / "x.png").string(), "--save-camera", cam.string()});
    }
    const auto r = run_fabrica(args, root / "log");
    EXPECT_EQ(r.code, 0) << r.log;
    const json j = read_json(cam);
    return (vec(j["eye"]) - vec(j["center"])).norm();
  };
  const double half_v = 15.0 * M_PI / 180.0, half_h = std::atan(std::tan(half_v) * 0.5);
  for (const char* command : {"lines", "render"}) {
    const double square = distance("100x100", command), tall = distance("100x200", command);
    EXPECT_NEAR(tall / square, std::sin(half_v) / std::sin(half_h), 1e-9) << command;
    EXPECT_NEAR(distance("200x100", command), square, 1e-9 * square) << command;
  }
}
