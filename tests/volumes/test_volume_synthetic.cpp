// Synthetic volumes written by the test itself: orientation (a blob placed
// off-centre lands where the header says, mirrored axes do not mirror the
// surface), labels and names of .seg.nrrd files, and clear errors.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <numbers>
#include <sstream>

#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "test_support.hpp"
#include "volume_test_util.hpp"

using namespace fabrica;
using fabrica::io::ExtractOptions;
using fabrica::io::VolumeGeometry;

namespace {

constexpr double kPi = std::numbers::pi;

// Two spheres of different size and a bar: no mirror symmetry, so a flipped
// axis would show. Centres in LPS mm.
const Vec3 kBig(12.0, -20.0, 35.0);
const Vec3 kSmall(22.0, -12.0, 41.0);
constexpr double kBigR = 7.0, kSmallR = 4.0;

int two_spheres(const Vec3& p) {
  if ((p - kBig).norm() <= kBigR) return 1;
  if ((p - kSmall).norm() <= kSmallR) return 2;
  return 0;
}

// A geometry whose voxel grid covers both spheres with margin.
VolumeGeometry grid(const Mat3& direction, const Vec3& spacing) {
  VolumeGeometry g;
  g.direction = direction;
  g.spacing = spacing;
  // Choose dims and origin so the box [lo, hi] (LPS) is covered.
  const Vec3 lo(0.0, -32.0, 22.0), hi(32.0, -2.0, 52.0);
  Vec3 start = Vec3::Zero();
  for (int a = 0; a < 3; ++a) {
    const Vec3 axis = direction.col(a);
    double s_min = 1e300, s_max = -1e300;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 c((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                   (corner & 4) ? hi.z() : lo.z());
      s_min = std::min(s_min, axis.dot(c));
      s_max = std::max(s_max, axis.dot(c));
    }
    g.dims[a] = static_cast<int>(std::ceil((s_max - s_min) / spacing[a])) + 1;
    start += axis * s_min;
  }
  // direction is orthonormal: origin = sum over axes of its start projection.
  g.origin = start;
  return g;
}

Mat3 rotation(double ax, double ay, double az) {
  return (Eigen::AngleAxisd(az, Vec3::UnitZ()) * Eigen::AngleAxisd(ay, Vec3::UnitY()) *
          Eigen::AngleAxisd(ax, Vec3::UnitX()))
      .toRotationMatrix();
}

ExtractOptions light_smoothing() {
  ExtractOptions o;
  o.smoothing_iterations = 10;
  return o;
}

// Extract both labels and check they sit where the spheres are (LPS), point
// outward, close, and enclose the right volume.
void expect_two_spheres(const io::LabelVolume& volume, double tolerance_mm) {
  const auto surfaces = io::extract_surfaces(volume, light_smoothing());
  ASSERT_EQ(surfaces.size(), 2u);
  const Vec3 centres[2] = {kBig, kSmall};
  const double radii[2] = {kBigR, kSmallR};
  for (int s = 0; s < 2; ++s) {
    SCOPED_TRACE("label " + std::to_string(s + 1));
    const auto& surface = surfaces[s];
    EXPECT_EQ(surface.label, s + 1);
    ASSERT_FALSE(surface.mesh.empty()) << surface.problem;
    EXPECT_EQ(surface.mesh.space, Space::lps);
    const Vec3 c = test::volume_centroid(surface.mesh);
    EXPECT_LT((c - centres[s]).norm(), tolerance_mm)
        << "centroid " << c.transpose() << " expected " << centres[s].transpose();
    const double v = test::enclosed_volume(surface.mesh);
    const double expected = 4.0 / 3.0 * kPi * std::pow(radii[s], 3);
    EXPECT_GT(v, 0.0) << "faces point inward";
    EXPECT_NEAR(v, expected, 0.12 * expected);
    const auto [open, misoriented] = test::open_and_misoriented_edges(surface.mesh);
    EXPECT_EQ(open, 0u);
    EXPECT_EQ(misoriented, 0u);
  }
}

std::string as_string(const std::vector<std::uint8_t>& v) {
  return test::as_bytes(v);
}

}  // namespace

TEST(VolumeOrientation, NrrdLpsWithNegativeSpaceDirections) {
  const auto dir = test::temp_dir("vol-nrrd-neg");
  Mat3 d = Mat3::Identity();
  d(0, 0) = -1.0;  // i runs towards the right
  d(2, 2) = -1.0;  // k runs downwards
  const VolumeGeometry g = grid(d, Vec3(0.8, 1.0, 1.25));
  const auto labels = test::sample_labels(g, two_spheres);
  std::array<Vec3, 3> axes;
  for (int a = 0; a < 3; ++a) axes[a] = g.direction.col(a) * g.spacing[a];
  test::write_nrrd(dir / "neg.nrrd", g.dims, axes, g.origin, "left-posterior-superior",
                   as_string(labels), "uchar", false);
  const io::LabelVolume volume = io::read_label_volume(dir / "neg.nrrd");
  EXPECT_EQ(volume.format, "nrrd");
  EXPECT_TRUE(volume.integer_labels);
  EXPECT_EQ(volume.geometry.dims, g.dims);
  EXPECT_TRUE(volume.geometry.direction.isApprox(d, 1e-12));
  EXPECT_TRUE(volume.geometry.origin.isApprox(g.origin, 1e-12));
  expect_two_spheres(volume, 0.3);
}

TEST(VolumeOrientation, NrrdRasGzipIsConvertedToLps) {
  const auto dir = test::temp_dir("vol-nrrd-ras");
  const VolumeGeometry g = grid(rotation(0.3, -0.2, 0.5), Vec3(1.0, 0.9, 1.1));
  const auto labels = test::sample_labels(g, two_spheres);
  // Same grid, written in RAS: negate x and y of every vector and the origin.
  const Eigen::DiagonalMatrix<double, 3> ras(-1.0, -1.0, 1.0);
  std::array<Vec3, 3> axes;
  for (int a = 0; a < 3; ++a) axes[a] = ras * (g.direction.col(a) * g.spacing[a]);
  test::write_nrrd(dir / "ras.nrrd", g.dims, axes, ras * g.origin, "right-anterior-superior",
                   as_string(labels), "unsigned char", true);
  const io::LabelVolume volume = io::read_label_volume(dir / "ras.nrrd");
  EXPECT_TRUE(volume.geometry.direction.isApprox(g.direction, 1e-12));
  expect_two_spheres(volume, 0.3);
}

TEST(VolumeOrientation, MetaImageTransformMatrixIsApplied) {
  const auto dir = test::temp_dir("vol-mha");
  // A rotation with a mirrored axis (det = -1).
  Mat3 d = rotation(0.4, 0.1, -0.7);
  d.col(1) *= -1.0;
  const VolumeGeometry g = grid(d, Vec3(0.9, 0.9, 1.3));
  const auto labels = test::sample_labels(g, two_spheres);
  test::write_mha(dir / "blob.mha", g, as_string(labels), "MET_UCHAR", true);
  const io::LabelVolume volume = io::read_label_volume(dir / "blob.mha");
  EXPECT_EQ(volume.format, "metaimage");
  EXPECT_TRUE(volume.geometry.direction.isApprox(d, 1e-12));
  EXPECT_LT(volume.geometry.direction.determinant(), 0.0);
  expect_two_spheres(volume, 0.3);
}

TEST(VolumeOrientation, NiftiSformIsAppliedAndRasBecomesLps) {
  const auto dir = test::temp_dir("vol-nifti");
  Mat3 d = rotation(-0.2, 0.35, 0.15);
  d.col(0) *= -1.0;  // mirrored first axis
  const VolumeGeometry g = grid(d, Vec3(1.1, 0.95, 1.2));
  const auto labels = test::sample_labels(g, two_spheres);
  Eigen::Matrix<double, 3, 4> sform;
  const Eigen::DiagonalMatrix<double, 3> ras(-1.0, -1.0, 1.0);
  sform.leftCols<3>() = ras * g.direction * g.spacing.asDiagonal();
  sform.col(3) = ras * g.origin;
  for (const bool gz : {false, true}) {
    const auto path = dir / (gz ? "blob.nii.gz" : "blob.nii");
    test::write_nifti(path, g.dims, sform, labels, gz);
    const io::LabelVolume volume = io::read_label_volume(path);
    EXPECT_EQ(volume.format, "nifti");
    EXPECT_TRUE(volume.geometry.direction.isApprox(d, 1e-6));
    EXPECT_TRUE(volume.geometry.spacing.isApprox(g.spacing, 1e-6));
    expect_two_spheres(volume, 0.3);
  }
}

TEST(VolumeOrientation, NiftiQformWithNegativeQfac) {
  // No sform: the quaternion gives a proper rotation R and qfac = -1 mirrors
  // the k axis. Pick the LPS axes first, then derive R (RAS) from them.
  const auto dir = test::temp_dir("vol-nifti-qform");
  Mat3 d = rotation(0.25, -0.3, 0.6);
  d.col(2) *= -1.0;  // det -1
  VolumeGeometry g = grid(d, Vec3(0.9, 1.0, 1.2));
  const Eigen::DiagonalMatrix<double, 3> ras(-1.0, -1.0, 1.0);
  const Mat3 r = ras * d * Eigen::DiagonalMatrix<double, 3>(1.0, 1.0, -1.0);
  ASSERT_NEAR(r.determinant(), 1.0, 1e-12);
  // The header stores floats: snap the geometry to what the file can hold.
  const Eigen::Quaterniond q(r);
  const Vec3 offset = (ras * g.origin).cast<float>().cast<double>();
  test::write_nifti_qform(dir / "q.nii", g.dims, q, -1.0f, g.spacing, offset,
                          test::sample_labels(g, two_spheres));
  const io::LabelVolume volume = io::read_label_volume(dir / "q.nii");
  EXPECT_NE(volume.orientation_source.find("qform"), std::string::npos);
  EXPECT_TRUE(volume.geometry.direction.isApprox(d, 1e-6)) << volume.geometry.direction;
  EXPECT_LT(volume.geometry.direction.determinant(), 0.0);
  expect_two_spheres(volume, 0.3);
}

TEST(VolumeFormats, DetachedBigEndianAndTextData) {
  const auto dir = test::temp_dir("vol-formats");
  const VolumeGeometry g = grid(Mat3::Identity(), Vec3(1.0, 1.0, 1.0));
  const auto labels = test::sample_labels(g, two_spheres);
  std::string big;  // int16 big endian
  for (std::uint8_t v : labels) {
    big.push_back('\0');
    big.push_back(static_cast<char>(v));
  }
  // NRRD detached header (.nhdr) + raw data file, big endian.
  test::write_bytes(dir / "data.raw", big);
  std::ostringstream h;
  h << "NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: " << g.dims[0]
    << " " << g.dims[1] << " " << g.dims[2]
    << "\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nendian: big\nencoding: raw\n"
    << "space origin: " << test::vec_text(g.origin) << "\ndata file: data.raw\n";
  test::write_bytes(dir / "vol.nhdr", h.str());
  expect_two_spheres(io::read_label_volume(dir / "vol.nhdr"), 0.3);

  // MetaImage .mhd + .raw, big endian, with HeaderSize = -1 (data at the end).
  test::write_bytes(dir / "meta.raw", std::string(100, 'x') + big);
  std::ostringstream m;
  m << "NDims = 3\nDimSize = " << g.dims[0] << " " << g.dims[1] << " " << g.dims[2]
    << "\nElementSpacing = 1 1 1\nOffset = " << g.origin.x() << " " << g.origin.y() << " "
    << g.origin.z() << "\nElementByteOrderMSB = True\nHeaderSize = -1\n"
    << "ElementType = MET_SHORT\nElementDataFile = meta.raw\n";
  test::write_bytes(dir / "meta.mhd", m.str());
  expect_two_spheres(io::read_label_volume(dir / "meta.mhd"), 0.3);

  // NRRD ascii.
  std::ostringstream a;
  a << "NRRD0004\ntype: int\ndimension: 3\nspace: LPS\nsizes: " << g.dims[0] << " " << g.dims[1]
    << " " << g.dims[2]
    << "\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nencoding: ascii\nspace origin: "
    << test::vec_text(g.origin) << "\n\n";
  for (std::uint8_t v : labels) a << int(v) << (v == 2 ? "\n" : " ");
  test::write_bytes(dir / "text.nrrd", a.str());
  expect_two_spheres(io::read_label_volume(dir / "text.nrrd"), 0.3);
}

TEST(VolumeExtraction, SameBitsAtAnyThreadCount) {
  const auto dir = test::temp_dir("vol-threads");
  const VolumeGeometry g = grid(rotation(0.1, 0.2, 0.3), Vec3(0.8, 0.8, 0.8));
  test::write_mha(dir / "t.mha", g, as_string(test::sample_labels(g, two_spheres)), "MET_UCHAR",
                  false);
  const io::LabelVolume volume = io::read_label_volume(dir / "t.mha");
  ExtractOptions o;
  o.decimate = 0.3;
  const auto many = io::extract_surfaces(volume, o);
  std::vector<io::ExtractedSurface> one;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = io::extract_surfaces(volume, o);
  }
  ASSERT_EQ(many.size(), one.size());
  for (std::size_t s = 0; s < many.size(); ++s) {
    ASSERT_EQ(many[s].mesh.faces, one[s].mesh.faces);
    ASSERT_EQ(many[s].mesh.positions, one[s].mesh.positions);
  }
}

TEST(VolumeExtraction, DecimationHalvesFacesAndKeepsTheShape) {
  const auto dir = test::temp_dir("vol-decimate");
  const VolumeGeometry g = grid(Mat3::Identity(), Vec3(0.5, 0.5, 0.5));
  test::write_mha(dir / "d.mha", g, as_string(test::sample_labels(g, two_spheres)), "MET_UCHAR",
                  true);
  const io::LabelVolume volume = io::read_label_volume(dir / "d.mha");
  ExtractOptions o;
  o.labels = {1};
  const auto full = io::extract_surfaces(volume, o);
  o.decimate = 0.5;
  const auto half = io::extract_surfaces(volume, o);
  ASSERT_EQ(full.size(), 1u);
  ASSERT_EQ(half.size(), 1u);
  const double ratio = static_cast<double>(half[0].mesh.face_count()) /
                       static_cast<double>(full[0].mesh.face_count());
  EXPECT_NEAR(ratio, 0.5, 0.05);
  EXPECT_EQ(test::open_and_misoriented_edges(half[0].mesh).first, 0u);
  const double expected = 4.0 / 3.0 * kPi * std::pow(kBigR, 3);
  EXPECT_NEAR(test::enclosed_volume(half[0].mesh), expected, 0.05 * expected);
  EXPECT_LT((test::volume_centroid(half[0].mesh) - kBig).norm(), 0.1);
  double worst = 0.0;
  for (const Vec3& p : half[0].mesh.positions)
    worst = std::max(worst, std::abs((p - kBig).norm() - kBigR));
  EXPECT_LT(worst, 0.5);  // one voxel
}

TEST(VolumeExtraction, ProgressAndCancel) {
  const auto dir = test::temp_dir("vol-progress");
  const VolumeGeometry g = grid(Mat3::Identity(), Vec3(1.0, 1.0, 1.0));
  test::write_mha(dir / "p.mha", g, as_string(test::sample_labels(g, two_spheres)), "MET_UCHAR",
                  false);
  const io::LabelVolume volume = io::read_label_volume(dir / "p.mha");
  ExtractOptions o;
  std::vector<std::size_t> calls;
  o.progress = [&](std::size_t done, std::size_t total) {
    calls.push_back(done * 10 + total);
    return true;
  };
  const auto all = io::extract_surfaces(volume, o);
  EXPECT_EQ(calls, (std::vector<std::size_t>{12, 22}));
  // Cancel after the first label (one thread: the second never starts).
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
  o.progress = [](std::size_t, std::size_t) { return false; };
  const auto cancelled = io::extract_surfaces(volume, o);
  ASSERT_EQ(cancelled.size(), 2u);
  EXPECT_EQ(std::count_if(cancelled.begin(), cancelled.end(),
                          [](const io::ExtractedSurface& s) { return s.problem == "cancelled"; }),
            1);
}

TEST(VolumeOrientation, MirroredEncodingsGiveTheSameSurface) {
  // The same physical object stored with identity axes and with every axis
  // reversed and permuted (det -1): the surfaces must coincide, not mirror.
  const auto dir = test::temp_dir("vol-mirror");
  const VolumeGeometry g1 = grid(Mat3::Identity(), Vec3(1.0, 1.0, 1.0));
  Mat3 p;
  p << 0, 0, 1,  //
      -1, 0, 0,  //
      0, 1, 0;   // columns: i -> -y, j -> +z, k -> +x; det = -1
  ASSERT_LT(p.determinant(), 0.0);
  const VolumeGeometry g2 = grid(p, Vec3(1.0, 1.0, 1.0));
  test::write_mha(dir / "a.mha", g1, as_string(test::sample_labels(g1, two_spheres)), "MET_UCHAR",
                  false);
  test::write_mha(dir / "b.mha", g2, as_string(test::sample_labels(g2, two_spheres)), "MET_UCHAR",
                  false);
  const auto a = io::extract_surfaces(io::read_label_volume(dir / "a.mha"), light_smoothing());
  const auto b = io::extract_surfaces(io::read_label_volume(dir / "b.mha"), light_smoothing());
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  for (int s = 0; s < 2; ++s) {
    const test::TriangleDistance to_a(a[s].mesh, 2.0);
    double worst = 0.0;
    for (const Vec3& q : b[s].mesh.positions) worst = std::max(worst, to_a(q));
    EXPECT_LT(worst, 0.6) << "label " << s + 1;
    EXPECT_GT(test::enclosed_volume(b[s].mesh), 0.0);
  }
}

TEST(VolumeOrientation, FloatLevelSetIsoSurface) {
  // Signed distance to a sphere, negative inside (a level set), on a grid
  // with a mirrored axis; the zero surface is the sphere.
  const auto dir = test::temp_dir("vol-levelset");
  Mat3 d = Mat3::Identity();
  d(1, 1) = -1.0;
  const VolumeGeometry g = grid(d, Vec3(0.7, 0.8, 0.9));
  std::vector<float> phi(g.voxel_count());
  std::size_t n = 0;
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i)
        phi[n++] =
            static_cast<float>((g.index_to_patient(Vec3(i, j, k)) - kBig).norm() - kBigR + 0.01);
  test::write_mha(dir / "phi.mha", g, test::as_bytes(phi), "MET_FLOAT", true);
  const io::LabelVolume volume = io::read_label_volume(dir / "phi.mha");
  EXPECT_FALSE(volume.integer_labels);
  EXPECT_THROW(io::extract_surfaces(volume), InputError);  // needs an iso value
  ExtractOptions o;
  o.iso_value = 0.0;
  const auto surfaces = io::extract_surfaces(volume, o);
  ASSERT_EQ(surfaces.size(), 1u);
  const TriangleMesh& m = surfaces[0].mesh;
  ASSERT_FALSE(m.empty()) << surfaces[0].problem;
  double worst = 0.0;
  for (const Vec3& q : m.positions) worst = std::max(worst, std::abs((q - kBig).norm() - kBigR));
  EXPECT_LT(worst, 0.05);  // linear interpolation of a distance field is near exact
  EXPECT_GT(test::enclosed_volume(m), 0.0);
  o.iso_value = 1000.0;
  const auto none = io::extract_surfaces(volume, o);
  ASSERT_EQ(none.size(), 1u);
  EXPECT_TRUE(none[0].mesh.empty());
  EXPECT_NE(none[0].problem.find("iso value"), std::string::npos);
}

TEST(SegNrrd, LayeredSegmentsKeepNamesColoursAndLayers) {
  // 4D layered segmentation: two layers, overlapping segments. Layer 0 holds
  // "big" (value 1) and "small" (value 2); layer 1 holds "bar" (value 1),
  // which overlaps the big sphere.
  const auto dir = test::temp_dir("vol-seg");
  const VolumeGeometry g = grid(Mat3::Identity(), Vec3(1.0, 1.0, 1.0));
  const auto layer0 = test::sample_labels(g, two_spheres);
  const Vec3 bar_lo(6.0, -24.0, 30.0), bar_hi(26.0, -16.0, 38.0);
  const auto layer1 = test::sample_labels(g, [&](const Vec3& p) {
    return (p.array() >= bar_lo.array()).all() && (p.array() <= bar_hi.array()).all() ? 1 : 0;
  });
  std::string interleaved(2 * layer0.size(), '\0');
  for (std::size_t v = 0; v < layer0.size(); ++v) {
    interleaved[2 * v] = static_cast<char>(layer0[v]);
    interleaved[2 * v + 1] = static_cast<char>(layer1[v]);
  }
  const std::string segments =
      "Segment0_ID:=Segment_1\nSegment0_Name:=Big sphere\nSegment0_Color:=1 0 0\n"
      "Segment0_LabelValue:=1\nSegment0_Layer:=0\n"
      "Segment1_ID:=Segment_2\nSegment1_Name:=small/sphere\nSegment1_Color:=0 1 0\n"
      "Segment1_LabelValue:=2\nSegment1_Layer:=0\n"
      "Segment2_ID:=Segment_3\nSegment2_Name:=bar\nSegment2_Color:=0 0 0.5\n"
      "Segment2_LabelValue:=1\nSegment2_Layer:=1\n";
  std::array<Vec3, 3> axes{Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  test::write_nrrd(dir / "layers.seg.nrrd", g.dims, axes, g.origin, "left-posterior-superior",
                   interleaved, "uint8", true, segments, 2);
  const io::LabelVolume volume = io::read_label_volume(dir / "layers.seg.nrrd");
  EXPECT_EQ(volume.format, "seg.nrrd");
  ASSERT_EQ(volume.layers.size(), 2u);
  ASSERT_EQ(volume.labels.size(), 3u);
  EXPECT_EQ(volume.labels[1].name, "small/sphere");
  ASSERT_TRUE(volume.labels[2].color.has_value());
  EXPECT_DOUBLE_EQ((*volume.labels[2].color)[2], 0.5);

  const auto surfaces = io::extract_surfaces(volume, light_smoothing());
  ASSERT_EQ(surfaces.size(), 3u);
  EXPECT_EQ(surfaces[0].name, "Big sphere");
  EXPECT_EQ(surfaces[1].name, "small/sphere");
  EXPECT_EQ(surfaces[2].name, "bar");
  EXPECT_EQ(surfaces[2].layer, 1);
  EXPECT_LT((test::volume_centroid(surfaces[0].mesh) - kBig).norm(), 0.3);
  EXPECT_LT((test::volume_centroid(surfaces[1].mesh) - kSmall).norm(), 0.3);
  EXPECT_LT((test::volume_centroid(surfaces[2].mesh) - 0.5 * (bar_lo + bar_hi)).norm(), 0.3);
  // Voxel counts are exact: the bar is 21 x 9 x 9 voxel centres.
  EXPECT_EQ(surfaces[2].voxel_count, 21u * 9u * 9u);

  // Selecting label 1 gives both segments with value 1 (one per layer).
  ExtractOptions only1 = light_smoothing();
  only1.labels = {1, 7};
  const auto some = io::extract_surfaces(volume, only1);
  ASSERT_EQ(some.size(), 3u);
  EXPECT_EQ(some[0].name, "Big sphere");
  EXPECT_EQ(some[1].name, "label_7_layer0");
  EXPECT_TRUE(some[1].mesh.empty());
  EXPECT_NE(some[1].problem.find("no voxels"), std::string::npos);
  EXPECT_EQ(some[2].name, "bar");
}

TEST(SegNrrd, ThreeDimensionalRawSegmentation) {
  const auto dir = test::temp_dir("vol-seg3d");
  const VolumeGeometry g = grid(Mat3::Identity(), Vec3(1.0, 1.0, 1.0));
  const auto labels = test::sample_labels(g, two_spheres);
  std::vector<std::int16_t> wide(labels.begin(), labels.end());
  for (auto& v : wide) v = static_cast<std::int16_t>(v * 5);  // values 5 and 10
  std::array<Vec3, 3> axes{Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  test::write_nrrd(dir / "s.seg.nrrd", g.dims, axes, g.origin, "LPS", test::as_bytes(wide), "short",
                   false,
                   "Segment0_Name:=liver\nSegment0_LabelValue:=10\nSegment0_Color:=0.8 0.4 0.3\n");
  const io::LabelVolume volume = io::read_label_volume(dir / "s.seg.nrrd");
  const auto counts = io::label_voxel_counts(volume);
  ASSERT_EQ(counts.size(), 1u);
  EXPECT_EQ(counts[0].size(), 2u);
  EXPECT_TRUE(counts[0].count(5) && counts[0].count(10));
  const auto surfaces = io::extract_surfaces(volume, light_smoothing());
  ASSERT_EQ(surfaces.size(), 2u);
  EXPECT_EQ(surfaces[0].name, "label_5");
  EXPECT_EQ(surfaces[1].name, "liver");
  EXPECT_LT((test::volume_centroid(surfaces[1].mesh) - kSmall).norm(), 0.3);
}

TEST(LabelVolume, NiftiLabelTableExtensionNamesLabels) {
  const auto dir = test::temp_dir("vol-nifti-names");
  const VolumeGeometry g = grid(Mat3::Identity(), Vec3(1.0, 1.0, 1.0));
  Eigen::Matrix<double, 3, 4> sform;
  sform.leftCols<3>() = Eigen::DiagonalMatrix<double, 3>(-1.0, -1.0, 1.0).toDenseMatrix();
  sform.col(3) = Vec3(-g.origin.x(), -g.origin.y(), g.origin.z());
  const std::string xml =
      "<?xml version=\"1.0\"?><CaretExtension><VolumeInformation Index=\"0\"><LabelTable>"
      "<Label Key=\"1\" Red=\"1\" Green=\"0\" Blue=\"0\" Alpha=\"1\"><![CDATA[spleen]]></Label>"
      "<Label Key=\"2\" Red=\"0\" Green=\"0\" Blue=\"1\" Alpha=\"1\"><![CDATA[kidney_right]]>"
      "</Label></LabelTable></VolumeInformation></CaretExtension>";
  test::write_nifti(dir / "named.nii.gz", g.dims, sform, test::sample_labels(g, two_spheres), true,
                    xml);
  const io::LabelVolume volume = io::read_label_volume(dir / "named.nii.gz");
  ASSERT_EQ(volume.labels.size(), 2u);
  EXPECT_EQ(volume.labels[0].name, "spleen");
  EXPECT_EQ(volume.labels[1].name, "kidney_right");
  ASSERT_TRUE(volume.labels[1].color.has_value());
  EXPECT_EQ((*volume.labels[1].color)[2], 1.0);
  expect_two_spheres(volume, 0.3);
}

TEST(LabelVolume, LabelNameTables) {
  const auto dir = test::temp_dir("vol-names");
  test::write_bytes(dir / "slicer.txt",
                    "# Slicer colour table\n0 background 0 0 0 0\n1 liver 221 130 101 255\n"
                    "2 aorta 0.8 0.1 0.1\n\n5 vein\n");
  const auto names = io::read_label_names(dir / "slicer.txt");
  ASSERT_EQ(names.size(), 4u);
  EXPECT_EQ(names[1].name, "liver");
  ASSERT_TRUE(names[1].color.has_value());
  EXPECT_NEAR((*names[1].color)[0], 221.0 / 255.0, 1e-12);
  EXPECT_NEAR((*names[2].color)[0], 0.8, 1e-12);
  EXPECT_FALSE(names[3].color.has_value());
  test::write_bytes(dir / "itksnap.txt",
                    "    1   255    0    0        1  1  1    \"Left kidney\"\n");
  const auto snap = io::read_label_names(dir / "itksnap.txt");
  ASSERT_EQ(snap.size(), 1u);
  EXPECT_EQ(snap[0].name, "Left kidney");
  EXPECT_NEAR((*snap[0].color)[0], 1.0, 1e-12);
  test::write_bytes(dir / "bad.txt", "liver 1\n");
  EXPECT_THROW(io::read_label_names(dir / "bad.txt"), InputError);
}

// ------------------------------------------------------------------ errors

namespace {

void expect_input_error(const std::filesystem::path& path, const std::string& fragment) {
  try {
    io::read_label_volume(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path.filename().string()), std::string::npos) << message;
    EXPECT_NE(message.find(fragment), std::string::npos)
        << "message '" << message << "' should mention '" << fragment << "'";
  }
}

}  // namespace

TEST(VolumeErrors, MissingAndGarbledFilesAreReported) {
  const auto dir = test::temp_dir("vol-errors");
  expect_input_error(dir / "missing.nii.gz", "not found");
  expect_input_error(dir / "missing.nrrd", "not found");

  test::write_bytes(dir / "garbage.nrrd", "this is not a volume\n\x01\x02");
  expect_input_error(dir / "garbage.nrrd", "not a NRRD");
  test::write_bytes(dir / "garbled.nrrd", "NRRD0004\ntype uchar\n\n");
  expect_input_error(dir / "garbled.nrrd", "garbled");
  test::write_bytes(dir / "nosizes.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nencoding: raw\n\n");
  expect_input_error(dir / "nosizes.nrrd", "sizes");

  // Truncated raw and gzip data.
  const std::array<Vec3, 3> axes{Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  test::write_nrrd(dir / "short.nrrd", {10, 10, 10}, axes, Vec3::Zero(), "LPS",
                   std::string(999, '\1'), "uchar", false);
  expect_input_error(dir / "short.nrrd", "truncated");
  const std::string full(1000, '\1');
  test::write_nrrd(dir / "cut.nrrd", {10, 10, 10}, axes, Vec3::Zero(), "LPS", full, "uchar", true);
  {
    std::string bytes;
    std::ifstream in(dir / "cut.nrrd", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    in.close();
    bytes.resize(bytes.size() - 12);
    test::write_bytes(dir / "cut.nrrd", bytes);
  }
  expect_input_error(dir / "cut.nrrd", "compressed");
  test::write_bytes(dir / "corrupt.nrrd",
                    "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\n"
                    "\x1f\x8b\x08\x00garbage-garbage-garbage");
  expect_input_error(dir / "corrupt.nrrd", "corrupt");

  // MetaImage without sizes, NIfTI with a broken header or 4D data.
  test::write_bytes(dir / "nodims.mha",
                    "ObjectType = Image\nNDims = 3\nElementType = MET_UCHAR\n"
                    "ElementDataFile = LOCAL\n");
  expect_input_error(dir / "nodims.mha", "DimSize");
  test::write_bytes(dir / "junk.mha", "\x89PNG\r\n\x1a\n not a header at all");
  expect_input_error(dir / "junk.mha", "MetaImage");
  test::write_bytes(dir / "junk.nii", std::string(400, 'x'));
  expect_input_error(dir / "junk.nii", "not a NIfTI");
  test::write_bytes(dir / "tiny.nii.gz", test::gzip_bytes("abc"));
  expect_input_error(dir / "tiny.nii.gz", "too short");
  Eigen::Matrix<double, 3, 4> sform = Eigen::Matrix<double, 3, 4>::Identity();
  test::write_nifti(dir / "cut.nii", {8, 8, 8}, sform, std::vector<std::uint8_t>(100, 1), false);
  expect_input_error(dir / "cut.nii", "truncated");
  test::write_bytes(dir / "what.xyz", "hello");
  expect_input_error(dir / "what.xyz", "unknown volume format");
}

TEST(VolumeErrors, NonFiniteValuesAndBadOptions) {
  const auto dir = test::temp_dir("vol-nan");
  VolumeGeometry g;
  g.dims = {4, 4, 4};
  std::vector<float> values(64, 0.5f);
  values[17] = std::numeric_limits<float>::quiet_NaN();
  test::write_mha(dir / "nan.mha", g, test::as_bytes(values), "MET_FLOAT", false);
  expect_input_error(dir / "nan.mha", "not finite");

  std::vector<std::uint8_t> labels(64, 0);
  labels[21] = 3;
  test::write_mha(dir / "one.mha", g, test::as_bytes(labels), "MET_UCHAR", false);
  const io::LabelVolume volume = io::read_label_volume(dir / "one.mha");
  ExtractOptions bad;
  bad.smoothing_passband = 2.5;
  EXPECT_THROW(io::extract_surfaces(volume, bad), InputError);
  bad = {};
  bad.decimate = 1.0;
  EXPECT_THROW(io::extract_surfaces(volume, bad), InputError);
  // A single voxel still yields a closed (octahedron-like) surface.
  ExtractOptions raw;
  raw.smoothing_iterations = 0;
  const auto one = io::extract_surfaces(volume, raw);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].label, 3);
  EXPECT_EQ(one[0].voxel_count, 1u);
  ASSERT_FALSE(one[0].mesh.empty());
  EXPECT_EQ(test::open_and_misoriented_edges(one[0].mesh).first, 0u);
  EXPECT_GT(test::enclosed_volume(one[0].mesh), 0.0);
  // A voxel at the border of the volume still closes (padding).
  labels.assign(64, 0);
  labels[0] = 1;
  test::write_mha(dir / "corner.mha", g, test::as_bytes(labels), "MET_UCHAR", false);
  const auto corner = io::extract_surfaces(io::read_label_volume(dir / "corner.mha"), raw);
  ASSERT_EQ(corner.size(), 1u);
  EXPECT_EQ(test::open_and_misoriented_edges(corner[0].mesh).first, 0u);
}

TEST(VolumeErrors, HeadersDeclaringTooMuchOrAbsurdGeometryAreRefusedWhenRead) {
  // Issue 15's adversarial findings: each was read without complaint and
  // failed only when meshes were written (exit 3), or crashed (std::stoi).
  const auto dir = test::temp_dir("vol-limits");
  auto nrrd = [](const std::string& extra, const std::string& sizes = "2 2 2",
                 const std::string& encoding = "ascii") {
    return "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " + sizes + "\nencoding: " + encoding +
           "\n" + extra + "\n0 1 0 1 0 1 0 1\n";
  };
  test::write_bytes(dir / "index.seg.nrrd", nrrd("Segment4294967296_Name:=a\n"));
  expect_input_error(dir / "index.seg.nrrd", "too large");
  test::write_bytes(dir / "value.seg.nrrd", nrrd("Segment0_LabelValue:=4294967296\n"));
  expect_input_error(dir / "value.seg.nrrd", "32-bit");
  test::write_bytes(dir / "name.seg.nrrd", nrrd("Segment0_Name:=\xc3\x28 bad\n"));
  expect_input_error(dir / "name.seg.nrrd", "UTF-8");
  test::write_bytes(dir / "ascii.nrrd", nrrd("", "1000 1000 1000"));
  expect_input_error(dir / "ascii.nrrd", "header describes");
  test::write_bytes(dir / "huge.nrrd", nrrd("", "100000 100000 100000", "raw"));
  expect_input_error(dir / "huge.nrrd", "voxels");
  test::write_bytes(dir / "gz.nrrd", nrrd("", "1000 1000 1000", "gzip"));
  expect_input_error(dir / "gz.nrrd", "compressed");
  test::write_bytes(dir / "comma.nrrd", nrrd("spacings: 1 , 1\n"));  // fuzz_nrrd finding
  expect_input_error(dir / "comma.nrrd", "spacings");
  test::write_bytes(dir / "spacing.nrrd", nrrd("spacings: 1e23 1 1\n"));
  expect_input_error(dir / "spacing.nrrd", "spacing");
  test::write_bytes(dir / "origin.nrrd",
                    nrrd("space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (1e308,0,0)\n"));
  expect_input_error(dir / "origin.nrrd", "mm from the origin");
  Eigen::Matrix<double, 3, 4> sform = Eigen::Matrix<double, 3, 4>::Identity();
  sform(0, 0) = 1e30;
  test::write_nifti(dir / "srow.nii", {2, 2, 2}, sform, std::vector<std::uint8_t>(8, 1), false);
  expect_input_error(dir / "srow.nii", "spacing");
  test::write_bytes(dir / "names.txt", "1 \"caf\xe9\"\n");
  try {
    (void)io::read_label_names(dir / "names.txt");
    ADD_FAILURE() << "a Latin-1 label name was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("UTF-8"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)io::read_label_volume("/dev/zero"), InputError);
  std::vector<std::uint8_t> labels(8, 1);
  VolumeGeometry g;
  g.dims = {2, 2, 2};
  test::write_mha(dir / "one.mha", g, test::as_bytes(labels), "MET_UCHAR", false);
  ExtractOptions tiny;
  tiny.smoothing_passband = 1e-308;
  EXPECT_THROW(io::extract_surfaces(io::read_label_volume(dir / "one.mha"), tiny), InputError);
}
