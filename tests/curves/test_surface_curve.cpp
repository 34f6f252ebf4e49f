// SurfaceCurve helpers: edge-point conversion, snapping, common faces,
// validation errors, and the discrete geodesic curvature (turning angles),
// checked against the discrete Gauss–Bonnet theorem.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "curve_test_helpers.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/curve_smoothing.hpp"
#include "fabrica/core/surface_curve.hpp"
#include "fabrica/core/topology.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

constexpr double kPi = std::numbers::pi;

// Angle defect 2 pi - sum of corner angles at vertex v.
double angle_defect(const TriangleMesh& m, const Topology& t, std::size_t v) {
  double sum = 0.0;
  const auto faces = t.vertex_faces(v);
  const auto corners = t.vertex_face_corners(v);
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const Face& F = m.faces[static_cast<std::size_t>(faces[i])];
    const int k = corners[i];
    const Vec3 a = m.positions[F[(k + 1) % 3]] - m.positions[v];
    const Vec3 b = m.positions[F[(k + 2) % 3]] - m.positions[v];
    sum += std::atan2(a.cross(b).norm(), a.dot(b));
  }
  return 2.0 * kPi - sum;
}

}  // namespace

TEST(SurfaceCurve, EdgePointRoundTripAndPosition) {
  const auto mesh = test::make_torus(3.0, 1.0, 10, 8, 0.2);
  const Topology topo(mesh);
  for (std::size_t e = 0; e < topo.edge_count(); e += 7)
    for (const double t : {0.1, 0.5, 0.93}) {
      const EdgePoint ep{static_cast<std::int32_t>(e), t};
      const SurfacePoint sp = from_edge_point(mesh, topo, ep);
      const auto back = to_edge_point(mesh, topo, sp);
      ASSERT_TRUE(back.has_value());
      EXPECT_EQ(back->edge, ep.edge);
      EXPECT_NEAR(back->t, t, 1e-15);
      const auto& ed = topo.edge(e);
      const Vec3 expected = (1 - t) * mesh.positions[ed[0]] + t * mesh.positions[ed[1]];
      EXPECT_LT((sp.position(mesh) - expected).norm(), 1e-14);
      EXPECT_FALSE(to_vertex(mesh, sp).has_value());
    }
  EXPECT_THROW(from_edge_point(mesh, topo, EdgePoint{-1, 0.5}), InputError);
  EXPECT_THROW(from_edge_point(mesh, topo, EdgePoint{0, 1.5}), InputError);
  EXPECT_THROW(from_edge_point(mesh, topo, EdgePoint{0, std::nan("")}), InputError);
}

TEST(SurfaceCurve, SnappingPutsPointsExactlyOnEdgesAndVertices) {
  const auto mesh = test::make_plane(1.0, 3);
  const Topology topo(mesh);
  SurfacePoint p{0, Vec3(1e-12, 0.4, 0.6 - 1e-12)};
  const SurfacePoint q = snap_barycentrics(p);
  EXPECT_EQ(q.bary[0], 0.0);
  EXPECT_DOUBLE_EQ(q.bary.sum(), 1.0);
  const auto ep = to_edge_point(mesh, topo, p);
  ASSERT_TRUE(ep.has_value());
  EXPECT_EQ(ep->edge, topo.face_edge(0, 0));
  const SurfacePoint corner{3, Vec3(-1e-13, 1.0, 2e-13)};
  const auto v = to_vertex(mesh, corner);
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(*v, mesh.faces[3][1]);
  EXPECT_FALSE(to_edge_point(mesh, topo, corner).has_value());
  EXPECT_FALSE(to_edge_point(mesh, topo, SurfacePoint{0, Vec3(0.2, 0.3, 0.5)}).has_value());
}

TEST(SurfaceCurve, CommonFaceOfEdgeAndVertexPoints) {
  const auto mesh = test::make_plane(4.0, 5);  // 4x4 squares, 32 faces
  const Topology topo(mesh);
  // A vertex point and an edge point of a face opposite it.
  const SurfacePoint a{0, Vec3(1, 0, 0)};  // vertex 0
  const SurfacePoint b{0, Vec3(0, 0.5, 0.5)};
  EXPECT_EQ(common_face(mesh, topo, a, b), 0);
  // Points in faces far apart share nothing.
  const SurfacePoint c{31, Vec3(0.2, 0.3, 0.5)};
  EXPECT_EQ(common_face(mesh, topo, a, c), -1);
  // The same edge point expressed in either face of its edge.
  const std::int32_t e = topo.face_edge(0, 1);
  ASSERT_EQ(topo.edge_faces(static_cast<std::size_t>(e)).size(), 2u);
  const SurfacePoint d = from_edge_point(mesh, topo, EdgePoint{e, 0.25});
  const std::int32_t other = topo.edge_faces(static_cast<std::size_t>(e))[1];
  const SurfacePoint inside_other{other, Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3)};
  EXPECT_EQ(common_face(mesh, topo, d, inside_other), other);
}

TEST(SurfaceCurve, ValidationNamesTheOffendingPoint) {
  const auto mesh = test::make_plane(4.0, 5);
  const Topology topo(mesh);
  SurfaceCurve good;
  good.points = {SurfacePoint{0, Vec3(1, 0, 0)}, SurfacePoint{0, Vec3(0, 0.5, 0.5)}};
  EXPECT_NO_THROW(validate_surface_curve(mesh, topo, good));
  EXPECT_NEAR(curve_length(mesh, good), (good.points[1].position(mesh) - mesh.positions[0]).norm(),
              1e-15);

  auto expect_error = [&](const SurfaceCurve& c, const std::string& fragment) {
    try {
      validate_surface_curve(mesh, topo, c, "my curve");
      ADD_FAILURE() << "no error for " << fragment;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("my curve"), std::string::npos) << msg;
      EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
    }
  };
  SurfaceCurve bad_face = good;
  bad_face.points[1].face = 32;
  expect_error(bad_face, "point 1 (face 32) has a face index out of range");
  SurfaceCurve nan_bary = good;
  nan_bary.points[1].bary[0] = std::nan("");
  expect_error(nan_bary, "point 1");
  SurfaceCurve not_summing = good;
  not_summing.points[1].bary = Vec3(0.0, 0.5, 0.6);
  expect_error(not_summing, "sum to 1");
  SurfaceCurve apart = good;
  apart.points[1] = SurfacePoint{31, Vec3(0.2, 0.3, 0.5)};
  expect_error(apart, "do not lie on a common face");
  SurfaceCurve two_closed = good;
  two_closed.closed = true;
  expect_error(two_closed, "at least 3 points");

  const auto other_mesh = test::make_plane(4.0, 6);
  EXPECT_THROW(validate_surface_curve(other_mesh, topo, good), InputError);

  // Smoothing additionally needs interior points on edges.
  SurfaceCurve inside;
  inside.points = {SurfacePoint{0, Vec3(1, 0, 0)}, SurfacePoint{0, Vec3(0.2, 0.3, 0.5)},
                   SurfacePoint{0, Vec3(0, 1, 0)}};
  EXPECT_NO_THROW(validate_surface_curve(mesh, topo, inside));
  EXPECT_THROW(smooth_surface_curve(mesh, topo, inside), InputError);
  CurveSmoothingOptions bad_step;
  bad_step.step = 0.0;
  EXPECT_THROW(smooth_surface_curve(mesh, topo, good, bad_step), InputError);
}

TEST(SurfaceCurve, StraightLineOnPlaneHasZeroTurning) {
  const auto mesh = test::make_plane(10.0, 11);
  const Topology topo(mesh);
  std::vector<double> f(mesh.vertex_count());
  for (std::size_t v = 0; v < f.size(); ++v)
    f[v] = mesh.positions[v].y() - 3.3 - 0.37 * mesh.positions[v].x();
  const SurfaceCurve line = test::level_set_curve(mesh, topo, f);
  ASSERT_FALSE(line.closed);
  ASSERT_GT(line.size(), 10u);
  for (const double a : geodesic_turning_angles(mesh, topo, line)) EXPECT_NEAR(a, 0.0, 1e-12);
}

TEST(SurfaceCurve, ClosedPlaneLoopTurnsByTwoPi) {
  const auto mesh = test::make_plane(10.0, 21);
  const Topology topo(mesh);
  std::vector<double> f(mesh.vertex_count());
  for (std::size_t v = 0; v < f.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    f[v] = std::hypot((p.x() - 5.1) / 3.0, (p.y() - 4.9) / 2.0) - 1.0;
  }
  const SurfaceCurve loop = test::level_set_curve(mesh, topo, f);
  ASSERT_TRUE(loop.closed);
  double sum = 0.0;
  for (const double a : geodesic_turning_angles(mesh, topo, loop)) sum += a;
  EXPECT_NEAR(std::abs(sum), 2.0 * kPi, 1e-10);
}

// Discrete Gauss–Bonnet: for a closed curve of edge points bounding a disc
// D, the total signed turning is 2 pi minus the angle defects of the
// vertices inside D. Checks the edge unfolding exactly on a curved mesh.
TEST(SurfaceCurve, TurningObeysDiscreteGaussBonnetOnSphere) {
  const auto mesh = test::make_sphere(1.0, 12, 24);
  const Topology topo(mesh);
  for (const double z0 : {0.61, 0.23, -0.4}) {
    std::vector<double> f(mesh.vertex_count());
    double enclosed_defect = 0.0;
    for (std::size_t v = 0; v < f.size(); ++v) {
      const Vec3& p = mesh.positions[v];
      f[v] = p.z() - z0 - 0.1 * p.x() + 0.05 * p.y();  // a tilted, off-centre loop
      if (f[v] > 0.0) enclosed_defect += angle_defect(mesh, topo, v);
    }
    const SurfaceCurve loop = test::level_set_curve(mesh, topo, f);
    ASSERT_TRUE(loop.closed);
    double sum = 0.0;
    for (const double a : geodesic_turning_angles(mesh, topo, loop)) sum += a;
    EXPECT_NEAR(std::abs(sum), std::abs(2.0 * kPi - enclosed_defect), 1e-9) << "z0 = " << z0;
    EXPECT_NEAR(total_absolute_turning(mesh, topo, loop), std::abs(2.0 * kPi - enclosed_defect),
                1e-9)
        << "a convex loop turns one way only";
  }
}

// A vertex passage: Polthier–Schmies turning is 0 when the curve halves the
// vertex angle, and pi - (the angle on the inner side) on a flat vertex.
TEST(SurfaceCurve, TurningAtVerticesFollowsPolthierSchmies) {
  const auto flat = test::make_fan(8, Vec3(0, 0, 0), [](int) { return 0.0; });
  const Topology topo(flat);
  const auto straight = test::vertex_path_curve(flat, topo, {1, 0, 5});
  EXPECT_NEAR(geodesic_turning_angles(flat, topo, straight)[1], 0.0, 1e-12);
  const auto bent = test::vertex_path_curve(flat, topo, {1, 0, 3});  // 90 degrees
  EXPECT_NEAR(std::abs(geodesic_turning_angles(flat, topo, bent)[1]), kPi / 2, 1e-12);
  // Left and right turns have opposite signs.
  const auto bent_other = test::vertex_path_curve(flat, topo, {1, 0, 7});
  EXPECT_NEAR(geodesic_turning_angles(flat, topo, bent)[1],
              -geodesic_turning_angles(flat, topo, bent_other)[1], 1e-12);
  // Seen from +z, 1 -> 0 -> 3 heads west then north: a right turn, negative.
  EXPECT_LT(geodesic_turning_angles(flat, topo, bent)[1], 0.0);
}
