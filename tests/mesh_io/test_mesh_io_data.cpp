// Reading the bundled real meshes: counts from SOURCES.md / rtsc, agreement
// with independent readers (OpenMesh, VTK), and read speed.
#include <gtest/gtest.h>

// OpenMesh: MeshIO.hh must come before the mesh types (registers readers).
#include <vtkCellArray.h>
#include <vtkNew.h>
#include <vtkPLYReader.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkPolyDataWriter.h>
#include <vtkSTLReader.h>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <chrono>
#include <sstream>
#include <string>

#include "fabrica/io/mesh_io.hpp"
#include "mesh_io_test_util.hpp"
#include "sanitized.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

std::filesystem::path mesh_path(const std::string& relative) {
  return test::bundled_data() / "meshes" / relative;
}

struct Expected {
  const char* path;
  const char* format;
  std::size_t vertices;
  std::size_t triangles;
  bool binary;
};

class SharedMesh : public ::testing::TestWithParam<Expected> {};

TEST_P(SharedMesh, HasTheDocumentedCounts) {
  const Expected e = GetParam();
  const auto r = io::read_mesh(mesh_path(e.path));
  EXPECT_EQ(r.info.format, e.format);
  EXPECT_EQ(r.info.binary, e.binary);
  EXPECT_EQ(r.mesh.vertex_count(), e.vertices);
  EXPECT_EQ(r.mesh.face_count(), e.triangles);
  EXPECT_EQ(r.mesh.space, Space::lps);
  EXPECT_EQ(r.mesh.space_source, SpaceSource::default_assumed);
  EXPECT_NO_THROW(check_mesh_indices_and_values(r.mesh, e.path));
}

INSTANTIATE_TEST_SUITE_P(
    Files, SharedMesh,
    ::testing::Values(Expected{"anatomy/bones/gfxmorph_femur.stl", "stl", 10156, 20308, true},
                      Expected{"anatomy/bones/jigsaw_hip.stl", "stl", 8107, 16218, true},
                      Expected{"anatomy/vessels/vmtk_aorta-surface.stl", "stl", 6468, 12932, true},
                      Expected{"anatomy/vessels/vmtk_aorta-surface.vtp", "vtp", 6468, 12932, true},
                      Expected{"anatomy/vessels/sofa_aneurysm3D_1.off", "off", 7095, 14186, false},
                      Expected{"anatomy/skull/sofa_skull.vtp", "vtp", 3305, 6621, true},
                      Expected{"anatomy/torso/vtkdata_Torso.vtp", "vtp", 12015, 23762, true},
                      Expected{"anatomy/bones/vtkdata_footbones.ply", "ply", 2154, 4204, false},
                      Expected{"anatomy/liver/sofa_liver-smooth.obj", "obj", 2194, 4384, false},
                      Expected{"anatomy/liver/sofa_liver_coarse.obj", "obj", 181, 274, false},
                      Expected{"anatomy/brain/fsaverage5/pial_left.off", "off", 10242, 20480,
                               false},
                      Expected{"classic/c3d_igea.ply", "ply", 134345, 268686, true},
                      Expected{"classic/vtkdata_horse.ply", "ply", 48485, 96966, true},
                      Expected{"classic/vtkdata_lucy.ply", "ply", 49987, 99970, true},
                      Expected{"classic/c3d_cow.obj", "obj", 2903, 5804, false},
                      Expected{"classic/c3d_stanford-bunny.obj", "obj", 35947, 69451, false},
                      Expected{"classic/c3d_fandisk.obj", "obj", 6475, 12946, false},
                      Expected{"classic/libigl_bunny.off", "off", 3485, 6966, false},
                      Expected{"classic/libigl_camelhead.off", "off", 11381, 22704, false},
                      Expected{"classic/vtkdata_fran_cut.vtk", "vtk", 2205, 4224, false}),
    [](const auto& info) {
      std::string n = std::filesystem::path(info.param.path).filename().string();
      for (char& c : n)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return n;
    });

TEST(SharedMeshDetails, StlWeldingCountsAndVtpAgreesWithStl) {
  const auto femur = io::read_mesh(mesh_path("anatomy/bones/gfxmorph_femur.stl"));
  EXPECT_EQ(femur.info.file_vertices, 60924u);
  EXPECT_EQ(femur.info.welded_vertices, 60924u - 10156u);
  EXPECT_EQ(femur.info.file_polygons, 20308u);

  const auto stl = io::read_mesh(mesh_path("anatomy/vessels/vmtk_aorta-surface.stl"));
  const auto vtp = io::read_mesh(mesh_path("anatomy/vessels/vmtk_aorta-surface.vtp"));
  EXPECT_EQ(stl.info.file_vertices, 38796u);
  const BoundingBox a = bounding_box(stl.mesh.positions), b = bounding_box(vtp.mesh.positions);
  EXPECT_LT((a.min - b.min).norm(), 1e-4);
  EXPECT_LT((a.max - b.max).norm(), 1e-4);
  EXPECT_NEAR(a.min.x(), 205.6186, 1e-4);
}

TEST(SharedMeshDetails, TriangleStripsAndPolygonsAreReported) {
  const auto igea = io::read_mesh(mesh_path("classic/c3d_igea.ply"));
  // rtsc/trimesh2 count: every strip triangle of igea is kept (none repeats a vertex).
  EXPECT_EQ(igea.info.file_polygons, 268686u);
  EXPECT_EQ(igea.info.file_vertices, 134345u);
  const auto skull = io::read_mesh(mesh_path("anatomy/skull/sofa_skull.vtp"));
  EXPECT_EQ(skull.info.file_polygons, 3779u);
  EXPECT_GT(skull.info.triangulated_polygons, 0u);
}

TEST(SharedMeshDetails, ObjNormalsOnlyWhenAsked) {
  const auto path = mesh_path("anatomy/liver/sofa_liver-smooth.obj");
  EXPECT_TRUE(io::read_mesh(path).info.file_normals.empty());
  io::ReadOptions ro;
  ro.keep_file_normals = true;
  const auto r = io::read_mesh(path, ro);
  ASSERT_EQ(r.info.file_normals.size(), r.mesh.vertex_count());
  for (const Vec3& n : r.info.file_normals) EXPECT_NEAR(n.norm(), 1.0, 1e-3);
}

struct DoubleTraits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;

/// OpenMesh's reader (independent code) agrees on positions and faces for
/// files whose vertices it does not split (manifold, no STL soup).
void expect_same_as_openmesh(const std::string& relative, double tolerance) {
  const auto path = mesh_path(relative);
  OmMesh om;
  std::ostringstream quiet;
  omerr().disable();
  omlog().disable();
  ASSERT_TRUE(OpenMesh::IO::read_mesh(om, path.string())) << relative;
  omerr().enable();
  omlog().enable();
  const auto r = io::read_mesh(path);
  ASSERT_EQ(r.mesh.vertex_count(), om.n_vertices()) << relative;
  ASSERT_EQ(r.mesh.face_count(), om.n_faces()) << relative;
  double worst = 0;
  for (std::size_t i = 0; i < r.mesh.vertex_count(); ++i) {
    const auto& p = om.point(OmMesh::VertexHandle(static_cast<int>(i)));
    worst = std::max(worst, (r.mesh.positions[i] - Vec3(p[0], p[1], p[2])).cwiseAbs().maxCoeff());
  }
  EXPECT_LE(worst, tolerance) << relative;
  std::size_t mismatched = 0;
  for (std::size_t f = 0; f < r.mesh.face_count(); ++f) {
    std::array<int, 3> o{};
    int k = 0;
    for (auto v : om.fv_range(OmMesh::FaceHandle(static_cast<int>(f))))
      o[static_cast<std::size_t>(k++)] = v.idx();
    const Face& m = r.mesh.faces[f];
    bool same = false;
    for (int s = 0; s < 3; ++s)  // same cyclic order, any starting corner
      same = same || (o[0] == m[static_cast<std::size_t>(s)] &&
                      o[1] == m[static_cast<std::size_t>((s + 1) % 3)] &&
                      o[2] == m[static_cast<std::size_t>((s + 2) % 3)]);
    mismatched += same ? 0 : 1;
  }
  EXPECT_EQ(mismatched, 0u) << relative;
}

TEST(IndependentReaders, OpenMeshAgreesOnOffAndPly) {
  expect_same_as_openmesh("classic/libigl_bunny.off", 1e-6);  // ascii, float in OpenMesh
  expect_same_as_openmesh("anatomy/vessels/sofa_aneurysm3D_1.off", 1e-5);
  expect_same_as_openmesh("classic/vtkdata_lucy.ply", 0.0);  // binary float: exact
}

TEST(IndependentReaders, VtkAgreesOnBigEndianPlyAndBinaryStl) {
  {
    vtkNew<vtkPLYReader> reader;
    const auto path = mesh_path("classic/vtkdata_horse.ply");
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkPoints* points = reader->GetOutput()->GetPoints();
    const auto r = io::read_mesh(path);
    ASSERT_EQ(static_cast<std::size_t>(points->GetNumberOfPoints()), r.mesh.vertex_count());
    for (vtkIdType i = 0; i < points->GetNumberOfPoints(); ++i) {
      double p[3];
      points->GetPoint(i, p);
      ASSERT_EQ(Vec3(p[0], p[1], p[2]), r.mesh.positions[static_cast<std::size_t>(i)]) << i;
    }
    EXPECT_EQ(static_cast<std::size_t>(reader->GetOutput()->GetNumberOfPolys()),
              r.mesh.face_count());
  }
  {
    vtkNew<vtkSTLReader> reader;  // merges coincident points, like ours
    const auto path = mesh_path("anatomy/bones/gfxmorph_femur.stl");
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkPolyData* poly = reader->GetOutput();
    const auto r = io::read_mesh(path);
    ASSERT_EQ(static_cast<std::size_t>(poly->GetNumberOfPoints()), r.mesh.vertex_count());
    ASSERT_EQ(static_cast<std::size_t>(poly->GetNumberOfPolys()), r.mesh.face_count());
    // Compare triangle by triangle through positions (numbering may differ).
    vtkIdType n = 0;
    const vtkIdType* ids = nullptr;
    std::size_t f = 0, differing = 0;
    vtkCellArray* polys = poly->GetPolys();
    for (polys->InitTraversal(); polys->GetNextCell(n, ids); ++f)
      for (int k = 0; k < 3; ++k) {
        double p[3];
        poly->GetPoint(ids[k], p);
        if (Vec3(p[0], p[1], p[2]) !=
            r.mesh
                .positions[static_cast<std::size_t>(r.mesh.faces[f][static_cast<std::size_t>(k)])])
          ++differing;
      }
    EXPECT_EQ(differing, 0u);
  }
}

/// Our legacy VTK parser against vtkPolyDataReader: the classic file, and the
/// 5.1 layout (OFFSETS/CONNECTIVITY) VTK 9 writes, in ascii and binary.
TEST(IndependentReaders, LegacyVtkAgreesWithVtkPolyDataReader) {
  const auto original = mesh_path("classic/vtkdata_fran_cut.vtk");
  vtkNew<vtkPolyDataReader> reader;
  reader->SetFileName(original.c_str());
  reader->Update();
  vtkPolyData* poly = reader->GetOutput();
  ASSERT_GT(poly->GetNumberOfPolys(), 0);
  const auto dir = test::temp_dir("mesh_io_legacy");
  std::vector<std::filesystem::path> files = {original};
  for (bool binary : {false, true}) {
    vtkNew<vtkPolyDataWriter> writer;
    const auto path = dir / (binary ? "fran_binary.vtk" : "fran_ascii51.vtk");
    writer->SetFileName(path.c_str());
    writer->SetInputData(poly);
    if (binary) writer->SetFileTypeToBinary();
    writer->SetHeader("written by VTK SPACE=RAS");
    ASSERT_EQ(writer->Write(), 1);
    files.push_back(path);
  }
  for (const auto& path : files) {
    const auto r = io::read_mesh(path);
    ASSERT_EQ(static_cast<std::size_t>(poly->GetNumberOfPoints()), r.mesh.vertex_count()) << path;
    for (vtkIdType i = 0; i < poly->GetNumberOfPoints(); ++i) {
      double p[3];
      poly->GetPoint(i, p);
      // VTK rounds ascii "float" data to float; we keep the decimal value as double.
      const Vec3 ours = r.mesh.positions[static_cast<std::size_t>(i)];
      for (int k = 0; k < 3; ++k)
        ASSERT_EQ(static_cast<float>(ours[k]), static_cast<float>(p[k])) << path << " point " << i;
    }
    vtkIdType n = 0;
    const vtkIdType* ids = nullptr;
    std::size_t f = 0;
    vtkCellArray* polys = poly->GetPolys();
    for (polys->InitTraversal(); polys->GetNextCell(n, ids);)
      for (vtkIdType k = 1; k + 1 < n; ++k, ++f) {
        ASSERT_LT(f, r.mesh.face_count());
        const Face expected = {static_cast<std::int32_t>(ids[0]), static_cast<std::int32_t>(ids[k]),
                               static_cast<std::int32_t>(ids[k + 1])};
        ASSERT_EQ(r.mesh.faces[f], expected) << path;
      }
    EXPECT_EQ(f, r.mesh.face_count());
    EXPECT_EQ(r.info.binary, path.filename() == "fran_binary.vtk");
    EXPECT_EQ(r.mesh.space, path == original ? Space::lps : Space::ras) << path;
  }
}

TEST(ReadSpeed, IgeaBinaryPlyAndFemurStlAreFast) {
  // Generous bound for a shared 2-core machine; the measured time is printed.
  for (const char* relative : {"classic/c3d_igea.ply", "anatomy/bones/gfxmorph_femur.stl",
                               "classic/c3d_stanford-bunny.obj"}) {
    double best = 1e9;
    for (int repeat = 0; repeat < 3; ++repeat) {
      const auto start = std::chrono::steady_clock::now();
      const auto r = io::read_mesh(mesh_path(relative));
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      best = std::min(best, ms);
      ASSERT_GT(r.mesh.face_count(), 0u);
    }
    std::cout << "[ timing ] read " << relative << ": " << best << " ms\n";
    EXPECT_LT(best, 500.0 * test::kTimeScale) << relative;
  }
}

}  // namespace
}  // namespace fabrica
