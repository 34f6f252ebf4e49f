// Every malformed input gives an InputError with a one-line message naming
// the file: never a crash, hang, NaN or VTK noise on stderr.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "fabrica/io/mesh_io.hpp"
#include "mesh_io_test_util.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

using test::expect_input_error;
using test::write_bytes;

const char* kPlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

class MalformedFiles : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::temp_dir("mesh_io_errors"); }
  std::filesystem::path file(const std::string& name, const std::string& bytes) {
    write_bytes(dir_ / name, bytes);
    return dir_ / name;
  }
  std::filesystem::path dir_;
};

TEST_F(MalformedFiles, MissingEmptyFolderAndUnknownExtension) {
  expect_input_error(dir_ / "nothing_here.stl", "does not exist");
  expect_input_error(file("empty.obj", ""), "empty");
  expect_input_error(file("empty.vtp", ""), "empty");
  std::filesystem::create_directories(dir_ / "folder.obj");
  expect_input_error(dir_ / "folder.obj", "folder");
  expect_input_error(file("mesh.xyz", "1 2 3\n"), "unknown mesh file extension");
}

TEST_F(MalformedFiles, Stl) {
  // A PNG renamed .stl: neither binary (size) nor ascii.
  std::string png = "\x89PNG\r\n\x1a\n";
  png += std::string("\0\0\0\rIHDR\0\0\0\x10\0\0\0\x10\x08\x06\0\0\0", 21);
  for (int i = 0; i < 300; ++i) png.push_back(static_cast<char>((i * 37 + 11) & 0xff));
  expect_input_error(file("picture.stl", png), "not an STL file");
  // Truncated binary STL (last triangle cut).
  TriangleMesh mesh = test::make_icosphere(10.0, 1);
  io::write_mesh(mesh, dir_ / "good.stl");
  const std::string good = test::read_bytes(dir_ / "good.stl");
  expect_input_error(file("truncated.stl", good.substr(0, good.size() - 20)),
                     "truncated binary STL");
  expect_input_error(file("tiny.stl", "abc"), "not an STL file");
  // Ascii STL that breaks off / has garbage.
  expect_input_error(file("broken_ascii.stl",
                          "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\n"),
                     "not a valid ascii STL");
  expect_input_error(file("nan_ascii.stl",
                          "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\n"
                          "vertex 0 1 0\nendloop\nendfacet\nendsolid x\n"),
                     "not a finite number");
  // Binary STL with a NaN coordinate.
  std::string nan_stl = good;
  const float nan = std::nanf("");
  std::memcpy(nan_stl.data() + 84 + 12, &nan, 4);
  expect_input_error(file("nan_binary.stl", nan_stl), "not a finite number");
  expect_input_error(file("no_faces.stl", std::string(80, ' ') + std::string(4, '\0')), "no faces");
}

TEST_F(MalformedFiles, Ply) {
  io::WriteOptions wo;
  io::write_mesh(test::make_icosphere(10.0, 1), dir_ / "good.ply", wo);
  const std::string good = test::read_bytes(dir_ / "good.ply");
  expect_input_error(file("truncated.ply", good.substr(0, good.size() - 7)), "truncated");
  expect_input_error(file("truncated_header.ply", good.substr(0, 60)), "end_header");
  expect_input_error(file("few_vertices.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n3 0 1 2\n"),
                     "");
  expect_input_error(
      file("extra.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n"),
      "more data");
  expect_input_error(file("nan.ply", std::string(kPlyHeader) + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
                     "not a finite number");
  expect_input_error(file("range.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
                     "refers to vertex 3");
  expect_input_error(
      file("negative.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"),
      "refers to vertex -1");
  expect_input_error(file("huge_count.ply",
                          "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                          "property float x\nproperty float y\nproperty float z\nend_header\n"),
                     "");
  expect_input_error(file("not.ply", "plyx\n"), "not a PLY file");
  expect_input_error(file("nofaces.ply",
                          "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                          "property float y\nproperty float z\nend_header\n0 0 0\n"),
                     "no faces");
}

TEST_F(MalformedFiles, Off) {
  expect_input_error(file("more_declared.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "");
  expect_input_error(file("fewer_declared.off", "OFF\n2 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "");
  expect_input_error(file("faces_missing.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
                     "file ends after 1 faces");
  expect_input_error(file("nan.off", "OFF\n3 1 0\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n"),
                     "not a finite number");
  expect_input_error(file("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
                     "refers to vertex 7");
  expect_input_error(file("header.off", "OFX\n3 1 0\n"), "not an OFF file");
  expect_input_error(file("fourd.off", "4OFF\n3 1 0\n"), "not supported");
}

TEST_F(MalformedFiles, Obj) {
  expect_input_error(file("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
                     "not a finite number");
  expect_input_error(file("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"),
                     "refers to vertex 3");
  expect_input_error(file("negative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n"), "line 4");
  expect_input_error(file("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), "index 0");
  expect_input_error(file("short.obj", "v 0 0\n"), "line 1");
  expect_input_error(file("garbage.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n"),
                     "bad face vertex");
  expect_input_error(file("points.obj", "v 0 0 0\nv 1 0 0\n"), "no faces");
  expect_input_error(file("two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n"), "only 2 vertices");
}

TEST_F(MalformedFiles, VtkFilesFailQuietly) {
  ::testing::internal::CaptureStderr();
  expect_input_error(
      file("garbage.vtp", "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\">\n<Poly"), "");
  expect_input_error(file("text.vtp", "hello world\n"), "");
  expect_input_error(file("garbage.vtk",
                          "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n"
                          "POINTS 3 float\n0 0 0 1 0\n"),
                     "");
  expect_input_error(file("grid.vtk",
                          "# vtk DataFile Version 3.0\nx\nASCII\n"
                          "DATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n"),
                     "POLYDATA");
  expect_input_error(file("range.vtk",
                          "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n"
                          "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 5\n"),
                     "");
  // A truncated copy of a real file (this crashes vtkPolyDataReader).
  const std::string fran =
      test::read_bytes(test::bundled_data() / "meshes/classic/vtkdata_fran_cut.vtk");
  ASSERT_GT(fran.size(), 117480u);
  expect_input_error(file("truncated.vtk", fran.substr(0, 117480)), "");
  expect_input_error(file("truncated_points.vtk", fran.substr(0, 2000)), "truncated");
  expect_input_error(file("nan.vtk",
                          "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n"
                          "POINTS 3 float\n0 0 0 1 nan 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n"),
                     "not a finite number");
  const std::string noise = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(noise.empty()) << "VTK printed: " << noise;
}

}  // namespace
}  // namespace fabrica
