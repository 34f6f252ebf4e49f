// End to end: the built `fabrica info` executable on a real mesh, with
// --json, --repair -o, --space, and on missing and malformed files (exit 2,
// message naming the file).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/validate.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

struct CommandResult {
  int exit_code = -1;
  std::string out;  // stdout
  std::string all;  // stdout + stderr
};

std::string quote(const std::string& s) {
  return "'" + s + "'";
}

CommandResult run_fabrica(const std::string& args) {
  CommandResult r;
  const auto err = test::temp_dir("info-cli-stderr") / "stderr.txt";
  const std::string cmd = quote(FABRICA_EXECUTABLE) + " " + args + " 2>" + quote(err.string());
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err);
  r.all = r.out + std::string(std::istreambuf_iterator<char>(in), {});
  return r;
}

std::string aorta() {
  return (test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.stl").string();
}

TEST(InfoCli, ReadableReportOfTheAorta) {
  const CommandResult r = run_fabrica("info " + quote(aorta()));
  ASSERT_EQ(r.exit_code, 0) << r.all;
  EXPECT_NE(r.out.find("stl (binary)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("6468 vertices, 12932 faces"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("welded"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("LPS"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("normals point inward"), std::string::npos) << r.out;
}

TEST(InfoCli, JsonWithSpaceOverride) {
  const CommandResult r = run_fabrica("info --json --space ras " + quote(aorta()));
  ASSERT_EQ(r.exit_code, 0) << r.all;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("file").at("format"), "stl");
  EXPECT_EQ(j.at("space").at("name"), "RAS");
  EXPECT_EQ(j.at("space").at("source"), to_string(SpaceSource::user_override));
  EXPECT_EQ(j.at("validation").at("faces"), 12932);
  EXPECT_EQ(j.at("validation").at("outward"), false);
  EXPECT_FALSE(j.contains("repair"));
}

TEST(InfoCli, RepairWritesAnOutwardMesh) {
  const auto out = test::temp_dir("info-cli-repair") / "aorta-repaired.ply";
  const CommandResult r =
      run_fabrica("info --json --repair " + quote(aorta()) + " -o " + quote(out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.all;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("repair").at("flipped_faces"), 12932);
  EXPECT_EQ(j.at("after_repair").at("clean"), true);
  const auto written = io::read_mesh(out);
  const auto v = io::validate_mesh(written.mesh);
  EXPECT_EQ(v.vertices, 6468u);
  EXPECT_TRUE(v.outward.value_or(false));
  EXPECT_TRUE(v.clean());
}

TEST(InfoCli, MissingFileIsBadInput) {
  const std::string missing = (test::temp_dir("info-cli-missing") / "no-such-mesh.stl").string();
  const CommandResult r = run_fabrica("info " + quote(missing));
  EXPECT_EQ(r.exit_code, 2) << r.all;
  EXPECT_NE(r.all.find("no-such-mesh.stl"), std::string::npos) << r.all;
}

TEST(InfoCli, MalformedFileIsBadInput) {
  const auto bad = test::temp_dir("info-cli-bad") / "garbage.obj";
  std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  const CommandResult r = run_fabrica("info " + quote(bad.string()));
  EXPECT_EQ(r.exit_code, 2) << r.all;
  EXPECT_NE(r.all.find("garbage.obj"), std::string::npos) << r.all;
}

TEST(InfoCli, BadArgumentIsBadInput) {
  EXPECT_EQ(run_fabrica("info --space xyz " + quote(aorta())).exit_code, 2);
}

}  // namespace
}  // namespace fabrica
