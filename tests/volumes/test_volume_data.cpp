// Real volumes from the bundled data (tests/data/, meshes/volumes): the TotalSegmentator
// label map (NIfTI, sform, label-table extension), the frog label map
// (MetaImage + zlib .zraw) and the vmtk aorta level set (MetaImage with a
// mirrored TransformMatrix) against the vmtk surface of the same aorta.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <set>

#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "sanitized.hpp"
#include "test_support.hpp"
#include "volume_test_util.hpp"

using namespace fabrica;

namespace {

std::filesystem::path volumes() {
  return test::bundled_data() / "meshes" / "volumes";
}

const io::ExtractedSurface& find(const std::vector<io::ExtractedSurface>& s, int label) {
  for (const auto& x : s)
    if (x.label == label) return x;
  throw std::runtime_error("label " + std::to_string(label) + " not extracted");
}

}  // namespace

TEST(VolumeData, TotalSegmentatorLabelMap) {
  const auto path = volumes() / "totalseg_example_seg.nii.gz";
  const io::LabelVolume volume = io::read_label_volume(path);
  EXPECT_EQ(volume.format, "nifti");
  EXPECT_EQ(volume.geometry.dims, (std::array<int, 3>{122, 101, 30}));
  EXPECT_TRUE(volume.geometry.spacing.isApprox(Vec3(3, 3, 3), 1e-6));
  // sform diag(3,3,3) in RAS -> LPS directions diag(-1,-1,1), origin x,y negated.
  EXPECT_TRUE(volume.geometry.direction.isApprox(Vec3(-1, -1, 1).asDiagonal().toDenseMatrix()));
  EXPECT_NEAR(volume.geometry.origin.x(), 177.95632934570312, 1e-4);
  EXPECT_NEAR(volume.geometry.origin.y(), -11.319000244140625, 1e-4);

  // The labels present are those listed in SOURCES.md.
  const std::set<int> expected = {1,  2,  3,   4,   5,   6,   7,   8,   9,   10,  11,  13,  14, 18,
                                  19, 20, 30,  31,  32,  33,  52,  63,  64,  79,  86,  87,  88, 89,
                                  98, 99, 100, 101, 102, 103, 110, 111, 112, 113, 114, 115, 117};
  const auto counts = io::label_voxel_counts(volume);
  ASSERT_EQ(counts.size(), 1u);
  std::set<int> present;
  for (const auto& [value, n] : counts[0]) present.insert(value);
  EXPECT_EQ(present, expected);

  const auto t0 = std::chrono::steady_clock::now();
  const auto surfaces = io::extract_surfaces(volume);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ measure  ] TotalSegmentator: %zu labels extracted in %.2f s\n", surfaces.size(),
              seconds);
  EXPECT_LT(seconds, 20.0 * test::kTimeScale);
  ASSERT_EQ(surfaces.size(), expected.size());

  // Names come from the label table in the NIfTI extension.
  EXPECT_EQ(find(surfaces, 5).name, "liver");
  EXPECT_EQ(find(surfaces, 1).name, "spleen");
  EXPECT_EQ(find(surfaces, 2).name, "kidney_right");
  EXPECT_EQ(find(surfaces, 52).name, "aorta");
  EXPECT_EQ(find(surfaces, 79).name, "spinal_cord");
  EXPECT_TRUE(find(surfaces, 5).color.has_value());

  std::size_t nonmanifold = 0, faces = 0;
  for (const auto& s : surfaces) {
    SCOPED_TRACE(s.name);
    ASSERT_FALSE(s.mesh.empty()) << s.problem;
    EXPECT_EQ(test::open_and_misoriented_edges(s.mesh).first, 0u);
    EXPECT_GT(test::enclosed_volume(s.mesh), 0.0);
    nonmanifold += test::nonmanifold_edges(s.mesh);
    faces += s.mesh.face_count();
  }
  std::printf("[ measure  ] TotalSegmentator: %zu faces, %zu non-manifold edges\n", faces,
              nonmanifold);
  // Smoothing keeps volume: the liver's mesh volume is close to its voxels'.
  const auto& liver = find(surfaces, 5);
  const double voxel_volume = static_cast<double>(liver.voxel_count) * 27.0;
  EXPECT_NEAR(test::enclosed_volume(liver.mesh), voxel_volume, 0.1 * voxel_volume);

  // Anatomy in LPS (+x left, +y posterior, +z superior).
  const auto centre = [&](int label) { return test::volume_centroid(find(surfaces, label).mesh); };
  EXPECT_LT(centre(5).x(), centre(1).x());    // liver right of spleen
  EXPECT_LT(centre(2).x(), centre(3).x());    // right kidney right of left kidney
  EXPECT_LT(centre(52).y(), centre(79).y());  // aorta anterior to spinal cord
  EXPECT_GT(centre(11).z(), centre(3).z());   // lung lobe above kidney
}

TEST(VolumeData, FrogLabelMap) {
  const auto path = volumes() / "frog" / "frogtissue.mhd";
  const io::LabelVolume volume = io::read_label_volume(path);
  EXPECT_EQ(volume.format, "metaimage");
  EXPECT_EQ(volume.geometry.dims, (std::array<int, 3>{500, 470, 136}));
  EXPECT_TRUE(volume.geometry.spacing.isApprox(Vec3(1, 1, 1.5)));
  io::ExtractOptions options;
  options.labels = {2, 6, 8};  // brain, heart, kidney
  const auto t0 = std::chrono::steady_clock::now();
  const auto surfaces = io::extract_surfaces(volume, options);
  std::printf("[ measure  ] frog: 3 labels in %.2f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  ASSERT_EQ(surfaces.size(), 3u);
  for (const auto& s : surfaces) {
    SCOPED_TRACE(s.name);
    ASSERT_FALSE(s.mesh.empty()) << s.problem;
    EXPECT_EQ(test::open_and_misoriented_edges(s.mesh).first, 0u);
    const double voxels = static_cast<double>(s.voxel_count) * 1.5;
    const double v = test::enclosed_volume(s.mesh);
    std::printf("[ measure  ] frog %s: %zu voxels (%.0f mm3), surface encloses %.0f mm3\n",
                s.name.c_str(), s.voxel_count, voxels, v);
    EXPECT_NEAR(v, voxels, 0.12 * voxels);
    // Every vertex lies inside the volume's extent.
    const BoundingBox box = bounding_box(s.mesh.positions);
    EXPECT_GE(box.min.minCoeff(), -1.0);
    EXPECT_LE(box.max.x(), 500.0);
  }
}

TEST(VolumeData, VmtkAortaLevelSetMatchesTheVmtkSurface) {
  const io::LabelVolume volume = io::read_label_volume(volumes() / "vmtk_aorta-final-levelset.mha");
  EXPECT_FALSE(volume.integer_labels);
  EXPECT_TRUE(volume.geometry.direction.isApprox(Vec3(-1, -1, 1).asDiagonal().toDenseMatrix()));
  io::ExtractOptions options;
  options.iso_value = 0.0;
  const auto surfaces = io::extract_surfaces(volume, options);
  ASSERT_EQ(surfaces.size(), 1u);
  const TriangleMesh& ours = surfaces[0].mesh;
  ASSERT_FALSE(ours.empty()) << surfaces[0].problem;
  EXPECT_GT(test::enclosed_volume(ours), 0.0);

  // vmtk writes world coordinates in RAS (x, y negated w.r.t. ITK's LPS).
  TriangleMesh vmtk = io::read_mesh(test::bundled_data() / "meshes" / "anatomy" / "vessels" /
                                    "vmtk_aorta-surface.stl")
                          .mesh;
  ASSERT_EQ(vmtk.faces.size(), 12932u);
  for (Vec3& p : vmtk.positions) p = Vec3(-p.x(), -p.y(), p.z());

  const double voxel = volume.geometry.spacing.minCoeff();
  const test::TriangleDistance to_vmtk(vmtk, 2.0), to_ours(ours, 2.0);
  // vmtk's surface is capped where the vessels leave the region of interest;
  // ours follows the level set further: measure from vmtk's vertices to ours
  // (every part of vmtk's surface must be matched) and ours -> vmtk near it.
  double sum = 0.0, worst = 0.0;
  for (const Vec3& p : vmtk.positions) {
    const double d = to_ours(p);
    sum += d;
    worst = std::max(worst, d);
  }
  const double mean_vmtk_to_ours = sum / static_cast<double>(vmtk.positions.size());
  double sum2 = 0.0;
  std::size_t near = 0;
  for (const Vec3& p : ours.positions) {
    const double d = to_vmtk(p);
    if (d < 5.0) {
      sum2 += d;
      ++near;
    }
  }
  const double mean_ours_to_vmtk = sum2 / static_cast<double>(std::max<std::size_t>(near, 1));
  std::printf(
      "[ measure  ] aorta: vmtk->ours mean %.2e max %.2e mm; ours->vmtk mean %.2e mm "
      "(%zu of %zu vertices within 5 mm); voxel %.3f mm\n",
      mean_vmtk_to_ours, worst, mean_ours_to_vmtk, near, ours.positions.size(), voxel);
  EXPECT_LT(mean_vmtk_to_ours, voxel);
  // vmtk's surface is the marching-cubes zero set of this very level set, so
  // with the orientation right the two coincide to float precision.
  EXPECT_LT(mean_vmtk_to_ours, 1e-3);
  EXPECT_LT(worst, 1e-2);
  EXPECT_LT(mean_ours_to_vmtk, voxel);
  EXPECT_GT(static_cast<double>(near), 0.5 * static_cast<double>(ours.positions.size()));
}
