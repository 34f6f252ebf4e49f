// ConFIS (Lawonn, Moench & Preim 2013; docs/algorithms.md §9a): the shared
// maximal-curvature direction field, the feature regions and the contour
// margin on analytic surfaces (torus, ellipsoid, sphere), then the traced
// streamlines: along the analytic direction, inside the masks, deterministic.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/curvature_field.hpp"
#include "test_support.hpp"

using namespace fabrica;
using namespace fabrica::hatching;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Torus about z (major R, minor r): the maximal-curvature direction (|1/r|
/// > |cos v / (R + r cos v)| when R > 2r) runs around the tube: n × φ̂.
Vec3 torus_e1(const Vec3& p, double R) {
  const Vec3 axis_point = R * Vec3(p.x(), p.y(), 0.0).normalized();
  const Vec3 n = (p - axis_point).normalized();
  const Vec3 phi = Vec3(-p.y(), p.x(), 0.0).normalized();
  return n.cross(phi).normalized();
}

/// Ellipsoid x²/a² + y²/b² + z²/c² = 1: the tangent eigenvector of the shape
/// operator P H P / |∇F| with the eigenvalue of larger magnitude.
Vec3 ellipsoid_e1(const Vec3& p, double a, double b, double c) {
  const Vec3 grad(2 * p.x() / (a * a), 2 * p.y() / (b * b), 2 * p.z() / (c * c));
  const Vec3 n = grad.normalized();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  H(0, 0) = 2 / (a * a);
  H(1, 1) = 2 / (b * b);
  H(2, 2) = 2 / (c * c);
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - n * n.transpose();
  const Eigen::Matrix3d S = P * H * P / grad.norm();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(S);
  // One eigenvalue is 0 (the normal); take the largest of the other two
  // (all positive on an ellipsoid).
  int best = -1;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(es.eigenvectors().col(k).dot(n)) > 0.5) continue;
    if (best < 0 || std::abs(es.eigenvalues()[k]) > std::abs(es.eigenvalues()[best])) best = k;
  }
  return es.eigenvectors().col(best).normalized();
}

Vec3 centroid(const Surface& s, std::size_t f) {
  const Face& t = s.faces()[f];
  return (s.positions()[t[0]] + s.positions()[t[1]] + s.positions()[t[2]]) / 3.0;
}

/// Mean angle (degrees) between the reliable face directions and an analytic line field.
template <class E1>
double mean_field_angle(const Surface& s, const CurvatureField& field, E1 e1,
                        std::size_t* counted = nullptr) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t f = 0; f < s.face_count(); ++f) {
    if (!field.face_reliable[f]) continue;
    const double c = std::min(1.0, std::abs(field.face_direction[f].dot(e1(centroid(s, f)))));
    sum += std::acos(c) * 180.0 / kPi;
    ++n;
  }
  if (counted) *counted = n;
  return n ? sum / n : 180.0;
}

void expect_unit_tangent(const Surface& s, const CurvatureField& field) {
  for (std::size_t f = 0; f < s.face_count(); ++f) {
    const Vec3& d = field.face_direction[f];
    ASSERT_TRUE(d.allFinite()) << "face " << f;
    ASSERT_NEAR(d.norm(), 1.0, 1e-9) << "face " << f;
    ASSERT_NEAR(d.dot(s.face_normals()[f]), 0.0, 1e-9) << "face " << f;
  }
}

}  // namespace

TEST(CurvatureField, TorusFollowsTheTubeDirection) {
  const double R = 3.0, r = 1.0;
  Surface s(test::make_torus(R, r, 120, 48, 0.2));
  const CurvatureField field = compute_curvature_field(s);
  expect_unit_tangent(s, field);
  std::size_t counted = 0;
  const double angle = mean_field_angle(
      s, field, [&](const Vec3& p) { return torus_e1(p, R); }, &counted);
  EXPECT_EQ(counted, s.face_count());  // no umbilics on this torus
  EXPECT_LT(angle, 3.0);
  // The field is orientable on the torus: propagation leaves no seam.
  EXPECT_EQ(field.seam_edges, 0u);
}

TEST(CurvatureField, EllipsoidFollowsTheAnalyticDirectionAwayFromUmbilics) {
  const double a = 3.0, b = 2.0, c = 1.2;
  Surface s(test::make_ellipsoid(a, b, c, 80, 160));
  const CurvatureField field = compute_curvature_field(s);
  expect_unit_tangent(s, field);
  std::size_t counted = 0;
  const double angle = mean_field_angle(
      s, field, [&](const Vec3& p) { return ellipsoid_e1(p, a, b, c); }, &counted);
  EXPECT_GT(counted, s.face_count() * 8 / 10);
  EXPECT_LT(counted, s.face_count());  // the four umbilics are flagged
  EXPECT_LT(angle, 5.0);
}

TEST(CurvatureField, SphereIsUmbilicEverywhereAndStillDefined) {
  Surface s(test::make_icosphere(2.0, 4));
  const CurvatureField field = compute_curvature_field(s);
  expect_unit_tangent(s, field);
  EXPECT_EQ(field.reliable_faces, 0u);
  const FeatureRegions regions = compute_feature_regions(s);
  for (std::size_t v = 0; v < s.vertex_count(); ++v) {
    EXPECT_TRUE(regions.umbilic[v]);
    EXPECT_FALSE(regions.mask[v]);
    EXPECT_TRUE(std::isfinite(regions.scalar[v]));
  }
}

TEST(CurvatureField, EllipsoidFeatureRegionsAreTheStronglyCurvedEnds) {
  const double a = 3.0, b = 2.0, c = 1.2;
  Surface s(test::make_ellipsoid(a, b, c, 60, 120));
  FeatureRegionOptions options;
  // s = k1 · s_f; the ends of the long axis have k1 = a / c² (the largest),
  // the y ends b / c².
  const double sf = s.feature_size();
  options.convex_threshold = 0.75 * (a / (c * c)) * sf;  // above b / c² at the y ends
  const FeatureRegions regions = compute_feature_regions(s, options);
  std::size_t inside = 0;
  for (std::size_t v = 0; v < s.vertex_count(); ++v) {
    const Vec3& p = s.positions()[v];
    EXPECT_GT(regions.scalar[v], 0.0);  // convex everywhere, outward normals
    if (regions.mask[v]) {
      ++inside;
      EXPECT_GT(std::abs(p.x()), 0.5 * a) << v;  // only near the long axis' ends
      EXPECT_GE(regions.level[v], 0.0);
    } else {
      EXPECT_LT(regions.level[v], 0.0);
    }
    EXPECT_GE(regions.strength[v], 0.0);
    EXPECT_LE(regions.strength[v], 1.0);
  }
  EXPECT_GT(inside, 10u);
  EXPECT_LT(inside, s.vertex_count() / 2);
}

TEST(CurvatureField, ContourMarginIsTheGrazingBand) {
  Surface s(test::make_icosphere(1.0, 4));
  Camera cam;
  cam.projection = Projection::orthographic;
  cam.eye = Vec3(0, 0, 10);
  cam.center = Vec3::Zero();
  const double eps = 0.3;
  const ContourMargin m = compute_contour_margin(s, cam, eps);
  for (std::size_t v = 0; v < s.vertex_count(); ++v) {
    const double facing = s.vertex_normals()[v].z();
    EXPECT_NEAR(m.facing[v], facing, 1e-12);
    EXPECT_EQ(m.mask[v] != 0, facing >= 0.0 && facing < eps);
    if (m.mask[v]) EXPECT_NEAR(m.strength[v], 1.0 - facing / eps, 1e-12);
  }
  EXPECT_THROW(compute_contour_margin(s, cam, 0.0), InputError);
  EXPECT_THROW(compute_contour_margin(s, cam, 1.5), InputError);
}

TEST(CurvatureField, DeterministicAtAnyThreadCount) {
  Surface s(test::make_torus(3.0, 1.0, 90, 36, 0.3));
  s.precompute();
  std::vector<Vec3> ref;
  for (int threads : {1, 2, 8}) {
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
    const CurvatureField f = compute_curvature_field(s);
    if (ref.empty())
      ref = f.face_direction;
    else
      EXPECT_EQ(ref, f.face_direction) << threads << " threads";
  }
}

TEST(CurvatureField, BadOptionsAreInputErrors) {
  Surface s(test::make_icosphere(1.0, 1));
  CurvatureFieldOptions o;
  o.umbilic_threshold = -1.0;
  EXPECT_THROW(compute_curvature_field(s, o), InputError);
  o = {};
  o.min_coherence = 2.0;
  EXPECT_THROW(compute_curvature_field(s, o), InputError);
  FeatureRegionOptions r;
  r.convex_threshold = 0.0;
  EXPECT_THROW(compute_feature_regions(s, r), InputError);
}
