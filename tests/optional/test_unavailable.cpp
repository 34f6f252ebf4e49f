// The parts a build leaves out (FABRICA_WITH_VTK=OFF, FABRICA_WITH_CGAL=OFF)
// are not silently missing: they throw ErrorKind::unavailable (exit code 4)
// with a message naming the option that turns them on, while the rest of the
// library keeps working.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/validate.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

void expect_unavailable(const std::function<void()>& call, const std::string& option,
                        const std::string& subject) {
  try {
    call();
    ADD_FAILURE() << "expected an unavailable error mentioning " << option;
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::unavailable) << e.what();
    EXPECT_EQ(e.exit_code(), 4);
    const std::string message = e.what();
    EXPECT_NE(message.find("-D" + option + "=ON"), std::string::npos) << message;
    EXPECT_NE(message.find(subject), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "one line: " << message;
  }
}

#ifndef FABRICA_HAVE_VTK
TEST(Unavailable, VtpNeedsVtk) {
  const auto path = test::temp_dir("unavailable") / "surface.vtp";
  std::ofstream(path) << "<VTKFile type=\"PolyData\"></VTKFile>\n";
  expect_unavailable([&] { io::read_mesh(path); }, "FABRICA_WITH_VTK", path.string());
}

TEST(Unavailable, ExtractionNeedsVtk) {
  io::LabelVolume volume;
  volume.path = "labels.nrrd";
  expect_unavailable([&] { io::extract_surfaces(volume); }, "FABRICA_WITH_VTK", "labels.nrrd");
}

TEST(Unavailable, PlainReadersWorkWithoutVtk) {
  const auto mesh = io::read_mesh(test::bundled_data() / "meshes" / "classic" / "libigl_bunny.off");
  EXPECT_GT(mesh.mesh.faces.size(), 100u);
}
#endif

#ifndef FABRICA_HAVE_CGAL
TEST(Unavailable, SelfIntersectionsNeedCgal) {
  io::ValidateOptions options;
  options.self_intersections = true;
  const TriangleMesh sphere = test::make_icosphere(1.0, 2);
  expect_unavailable([&] { io::validate_mesh(sphere, options); }, "FABRICA_WITH_CGAL",
                     "self-intersection");
  // The rest of the validation runs as before.
  const io::ValidationReport report = io::validate_mesh(sphere);
  EXPECT_TRUE(report.problems.empty());
}
#endif

}  // namespace
}  // namespace fabrica
