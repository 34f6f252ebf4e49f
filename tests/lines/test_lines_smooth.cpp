// Smoothing chained feature lines on the surface (lines/smooth.hpp):
// invariants (on the surface, closed stays closed, counts, fixed points and
// attributes), less geodesic curvature on a jittered torus, agreement with
// the analytic contour circle of a sphere, determinism across thread
// counts, and no failure on real meshes with every family.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numbers>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/surface_curve.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/smooth.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

Camera camera_at(const Vec3& eye, int size = 512) {
  Camera c;
  c.eye = eye;
  c.center = Vec3::Zero();
  c.up = Vec3::UnitZ();
  if (std::abs(eye.normalized().z()) > 0.9) c.up = Vec3::UnitY();
  c.fov_deg = 40.0;
  c.width = c.height = size;
  return c;
}

LineSet lines_for(const Surface& s, const Camera& cam, std::vector<LineFamily> fams,
                  double feature_size = 0.0) {
  LineOptions o;
  o.families = std::move(fams);
  o.feature_size = feature_size;
  LineExtractor ex(s, o);
  return chain_segments(ex.extract(cam));
}

SurfaceCurve to_curve(const Polyline& pl) {
  SurfaceCurve c;
  c.closed = pl.closed;
  for (const auto& v : pl.vertices) c.points.push_back(v.anchor);
  return c;
}

/// Whether face f holds p: p's corners with nonzero weight are corners of f.
bool face_holds(const TriangleMesh& mesh, std::int32_t f, const SurfacePoint& p) {
  if (f < 0 || static_cast<std::size_t>(f) >= mesh.face_count()) return false;
  const Face& F = mesh.faces[static_cast<std::size_t>(f)];
  const Face& P = mesh.faces[static_cast<std::size_t>(p.face)];
  for (int k = 0; k < 3; ++k)
    if (std::abs(p.bary[k]) > 1e-9 && std::find(F.begin(), F.end(), P[k]) == F.end()) return false;
  return true;
}

/// Every point on the surface (anchor valid, position = anchor's position to
/// 1e-9), consecutive points in a common face, edge_faces consistent.
void expect_on_surface(const Surface& s, const LineSet& lines, const char* what) {
  const TriangleMesh& mesh = s.mesh();
  const Topology& topo = s.topology();
  for (std::size_t p = 0; p < lines.polylines.size(); ++p) {
    const Polyline& pl = lines.polylines[p];
    const std::size_t n = pl.vertices.size();
    ASSERT_GE(n, 2u) << what << " polyline " << p;
    for (std::size_t i = 0; i < n; ++i) {
      const auto& v = pl.vertices[i];
      ASSERT_GE(v.anchor.face, 0);
      ASSERT_LT(static_cast<std::size_t>(v.anchor.face), mesh.face_count());
      ASSERT_LE((v.anchor.position(mesh) - v.position).norm(), 1e-9)
          << what << " polyline " << p << " point " << i;
      ASSERT_TRUE(std::isfinite(v.strength));
      ASSERT_GE(v.strength, 0.0f);
      ASSERT_LE(v.strength, 1.0f);
    }
    const std::size_t segs = pl.closed ? n : n - 1;
    if (!pl.edge_faces.empty()) {
      ASSERT_EQ(pl.edge_faces.size(), segs);
    }
    for (std::size_t i = 0; i < segs; ++i) {
      ASSERT_GE(common_face(mesh, topo, pl.vertices[i].anchor, pl.vertices[(i + 1) % n].anchor), 0)
          << what << " polyline " << p << " segment " << i;
      if (!pl.edge_faces.empty()) {
        for (const auto* v : {&pl.vertices[i], &pl.vertices[(i + 1) % n]})
          ASSERT_TRUE(face_holds(mesh, pl.edge_faces[i], v->anchor))
              << what << " polyline " << p << " segment " << i << " is not in its edge face";
      }
    }
    EXPECT_NO_THROW(validate_surface_curve(mesh, topo, to_curve(pl)));
  }
}

bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

bool same_lines(const LineSet& a, const LineSet& b) {
  if (a.polylines.size() != b.polylines.size()) return false;
  for (std::size_t p = 0; p < a.polylines.size(); ++p) {
    const auto &x = a.polylines[p], &y = b.polylines[p];
    if (x.family != y.family || x.closed != y.closed || x.vertices.size() != y.vertices.size() ||
        x.edge_faces != y.edge_faces)
      return false;
    for (std::size_t i = 0; i < x.vertices.size(); ++i) {
      const auto &u = x.vertices[i], &v = y.vertices[i];
      for (int k = 0; k < 3; ++k)
        if (!same_bits(u.position[k], v.position[k]) ||
            !same_bits(u.anchor.bary[k], v.anchor.bary[k]))
          return false;
      if (u.anchor.face != v.anchor.face || u.visible != v.visible ||
          std::memcmp(&u.strength, &v.strength, sizeof(float)) != 0)
        return false;
    }
  }
  return true;
}

struct JitteredTorus {
  Surface surface{test::make_torus(2.0, 0.7, 160, 64, 0.3)};
  Camera camera = camera_at(Vec3(0.3, -6.0, 3.0));
};

}  // namespace

TEST(LinesSmooth, JitteredTorusContoursLoseTurningAndStayOnTheSurface) {
  JitteredTorus t;
  const LineSet before =
      lines_for(t.surface, t.camera, {LineFamily::contour, LineFamily::suggestive}, 0.1);
  ASSERT_GT(before.polylines.size(), 1u);
  LineSet after = before;
  LineSmoothingOptions o;
  o.iterations = 5;
  const LineSmoothingStats st = smooth_lines(after, t.surface, o);

  ASSERT_EQ(after.polylines.size(), before.polylines.size());
  EXPECT_EQ(st.polylines, before.polylines.size());
  EXPECT_EQ(st.smoothed + st.too_short + st.invalid + st.collapsed, st.polylines);
  EXPECT_EQ(st.invalid, 0u);
  EXPECT_GT(st.smoothed, 0u);
  expect_on_surface(t.surface, after, "smoothed torus lines");

  const TriangleMesh& mesh = t.surface.mesh();
  const Topology& topo = t.surface.topology();
  double turning_before = 0.0, turning_after = 0.0;
  std::size_t loops = 0;
  for (std::size_t p = 0; p < before.polylines.size(); ++p) {
    const Polyline &a = before.polylines[p], &b = after.polylines[p];
    EXPECT_EQ(a.closed, b.closed) << p;
    EXPECT_EQ(a.family, b.family) << p;
    loops += a.closed ? 1 : 0;
    const double ta = total_absolute_turning(mesh, topo, to_curve(a));
    const double tb = total_absolute_turning(mesh, topo, to_curve(b));
    EXPECT_LE(tb, ta + 1e-9) << "polyline " << p;
    EXPECT_LE(b.length(), a.length() * (1.0 + 1e-9)) << "polyline " << p;
    if (!a.closed) {  // open ends stay where they were, exactly
      EXPECT_TRUE(same_bits(a.vertices.front().position.x(), b.vertices.front().position.x()));
      EXPECT_TRUE(same_bits(a.vertices.back().position.z(), b.vertices.back().position.z()));
    }
    turning_before += ta;
    turning_after += tb;
  }
  EXPECT_GT(loops, 0u);
  // The zig-zag of the jittered mesh is most of the turning: far less remains.
  EXPECT_LT(turning_after, 0.5 * turning_before)
      << "before " << turning_before << " after " << turning_after;
  EXPECT_LE(st.length_after, st.length_before);
  EXPECT_LT(st.length_after, 0.99 * st.length_before);
}

TEST(LinesSmooth, MoreIterationsSmoothMore) {
  JitteredTorus t;
  const LineSet before = lines_for(t.surface, t.camera, {LineFamily::contour});
  double previous = std::numeric_limits<double>::infinity();
  for (int it : {1, 3, 10}) {
    LineSet l = before;
    LineSmoothingOptions o;
    o.iterations = it;
    smooth_lines(l, t.surface, o);
    double turning = 0.0;
    for (const auto& pl : l.polylines)
      turning += total_absolute_turning(t.surface.mesh(), t.surface.topology(), to_curve(pl));
    EXPECT_LT(turning, previous) << it << " iterations";
    previous = turning;
  }
}

TEST(LinesSmooth, ZeroIterationsAndOtherFamiliesAreUntouched) {
  JitteredTorus t;
  const LineSet before =
      lines_for(t.surface, t.camera, {LineFamily::contour, LineFamily::ridge}, 0.1);
  LineSet l = before;
  LineSmoothingOptions o;
  o.iterations = 0;
  smooth_lines(l, t.surface, o);
  EXPECT_TRUE(same_lines(l, before));

  o.iterations = 5;
  o.families = {LineFamily::ridge};
  smooth_lines(l, t.surface, o);
  std::size_t ridges = 0;
  for (std::size_t p = 0; p < l.polylines.size(); ++p) {
    if (l.polylines[p].family != LineFamily::contour) {
      ++ridges;
      continue;
    }
    LineSet a, b;
    a.polylines = {l.polylines[p]};
    b.polylines = {before.polylines[p]};
    EXPECT_TRUE(same_lines(a, b)) << "contour polyline " << p << " was changed";
  }
  EXPECT_GT(ridges, 0u);
}

TEST(LinesSmooth, BoundariesAreNotSmoothedByDefault) {
  Surface cyl(test::make_cylinder(1.0, 2.0, 20, 48));
  const Camera cam = camera_at(Vec3(0.5, -6.0, 2.0));
  const LineSet before = lines_for(cyl, cam, {LineFamily::boundary, LineFamily::contour});
  std::size_t boundaries = 0;
  for (const auto& pl : before.polylines) boundaries += pl.family == LineFamily::boundary;
  ASSERT_GT(boundaries, 0u);
  LineSet l = before;
  smooth_lines(l, cyl);
  for (std::size_t p = 0; p < l.polylines.size(); ++p)
    if (l.polylines[p].family == LineFamily::boundary) {
      LineSet a, b;
      a.polylines = {l.polylines[p]};
      b.polylines = {before.polylines[p]};
      EXPECT_TRUE(same_lines(a, b));
    }
  expect_on_surface(cyl, l, "cylinder");
}

// The contour of a unit sphere seen from (0,0,d) is the circle z = 1/d,
// radius sqrt(1 - 1/d^2). A few iterations keep it there (the loop shrinks
// only by O(iterations h^2 kappa_g)), and never leave the surface.
TEST(LinesSmooth, SphereContourStaysOnTheAnalyticCircle) {
  const double d = 4.0;
  Surface sphere(test::make_icosphere(1.0, 5));
  const Camera cam = camera_at(Vec3(0.0, 0.0, d));
  const LineSet before = lines_for(sphere, cam, {LineFamily::contour});
  ASSERT_EQ(before.polylines.size(), 1u);
  ASSERT_TRUE(before.polylines[0].closed);
  LineSet after = before;
  LineSmoothingOptions o;
  o.iterations = 5;
  const auto st = smooth_lines(after, sphere, o);
  EXPECT_EQ(st.smoothed, 1u);
  ASSERT_EQ(after.polylines.size(), 1u);
  EXPECT_TRUE(after.polylines[0].closed);
  expect_on_surface(sphere, after, "sphere contour");
  const double z0 = 1.0 / d, rho0 = std::sqrt(1.0 - z0 * z0);
  auto deviation = [&](const Polyline& pl) {
    double worst = 0.0;
    for (const auto& v : pl.vertices) {
      const Vec3& p = v.position;
      const double rho = std::hypot(p.x(), p.y());
      worst = std::max(worst, std::hypot(p.z() - z0, rho - rho0));
    }
    return worst;
  };
  const double dev_before = deviation(before.polylines[0]);
  const double dev_after = deviation(after.polylines[0]);
  // Icosphere level 5: edges ~0.038; the interpolated contour lies within
  // ~0.003 of the circle.
  EXPECT_LT(dev_before, 0.004);
  EXPECT_LT(dev_after, 0.006) << "before " << dev_before;
  const double circumference = 2.0 * std::numbers::pi * rho0;
  EXPECT_NEAR(after.polylines[0].length(), circumference, 0.005 * circumference);
}

TEST(LinesSmooth, PointsInsideFacesAndOpenEndsAreKeptWithTheirAttributes) {
  JitteredTorus t;
  LineSet lines = lines_for(t.surface, t.camera, {LineFamily::contour});
  // Take the longest loop and the longest loop again as an open polyline;
  // insert face-centroid points (like ridge centroid joins) into both and
  // give them a strength ramp.
  std::size_t longest = 0;
  for (std::size_t p = 0; p < lines.polylines.size(); ++p)
    if (lines.polylines[p].closed &&
        (!lines.polylines[longest].closed ||
         lines.polylines[p].vertices.size() > lines.polylines[longest].vertices.size()))
      longest = p;
  ASSERT_TRUE(lines.polylines[longest].closed);
  ASSERT_GT(lines.polylines[longest].vertices.size(), 60u);
  const TriangleMesh& mesh = t.surface.mesh();
  const Topology& topo = t.surface.topology();
  auto with_centroids = [&](Polyline pl, bool closed) {
    pl.closed = closed;
    std::vector<LineVertex> out;
    const std::size_t n = pl.vertices.size();
    for (std::size_t i = 0; i < n; ++i) {
      out.push_back(pl.vertices[i]);
      if (i % 25 == 10 && i + 1 < n) {
        const std::int32_t f =
            common_face(mesh, topo, pl.vertices[i].anchor, pl.vertices[i + 1].anchor);
        LineVertex c;
        c.anchor = {f, Vec3::Constant(1.0 / 3.0)};
        c.position = c.anchor.position(mesh);
        out.push_back(c);
      }
    }
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i].strength = static_cast<float>(i) / static_cast<float>(out.size() - 1);
    pl.vertices = out;
    pl.edge_faces.clear();
    return pl;
  };
  LineSet input;
  input.polylines = {with_centroids(lines.polylines[longest], true),
                     with_centroids(lines.polylines[longest], false)};
  LineSet out = input;
  LineSmoothingOptions o;
  o.iterations = 8;
  const auto st = smooth_lines(out, t.surface, o);
  EXPECT_EQ(st.smoothed, 2u);
  EXPECT_GT(st.fixed_points, 4u);
  expect_on_surface(t.surface, out, "with centroids");
  for (int k = 0; k < 2; ++k) {
    const Polyline &a = input.polylines[k], &b = out.polylines[k];
    EXPECT_EQ(b.closed, k == 0);
    // Every centroid is still there, in order, bit for bit, with its strength.
    std::size_t j = 0;
    for (const auto& v : a.vertices) {
      if (v.anchor.bary[0] != 1.0 / 3.0) continue;
      while (j < b.vertices.size() && !(b.vertices[j].anchor.face == v.anchor.face &&
                                        b.vertices[j].anchor.bary == v.anchor.bary))
        ++j;
      ASSERT_LT(j, b.vertices.size()) << "a centroid point was lost or reordered";
      EXPECT_TRUE(same_bits(b.vertices[j].position.y(), v.position.y()));
      EXPECT_EQ(b.vertices[j].strength, v.strength);
    }
    if (k == 1) {
      EXPECT_EQ(b.vertices.front().strength, 0.0f);
      EXPECT_EQ(b.vertices.back().strength, 1.0f);
      // Strength follows arc length: still increasing along the open line.
      for (std::size_t i = 1; i < b.vertices.size(); ++i)
        EXPECT_GE(b.vertices[i].strength, b.vertices[i - 1].strength) << i;
    }
    EXPECT_LT(total_absolute_turning(mesh, topo, to_curve(b)),
              total_absolute_turning(mesh, topo, to_curve(a)));
  }
}

TEST(LinesSmooth, BrokenPolylinesAreLeftUnchangedAndCounted) {
  JitteredTorus t;
  LineSet lines = lines_for(t.surface, t.camera, {LineFamily::contour});
  // The two first polylines with at least 4 points.
  std::stable_partition(lines.polylines.begin(), lines.polylines.end(),
                        [](const Polyline& pl) { return pl.vertices.size() >= 4; });
  ASSERT_GE(lines.polylines.size(), 2u);
  ASSERT_GE(lines.polylines[1].vertices.size(), 4u);
  // Polyline 0: a jump to a far-away face (no common face with its neighbours).
  Polyline& a = lines.polylines[0];
  ASSERT_GE(a.vertices.size(), 4u);
  const std::int32_t far =
      (a.vertices[1].anchor.face + static_cast<std::int32_t>(t.surface.face_count() / 2)) %
      static_cast<std::int32_t>(t.surface.face_count());
  a.vertices[1].anchor = {far, Vec3(0.2, 0.3, 0.5)};
  a.vertices[1].position = a.vertices[1].anchor.position(t.surface.mesh());
  // Polyline 1: a NaN barycentric coordinate and a face index out of range.
  lines.polylines[1].vertices[1].anchor.bary[0] = std::nan("");
  Polyline bad_face = lines.polylines[1];
  bad_face.vertices[1].anchor = {static_cast<std::int32_t>(t.surface.face_count()),
                                 Vec3(1.0, 0.0, 0.0)};
  lines.polylines.push_back(bad_face);
  // A closed loop of two points.
  Polyline tiny = lines.polylines.back();
  tiny.vertices.resize(2);
  tiny.closed = true;
  lines.polylines.push_back(tiny);
  const LineSet before = lines;
  LineSmoothingOptions o;
  o.iterations = 5;
  const auto st = smooth_lines(lines, t.surface, o);
  EXPECT_EQ(st.invalid, 4u);
  EXPECT_EQ(st.smoothed + st.invalid + st.too_short + st.collapsed, lines.polylines.size());
  for (std::size_t p :
       {std::size_t{0}, std::size_t{1}, lines.polylines.size() - 2, lines.polylines.size() - 1}) {
    LineSet x, y;
    x.polylines = {lines.polylines[p]};
    y.polylines = {before.polylines[p]};
    // NaN != NaN, so compare bits.
    EXPECT_TRUE(same_lines(x, y)) << "polyline " << p;
  }
}

// The smoothing is intrinsic: the same lines on a rotated, moved and scaled
// copy of the mesh give the same lines, moved and scaled. Not to rounding:
// the discrete steps (vertex snapping, removals) may decide a near tie
// differently, which moves a few points by up to ~1e-3 edge lengths.
TEST(LinesSmooth, SameAnchorsUnderRigidMotionAndScaling) {
  JitteredTorus t;
  const LineSet lines =
      lines_for(t.surface, t.camera, {LineFamily::contour, LineFamily::suggestive}, 0.1);
  TriangleMesh moved = t.surface.mesh();
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, -0.5).normalized()).toRotationMatrix();
  for (auto& p : moved.positions) p = 3.0 * (R * p) + Vec3(10.0, -4.0, 2.5);
  Surface other(moved);
  LineSet a = lines, b = lines;
  for (auto& pl : b.polylines)
    for (auto& v : pl.vertices) v.position = v.anchor.position(moved);
  LineSmoothingOptions o;
  o.iterations = 4;
  const auto sa = smooth_lines(a, t.surface, o);
  const auto sb = smooth_lines(b, other, o);
  EXPECT_EQ(sa.smoothed, sb.smoothed);
  EXPECT_NEAR(sb.length_after, 3.0 * sa.length_after, 1e-6 * sb.length_after);
  ASSERT_EQ(a.polylines.size(), b.polylines.size());
  for (std::size_t p = 0; p < a.polylines.size(); ++p) {
    const auto &x = a.polylines[p].vertices, &y = b.polylines[p].vertices;
    ASSERT_EQ(x.size(), y.size()) << "polyline " << p;
    for (std::size_t i = 0; i < x.size(); ++i) {
      // Compare positions (the anchor's face may differ for a point on an edge).
      const Vec3 expected = 3.0 * (R * x[i].position) + Vec3(10.0, -4.0, 2.5);
      EXPECT_LT((y[i].position - expected).norm(), 3.0 * 2e-4)
          << "polyline " << p << " point " << i;
      EXPECT_NEAR(y[i].strength, x[i].strength, 1e-3);
    }
  }
}

TEST(LinesSmooth, RejectsBadOptions) {
  JitteredTorus t;
  LineSet l;
  LineSmoothingOptions o;
  o.iterations = -1;
  EXPECT_THROW(smooth_lines(l, t.surface, o), InputError);
  o = {};
  o.step = 0.0;
  EXPECT_THROW(smooth_lines(l, t.surface, o), InputError);
  o = {};
  o.vertex_snap = 0.5;
  EXPECT_THROW(smooth_lines(l, t.surface, o), InputError);
}

namespace {

LineSet smoothed_with_threads(int threads, const TriangleMesh& mesh) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  Surface surface(mesh);
  const Camera cam = anatomical_camera(AnatomicalView::anterior, bounding_box(mesh.positions),
                                       mesh.space, 800, 600);
  LineOptions lo;
  lo.families = all_families();
  LineExtractor ex(surface, lo);
  LineSet lines = chain_segments(ex.extract(cam));
  LineSmoothingOptions o;
  o.iterations = 5;
  o.families = all_families();
  smooth_lines(lines, surface, o);
  return lines;
}

}  // namespace

TEST(LinesSmooth, SameBitsAtOneAndTwoThreads) {
  const auto path = test::bundled_data() / "meshes/anatomy/vessels/sofa_aneurysm3D_1.off";
  TriangleMesh mesh = io::read_mesh(path).mesh;
  io::prepare_for_lines(mesh);
  const LineSet one = smoothed_with_threads(1, mesh);
  const LineSet two = smoothed_with_threads(2, mesh);
  EXPECT_GT(one.polylines.size(), 20u);
  EXPECT_TRUE(same_lines(one, two));
}

// Every family on real meshes (igea: a noisy scan; a bone; the cortex):
// nothing thrown, every polyline accounted for, every point on the surface,
// lines never longer.
class LinesSmoothRealMesh : public ::testing::TestWithParam<const char*> {};

TEST_P(LinesSmoothRealMesh, EveryFamilySmoothsWithoutFailure) {
  TriangleMesh mesh = io::read_mesh(test::bundled_data() / "meshes" / GetParam()).mesh;
  io::prepare_for_lines(mesh);
  Surface surface(mesh);
  const Camera cam = anatomical_camera(AnatomicalView::anterior, bounding_box(mesh.positions),
                                       mesh.space, 800, 800);
  LineOptions lo;
  lo.families = all_families();
  LineExtractor ex(surface, lo);
  LineSet lines = chain_segments(ex.extract(cam));
  const LineSet before = lines;
  LineSmoothingOptions o;
  o.iterations = 5;
  o.families = all_families();
  LineSmoothingStats st;
  ASSERT_NO_THROW(st = smooth_lines(lines, surface, o));
  ASSERT_EQ(lines.polylines.size(), before.polylines.size());
  EXPECT_EQ(st.polylines, lines.polylines.size());
  EXPECT_EQ(st.smoothed + st.too_short + st.invalid + st.collapsed, st.polylines);
  EXPECT_EQ(st.invalid, 0u);
  EXPECT_GT(st.smoothed, st.polylines / 2);
  EXPECT_LE(st.length_after, st.length_before);
  for (std::size_t p = 0; p < lines.polylines.size(); ++p)
    EXPECT_EQ(lines.polylines[p].closed, before.polylines[p].closed);
  expect_on_surface(surface, lines, GetParam());
  RecordProperty("smoothed", static_cast<int>(st.smoothed));
  std::printf(
      "%s: %zu polylines, %zu smoothed, %zu too short, %zu collapsed, %zu fixed points, "
      "points %zu -> %zu, length %.1f -> %.1f\n",
      GetParam(), st.polylines, st.smoothed, st.too_short, st.collapsed, st.fixed_points,
      st.points_before, st.points_after, st.length_before, st.length_after);
}

INSTANTIATE_TEST_SUITE_P(Meshes, LinesSmoothRealMesh,
                         ::testing::Values("classic/c3d_igea.ply", "anatomy/bones/jigsaw_femur.stl",
                                           "anatomy/brain/fsaverage5/pial_left.off"));
