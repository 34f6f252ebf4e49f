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
#include "fabrica/hatching/confis.hpp"
#include "fabrica/hatching/curvature_field.hpp"
#include "fabrica/hatching/svg_writer.hpp"
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

// ---------------------------------------------------------------------------
// Streamlines

namespace {

Camera view_of(const Surface& s, const Vec3& towards_eye, int size) {
  Camera c;
  c.center = s.bounding_sphere_center();
  const double r = s.bounding_sphere_radius();
  c.fov_deg = 30.0;
  c.eye = c.center + towards_eye.normalized() * (1.05 * r / std::sin(15.0 * kPi / 180.0));
  c.up = std::abs(towards_eye.normalized().z()) > 0.9 ? Vec3::UnitY() : Vec3::UnitZ();
  c.width = c.height = size;
  return c;
}

/// Length-weighted mean angle (degrees) between stroke segments and a line field.
template <class E1>
double mean_stroke_angle(const StrokeSet& strokes, E1 e1) {
  double sum = 0.0, weight = 0.0;
  for (const Stroke& st : strokes.strokes)
    for (std::size_t k = 0; k + 1 < st.vertices.size(); ++k) {
      const Vec3 d = st.vertices[k + 1].position - st.vertices[k].position;
      const double len = d.norm();
      if (!(len > 0.0)) continue;
      const Vec3 mid = 0.5 * (st.vertices[k + 1].position + st.vertices[k].position);
      const double c = std::min(1.0, std::abs(d.dot(e1(mid))) / len);
      sum += len * std::acos(c) * 180.0 / kPi;
      weight += len;
    }
  return weight > 0.0 ? sum / weight : 180.0;
}

double interpolate(const Surface& s, const std::vector<double>& values, const SurfacePoint& p) {
  const Face& t = s.faces()[static_cast<std::size_t>(p.face)];
  return p.bary[0] * values[t[0]] + p.bary[1] * values[t[1]] + p.bary[2] * values[t[2]];
}

/// Counts stroke vertices outside margin ∪ feature regions (beyond `tol`);
/// checks every number is finite and the weights are in [min_weight, 1].
std::size_t outside_masks(const Surface& s, const Camera& cam, const StrokeSet& strokes,
                          const ConfisOptions& o, double tol = 1e-6) {
  const ContourMargin m = compute_contour_margin(s, cam, o.contour_margin);
  const FeatureRegions r = compute_feature_regions(s, o.feature_regions, o.field.umbilic_threshold);
  std::size_t outside = 0;
  for (const Stroke& st : strokes.strokes)
    for (const StrokeVertex& v : st.vertices) {
      EXPECT_TRUE(v.position.allFinite());
      EXPECT_TRUE(v.pixel.allFinite());
      EXPECT_GE(v.weight, o.min_weight - 1e-12);
      EXPECT_LE(v.weight, 1.0);
      const double facing = interpolate(s, m.facing, v.anchor);
      const bool in_margin = o.contours && facing >= -tol && facing < o.contour_margin + tol;
      const bool in_feature = o.features && interpolate(s, r.level, v.anchor) >= -tol;
      if (!in_margin && !in_feature) ++outside;
    }
  return outside;
}

std::size_t vertex_count(const StrokeSet& strokes) {
  std::size_t n = 0;
  for (const Stroke& st : strokes.strokes) n += st.vertices.size();
  return n;
}

}  // namespace

TEST(Confis, TorusStreamlinesFollowTheMaximalCurvatureDirection) {
  const double R = 3.0, r = 1.0;
  Surface s(test::make_torus(R, r, 160, 64, 0.2));
  const Camera cam = view_of(s, Vec3(0.2, -0.6, 1.0), 600);
  ConfisOptions o;  // k1 · s_f = s_f: with thresholds 0.01 all of the torus is a feature region
  o.feature_regions.convex_threshold = o.feature_regions.concave_threshold = 0.01;
  const StrokeSet strokes = confis(s, cam, o);
  ASSERT_GT(strokes.strokes.size(), 30u);
  const double angle = mean_stroke_angle(strokes, [&](const Vec3& p) { return torus_e1(p, R); });
  RecordProperty("mean_angle_deg", std::to_string(angle));
  EXPECT_LT(angle, 3.0);  // measured 1.2°
  EXPECT_EQ(outside_masks(s, cam, strokes, o), 0u);
}

TEST(Confis, TorusContourOnlyStaysInTheMargin) {
  Surface s(test::make_torus(3.0, 1.0, 160, 64, 0.2));
  const Camera cam = view_of(s, Vec3(0.2, -0.6, 1.0), 600);
  ConfisOptions o;
  o.features = false;
  o.contour_margin = 0.25;
  const StrokeSet strokes = confis(s, cam, o);
  ASSERT_GT(strokes.strokes.size(), 10u);
  EXPECT_EQ(outside_masks(s, cam, strokes, o), 0u);
  // And the margin really limits them: with the whole torus a feature
  // region there are many more.
  ConfisOptions all = o;
  all.features = true;
  all.feature_regions.convex_threshold = all.feature_regions.concave_threshold = 0.01;
  EXPECT_GT(vertex_count(confis(s, cam, all)), 2 * vertex_count(strokes));
}

TEST(Confis, EllipsoidStreamlinesFollowTheFieldAndRespectTheMasks) {
  const double a = 3.0, b = 2.0, c = 1.2;
  Surface s(test::make_ellipsoid(a, b, c, 100, 200));
  const Camera cam = view_of(s, Vec3(0.3, -1.0, 0.6), 600);
  ConfisOptions o;
  o.feature_regions.convex_threshold = 0.75 * (a / (c * c)) * s.feature_size();
  o.contour_margin = 0.25;
  const StrokeSet strokes = confis(s, cam, o);
  ASSERT_GT(strokes.strokes.size(), 20u);
  EXPECT_EQ(outside_masks(s, cam, strokes, o), 0u);
  const double angle =
      mean_stroke_angle(strokes, [&](const Vec3& p) { return ellipsoid_e1(p, a, b, c); });
  RecordProperty("mean_angle_deg", std::to_string(angle));
  EXPECT_LT(angle, 3.0);  // measured 1.1°
  // Feature strokes exist away from the contour (at the long axis' ends).
  const ContourMargin m = compute_contour_margin(s, cam, o.contour_margin);
  std::size_t feature_only = 0;
  for (const Stroke& st : strokes.strokes)
    for (const StrokeVertex& v : st.vertices)
      if (interpolate(s, m.facing, v.anchor) > o.contour_margin + 0.05) ++feature_only;
  EXPECT_GT(feature_only, 20u);
}

TEST(Confis, SphereGivesOnlyContourMarginStrokes) {
  Surface s(test::make_icosphere(1.0, 5));
  const Camera cam = view_of(s, Vec3(0.1, 0.2, 1.0), 500);
  ConfisOptions o;
  const StrokeSet strokes = confis(s, cam, o);
  ASSERT_GT(strokes.strokes.size(), 10u);
  ConfisOptions margin_only = o;
  margin_only.features = false;
  EXPECT_EQ(outside_masks(s, cam, strokes, margin_only), 0u);
  // Features alone: nothing (the whole sphere is umbilic).
  ConfisOptions features_only = o;
  features_only.contours = false;
  EXPECT_TRUE(confis(s, cam, features_only).strokes.empty());
}

TEST(Confis, DeterministicAtOneTwoAndEightThreads) {
  std::string reference;
  for (int threads : {1, 2, 8}) {
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
    Surface s(test::make_torus(3.0, 1.0, 120, 48, 0.3));
    const Camera cam = view_of(s, Vec3(0.4, -0.5, 1.0), 500);
    const std::string svg = hatching_svg(confis(s, cam, ConfisOptions{}));
    if (reference.empty())
      reference = svg;
    else
      EXPECT_EQ(svg, reference) << threads << " threads";
  }
  EXPECT_NE(reference.find("stroke-opacity"), std::string::npos);  // weights are drawn
}

TEST(Confis, SpacingIsKept) {
  Surface s(test::make_torus(3.0, 1.0, 160, 64, 0.2));
  const Camera cam = view_of(s, Vec3(0.2, -0.6, 1.0), 600);
  ConfisOptions o;
  o.spacing_px = 8.0;
  const StrokeSet strokes = confis(s, cam, o);
  const int level = confis_spacing_level(600, 8.0);
  EXPECT_EQ(strokes.seed_depth, level);
  EXPECT_EQ(strokes.grid_depth, level + 2);
  // Seeds keep s_level from earlier strokes; a stroke's points keep at least
  // half of it (level + 2) from strokes made before it.
  const double half = 600.0 / std::pow(std::sqrt(2.0), level + 2);
  for (std::size_t i = 1; i < strokes.strokes.size(); i += 7) {
    const Vec2 p = strokes.strokes[i].vertices[strokes.strokes[i].seed_vertex].pixel;
    for (std::size_t j = 0; j < i; ++j)
      for (const StrokeVertex& v : strokes.strokes[j].vertices)
        ASSERT_GE((v.pixel - p).norm(), half) << i << " vs " << j;
  }
}

TEST(Confis, BadOptionsAndMismatchedPrecomputeAreInputErrors) {
  Surface s(test::make_icosphere(1.0, 2));
  const Camera cam = view_of(s, Vec3(0, 0, 1), 100);
  ConfisOptions o;
  o.spacing_px = 0.0;
  EXPECT_THROW(confis(s, cam, o), InputError);
  o = {};
  o.contours = o.features = false;
  EXPECT_THROW(confis(s, cam, o), InputError);
  o = {};
  o.contour_margin = 0.0;
  EXPECT_THROW(confis(s, cam, o), InputError);
  Surface other(test::make_icosphere(1.0, 1));
  EXPECT_THROW(confis(s, cam, precompute_confis(other)), InputError);
}
