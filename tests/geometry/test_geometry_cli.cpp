// End-to-end check of `fabrica geometry`: CSV header and columns, one row
// per vertex in file order, analytic values on a sphere, exit codes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace fabrica {
namespace {

const std::filesystem::path kFabrica =
    std::filesystem::path(FABRICA_BINARY_DIR) / "apps" / "fabrica" / "fabrica";

int run(const std::string& args) {
  const std::string cmd = kFabrica.string() + " geometry " + args + " > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  return out;
}

TEST(GeometryCommand, SphereCsv) {
  if (!std::filesystem::exists(kFabrica)) GTEST_SKIP() << "fabrica not built";
  const auto dir = test::temp_dir("geometry-cli");
  const TriangleMesh m = test::make_icosphere(2.0, 3);
  {
    std::ofstream obj(dir / "sphere.obj");
    obj.precision(17);
    for (const Vec3& p : m.positions) obj << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
    for (const Face& f : m.faces)
      obj << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
  }
  const auto csv = dir / "out.csv";
  ASSERT_EQ(run((dir / "sphere.obj").string() + " -o " + csv.string() + " --normals angle"), 0);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "x,y,z,nx,ny,nz,area,k1,k2,e1x,e1y,e1z,e2x,e2y,e2z,mean,gaussian,a,b,c,d,valid");
  std::size_t rows = 0;
  double area = 0;
  while (std::getline(in, line)) {
    const auto c = split(line);
    ASSERT_EQ(c.size(), 22u);
    // File order: row i is vertex i.
    EXPECT_NEAR(std::stod(c[0]), m.positions[rows].x(), 1e-12);
    EXPECT_NEAR(std::stod(c[2]), m.positions[rows].z(), 1e-12);
    EXPECT_NEAR(std::stod(c[7]), 0.5, 0.02);    // k1 = 1/R
    EXPECT_NEAR(std::stod(c[15]), 0.5, 0.02);   // mean
    EXPECT_NEAR(std::stod(c[16]), 0.25, 0.02);  // gaussian
    EXPECT_EQ(c[21], "1");
    area += std::stod(c[6]);
    ++rows;
  }
  EXPECT_EQ(rows, m.vertex_count());
  EXPECT_NEAR(area, 4 * M_PI * 4, 0.05 * 4 * M_PI * 4);

  // Bad input: 2; output folder missing: 3 and nothing written; bad option: 2.
  EXPECT_EQ(run((dir / "missing.obj").string() + " -o " + (dir / "x.csv").string()), 2);
  EXPECT_EQ(run((dir / "sphere.obj").string() + " -o " + (dir / "no" / "x.csv").string()), 3);
  EXPECT_FALSE(std::filesystem::exists(dir / "no"));
  EXPECT_EQ(run((dir / "sphere.obj").string() + " -o " + csv.string() + " --normals foo"), 2);
  EXPECT_EQ(run((dir / "sphere.obj").string() + " -o " + csv.string() + " --smooth 2"), 0);
}

}  // namespace
}  // namespace fabrica
