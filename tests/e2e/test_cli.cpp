// End-to-end tests of the `fabrica` executable: runs the built program (path
// in FABRICA_EXE) as a child process and checks exit codes (docs/cli.md:
// 0 ok, 1 internal, 2 bad input, 3 output not writable, 4 facility
// unavailable, 5 batch partly failed), one-line error messages naming the
// file, atomic outputs (no partial or temporary file left), the geometry CSV
// (complete, finite, in file vertex order), `info --json`, `extract` on a real
// label volume, the drawing commands, and that README / scripts/run only use
// commands that exist. Only the sub-commands compiled in are tested
// (FABRICA_E2E_COMMANDS, from the cmd_*.cpp files present).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <pugixml.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bad_meshes.hpp"
#include "test_support.hpp"

extern char** environ;

namespace fs = std::filesystem;
using namespace fabrica;

namespace {

// ---------------------------------------------------------------- helpers

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(s);
  while (std::getline(in, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

/// The sub-commands compiled into this build of fabrica.
const std::vector<std::string>& present_commands() {
  static const std::vector<std::string> commands = split(FABRICA_E2E_COMMANDS, ',');
  return commands;
}

bool has_command(const std::string& name) {
  const auto& c = present_commands();
  return std::find(c.begin(), c.end(), name) != c.end();
}

/// Of `wanted`, those compiled in (at least one entry so that parameterised
/// suites always instantiate; "none" marks an empty list and is skipped).
std::vector<std::string> present_of(const std::vector<std::string>& wanted) {
  std::vector<std::string> out;
  for (const auto& w : wanted)
    if (has_command(w)) out.push_back(w);
  if (out.empty()) out.push_back("none");
  return out;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// One folder per test process under the system temp folder, removed at exit:
/// work folders for the tests, captured output, and XDG_CACHE_HOME.
struct ProcessTemp {
  fs::path root = test::temp_dir("e2e-" + std::to_string(::getpid()));
  ProcessTemp() {
    fs::create_directories(root / "logs");
    fs::create_directories(root / "cache");
  }
  ~ProcessTemp() {
    std::error_code ec;
    fs::remove_all(root, ec);
  }
};

ProcessTemp& process_temp() {
  static ProcessTemp t;
  return t;
}

/// A fresh empty folder for the current test.
fs::path work_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "." + info->name();
  std::replace(name.begin(), name.end(), '/', '_');
  const fs::path dir = process_temp().root / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct Outcome {
  int code = -1;  ///< exit status, or 128 + signal number when killed by a signal
  std::string out, err;
  std::string command;
};

std::string describe(const Outcome& r) {
  return "command: " + r.command + "\nexit " + std::to_string(r.code) + "\nstderr:\n" + r.err +
         "stdout (first 2000 chars):\n" + r.out.substr(0, 2000);
}

/// Runs `program` with `args`; stdin is /dev/null, stdout and stderr
/// captured, XDG_CACHE_HOME set to a private folder. Killed after `timeout`.
Outcome run_program(const std::string& program, const std::vector<std::string>& args,
                    std::chrono::seconds timeout = std::chrono::seconds(60)) {
  static int counter = 0;
  const int n = counter++;
  const fs::path out_path = process_temp().root / "logs" / ("out-" + std::to_string(n));
  const fs::path err_path = process_temp().root / "logs" / ("err-" + std::to_string(n));
  Outcome r;
  r.command = program;
  for (const auto& a : args) r.command += " '" + a + "'";

  std::vector<std::string> argv_s{program};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);

  std::vector<std::string> env_s;
  for (char** e = environ; *e != nullptr; ++e)
    if (std::strncmp(*e, "XDG_CACHE_HOME=", 15) != 0) env_s.emplace_back(*e);
  env_s.push_back("XDG_CACHE_HOME=" + (process_temp().root / "cache").string());
  std::vector<char*> envp;
  for (auto& e : env_s) envp.push_back(e.data());
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  pid_t pid = 0;
  const int spawned =
      posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    ADD_FAILURE() << "cannot start " << program << ": " << std::strerror(spawned);
    return r;
  }
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  for (;;) {
    const pid_t w = ::waitpid(pid, &status, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) {
      ADD_FAILURE() << "waitpid failed: " << std::strerror(errno);
      return r;
    }
    if (std::chrono::steady_clock::now() - start > timeout) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      ADD_FAILURE() << "timed out after " << timeout.count() << " s: " << r.command;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = read_text(out_path);
  r.err = read_text(err_path);
  return r;
}

Outcome run_fabrica(const std::vector<std::string>& args,
                    std::chrono::seconds timeout = std::chrono::seconds(60)) {
  return run_program(FABRICA_EXE, args, timeout);
}

/// Exactly one non-empty line, ending in a newline.
bool one_line(const std::string& s) {
  return s.size() > 1 && s.back() == '\n' && std::count(s.begin(), s.end(), '\n') == 1;
}

/// Names of the entries of a folder (sorted).
std::vector<std::string> list_dir(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// Entries that look like a temporary file left by write_file_atomically.
std::vector<std::string> temporaries(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& name : list_dir(dir))
    if (name.find(".tmp-") != std::string::npos || name.find(".tmp") == name.size() - 4)
      out.push_back(name);
  return out;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

fs::path aneurysm() {
  return test::bundled_data() / "meshes" / "anatomy" / "vessels" / "sofa_aneurysm3D_1.off";
}

fs::path totalseg() {
  return test::bundled_data() / "meshes" / "volumes" / "totalseg_example_seg.nii.gz";
}

/// The output file extension a command writes with -o.
std::string output_extension(const std::string& command) {
  if (command == "info") return ".off";
  if (command == "geometry") return ".csv";
  if (command == "render") return ".png";
  return ".svg";  // lines, hatch
}

/// Arguments running `command` on `mesh`, writing `output` (empty: info
/// without -o). Drawing commands get --view anterior.
std::vector<std::string> mesh_command_args(const std::string& command, const fs::path& mesh,
                                           const fs::path& output) {
  std::vector<std::string> args{command, mesh.string()};
  if (!output.empty()) {
    args.push_back("-o");
    args.push_back(output.string());
  }
  if (command == "lines" || command == "render" || command == "hatch") {
    args.push_back("--view");
    args.push_back("anterior");
  }
  return args;
}

// Mesh commands (take a mesh file as their input).
const std::vector<std::string> kMeshCommands{"info", "geometry", "lines", "render", "hatch"};
// Commands with a file output given by -o.
const std::vector<std::string> kOutputCommands{"info", "geometry", "lines", "render", "hatch"};
// Drawing commands (--view, --camera).
const std::vector<std::string> kDrawingCommands{"lines", "render", "hatch"};

#define SKIP_IF_NONE(cmd)                                               \
  if ((cmd) == "none") GTEST_SKIP() << "no such command in this build"; \
  static_assert(true)

using test::bad_mesh;
using test::bad_mesh_names;
using test::BadMesh;
using test::kTetraObj;
using test::png_bytes;

// ============================================================ the program

TEST(Cli, NoCommandExits2WithUsage) {
  const Outcome r = run_fabrica({});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_NE((r.err + r.out).find("Usage"), std::string::npos) << describe(r);
  for (const auto& c : present_commands())
    EXPECT_NE((r.err + r.out).find(c), std::string::npos) << "usage does not list " << c;
}

TEST(Cli, HelpListsEveryCompiledCommand) {
  const Outcome r = run_fabrica({"--help"});
  ASSERT_EQ(r.code, 0) << describe(r);
  ASSERT_FALSE(present_commands().empty());
  for (const auto& c : present_commands())
    EXPECT_TRUE(std::regex_search(r.out, std::regex("\\n\\s+" + c + "\\s")))
        << c << " missing from --help:\n"
        << r.out;
}

TEST(Cli, VersionExits0) {
  const Outcome r = run_fabrica({"--version"});
  EXPECT_EQ(r.code, 0) << describe(r);
  EXPECT_NE(r.out.find("fabrica"), std::string::npos) << describe(r);
}

TEST(Cli, UnknownCommandExits2) {
  const Outcome r = run_fabrica({"frobnicate", "x.off"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_FALSE(r.err.empty());
}

// ------------------------------------------------------- every command

class EveryCommand : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryCommand, HelpExits0AndNamesMainOptions) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const Outcome r = run_fabrica({cmd, "--help"});
  ASSERT_EQ(r.code, 0) << describe(r);
  std::vector<std::string> options;
  if (cmd == "info") options = {"--json", "--repair", "--space", "--output"};
  if (cmd == "geometry") options = {"--output", "--normals", "--smooth"};
  if (cmd == "extract") options = {"--output", "--labels", "--smooth", "--format"};
  if (cmd == "lines") options = {"--output", "--camera", "--view", "--types"};
  if (cmd == "render") options = {"--output", "--camera", "--view", "--style"};
  if (cmd == "hatch") options = {"--output", "--camera", "--view", "--light"};
  for (const auto& o : options)
    EXPECT_NE(r.out.find(o), std::string::npos) << cmd << " --help does not mention " << o;
}

TEST_P(EveryCommand, UnknownOptionExits2) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const Outcome r =
      run_fabrica({cmd, aneurysm().string(), "-o", (dir / "x.out").string(), "--no-such-option"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_NE(r.err.find("--no-such-option"), std::string::npos) << describe(r);
  EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
}

TEST_P(EveryCommand, MissingArgumentsExit2) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const Outcome r = run_fabrica({cmd});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_FALSE(r.err.empty());
}

INSTANTIATE_TEST_SUITE_P(Present, EveryCommand, ::testing::ValuesIn(present_commands()),
                         [](const auto& info) { return info.param; });

// ------------------------------------------------------------ bad inputs

using BadInputParam = std::tuple<std::string, std::string>;  // command, case
class BadInput : public ::testing::TestWithParam<BadInputParam> {};

TEST_P(BadInput, Exits2WithOneLineNamingTheFile) {
  const auto& [cmd, case_name] = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const fs::path in_dir = dir / "in", out_dir = dir / "out";
  fs::create_directories(in_dir);
  fs::create_directories(out_dir);
  const fs::path mesh = bad_mesh(case_name).make(in_dir);
  const fs::path output = cmd == "info" ? fs::path() : out_dir / ("result" + output_extension(cmd));
  const Outcome r = run_fabrica(mesh_command_args(cmd, mesh, output));
  EXPECT_LT(r.code, 128) << "killed by a signal\n" << describe(r);
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << "expected one line on stderr\n" << describe(r);
  EXPECT_NE(r.err.find(mesh.string()), std::string::npos)
      << "the message does not name " << mesh << "\n"
      << describe(r);
  EXPECT_TRUE(list_dir(out_dir).empty()) << "left behind: " << joined(list_dir(out_dir));
  EXPECT_TRUE(temporaries(in_dir).empty()) << joined(temporaries(in_dir));
  EXPECT_TRUE(r.out.empty()) << "nothing (no partial report) on stdout\n" << describe(r);
}

INSTANTIATE_TEST_SUITE_P(Meshes, BadInput,
                         ::testing::Combine(::testing::ValuesIn(present_of(kMeshCommands)),
                                            ::testing::ValuesIn(bad_mesh_names())),
                         [](const auto& info) {
                           return std::get<0>(info.param) + "_" + std::get<1>(info.param);
                         });

// Every malformed-file kind as an input of one batch, beside a good mesh: the
// batch goes past each bad item (failed, with the reader's one-line reason
// naming the file), makes the good one, writes nothing for the bad ones and
// exits 5 — never a signal, never a hang (a FIFO among the inputs).
TEST(BadInputBatch, EveryBadMeshIsAFailedItemWithTheReasonAndTheGoodOneIsMade) {
  if (!has_command("batch")) GTEST_SKIP() << "no batch command in this build";
  const fs::path dir = work_dir();
  const fs::path in_dir = dir / "in", out_dir = dir / "out";
  nlohmann::json inputs = nlohmann::json::array();
  std::vector<fs::path> bad;
  for (const auto& name : bad_mesh_names()) {
    const fs::path case_dir = in_dir / name;  // one folder each: some cases share file names
    fs::create_directories(case_dir);
    bad.push_back(bad_mesh(name).make(case_dir));
    inputs.push_back({{"mesh", fs::relative(bad.back(), dir).string()}});
  }
  write_bytes(dir / "good.obj", kTetraObj);
  inputs.push_back({{"mesh", "good.obj"}});
  const nlohmann::json manifest{
      {"inputs", inputs},
      {"views", {"anterior"}},
      {"styles",
       {{{"name", "l"}, {"command", "lines"}, {"types", {"contour"}}, {"formats", {"svg"}}}}},
      {"size", {64, 64}},
      {"output", "{index}-{style}.{ext}"}};
  write_bytes(dir / "manifest.json", manifest.dump(2));
  const Outcome r = run_fabrica(
      {"batch", (dir / "manifest.json").string(), "-o", out_dir.string(), "--jobs", "2", "--quiet"},
      std::chrono::seconds(300));
  ASSERT_LT(r.code, 128) << "killed by a signal\n" << describe(r);
  ASSERT_EQ(r.code, 5) << describe(r);
  const auto report = nlohmann::json::parse(read_text(out_dir / "batch-report.json"));
  ASSERT_EQ(report["items"].size(), bad.size() + 1);
  EXPECT_EQ(report["summary"]["failed"], bad.size());
  EXPECT_EQ(report["summary"]["made"], 1);
  for (std::size_t k = 0; k < report["items"].size(); ++k) {
    const auto& item = report["items"][k];
    if (k == bad.size()) {
      EXPECT_EQ(item["status"], "made") << item.dump();
      continue;
    }
    EXPECT_EQ(item["status"], "failed") << item.dump();
    const std::string reason = item.value("reason", "");
    EXPECT_NE(reason.find(bad[k].filename().string()), std::string::npos)
        << "the reason does not name the file\n"
        << item.dump();
    EXPECT_EQ(reason.find('\n'), std::string::npos) << item.dump();
    for (const auto& o : item["outputs"])
      EXPECT_FALSE(fs::exists(out_dir / o.get<std::string>())) << o;
  }
}

// ------------------------------------------------------ awkward meshes
// Valid files with defects the commands must survive (exit 0, finite output).

const std::vector<std::pair<std::string, std::string>>& awkward_meshes() {
  static const std::vector<std::pair<std::string, std::string>> cases{
      {"nonmanifold_edge",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n"},
      {"bowtie_vertex",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv -1 0 0\nv 0 -1 0\nv 0 0 -1\n"
       "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 5 6\nf 1 7 5\nf 1 6 7\nf 5 7 6\n"},
      {"duplicate_faces_unreferenced_vertex",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 5 5 5\n"
       "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 2 3 4\nf 4 3 2\n"},
      {"inconsistent_orientation",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 4 2\nf 1 4 3\nf 2 3 4\n"},
      {"all_degenerate", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\nf 1 3 4\n"},
      {"single_triangle", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"},
      {"tiny_coordinates",
       "v 0 0 0\nv 1e-300 0 0\nv 0 1e-300 0\nv 0 0 1e-300\n"
       "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"},
      // A face with a repeated vertex (read out of bounds in hatching's
      // intensity ridges before issue 15), slivers, coincident vertices, an
      // open surface, many components.
      {"repeated_vertex_face",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 1 2\n"},
      {"slivers",
       "v 0 0 0\nv 1 0 0\nv 0.5 1e-9 0\nv 0.5 0.5 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"},
      {"coincident_vertices",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 0 0\nv 0 1 0\n"
       "f 1 3 2\nf 1 5 4\nf 1 4 6\nf 2 3 4\n"},
      {"open_surface", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.2\nf 1 2 3\nf 2 4 3\n"},
      {"many_components",
       "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 3 0 0\nv 4 0 0\nv 3 1 0\nv 3 0 1\n"
       "v 6 0 0\nv 7 0 0\nv 6 1 0\nv 6 0 1\n"
       "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 5 7 6\nf 5 6 8\nf 5 8 7\nf 6 7 8\n"
       "f 9 11 10\nf 9 10 12\nf 9 12 11\nf 10 11 12\n"},
  };
  return cases;
}

std::vector<std::string> awkward_names() {
  std::vector<std::string> names;
  for (const auto& c : awkward_meshes()) names.push_back(c.first);
  return names;
}

using AwkwardParam = std::tuple<std::string, std::string>;  // command, case
class Awkward : public ::testing::TestWithParam<AwkwardParam> {};

TEST_P(Awkward, SucceedsWithACompleteFiniteOutput) {
  const auto& [cmd, case_name] = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  std::string text;
  for (const auto& c : awkward_meshes())
    if (c.first == case_name) text = c.second;
  const fs::path mesh = dir / (case_name + ".obj");
  write_bytes(mesh, text);
  const fs::path output = cmd == "info" ? fs::path() : dir / ("result" + output_extension(cmd));
  const Outcome r = run_fabrica(mesh_command_args(cmd, mesh, output));
  if (cmd == "render" && r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  if (output.empty()) return;
  ASSERT_TRUE(fs::exists(output));
  EXPECT_TRUE(temporaries(dir).empty()) << joined(temporaries(dir));
  const std::string data = read_text(output);
  if (cmd == "geometry") {
    const auto lines = split(data, '\n');
    const std::size_t nv = static_cast<std::size_t>(std::count(text.begin(), text.end(), 'v'));
    EXPECT_EQ(lines.size(), nv + 1) << data;
  }
  if (output.extension() != ".png") {
    for (const char* bad : {"nan", "inf", "NaN", "Inf"})
      EXPECT_EQ(data.find(bad), std::string::npos) << bad << " in " << output << ":\n"
                                                   << data.substr(0, 3000);
  }
}

INSTANTIATE_TEST_SUITE_P(Meshes, Awkward,
                         ::testing::Combine(::testing::ValuesIn(present_of(kMeshCommands)),
                                            ::testing::ValuesIn(awkward_names())),
                         [](const auto& info) {
                           return std::get<0>(info.param) + "_" + std::get<1>(info.param);
                         });

TEST(Paths, SpacesAndNonAsciiCharacters) {
  if (!has_command("geometry")) GTEST_SKIP() << "no geometry command in this build";
  const fs::path dir = work_dir() / "a folder \xc3\xa9";
  fs::create_directories(dir);
  const fs::path mesh = dir / "my mesh \xc3\xa9.off";
  fs::copy_file(aneurysm(), mesh);
  const fs::path csv = dir / "out put \xc3\xa9.csv";
  const Outcome r = run_fabrica({"geometry", mesh.string(), "-o", csv.string()});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(split(read_text(csv), '\n').size(), 7096u);
  fs::remove(mesh);
  const Outcome missing = run_fabrica({"geometry", mesh.string(), "-o", csv.string()});
  EXPECT_EQ(missing.code, 2) << describe(missing);
  EXPECT_NE(missing.err.find(mesh.string()), std::string::npos) << describe(missing);
}

// ------------------------------------------------------------ outputs

class Outputs : public ::testing::TestWithParam<std::string> {};

TEST_P(Outputs, MissingOutputFolderExits3AndLeavesNothing) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const fs::path output = dir / "missing" / "deeper" / ("result" + output_extension(cmd));
  const Outcome r = run_fabrica(mesh_command_args(cmd, aneurysm(), output));
  if (cmd == "render" && r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  EXPECT_EQ(r.code, 3) << describe(r);
  EXPECT_NE(r.err.find("missing"), std::string::npos) << "message does not name the output\n"
                                                      << describe(r);
  EXPECT_FALSE(fs::exists(dir / "missing"));
  EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
}

TEST_P(Outputs, FailedRunLeavesAnExistingTargetUntouched) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const fs::path bad = dir / "bad.obj";
  write_bytes(bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n");
  const fs::path output = dir / ("result" + output_extension(cmd));
  write_bytes(output, "previous contents\n");
  const Outcome r = run_fabrica(mesh_command_args(cmd, bad, output));
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_EQ(read_text(output), "previous contents\n");
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"bad.obj", output.filename().string()}));
}

TEST_P(Outputs, TargetThatIsAFolderExits3WithoutTemporaries) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  if (cmd == "render") GTEST_SKIP() << "needs a GL context; covered by the other commands";
  const fs::path dir = work_dir();
  const fs::path output = dir / ("result" + output_extension(cmd));
  fs::create_directories(output);
  const Outcome r = run_fabrica(mesh_command_args(cmd, aneurysm(), output));
  EXPECT_EQ(r.code, 3) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << describe(r);
  EXPECT_NE(r.err.find(output.filename().string()), std::string::npos) << describe(r);
  EXPECT_EQ(r.err.find("Success"), std::string::npos) << "the reason is lost\n" << describe(r);
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{output.filename().string()}));
  EXPECT_TRUE(fs::is_empty(output));
}

INSTANTIATE_TEST_SUITE_P(Present, Outputs, ::testing::ValuesIn(present_of(kOutputCommands)),
                         [](const auto& info) { return info.param; });

TEST(Outputs, InterruptedWriteLeavesNoTemporary) {
  // SIGTERM while the CSV is being written (a 56 MB file for igea): the
  // process dies by the signal and leaves neither the target nor its temporary.
  if (!has_command("geometry")) GTEST_SKIP() << "no geometry command in this build";
  const fs::path mesh = test::bundled_data() / "meshes" / "classic" / "c3d_igea.ply";
  if (!fs::exists(mesh)) GTEST_SKIP() << "no " << mesh;
  const fs::path dir = work_dir();
  const fs::path csv = dir / "igea.csv";
  std::vector<std::string> argv_s{FABRICA_EXE, "geometry", mesh.string(), "-o", csv.string()};
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, FABRICA_EXE, &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  bool interrupted = false, exited = false;
  int status = 0;
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    if (!temporaries(dir).empty()) {
      ::kill(pid, SIGTERM);
      interrupted = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(300));
  }
  if (!exited) {
    if (!interrupted) ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  if (!interrupted) GTEST_SKIP() << "the write was too quick to interrupt";
  if (WIFEXITED(status)) GTEST_SKIP() << "the write finished before the signal arrived";
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << "status " << status;
  EXPECT_TRUE(list_dir(dir).empty()) << "left behind: " << joined(list_dir(dir));
}

// ------------------------------------------------------------ info

// ============================================================ the VTK module
// fabrica_io loads its VTK parts (.vtp, extraction, smoothing) from
// libfabrica_io_vtk.so on first use (core/io/vtk_module.cmake).
#ifdef FABRICA_E2E_HAVE_VTK_MODULE

/// Sets an environment variable (inherited by run_fabrica) for one scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_, old_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

TEST(VtkModule, TheProgramDoesNotLinkVtk) {
  FILE* pipe = ::popen(("ldd '" + std::string(FABRICA_EXE) + "' 2>/dev/null").c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string libs;
  std::array<char, 512> buf{};
  while (std::fgets(buf.data(), static_cast<int>(buf.size()), pipe) != nullptr) libs += buf.data();
  ::pclose(pipe);
  if (libs.find("libc.so") == std::string::npos) GTEST_SKIP() << "no usable ldd";
  EXPECT_EQ(libs.find("libvtk"), std::string::npos) << libs;
}

TEST(VtkModule, WithoutItOtherFormatsWorkAndVtpIsExitCode4) {
  const fs::path dir = work_dir();
  const ScopedEnv missing("FABRICA_IO_VTK_MODULE", (dir / "libfabrica_io_vtk.so").string());
  const Outcome off = run_fabrica({"info", aneurysm().string(), "-o", (dir / "a.ply").string()});
  ASSERT_EQ(off.code, 0) << describe(off);
  const Outcome ply = run_fabrica(mesh_command_args("lines", dir / "a.ply", dir / "a.svg"));
  EXPECT_EQ(ply.code, 0) << describe(ply);
  EXPECT_TRUE(fs::exists(dir / "a.svg"));
  const fs::path vtp = test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.vtp";
  const Outcome r = run_fabrica({"info", vtp.string()});
  EXPECT_EQ(r.code, 4) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << describe(r);
  EXPECT_NE(r.err.find("libfabrica_io_vtk.so was not found"), std::string::npos) << describe(r);
  EXPECT_NE(r.err.find(vtp.string()), std::string::npos) << describe(r);
}

// Bad extraction options are bad input (exit 2) whether or not the module is
// there: they are checked before it is looked for.
TEST(VtkModule, WithoutItBadExtractOptionsAreStillExitCode2) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const fs::path dir = work_dir();
  const ScopedEnv missing("FABRICA_IO_VTK_MODULE", (dir / "libfabrica_io_vtk.so").string());
  const Outcome r = run_fabrica(
      {"extract", totalseg().string(), "--passband", "5", "-o", (dir / "out").string()});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << describe(r);
  EXPECT_NE(r.err.find("pass band"), std::string::npos) << describe(r);
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// An installed layout (bin/fabrica, lib/fabrica/libfabrica_io_vtk.so)
// anywhere: the module beside the executable's bin folder is the one loaded.
TEST(VtkModule, FoundBesideTheExecutablesBinFolder) {
  const fs::path dir = work_dir();
  const fs::path exe = dir / "bin" / "fabrica";
  const fs::path module =
      (exe.parent_path() / FABRICA_E2E_BIN_TO_MODULE / "libfabrica_io_vtk.so").lexically_normal();
  fs::create_directories(exe.parent_path());
  fs::create_directories(module.parent_path());
  fs::copy_file(FABRICA_EXE, exe);
  fs::copy_file(FABRICA_E2E_VTK_MODULE, module);
  const ScopedEnv debug("LD_DEBUG", "files");
  const fs::path vtp = test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.vtp";
  const Outcome r = run_program(exe.string(), {"info", vtp.string()}, std::chrono::seconds(60));
  EXPECT_EQ(r.code, 0) << describe(r);
  EXPECT_NE(r.err.find("file=" + module.string() + " "), std::string::npos) << describe(r);
}

TEST(VtkModule, WithItVtpIsRead) {
  const fs::path vtp = test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.vtp";
  const Outcome r = run_fabrica({"info", vtp.string()});
  EXPECT_EQ(r.code, 0) << describe(r);
  EXPECT_NE(r.out.find("format          vtp"), std::string::npos) << describe(r);
}

#endif

TEST(Info, JsonReportsTheAneurysm) {
  if (!has_command("info")) GTEST_SKIP() << "no info command in this build";
  const Outcome r = run_fabrica({"info", aneurysm().string(), "--json"});
  ASSERT_EQ(r.code, 0) << describe(r);
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out.substr(0, 2000);
  const auto& v = j.at("validation");
  EXPECT_EQ(v.at("vertices").get<int>(), 7095);
  EXPECT_EQ(v.at("faces").get<int>(), 14186);
  EXPECT_EQ(v.at("components").get<int>(), 1);
  EXPECT_TRUE(v.at("closed").get<bool>());
  EXPECT_EQ(v.at("boundary_edges").get<int>(), 0);
  EXPECT_EQ(v.at("euler_characteristic").get<int>(), 2);  // a sphere: V - E + F = 2
  EXPECT_EQ(j.at("file").at("format").get<std::string>().find("OFF") != std::string::npos ||
                j.at("file").at("format").get<std::string>().find("off") != std::string::npos,
            true)
      << j.at("file").dump();
}

TEST(Info, RepairWritesAReadableMesh) {
  if (!has_command("info")) GTEST_SKIP() << "no info command in this build";
  const fs::path dir = work_dir();
  const Outcome r = run_fabrica({"info", aneurysm().string(), "-o", (dir / "fixed.ply").string()});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"fixed.ply"}));
  const Outcome back = run_fabrica({"info", (dir / "fixed.ply").string(), "--json"});
  ASSERT_EQ(back.code, 0) << describe(back);
  const auto j = nlohmann::json::parse(back.out);
  EXPECT_EQ(j.at("validation").at("vertices").get<int>(), 7095);
  EXPECT_EQ(j.at("validation").at("faces").get<int>(), 14186);
}

// ------------------------------------------------------------ geometry

/// The vertices of an OFF file, parsed here independently of fabrica.
std::vector<std::array<double, 3>> read_off_vertices(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> tokens;
  std::string line;
  std::size_t nv = 0;
  std::vector<std::array<double, 3>> v;
  bool header = false, counts = false;
  while (std::getline(in, line)) {
    if (const auto h = line.find('#'); h != std::string::npos) line.resize(h);
    std::istringstream ls(line);
    if (!header) {
      std::string off;
      if (ls >> off) header = true;
      continue;
    }
    if (!counts) {
      if (ls >> nv) counts = true;
      continue;
    }
    std::array<double, 3> p{};
    std::string tok[3];
    if (!(ls >> tok[0] >> tok[1] >> tok[2])) continue;
    for (int k = 0; k < 3; ++k) p[k] = std::strtod(tok[k].c_str(), nullptr);
    v.push_back(p);
    if (v.size() == nv) break;
  }
  return v;
}

TEST(Geometry, CsvIsCompleteFiniteAndInFileVertexOrder) {
  if (!has_command("geometry")) GTEST_SKIP() << "no geometry command in this build";
  const fs::path dir = work_dir();
  const fs::path csv = dir / "aneurysm.csv";
  const Outcome r = run_fabrica({"geometry", aneurysm().string(), "-o", csv.string()});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"aneurysm.csv"}));

  const auto vertices = read_off_vertices(aneurysm());
  ASSERT_EQ(vertices.size(), 7095u);
  const std::string text = read_text(csv);
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n') << "last row incomplete";
  const auto lines = split(text, '\n');
  ASSERT_EQ(lines.size(), vertices.size() + 1) << "expected a header and one row per vertex";
  const auto header = split(lines[0], ',');
  ASSERT_GE(header.size(), 4u);
  EXPECT_EQ(header[0], "x");
  EXPECT_EQ(header[1], "y");
  EXPECT_EQ(header[2], "z");
  std::size_t bad_numbers = 0, misplaced = 0, wrong_width = 0;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto fields = split(lines[i], ',');
    if (fields.size() != header.size()) {
      ++wrong_width;
      continue;
    }
    for (std::size_t k = 0; k < fields.size(); ++k) {
      double x = 0.0;
      const auto& f = fields[k];
      const auto res = std::from_chars(f.data(), f.data() + f.size(), x);
      if (res.ec != std::errc() || res.ptr != f.data() + f.size() || !std::isfinite(x)) {
        if (bad_numbers++ < 5) ADD_FAILURE() << "row " << i - 1 << " column " << k << ": " << f;
      }
      if (k < 3 && x != vertices[i - 1][k]) {
        if (misplaced++ < 5)
          ADD_FAILURE() << "row " << i - 1 << " column " << header[k] << " is " << f
                        << ", the file's vertex " << i - 1 << " has " << vertices[i - 1][k];
      }
    }
  }
  EXPECT_EQ(wrong_width, 0u);
  EXPECT_EQ(bad_numbers, 0u);
  EXPECT_EQ(misplaced, 0u);
}

// Choice values are case-insensitive (docs/README.md) and mean what their
// lower-case spelling means: `--normals AREA` must weight by area, not fall
// back to the default. An unknown value still exits 2 naming the choices.
TEST(Geometry, ChoiceValuesInAnyCaseMeanTheSame) {
  if (!has_command("geometry")) GTEST_SKIP() << "no geometry command in this build";
  const fs::path dir = work_dir();
  auto csv = [&](const std::string& normals) {
    const fs::path out = dir / ("normals-" + normals + ".csv");
    const Outcome r =
        run_fabrica({"geometry", aneurysm().string(), "--normals", normals, "-o", out.string()});
    EXPECT_EQ(r.code, 0) << describe(r);
    return read_text(out);
  };
  const std::string upper = csv("AREA"), lower = csv("area"), max = csv("max");
  ASSERT_FALSE(lower.empty());
  EXPECT_EQ(upper, lower);
  EXPECT_NE(lower, max) << "area weighting gave the default's normals: the test cannot tell";
  const Outcome bad = run_fabrica(
      {"geometry", aneurysm().string(), "--normals", "Areal", "-o", (dir / "bad.csv").string()});
  EXPECT_EQ(bad.code, 2) << describe(bad);
  EXPECT_NE(bad.err.find("max,area,angle"), std::string::npos) << bad.err;
}

// ------------------------------------------------------------ extract

TEST(Extract, OneReadableMeshPerLabelIntoANewFolder) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const fs::path dir = work_dir();
  const fs::path out = dir / "new" / "surfaces";
  const Outcome r = run_fabrica({"extract", totalseg().string(), "-o", out.string()});
  ASSERT_EQ(r.code, 0) << describe(r);
  ASSERT_TRUE(fs::is_directory(out));
  const auto manifest = nlohmann::json::parse(read_text(out / "surfaces.json"));
  const auto& surfaces = manifest.at("surfaces");
  ASSERT_GE(surfaces.size(), 2u);
  std::set<std::string> files{"surfaces.json", "scene.json"};
  std::set<int> labels;
  for (const auto& s : surfaces) {
    const std::string file = s.at("file").get<std::string>();
    files.insert(file);
    EXPECT_TRUE(labels.insert(s.at("label").get<int>()).second) << "label twice: " << s.dump();
    const Outcome info = run_fabrica({"info", (out / file).string(), "--json"});
    ASSERT_EQ(info.code, 0) << describe(info);
    const auto j = nlohmann::json::parse(info.out);
    EXPECT_EQ(j.at("validation").at("faces").get<std::size_t>(), s.at("faces").get<std::size_t>())
        << file;
    EXPECT_GT(j.at("validation").at("faces").get<std::size_t>(), 0u) << file;
  }
  const auto listed = list_dir(out);
  EXPECT_EQ(std::set<std::string>(listed.begin(), listed.end()), files)
      << "every written mesh in the manifest, nothing else in the folder";
  EXPECT_NE(r.out.find(std::to_string(surfaces.size()) + " surface(s) written"), std::string::npos)
      << r.out;
}

TEST(Extract, BadVolumesExit2NamingTheFile) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const fs::path dir = work_dir();
  const std::string gz = read_text(totalseg());
  ASSERT_GT(gz.size(), 1000u);
  write_bytes(dir / "cut.nii.gz", gz.substr(0, gz.size() / 2));
  write_bytes(dir / "empty.nii", "");
  write_bytes(dir / "picture.nii.gz", png_bytes());
  fs::create_directories(dir / "folder.nii");
  for (const fs::path& volume : {dir / "missing.nii.gz", dir / "cut.nii.gz", dir / "empty.nii",
                                 dir / "picture.nii.gz", dir / "folder.nii"}) {
    const fs::path out = dir / ("out-" + volume.filename().string());
    const Outcome r = run_fabrica({"extract", volume.string(), "-o", out.string()});
    EXPECT_EQ(r.code, 2) << describe(r);
    EXPECT_TRUE(one_line(r.err)) << describe(r);
    EXPECT_NE(r.err.find(volume.string()), std::string::npos) << describe(r);
    EXPECT_FALSE(fs::exists(out)) << "output folder created for a failing run: " << out;
  }
}

TEST(Extract, NoSurfaceExits2AndCreatesNoFolder) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const fs::path dir = work_dir();
  const Outcome r = run_fabrica(
      {"extract", totalseg().string(), "-o", (dir / "organs").string(), "--labels", "999"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << describe(r);
  EXPECT_NE(r.err.find(totalseg().string()), std::string::npos) << describe(r);
  EXPECT_TRUE(list_dir(dir).empty()) << "left behind: " << joined(list_dir(dir));
}

TEST(Extract, OutputUnderARegularFileExits3) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const fs::path dir = work_dir();
  write_bytes(dir / "a_file", "x");
  const Outcome r = run_fabrica(
      {"extract", totalseg().string(), "-o", (dir / "a_file" / "sub").string(), "--labels", "5"});
  EXPECT_EQ(r.code, 3) << describe(r);
  EXPECT_NE(r.err.find("a_file"), std::string::npos) << describe(r);
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{"a_file"}));
}

// ------------------------------------------------------------ drawings

class Drawing : public ::testing::TestWithParam<std::string> {};

TEST_P(Drawing, AnteriorViewWritesACompleteFile) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const fs::path output = dir / ("aneurysm" + output_extension(cmd));
  const Outcome r = run_fabrica(mesh_command_args(cmd, aneurysm(), output));
  if (cmd == "render" && r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(list_dir(dir), (std::vector<std::string>{output.filename().string()}));
  const std::string data = read_text(output);
  ASSERT_GT(data.size(), 1000u);
  if (output.extension() == ".png") {
    EXPECT_EQ(data.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(data.substr(data.size() - 8, 4), "IEND") << "PNG not complete";
  } else {
    EXPECT_NE(data.find("<svg"), std::string::npos);
    const auto end = data.find_last_not_of(" \r\n\t");
    ASSERT_NE(end, std::string::npos);
    EXPECT_EQ(data.substr(end - 5, 6), "</svg>") << "SVG not complete";
    EXPECT_TRUE(data.find("<path") != std::string::npos ||
                data.find("<polyline") != std::string::npos)
        << "no strokes in the SVG";
  }
}

TEST_P(Drawing, BadCameraFileExits2) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const fs::path out_dir = dir / "out";
  fs::create_directories(out_dir);
  write_bytes(dir / "broken.json", "{ \"eye\": [0, 0, ");
  write_bytes(dir / "same.json", R"({"eye": [1, 2, 3], "center": [1, 2, 3], "up": [0, 0, 1]})");
  write_bytes(dir / "words.json", R"({"eye": "front", "center": [0, 0, 0]})");
  // Issue 15: a field of view so narrow that image-space work explodes, an
  // image larger than any command draws, a camera that is not a file.
  write_bytes(dir / "narrow.json",
              R"({"eye": [0, 0, 100], "center": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 1e-9})");
  write_bytes(dir / "huge.json", R"({"eye": [0, 0, 100], "center": [0, 0, 0], "up": [0, 1, 0],
                                     "width": 100000, "height": 100000})");
  ::mkfifo((dir / "fifo.json").c_str(), 0644);
  for (const fs::path& camera :
       {dir / "broken.json", dir / "same.json", dir / "words.json", dir / "missing.json",
        dir / "narrow.json", dir / "huge.json", dir / "fifo.json"}) {
    const Outcome r = run_fabrica({cmd, aneurysm().string(), "-o",
                                   (out_dir / ("x" + output_extension(cmd))).string(), "--camera",
                                   camera.string()});
    EXPECT_EQ(r.code, 2) << describe(r);
    EXPECT_TRUE(one_line(r.err)) << describe(r);
    EXPECT_NE(r.err.find(camera.filename().string()), std::string::npos) << describe(r);
    EXPECT_TRUE(list_dir(out_dir).empty()) << joined(list_dir(out_dir));
  }
}

TEST_P(Drawing, UnknownViewExits2) {
  const std::string cmd = GetParam();
  SKIP_IF_NONE(cmd);
  const fs::path dir = work_dir();
  const Outcome r =
      run_fabrica({cmd, aneurysm().string(), "-o", (dir / ("x" + output_extension(cmd))).string(),
                   "--view", "sideways"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << describe(r);
  EXPECT_NE(r.err.find("sideways"), std::string::npos) << describe(r);
  EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
}

TEST(Lines, SegCountsMatchItsHeaderAndItsHeaderIsACamera) {
  if (!has_command("lines")) GTEST_SKIP() << "no lines command in this build";
  const fs::path dir = work_dir();
  const fs::path seg = dir / "all.seg";
  const Outcome r = run_fabrica({"lines", aneurysm().string(), "-o", seg.string(), "--view", "left",
                                 "--types", "all", "--no-visibility", "-q"});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_TRUE(r.err.empty()) << "-q prints nothing\n" << describe(r);
  const auto lines = split(read_text(seg), '\n');
  ASSERT_GE(lines.size(), 2u);
  ASSERT_EQ(lines[0].rfind("# {", 0), 0u) << lines[0].substr(0, 200);
  const auto header = nlohmann::json::parse(lines[0].substr(2));
  EXPECT_EQ(header.at("nv").get<int>(), 7095);
  EXPECT_EQ(header.at("nf").get<int>(), 14186);
  std::map<std::string, std::size_t> counted;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    std::istringstream in(lines[i]);
    std::string type;
    double c[6];
    ASSERT_TRUE(in >> type >> c[0] >> c[1] >> c[2] >> c[3] >> c[4] >> c[5]) << lines[i];
    for (double x : c) ASSERT_TRUE(std::isfinite(x)) << lines[i];
    ++counted[type];
  }
  std::size_t total = 0;
  for (const auto& [type, n] : header.at("segments").items()) {
    EXPECT_EQ(counted[type], n.get<std::size_t>()) << type;
    total += n.get<std::size_t>();
  }
  EXPECT_EQ(total, lines.size() - 1);
  EXPECT_GT(total, 1000u);

  // The .seg header is a camera file: the same view again, the same segments.
  const fs::path again = dir / "again.seg";
  const Outcome r2 = run_fabrica({"lines", aneurysm().string(), "-o", again.string(), "--camera",
                                  seg.string(), "--types", "all", "--no-visibility", "-q"});
  ASSERT_EQ(r2.code, 0) << describe(r2);
  const auto lines2 = split(read_text(again), '\n');
  EXPECT_TRUE(std::equal(lines.begin() + 1, lines.end(), lines2.begin() + 1, lines2.end()))
      << "a camera read from a .seg header differs from the view that wrote it";

  const fs::path json = dir / "lines.json";
  const Outcome r3 = run_fabrica({"lines", aneurysm().string(), "-o", json.string(), "-q"});
  ASSERT_EQ(r3.code, 0) << describe(r3);
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(read_text(json)));
  EXPECT_EQ(j.at("nv").get<int>(), 7095);
  EXPECT_FALSE(j.at("polylines").empty());
}

TEST(Lines, SmoothWritesACompleteSvgAndShorterLinesOnTheSameCount) {
  if (!has_command("lines")) GTEST_SKIP() << "no lines command in this build";
  const fs::path dir = work_dir();
  const fs::path svg = dir / "smooth.svg";
  const Outcome r = run_fabrica({"lines", aneurysm().string(), "-o", svg.string(), "--smooth", "5",
                                 "--types", "contour,suggestive,ridge,valley,apparent", "-q"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const std::string data = read_text(svg);
  EXPECT_EQ(data.rfind("<?xml", 0) == 0 || data.rfind("<svg", 0) == 0, true) << data.substr(0, 80);
  const auto end = data.find_last_not_of(" \r\n\t");
  ASSERT_NE(end, std::string::npos);
  EXPECT_EQ(data.substr(end - 5, 6), "</svg>") << "SVG not complete";
  EXPECT_NE(data.find("<path"), std::string::npos) << "no strokes in the SVG";
  EXPECT_EQ(data.find("nan"), std::string::npos);

  // JSON without visibility: the same polylines, each no longer, header says so.
  auto lengths = [&](const std::string& smooth) {
    const fs::path json = dir / ("s" + smooth + ".json");
    const Outcome o = run_fabrica({"lines", aneurysm().string(), "-o", json.string(), "--smooth",
                                   smooth, "--no-visibility", "-q"});
    EXPECT_EQ(o.code, 0) << describe(o);
    const auto j = nlohmann::json::parse(read_text(json));
    EXPECT_EQ(j.contains("smooth"), smooth != "0");
    std::vector<double> out;
    for (const auto& pl : j.at("polylines")) {
      double sum = 0.0;
      const auto& v = pl.at("vertices");
      const std::size_t n = v.size(), segs = pl.at("closed").get<bool>() ? n : n - 1;
      for (std::size_t i = 0; i < segs; ++i) {
        double d2 = 0.0;
        for (int k = 0; k < 3; ++k) {
          const double d =
              v[(i + 1) % n].at("position")[k].get<double>() - v[i].at("position")[k].get<double>();
          d2 += d * d;
        }
        sum += std::sqrt(d2);
      }
      out.push_back(sum);
    }
    return out;
  };
  const auto plain = lengths("0"), smoothed = lengths("5");
  ASSERT_EQ(plain.size(), smoothed.size());
  ASSERT_FALSE(plain.empty());
  double a = 0.0, b = 0.0;
  for (std::size_t i = 0; i < plain.size(); ++i) {
    EXPECT_LE(smoothed[i], plain[i] * (1.0 + 1e-9)) << "polyline " << i;
    a += plain[i];
    b += smoothed[i];
  }
  EXPECT_LT(b, a);

  const Outcome bad =
      run_fabrica({"lines", aneurysm().string(), "-o", (dir / "x.svg").string(), "--smooth", "-2"});
  EXPECT_EQ(bad.code, 2) << describe(bad);
  EXPECT_NE(bad.err.find("--smooth"), std::string::npos) << describe(bad);
  EXPECT_FALSE(fs::exists(dir / "x.svg"));
}

TEST(Render, SceneSvgKeepsAGroupPerStructure) {
  // issue 17, item 4: the bundled focus-and-context scene as a layered SVG
  // (and PDF): a group per structure in its line colour, focus over context.
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path scene = fs::path(FABRICA_SOURCE_DIR) / "data" / "aneurysm-scene.json";
  const fs::path dir = work_dir();
  std::vector<std::string> args = {"render", scene.string(), "-o",    (dir / "a.png").string(),
                                   "--size", "200x160",      "--svg", (dir / "a.svg").string(),
                                   "-q"};
  const Outcome r = run_fabrica(args);
  if (r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_file((dir / "a.svg").c_str()));
  std::vector<std::array<std::string, 3>> groups;  // label, role, stroke
  for (pugi::xml_node g : doc.child("svg").children("g")) {
    groups.push_back({g.attribute("inkscape:label").value(), g.attribute("data-role").value(),
                      g.attribute("stroke").value()});
    std::set<std::string> families;
    for (pugi::xml_node f : g.children("g")) {
      families.insert(f.attribute("data-family").value());
      EXPECT_FALSE(f.child("path").empty()) << groups.back()[0];
    }
    EXPECT_TRUE(families.count("contour")) << groups.back()[0];
    if (groups.back()[1] == "context") {
      EXPECT_EQ(families.size(), 1u);  // "lines": ["contour"]
    }
  }
  // data/aneurysm-scene.json: the context wall (line_color 0.25 0.3 0.4, alpha 0.5) first,
  // the focus aneurysm (default black lines) drawn over it.
  using G = std::array<std::string, 3>;
  EXPECT_EQ(groups, (std::vector<G>{G{"vessel wall", "context", "#404d66"},
                                    G{"aneurysm", "focus", "#000000"}}));
  EXPECT_EQ(std::string(doc.child("svg").child("g").attribute("stroke-opacity").value()), "0.50");
  // A PDF beside it when this build has cairo, else exit 4 naming cairo and no PNG.
  args.insert(args.end() - 1, {"--pdf", (dir / "b.pdf").string()});
  args[3] = (dir / "b.png").string();
  const Outcome pdf = run_fabrica(args);
  if (pdf.code == 0) {
    EXPECT_EQ(read_text(dir / "b.pdf").rfind("%PDF", 0), 0u);
  } else {
    EXPECT_NE(pdf.err.find("cairo"), std::string::npos) << describe(pdf);
    EXPECT_FALSE(fs::exists(dir / "b.png"));
  }
}

TEST(Render, SmoothFlagAndSceneKey) {
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path dir = work_dir();
  write_bytes(dir / "scene.json", "{\"structures\": [{\"mesh\": \"" + aneurysm().generic_string() +
                                      "\", \"smooth\": 2}]}");
  const Outcome r =
      run_fabrica({"render", (dir / "scene.json").string(), "-o", (dir / "a.png").string(),
                   "--size", "128x128", "--save-scene", (dir / "saved.json").string(), "-q"});
  if (r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  const auto saved = nlohmann::json::parse(read_text(dir / "saved.json"));
  EXPECT_EQ(saved.at("structures").at(0).at("smooth").get<int>(), 2);
  const Outcome flag =
      run_fabrica({"render", aneurysm().string(), "-o", (dir / "b.png").string(), "--size",
                   "128x128", "--smooth", "3", "--svg", (dir / "b.svg").string(), "-q"});
  ASSERT_EQ(flag.code, 0) << describe(flag);
  EXPECT_NE(read_text(dir / "b.svg").find("<path"), std::string::npos);
  write_bytes(dir / "bad.json", "{\"structures\": [{\"mesh\": \"" + aneurysm().generic_string() +
                                    "\", \"smooth\": -1}]}");
  for (const auto& args : {std::vector<std::string>{"render", (dir / "bad.json").string(), "-o",
                                                    (dir / "c.png").string()},
                           std::vector<std::string>{"render", aneurysm().string(), "-o",
                                                    (dir / "c.png").string(), "--smooth", "-1"}}) {
    const Outcome bad = run_fabrica(args);
    EXPECT_EQ(bad.code, 2) << describe(bad);
    EXPECT_NE(bad.err.find("smooth"), std::string::npos) << describe(bad);
    EXPECT_FALSE(fs::exists(dir / "c.png"));
  }
}

// Surface LIC (issue 21, item 2): --lic, its parameters and the scene keys;
// bad values exit 2 with a one-line message naming the option or key.
// `fabrica render` of the aneurysm with each case's extra options exits 2
// with one line containing the case's text.
void expect_bad_render_options(
    const fs::path& dir,
    const std::vector<std::pair<std::vector<std::string>, std::string>>& bad_cases) {
  for (const auto& [extra, needle] : bad_cases) {
    std::vector<std::string> args = {"render", aneurysm().string(), "-o", (dir / "c.png").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    const Outcome bad = run_fabrica(args);
    EXPECT_EQ(bad.code, 2) << describe(bad);
    EXPECT_TRUE(one_line(bad.err)) << describe(bad);
    EXPECT_NE(bad.err.find(needle), std::string::npos) << describe(bad);
  }
}

TEST(Render, LicFlagAndSceneKeys) {
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path dir = work_dir();
  const Outcome r =
      run_fabrica({"render", aneurysm().string(), "-o", (dir / "a.png").string(), "--size",
                   "128x128", "--lic", "--lic-length", "6", "--lic-strength", "0.5", "--save-scene",
                   (dir / "saved.json").string(), "-q"});
  if (r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  const auto saved = nlohmann::json::parse(read_text(dir / "saved.json"));
  EXPECT_TRUE(saved.at("structures").at(0).at("lic").get<bool>());
  EXPECT_EQ(saved.at("lic").at("kernel_length").get<double>(), 6.0);
  EXPECT_EQ(saved.at("lic").at("strength").get<double>(), 0.5);
  const Outcome again =
      run_fabrica({"render", (dir / "saved.json").string(), "-o", (dir / "b.png").string(), "-q"});
  ASSERT_EQ(again.code, 0) << describe(again);
  EXPECT_EQ(read_text(dir / "a.png"), read_text(dir / "b.png")) << "the saved scene re-renders";
  write_bytes(dir / "bad.json", "{\"lic\": {\"kernel_lenght\": 4}, \"structures\": [{\"mesh\": \"" +
                                    aneurysm().generic_string() + "\", \"lic\": true}]}");
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad_cases = {
      {{"--lic", "--lic-strength", "2"}, "--lic-strength"},
      {{"--lic", "--lic-length", "0"}, "--lic-length"},
      {{"--lic", "--lic-noise-scale", "-1"}, "--lic-noise-scale"},
      {{"--lic-length", "4"}, "need --lic"},
      {{"--lic-lenght", "4"}, "--lic-length"}};
  expect_bad_render_options(dir, bad_cases);
  const Outcome key =
      run_fabrica({"render", (dir / "bad.json").string(), "-o", (dir / "c.png").string()});
  EXPECT_EQ(key.code, 2) << describe(key);
  EXPECT_NE(key.err.find("kernel_length"), std::string::npos) << describe(key);
  EXPECT_FALSE(fs::exists(dir / "c.png"));
}

// The cutaway's options (issue 18, item 4): saved into the scene, which
// re-renders to the same picture; bad values exit 2 with one line naming
// the option or key.
TEST(Render, CutawayFlagsAndSceneKeys) {
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path dir = work_dir();
  const Outcome r = run_fabrica({"render", aneurysm().string(), "--context", aneurysm().string(),
                                 "-o", (dir / "a.png").string(), "--size", "128x128", "--cutaway",
                                 "--cutaway-margin", "20", "--cutaway-fade", "0", "--cutaway-rim",
                                 "--save-scene", (dir / "saved.json").string(), "-q"});
  if (r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  const auto saved = nlohmann::json::parse(read_text(dir / "saved.json"));
  EXPECT_TRUE(saved.at("cutaway").at("enabled").get<bool>());
  EXPECT_EQ(saved.at("cutaway").at("margin_px").get<double>(), 20.0);
  EXPECT_EQ(saved.at("cutaway").at("fade_px").get<double>(), 0.0);
  EXPECT_TRUE(saved.at("cutaway").at("rim").get<bool>());
  const Outcome again =
      run_fabrica({"render", (dir / "saved.json").string(), "-o", (dir / "b.png").string(), "-q"});
  ASSERT_EQ(again.code, 0) << describe(again);
  EXPECT_EQ(read_text(dir / "a.png"), read_text(dir / "b.png")) << "the saved scene re-renders";
  write_bytes(dir / "bad.json", "{\"cutaway\": {\"margin\": 4}, \"structures\": [{\"mesh\": \"" +
                                    aneurysm().generic_string() + "\"}]}");
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad_cases = {
      {{"--cutaway", "--cutaway-margin", "-1"}, "--cutaway-margin"},
      {{"--cutaway", "--cutaway-fade", "300"}, "--cutaway-fade"},
      {{"--cutaway", "--cutaway-margin", "wide"}, "--cutaway-margin"},
      {{"--cutaway-margin", "4"}, "need --cutaway"},
      {{"--cutaway-rim"}, "need --cutaway"}};
  expect_bad_render_options(dir, bad_cases);
  const Outcome key =
      run_fabrica({"render", (dir / "bad.json").string(), "-o", (dir / "c.png").string()});
  EXPECT_EQ(key.code, 2) << describe(key);
  EXPECT_NE(key.err.find("cutaway.margin: unknown key (did you mean 'margin_px'"),
            std::string::npos)
      << describe(key);
  EXPECT_FALSE(fs::exists(dir / "c.png"));
}

TEST(Pipeline, ExtractedSurfaceThroughEveryMeshCommand) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const fs::path dir = work_dir();
  const Outcome r = run_fabrica({"extract", totalseg().string(), "-o", (dir / "organs").string(),
                                 "--labels", "2", "--format", "ply", "--space", "ras"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const fs::path kidney = dir / "organs" / "kidney_right.ply";
  ASSERT_TRUE(fs::exists(kidney)) << joined(list_dir(dir / "organs"));
  for (const auto& cmd : kMeshCommands) {
    if (!has_command(cmd)) continue;
    const fs::path output = cmd == "info" ? fs::path() : dir / ("kidney" + output_extension(cmd));
    const Outcome c = run_fabrica(mesh_command_args(cmd, kidney, output));
    if (cmd == "render" && c.code == 4) continue;  // no headless GL here
    EXPECT_EQ(c.code, 0) << describe(c);
    if (!output.empty()) {
      EXPECT_GT(fs::exists(output) ? fs::file_size(output) : 0, 500u) << cmd;
    }
  }
}

TEST(Render, SecondOutputInAMissingFolderWritesNothing) {
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path dir = work_dir();
  const Outcome r = run_fabrica({"render", aneurysm().string(), "-o", (dir / "a.png").string(),
                                 "--svg", (dir / "missing" / "a.svg").string()});
  EXPECT_EQ(r.code, 3) << describe(r);
  EXPECT_TRUE(one_line(r.err)) << describe(r);
  EXPECT_NE(r.err.find("missing"), std::string::npos) << describe(r);
  EXPECT_TRUE(list_dir(dir).empty()) << "left behind: " << joined(list_dir(dir));
}

INSTANTIATE_TEST_SUITE_P(Present, Drawing, ::testing::ValuesIn(present_of(kDrawingCommands)),
                         [](const auto& info) { return info.param; });

// ------------------------------------------------------------ docs in step

/// Commands a script calls as `"$fabrica" CMD`.
std::set<std::string> commands_called_by(const fs::path& script) {
  std::set<std::string> out;
  const std::string text = read_text(script);
  const std::regex call(R"re("\$fabrica"\s+([a-z][a-z0-9_-]*))re");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), call); it != std::sregex_iterator();
       ++it)
    out.insert((*it)[1].str());
  return out;
}

TEST(Docs, EveryCommandScriptsRunCallsExists) {
  const fs::path script = fs::path(FABRICA_SOURCE_DIR) / "scripts" / "run";
  ASSERT_TRUE(fs::exists(script)) << script;
  const auto called = commands_called_by(script);
  ASSERT_FALSE(called.empty()) << "no \"$fabrica\" CMD lines in " << script;
  const Outcome help = run_fabrica({"--help"});
  ASSERT_EQ(help.code, 0) << describe(help);
  for (const auto& c : called) {
    EXPECT_TRUE(has_command(c)) << "scripts/run calls `fabrica " << c
                                << "`, which this build does not have";
    EXPECT_TRUE(std::regex_search(help.out, std::regex("\\n\\s+" + c + "\\s")))
        << c << " missing from fabrica --help";
    const Outcome r = run_fabrica({c, "--help"});
    EXPECT_EQ(r.code, 0) << describe(r);
  }
}

TEST(Docs, ScriptsRunFabricaLinesWorkOnTheBundledMesh) {
  // Runs each `"$fabrica" ...` line of scripts/run (not the script: it would
  // set up and rebuild) with the script's variables, on data/aneurysm.off.
  const fs::path root(FABRICA_SOURCE_DIR);
  const fs::path mesh = root / "data" / "aneurysm.off";
  if (!fs::exists(mesh)) GTEST_SKIP() << "no bundled mesh " << mesh;
  const fs::path out = work_dir() / "out";
  fs::create_directories(out);
  const std::string text = read_text(root / "scripts" / "run");
  std::istringstream lines(text);
  int ran = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("\"$fabrica\" ", 0) != 0) continue;
    const std::string script =
        "set -euo pipefail\nfabrica=\"$1\"\nmesh=\"$2\"\nout=\"$3\"\n"
        "name=\"$(basename \"${mesh%.*}\")\"\n" +
        line + "\n";
    const Outcome r =
        run_program("/bin/bash", {"-c", script, "bash", FABRICA_EXE, mesh.string(), out.string()});
    EXPECT_EQ(r.code, 0) << line << "\n" << describe(r);
    ++ran;
  }
  EXPECT_GT(ran, 0);
  for (const auto& name : list_dir(out)) EXPECT_GT(fs::file_size(out / name), 100u) << name;
  EXPECT_TRUE(temporaries(out).empty() ||
              // the script renames its own report .tmp in its next line
              temporaries(out) == std::vector<std::string>{"aneurysm-report.json.tmp"})
      << joined(temporaries(out));
  if (fs::exists(out / "aneurysm-report.json.tmp")) {
    const auto j = nlohmann::json::parse(read_text(out / "aneurysm-report.json.tmp"));
    EXPECT_EQ(j.at("validation").at("vertices").get<int>(), 7095);
  }
  if (fs::exists(out / "aneurysm-geometry.csv")) {
    EXPECT_EQ(split(read_text(out / "aneurysm-geometry.csv"), '\n').size(), 7096u);
  }
}

TEST(Docs, EveryCommandTheReadmeShowsExists) {
  const fs::path readme = fs::path(FABRICA_SOURCE_DIR) / "README.md";
  if (!fs::exists(readme)) GTEST_SKIP() << "no README.md";
  const std::string text = read_text(readme);
  // Command lines inside ``` code blocks: "fabrica CMD ..." at the start of a line.
  std::set<std::string> shown;
  const std::regex call(R"(^(?:\$ )?fabrica ([a-z][a-z0-9_-]*)\b)");
  bool in_code = false;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("```", 0) == 0) {
      in_code = !in_code;
      continue;
    }
    std::smatch m;
    if (in_code && std::regex_search(line, m, call)) shown.insert(m[1].str());
  }
  EXPECT_FALSE(shown.empty()) << "README.md shows no fabrica command";
  for (const auto& c : shown)
    EXPECT_TRUE(has_command(c)) << "README.md shows `fabrica " << c
                                << "`, which this build does not have";
}

// ------------------------------------------------- hardening (issue 15)

/// A 2x2x2 ASCII NRRD label volume with `extra` header lines.
std::string small_nrrd(const std::string& extra, const std::string& sizes = "2 2 2",
                       const std::string& spacings = "1 1 1") {
  return "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " + sizes + "\nspacings: " + spacings +
         "\nencoding: ascii\n" + extra + "\n0 1 0 1 0 1 0 1\n";
}

TEST(Hardening, DefectiveVolumeHeadersExit2NamingTheInputAndWriteNothing) {
  if (!has_command("extract")) GTEST_SKIP() << "no extract command in this build";
  const std::vector<std::pair<std::string, std::string>> cases{
      {"segment_index.seg.nrrd", small_nrrd("Segment4294967296_Name:=a\n")},
      {"label_value.seg.nrrd", small_nrrd("Segment0_Name:=a\nSegment0_LabelValue:=4294967296\n")},
      {"not_utf8.seg.nrrd", small_nrrd("Segment0_Name:=\xff\xfe bone\nSegment0_LabelValue:=1\n")},
      {"billion_voxels.nrrd", small_nrrd("", "1000 1000 1000")},
      {"spacing.nrrd", small_nrrd("", "2 2 2", "1e23 1 1")},
      {"nan_spacing.nrrd", small_nrrd("", "2 2 2", "1 nanx 1")},
      {"origin.nrrd",
       small_nrrd("space: left-posterior-superior\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
                  "space origin: (1e308,0,0)\n")},
  };
  for (const auto& [name, text] : cases) {
    const fs::path dir = work_dir();
    write_bytes(dir / name, text);
    const Outcome r = run_fabrica({"extract", (dir / name).string(), "-o", (dir / "out").string()});
    EXPECT_EQ(r.code, 2) << name << "\n" << describe(r);
    EXPECT_TRUE(one_line(r.err)) << describe(r);
    EXPECT_NE(r.err.find(name), std::string::npos) << describe(r);
    EXPECT_FALSE(fs::exists(dir / "out")) << name << ": something was written";
  }
  const fs::path dir = work_dir();
  const Outcome r = run_fabrica(
      {"extract", totalseg().string(), "-o", (dir / "out").string(), "--passband", "1e-308"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_NE(r.err.find("passband"), std::string::npos) << describe(r);
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(Hardening, NonFiniteOrNegativeWidthsAndParserErrorsExit2WithThePrefix) {
  const fs::path dir = work_dir();
  std::vector<std::vector<std::string>> calls;
  for (const char* value : {"inf", "nan", "-1", "0"}) {
    if (has_command("lines"))
      calls.push_back(
          {"lines", aneurysm().string(), "-o", (dir / "x.svg").string(), "--width", value});
    if (has_command("hatch"))
      calls.push_back(
          {"hatch", aneurysm().string(), "-o", (dir / "x.svg").string(), "--stroke-width", value});
  }
  if (has_command("geometry"))
    calls.push_back(
        {"geometry", aneurysm().string(), "-o", (dir / "x.csv").string(), "--smooth", "lots"});
  calls.push_back({"info", "--no-such-option"});
  for (const auto& call : calls) {
    const Outcome r = run_fabrica(call);
    EXPECT_EQ(r.code, 2) << describe(r);
    EXPECT_TRUE(one_line(r.err)) << describe(r);
    EXPECT_EQ(r.err.rfind("fabrica: ", 0), 0u) << describe(r);
    EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
  }
}

TEST(Hardening, HatchingMemoryIsBounded) {
  if (!has_command("hatch")) GTEST_SKIP() << "no hatch command in this build";
  const fs::path dir = work_dir();
  const Outcome deep = run_fabrica(
      {"hatch", aneurysm().string(), "-o", (dir / "x.svg").string(), "--grid-depth", "30"},
      std::chrono::seconds(20));
  EXPECT_EQ(deep.code, 2) << describe(deep);
  EXPECT_NE(deep.err.find("grid-depth"), std::string::npos) << describe(deep);
  EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
}

TEST(Hardening, RenderWritesAllItsOutputsOrNone) {
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path dir = work_dir();
  for (const char* option : {"--svg", "--save-camera", "--save-scene"}) {
    const std::string second = std::string(option) == "--svg" ? "x.svg" : "x.json";
    const Outcome r = run_fabrica({"render", aneurysm().string(), "-o", (dir / "r.png").string(),
                                   option, (dir / "missing" / second).string()});
    if (r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
    EXPECT_EQ(r.code, 3) << describe(r);
    EXPECT_TRUE(list_dir(dir).empty()) << option << " left " << joined(list_dir(dir));
  }
}

TEST(Hardening, StaleTemporariesOfDeadProcessesAreRemoved) {
  if (!has_command("geometry")) GTEST_SKIP() << "no geometry command in this build";
  const fs::path dir = work_dir();
  // The PID of a process that has ended.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  const std::string dead = "x.csv.tmp-" + std::to_string(child) + "-0";
  const std::string alive = "x.csv.tmp-" + std::to_string(::getpid()) + "-7";
  write_bytes(dir / dead, "partial");
  write_bytes(dir / alive, "being written");
  write_bytes(dir / "other.csv.tmp-1-0", "not ours");
  const Outcome r = run_fabrica({"geometry", aneurysm().string(), "-o", (dir / "x.csv").string()});
  ASSERT_EQ(r.code, 0) << describe(r);
  std::vector<std::string> kept{"other.csv.tmp-1-0", "x.csv", alive};
  std::sort(kept.begin(), kept.end());
  EXPECT_EQ(list_dir(dir), kept);
}

/// Output bytes of `args` run with --threads `threads` (stdout when `output` is empty).
std::string output_at(std::vector<std::string> args, const fs::path& output, int threads) {
  args.push_back("--threads");
  args.push_back(std::to_string(threads));
  const Outcome r = run_fabrica(args, std::chrono::seconds(300));
  if (r.code == 4) return "unavailable";
  EXPECT_EQ(r.code, 0) << describe(r);
  return output.empty() ? r.out : read_text(output);
}

TEST(Hardening, EveryOutputKindIsTheSameAtAnyThreadCount) {
  const fs::path dir = work_dir();
  const std::string mesh = aneurysm().string();
  std::vector<std::pair<std::vector<std::string>, fs::path>> runs;
  if (has_command("info")) runs.push_back({{"info", mesh, "--json"}, {}});
  if (has_command("geometry")) runs.push_back({{"geometry", mesh, "-o"}, dir / "g.csv"});
  if (has_command("lines"))
    for (const char* ext : {".svg", ".pdf", ".json", ".seg"})
      runs.push_back({{"lines", mesh, "--types", "all", "-o"}, dir / (std::string("l") + ext)});
  if (has_command("hatch")) runs.push_back({{"hatch", mesh, "-q", "-o"}, dir / "h.svg"});
  if (has_command("render")) runs.push_back({{"render", mesh, "-o"}, dir / "r.png"});
  if (has_command("extract"))
    runs.push_back({{"extract", totalseg().string(), "--labels", "5", "-o"}, dir / "e"});
  for (auto& [args, output] : runs) {
    if (!output.empty()) args.push_back(output.string());
    const bool folder = args[0] == "extract";
    auto result = [&, &args = args, &output = output](int threads) {
      if (folder) fs::remove_all(output);
      std::string bytes = output_at(args, folder ? fs::path() : output, threads);
      if (folder && fs::exists(output))
        for (const auto& name : list_dir(output)) bytes += name + read_text(output / name);
      return bytes;
    };
    const std::string one = result(1);
    if (one == "unavailable") continue;
    EXPECT_GT(one.size(), 100u) << args[0];
    for (int threads : {2, 8})
      EXPECT_TRUE(result(threads) == one)
          << args[0] << " " << output << " differs at --threads " << threads;
  }
}

// ConFIS (issue 21): `fabrica hatch --method confis` on the bundled anatomy
// (liver, vessels, cortex) exits 0 with strokes; bad parameters exit 2 with
// one line naming the option and leave no output.
TEST(ConfisCli, BundledAnatomyGivesStrokes) {
  if (!has_command("hatch")) GTEST_SKIP() << "no hatch command in this build";
  const fs::path dir = work_dir();
  const fs::path anatomy = test::bundled_data() / "meshes" / "anatomy";
  for (const fs::path& mesh :
       {anatomy / "liver" / "sofa_liver-smooth.obj", anatomy / "vessels" / "vmtk_aorta-surface.stl",
        anatomy / "brain" / "fsaverage5" / "pial_left.off"}) {
    const fs::path out = dir / (mesh.stem().string() + ".svg");
    const Outcome r = run_fabrica(
        {"hatch", mesh.string(), "--method", "confis", "--view", "left", "-o", out.string()});
    ASSERT_EQ(r.code, 0) << describe(r);
    // "OUT: confis, N strokes (...)"
    const auto at = r.out.find(": confis, ");
    ASSERT_NE(at, std::string::npos) << describe(r);
    const long strokes = std::stol(r.out.substr(at + 10));
    EXPECT_GT(strokes, 20) << describe(r);
    const std::string svg = read_text(out);
    EXPECT_GT(static_cast<long>(std::count(svg.begin(), svg.end(), '\n')), strokes);  // a path each
    EXPECT_NE(svg.find("stroke-opacity"), std::string::npos);  // weights fade to the borders
  }
}

TEST(ConfisCli, BadParametersExit2) {
  if (!has_command("hatch")) GTEST_SKIP() << "no hatch command in this build";
  const fs::path dir = work_dir();
  const std::string out = (dir / "x.svg").string();
  const std::vector<std::pair<std::vector<std::string>, std::string>> calls{
      {{"--method", "confsi"}, "did you mean 'confis'"},
      {{"--method", "confis", "--spacing", "0"}, "--spacing"},
      {{"--method", "confis", "--spacing", "nan"}, "--spacing"},
      {{"--method", "confis", "--contour-margin", "1.5"}, "--contour-margin"},
      {{"--method", "confis", "--contour-margin", "0"}, "--contour-margin"},
      {{"--method", "confis", "--convex-threshold", "-1"}, "--convex-threshold"},
      {{"--method", "confis", "--concave-threshold", "0"}, "--concave-threshold"},
      {{"--method", "confis", "--umbilic-threshold", "-0.5"}, "--umbilic-threshold"},
      {{"--method", "confis", "--min-weight", "2"}, "--min-weight"},
      {{"--method", "confis", "--min-length", "-3"}, "--min-length"},
      {{"--method", "confis", "--no-contours", "--no-features"}, "--no-features"},
      {{"--method", "confis", "--light", "view:1,0,0"}, "--light"},
      {{"--spacing", "4"}, "--spacing"},
  };
  for (const auto& [extra, expected] : calls) {
    std::vector<std::string> args{"hatch", aneurysm().string(), "-o", out};
    args.insert(args.end(), extra.begin(), extra.end());
    const Outcome r = run_fabrica(args);
    EXPECT_EQ(r.code, 2) << describe(r);
    EXPECT_TRUE(one_line(r.err)) << describe(r);
    EXPECT_NE(r.err.find(expected), std::string::npos) << describe(r);
    EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
  }
}

// structures[].hatching as an object (issue 21): the method and the ConFIS
// parameters per structure, named as the flags; a flag given on the command
// line wins over the key; unknown keys and values exit 2 naming the key;
// `fabrica lines` and `render` read the same scene.
TEST(ConfisCli, SceneHatchingKey) {
  if (!has_command("hatch")) GTEST_SKIP() << "no hatch command in this build";
  const fs::path dir = work_dir();
  const fs::path liver =
      test::bundled_data() / "meshes" / "anatomy" / "liver" / "sofa_liver-smooth.obj";
  auto scene = [&](const std::string& name, const std::string& hatching) {
    const fs::path path = dir / name;
    write_bytes(path, "{\"view\": \"left\", \"structures\": [{\"mesh\": \"" +
                          liver.generic_string() + "\", \"lines\": [], \"hatching\": " + hatching +
                          "}]}");
    return path.string();
  };
  // "OUT: METHOD, N strokes (M vertices), ..." without the output's name.
  auto summary = [](const Outcome& r) {
    const auto at = r.out.find(": ");
    const auto end = r.out.find(", grid depth");
    return at == std::string::npos ? r.out : r.out.substr(at, end - at);
  };
  auto hatch = [&](std::vector<std::string> args) {
    args.insert(args.begin(), "hatch");
    args.insert(args.end(), {"-o", (dir / "out.svg").string()});
    const Outcome r = run_fabrica(args);
    EXPECT_EQ(r.code, 0) << describe(r);
    fs::remove(dir / "out.svg");
    return summary(r);
  };
  const std::string keyed =
      scene("keyed.json", "{\"method\": \"confis\", \"spacing\": 5, \"contour_margin\": 0.4}");
  const std::string from_key = hatch({keyed});
  EXPECT_EQ(from_key.rfind(": confis, ", 0), 0u) << from_key;
  EXPECT_EQ(from_key, hatch({liver.string(), "--view", "left", "--method", "confis", "--spacing",
                             "5", "--contour-margin", "0.4"}));
  // The flag wins over the key.
  const std::string flag_wins = hatch({keyed, "--spacing", "9"});
  EXPECT_EQ(flag_wins, hatch({liver.string(), "--view", "left", "--method", "confis", "--spacing",
                              "9", "--contour-margin", "0.4"}));
  EXPECT_NE(flag_wins, from_key);
  // `lines` and `render` read the scene (the key does not change them).
  const Outcome lines = run_fabrica({"lines", keyed, "-o", (dir / "l.svg").string(), "-q"});
  EXPECT_EQ(lines.code, 0) << describe(lines);
  fs::remove(dir / "l.svg");

  const std::vector<std::pair<std::string, std::string>> bad{
      {"{\"method\": \"confsi\"}", "did you mean 'confis'"},
      {"{\"method\": \"confis\", \"spacnig\": 5}", "structures[0].hatching.spacnig"},
      {"{\"method\": \"confis\", \"spacing\": 0}", "structures[0].hatching.spacing"},
      {"{\"method\": \"confis\", \"contour_margin\": 2}", "structures[0].hatching.contour_margin"},
      {"{\"method\": \"confis\", \"no_contours\": 1}", "structures[0].hatching.no_contours"},
      {"{\"method\": \"shading\", \"spacing\": 5}", "structures[0].hatching.spacing"},
      {"{\"spacing\": 5}", "structures[0].hatching.spacing"},  // --method shading
      {"\"yes\"", "structures[0].hatching"}};
  for (const auto& [value, needle] : bad) {
    const Outcome r =
        run_fabrica({"hatch", scene("bad.json", value), "-o", (dir / "out.svg").string()});
    EXPECT_EQ(r.code, 2) << value << "\n" << describe(r);
    EXPECT_TRUE(one_line(r.err)) << describe(r);
    EXPECT_NE(r.err.find(needle), std::string::npos) << value << "\n" << describe(r);
  }
  fs::remove(dir / "bad.json");
  fs::remove(dir / "keyed.json");
  EXPECT_TRUE(list_dir(dir).empty()) << joined(list_dir(dir));
}

}  // namespace

TEST(Render, AnnotationFlagsAndTheirErrors) {
  // issue 17, item 5: --annotate draws labels, legend, scale bar and marker
  // into the PNG and an "annotation" layer of real <text> into the SVG, the
  // same bytes on every run; bad values and misspelt flags exit 2.
  if (!has_command("render")) GTEST_SKIP() << "no render command in this build";
  const fs::path scene = fs::path(FABRICA_SOURCE_DIR) / "data" / "aneurysm-scene.json";
  const fs::path dir = work_dir();
  auto args = [&](const std::string& stem) {
    return std::vector<std::string>{
        "render",     scene.string(), "-o",    (dir / (stem + ".png")).string(),
        "--size",     "320x240",      "--svg", (dir / (stem + ".svg")).string(),
        "--annotate", "--font-size",  "24",    "-q"};
  };
  const Outcome r = run_fabrica(args("a"));
  if (r.code == 4) GTEST_SKIP() << "no headless GL: " << r.err;
  ASSERT_EQ(r.code, 0) << describe(r);
  const Outcome second = run_fabrica(args("b"));
  ASSERT_EQ(second.code, 0) << describe(second);
  EXPECT_EQ(read_text(dir / "a.png"), read_text(dir / "b.png"));
  EXPECT_EQ(read_text(dir / "a.svg"), read_text(dir / "b.svg"));
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_file((dir / "a.svg").c_str()));
  const pugi::xml_node layer = doc.child("svg").last_child();
  EXPECT_EQ(std::string(layer.attribute("inkscape:label").value()), "annotation");
  std::set<std::string> roles;
  for (pugi::xml_node n : layer.children()) roles.insert(n.attribute("data-role").value());
  for (const char* role : {"label", "leader", "legend-text", "legend-swatch", "scale-bar",
                           "scale-bar-text", "orientation"})
    EXPECT_TRUE(roles.count(role)) << role;
  // Without the flags: no annotation layer, and the picture differs.
  std::vector<std::string> plain = args("c");
  plain.erase(plain.end() - 4, plain.end() - 1);
  ASSERT_EQ(run_fabrica(plain).code, 0);
  EXPECT_EQ(read_text(dir / "c.svg").find("annotation"), std::string::npos);
  EXPECT_NE(read_text(dir / "a.png"), read_text(dir / "c.png"));
  for (const auto& extra :
       {std::vector<std::string>{"--font-size", "0"},
        std::vector<std::string>{"--font-size", "big"}, std::vector<std::string>{"--scale-bars"}}) {
    std::vector<std::string> bad = {"render", scene.string(), "-o", (dir / "d.png").string()};
    bad.insert(bad.end(), extra.begin(), extra.end());
    const Outcome o = run_fabrica(bad);
    EXPECT_EQ(o.code, 2) << describe(o);
    EXPECT_FALSE(fs::exists(dir / "d.png"));
  }
  const Outcome typo =
      run_fabrica({"render", scene.string(), "-o", (dir / "d.png").string(), "--scale-bars"});
  EXPECT_NE(typo.err.find("--scale-bar"), std::string::npos) << describe(typo);
}
