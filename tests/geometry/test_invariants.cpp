// Invariants of the geometry core: areas, Laplacian, gradients, rigid
// motion, renumbering, scaling, degenerate and open inputs, determinism
// across thread counts, thread-safe lazy cache.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <thread>

#include "analytic.hpp"
#include "curvature_internal.hpp"  // the AVX2 fits' switch (core/src, private)
#include "fabrica/core/curvature.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/geometry.hpp"
#include "fabrica/core/laplacian.hpp"
#include "fabrica/core/surface.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

double total_area(const Surface& s) {
  double a = 0;
  for (double x : s.face_areas()) a += x;
  return a;
}

template <class T>
bool all_finite(const std::vector<T>& v) {
  for (const auto& x : v) {
    if constexpr (std::is_same_v<T, Vec3>) {
      if (!x.allFinite()) return false;
    } else if (!std::isfinite(static_cast<double>(x))) {
      return false;
    }
  }
  return true;
}

void expect_no_nan(const Surface& s) {
  s.precompute();
  EXPECT_TRUE(all_finite(s.face_normals()));
  EXPECT_TRUE(all_finite(s.face_areas()));
  EXPECT_TRUE(all_finite(s.corner_areas()));
  EXPECT_TRUE(all_finite(s.vertex_normals()));
  EXPECT_TRUE(all_finite(s.vertex_areas()));
  const auto& c = s.curvature();
  EXPECT_TRUE(all_finite(c.k1) && all_finite(c.k2) && all_finite(c.e1) && all_finite(c.e2));
  const auto& d = s.curvature_derivatives();
  EXPECT_TRUE(all_finite(d.a) && all_finite(d.b) && all_finite(d.c) && all_finite(d.d));
  EXPECT_TRUE(std::isfinite(s.feature_size()) && s.feature_size() > 0);
  for (std::size_t v = 0; v < s.vertex_count(); ++v)
    if (!c.valid[v]) {
      EXPECT_EQ(c.k1[v], 0.0);
      EXPECT_EQ(c.k2[v], 0.0);
      EXPECT_EQ(d.valid[v], 0);
      EXPECT_EQ(d.a[v], 0.0);
    }
}

TriangleMesh transformed(TriangleMesh m, const Mat3& R, const Vec3& t, double scale) {
  for (Vec3& p : m.positions) p = scale * (R * p) + t;
  return m;
}

// ---------------------------------------------------------------- areas

TEST(Areas, VoronoiAreasSumToSurfaceArea) {
  for (auto scheme : {MixedAreaScheme::clipped, MixedAreaScheme::meyer}) {
    for (const TriangleMesh& m :
         {test::make_torus(16, 4.5, 96, 48, 0.25), test::make_ellipsoid(6, 4, 3, 24, 48),
          test::make_cylinder(2, 10, 5, 17), test::make_icosphere(1, 3)}) {
      SurfaceOptions o;
      o.mixed_areas = scheme;
      Surface s(m, o);
      const double A = total_area(s);
      double sum = 0;
      for (double a : s.vertex_areas()) sum += a;
      EXPECT_NEAR(sum, A, 1e-12 * A);
      for (std::size_t f = 0; f < s.face_count(); ++f) {
        EXPECT_NEAR(s.corner_areas()[f].sum(), s.face_areas()[f], 1e-12 * s.face_areas()[f]);
        EXPECT_GT(s.corner_areas()[f].minCoeff(), 0.0);
      }
    }
  }
}

TEST(Areas, SphereAreaConverges) {
  const double exact = 4 * M_PI;
  double prev = 1e9;
  for (int sub : {2, 3, 4}) {
    Surface s(test::make_icosphere(1.0, sub));
    const double err = std::abs(total_area(s) - exact) / exact;
    EXPECT_LT(err, prev);
    prev = err;
  }
  EXPECT_LT(prev, 2e-3);
}

TEST(Areas, ClippedAndMeyerAgreeOnAcuteTriangles) {
  // An equilateral-ish icosphere has only acute triangles: both schemes are
  // the exact Voronoi areas.
  SurfaceOptions a, b;
  b.mixed_areas = MixedAreaScheme::meyer;
  Surface sa(test::make_icosphere(2.0, 2), a), sb(test::make_icosphere(2.0, 2), b);
  for (std::size_t f = 0; f < sa.face_count(); ++f)
    EXPECT_LT((sa.corner_areas()[f] - sb.corner_areas()[f]).norm(), 1e-12);
}

TEST(Areas, ObtuseTriangleCorners) {
  // Obtuse at corner 0: p0 = (0,0), p1 = (2,0), p2 = (-1,1). Clipped: corner 1
  // gets the right triangle at p1 cut by the bisector of p0p1: legs 1 and
  // tan(angle at p1) = 1/3, area 1/6.
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {2, 0, 0}, {-1, 1, 0}};
  m.faces = {{0, 1, 2}};
  const auto c = mixed_voronoi_corner_areas(m, MixedAreaScheme::clipped);
  EXPECT_NEAR(c[0][1], 1.0 / 6.0, 1e-14);
  // Corner 2: edge p0p2 has length sqrt(2), angle at p2 = 45 - 18.43 deg.
  const double ang2 = std::atan2(1.0, 1.0) - std::atan2(1.0, 3.0);
  EXPECT_NEAR(c[0][2], 0.5 * (std::sqrt(2.0) / 2) * (std::sqrt(2.0) / 2) * std::tan(ang2), 1e-14);
  EXPECT_NEAR(c[0].sum(), 1.0, 1e-14);
  const auto mey = mixed_voronoi_corner_areas(m, MixedAreaScheme::meyer);
  EXPECT_NEAR(mey[0][0], 0.5, 1e-14);
  EXPECT_NEAR(mey[0][1], 0.25, 1e-14);
}

// ---------------------------------------------------------------- normals

TEST(Normals, WeightingsOnSphereAndPlane) {
  // Max weights are exact for vertices on a sphere, whatever the
  // triangulation; area and angle weights are not, but close.
  TriangleMesh m = test::make_torus(16, 4.5, 20, 10, 0.0);
  m = test::make_sphere(2.0, 7, 11);
  for (auto w : {NormalWeighting::max, NormalWeighting::area, NormalWeighting::angle}) {
    const auto n = vertex_normals(m, Topology(m), w);
    double worst = 0;
    for (std::size_t v = 0; v < n.size(); ++v)
      worst = std::max(worst, (n[v] - m.positions[v].normalized()).norm());
    if (w == NormalWeighting::max)
      EXPECT_LT(worst, 1e-12);
    else
      EXPECT_LT(worst, 0.2);
    EXPECT_GT(worst, w == NormalWeighting::max ? -1.0 : 1e-6);
  }
  const TriangleMesh plane = test::make_plane(3.0, 6);
  for (auto w : {NormalWeighting::max, NormalWeighting::area, NormalWeighting::angle})
    for (const Vec3& n : vertex_normals(plane, Topology(plane), w))
      EXPECT_LT((n - Vec3::UnitZ()).norm(), 1e-15);
  // Surface uses its option.
  SurfaceOptions o;
  o.normal_weighting = NormalWeighting::area;
  Surface s(m, o);
  EXPECT_EQ(s.vertex_normals(), vertex_normals(m, Topology(m), NormalWeighting::area));
}

TEST(Normals, FaceNormalsOutward) {
  Surface s(test::make_icosphere(1.0, 2));
  for (std::size_t f = 0; f < s.face_count(); ++f) {
    const Face& F = s.faces()[f];
    const Vec3 c = (s.positions()[F[0]] + s.positions()[F[1]] + s.positions()[F[2]]) / 3;
    EXPECT_GT(s.face_normals()[f].dot(c), 0.9 * c.norm());
    EXPECT_NEAR(s.face_normals()[f].norm(), 1.0, 1e-14);
  }
}

// ---------------------------------------------------------------- Laplacian

TEST(Laplacian, ConstantSymmetricAndMatrixFree) {
  for (const TriangleMesh& m : {test::make_torus(16, 4.5, 48, 24, 0.2),
                                test::make_cylinder(2, 10, 5, 17), test::make_plane(1, 7)}) {
    Surface s(m);
    const auto L = cotan_laplacian_matrix(s);
    const Eigen::SparseMatrix<double> Lt = L.transpose();
    EXPECT_EQ((L - Lt).norm(), 0.0);
    const Eigen::VectorXd ones = Eigen::VectorXd::Ones(L.rows());
    EXPECT_LT((L * ones).cwiseAbs().maxCoeff(), 1e-12);
    CotanLaplacian op(s);
    const std::vector<double> c(s.vertex_count(), 3.7);
    for (double y : op.apply(c)) EXPECT_EQ(y, 0.0);
    // Matrix-free equals matrix for a non-trivial field.
    std::vector<double> x(s.vertex_count());
    for (std::size_t v = 0; v < x.size(); ++v)
      x[v] = std::sin(s.positions()[v].x()) + s.positions()[v].z();
    const Eigen::VectorXd lx = L * Eigen::Map<const Eigen::VectorXd>(x.data(), L.rows());
    const auto mf = op.apply_weak(x);
    for (std::size_t v = 0; v < x.size(); ++v) EXPECT_NEAR(mf[v], lx[v], 1e-12);
    // Negative semidefinite: x^T L x <= 0.
    EXPECT_LE(Eigen::Map<const Eigen::VectorXd>(x.data(), L.rows()).dot(lx), 0.0);
    const auto M = mass_matrix(s);
    EXPECT_NEAR(M.sum(), total_area(s), 1e-10 * total_area(s));
  }
}

TEST(Laplacian, LinearFieldOnPlaneAndSphereCoordinates) {
  Surface plane(test::make_plane(2.0, 9));
  std::vector<double> lin(plane.vertex_count());
  for (std::size_t v = 0; v < lin.size(); ++v)
    lin[v] = 2 * plane.positions()[v].x() - 3 * plane.positions()[v].y();
  const auto y = CotanLaplacian(plane).apply(lin);
  for (std::size_t v = 0; v < y.size(); ++v)
    if (!plane.topology().is_boundary_vertex(v)) {
      EXPECT_NEAR(y[v], 0.0, 1e-11);
    }
  // On a sphere of radius R, Δ z = -2 z / R² (the mean-curvature normal).
  double prev = 1e9;
  for (int sub : {2, 3, 4}) {
    const double R = 2.0;
    Surface s(test::make_icosphere(R, sub));
    std::vector<double> z(s.vertex_count());
    for (std::size_t v = 0; v < z.size(); ++v) z[v] = s.positions()[v].z();
    const auto lz = CotanLaplacian(s).apply(z);
    double err = 0;
    for (std::size_t v = 0; v < z.size(); ++v)
      err = std::max(err, std::abs(lz[v] + 2 * z[v] / (R * R)));
    EXPECT_LT(err, prev);
    prev = err;
  }
  EXPECT_LT(prev, 0.02);
}

TEST(Laplacian, BoundaryEdgeHasOneTerm) {
  // A single right triangle: every edge is a boundary edge with one cotangent.
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.faces = {{0, 1, 2}};
  Surface s(m);
  const auto w = cotan_edge_weights(s);
  // Edges in lexicographic order: (0,1) opposite p2 (45 deg), (0,2) opposite
  // p1 (45 deg), (1,2) opposite p0 (90 deg).
  EXPECT_NEAR(w[0], 0.5, 1e-15);
  EXPECT_NEAR(w[1], 0.5, 1e-15);
  EXPECT_NEAR(w[2], 0.0, 1e-15);
}

// ---------------------------------------------------------------- gradients

TEST(Gradient, LinearFieldsExact) {
  Surface s(test::make_torus(16, 4.5, 48, 24, 0.2));
  const Vec3 g(0.3, -1.2, 0.7);
  std::vector<double> f(s.vertex_count());
  for (std::size_t v = 0; v < f.size(); ++v) f[v] = g.dot(s.positions()[v]) + 5;
  const auto fg = face_gradients(s, f);
  for (std::size_t t = 0; t < s.face_count(); ++t) {
    const Vec3& n = s.face_normals()[t];
    EXPECT_LT((fg[t] - (g - g.dot(n) * n)).norm(), 1e-12);
  }
  // Vertex gradients: the tangential part of g, to first order.
  const auto vg = vertex_gradients(s, f);
  double worst = 0;
  for (std::size_t v = 0; v < f.size(); ++v) {
    const Vec3& n = s.vertex_normals()[v];
    worst = std::max(worst, (vg[v] - (g - g.dot(n) * n)).norm() / g.norm());
    EXPECT_NEAR(vg[v].dot(n), 0.0, 1e-12);
  }
  EXPECT_LT(worst, 0.15);  // coarse mesh: rotation vs projection differ at O(h k)
  // Covariant derivative along the principal direction e1.
  const auto d = covariant_derivative(s, f, s.curvature().e1);
  for (std::size_t v = 0; v < f.size(); ++v)
    EXPECT_NEAR(d[v], vg[v].dot(s.curvature().e1[v]), 1e-14);
  // On a plane everything is exact.
  Surface p(test::make_plane(1.0, 6));
  std::vector<double> fp(p.vertex_count());
  for (std::size_t v = 0; v < fp.size(); ++v)
    fp[v] = 2 * p.positions()[v].x() + p.positions()[v].y();
  for (const Vec3& x : vertex_gradients(p, fp)) EXPECT_LT((x - Vec3(2, 1, 0)).norm(), 1e-12);
  EXPECT_THROW(vertex_gradients(p, std::vector<double>(3)), InputError);
}

TEST(Gradient, VertexGradientConvergesOnSphere) {
  // f = z on a sphere: grad f = e_z - (e_z . n) n.
  double prev = 1e9;
  for (int sub : {2, 3, 4}) {
    Surface s(test::make_icosphere(1.0, sub));
    std::vector<double> f(s.vertex_count());
    for (std::size_t v = 0; v < f.size(); ++v) f[v] = s.positions()[v].z();
    const auto g = vertex_gradients(s, f);
    double err = 0;
    for (std::size_t v = 0; v < f.size(); ++v) {
      const Vec3 n = s.positions()[v].normalized();
      err = std::max(err, (g[v] - (Vec3::UnitZ() - n.z() * n)).norm());
    }
    EXPECT_LT(err, prev);
    prev = err;
  }
  EXPECT_LT(prev, 0.01);
}

// ---------------------------------------------------------------- invariance

TEST(Invariance, RigidMotionAndScaling) {
  const TriangleMesh m = test::make_torus(16, 4.5, 64, 32, 0.2);
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  Surface a(m);
  for (double scale : {1.0, 2.5, 0.01}) {
    Surface b(transformed(m, R, Vec3(10, -20, 5), scale));
    const auto &ca = a.curvature(), &cb = b.curvature();
    const auto &da = a.curvature_derivatives(), &db = b.curvature_derivatives();
    const double tol = test::kFloatRounding;  // single-precision fits (was 1e-8)
    for (std::size_t v = 0; v < a.vertex_count(); ++v) {
      ASSERT_TRUE(cb.valid[v]);
      EXPECT_NEAR(cb.k1[v] * scale, ca.k1[v], tol * std::abs(ca.k1[v]) + 1e-12);
      EXPECT_NEAR(cb.k2[v] * scale, ca.k2[v], tol * std::abs(ca.k1[v]) + 1e-12);
      EXPECT_NEAR(b.vertex_areas()[v] / (scale * scale), a.vertex_areas()[v],
                  1e-10 * a.vertex_areas()[v]);
      EXPECT_LT((b.vertex_normals()[v] - R * a.vertex_normals()[v]).norm(), 1e-10);
      if (std::abs(ca.k1[v] - ca.k2[v]) < 1e-3) continue;
      const Vec3 e1 = R * ca.e1[v];
      EXPECT_GT(std::abs(cb.e1[v].dot(e1)), 1 - test::kFloatRounding);
      const double s1 = cb.e1[v].dot(e1) > 0 ? 1 : -1;
      const double s2 = cb.e2[v].dot(R * ca.e2[v]) > 0 ? 1 : -1;
      const double cs = test::kFloatRoundingC * (std::abs(da.a[v]) + std::abs(da.b[v]) +
                                                 std::abs(da.c[v]) + std::abs(da.d[v]) + 1e-6);
      EXPECT_NEAR(s1 * db.a[v] * scale * scale, da.a[v], cs);
      EXPECT_NEAR(s2 * db.b[v] * scale * scale, da.b[v], cs);
      EXPECT_NEAR(s1 * db.c[v] * scale * scale, da.c[v], cs);
      EXPECT_NEAR(s2 * db.d[v] * scale * scale, da.d[v], cs);
    }
    EXPECT_NEAR(b.feature_size() / scale, a.feature_size(),
                test::kFloatRounding * a.feature_size());
    EXPECT_NEAR(b.median_edge_length() / scale, a.median_edge_length(),
                1e-12 * a.median_edge_length());
    EXPECT_NEAR(b.bounding_sphere_radius() / scale, a.bounding_sphere_radius(),
                1e-9 * a.bounding_sphere_radius());
  }
}

TEST(Invariance, VertexRenumbering) {
  TriangleMesh m = test::make_ellipsoid(6, 4, 3, 20, 40);
  std::vector<std::int32_t> perm(m.vertex_count());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(7));
  TriangleMesh p = m;
  for (std::size_t v = 0; v < perm.size(); ++v) p.positions[perm[v]] = m.positions[v];
  for (Face& f : p.faces)
    for (auto& i : f) i = perm[i];
  Surface a(m), b(p);
  const auto &ca = a.curvature(), &cb = b.curvature();
  const auto &da = a.curvature_derivatives(), &db = b.curvature_derivatives();
  for (std::size_t v = 0; v < perm.size(); ++v) {
    const std::size_t w = perm[v];
    EXPECT_NEAR(cb.k1[w], ca.k1[v], 1e-10);
    EXPECT_NEAR(cb.k2[w], ca.k2[v], 1e-10);
    EXPECT_NEAR(b.vertex_areas()[w], a.vertex_areas()[v], 1e-12);
    if (std::abs(ca.k1[v] - ca.k2[v]) < 1e-3) continue;
    EXPECT_GT(std::abs(cb.e1[w].dot(ca.e1[v])), 1 - 1e-9);
    const double s1 = cb.e1[w].dot(ca.e1[v]) > 0 ? 1 : -1;
    const double s2 = cb.e2[w].dot(ca.e2[v]) > 0 ? 1 : -1;
    EXPECT_NEAR(s1 * db.a[w], da.a[v], 1e-8);
    EXPECT_NEAR(s2 * db.b[w], da.b[v], 1e-8);
    EXPECT_NEAR(s1 * db.c[w], da.c[v], 1e-8);
    EXPECT_NEAR(s2 * db.d[w], da.d[v], 1e-8);
  }
  EXPECT_NEAR(a.feature_size(), b.feature_size(), 1e-12);
}

// ---------------------------------------------------------------- bad inputs

TEST(Robustness, OpenMultiComponentDegenerate) {
  // Plane (open), two spheres (multi-component), cylinder (two boundaries).
  TriangleMesh two = test::make_icosphere(1.0, 2);
  {
    TriangleMesh other = test::make_icosphere(0.5, 1);
    const auto off = static_cast<std::int32_t>(two.positions.size());
    for (const Vec3& q : other.positions) two.positions.push_back(q + Vec3(5, 0, 0));
    for (Face f : other.faces) two.faces.push_back({f[0] + off, f[1] + off, f[2] + off});
  }
  for (const TriangleMesh& m : {test::make_plane(1.0, 5), two, test::make_cylinder(1, 3, 3, 8)}) {
    Surface s(m);
    expect_no_nan(s);
    for (std::size_t v = 0; v < s.vertex_count(); ++v) EXPECT_TRUE(s.curvature().valid[v]);
  }
  Surface plane(test::make_plane(1.0, 5));
  for (std::size_t v = 0; v < plane.vertex_count(); ++v) {
    EXPECT_NEAR(plane.curvature().k1[v], 0.0, 1e-12);
    EXPECT_NEAR(plane.curvature_derivatives().a[v], 0.0, 1e-10);
  }
  // Flat everywhere: feature size falls back to 5% of the bounding radius.
  EXPECT_NEAR(plane.feature_size(), 0.05 * plane.bounding_sphere_radius(), 1e-15);

  // Degenerate pieces glued to a sphere: an isolated vertex, a face with a
  // repeated vertex, a zero-area (collinear) face on its own vertices, and a
  // vertex whose only face is degenerate.
  TriangleMesh m = test::make_icosphere(1.0, 2);
  const auto n = static_cast<std::int32_t>(m.positions.size());
  m.positions.push_back({3, 3, 3});          // n: isolated
  m.positions.push_back({4, 0, 0});          // n+1
  m.positions.push_back({5, 0, 0});          // n+2
  m.positions.push_back({6, 0, 0});          // n+3
  m.faces.push_back({n + 1, n + 2, n + 3});  // collinear
  m.faces.push_back({0, 0, 1});              // repeated vertex
  m.positions.push_back({7, 7, 7});          // n+4
  m.faces.push_back({n + 4, n + 4, n + 4});  // all one vertex
  Surface s(m);
  expect_no_nan(s);
  const auto& c = s.curvature();
  for (std::int32_t v : {n, n + 1, n + 2, n + 3, n + 4}) {
    EXPECT_EQ(c.valid[v], 0) << v;
    EXPECT_EQ(s.vertex_normals()[v], Vec3::Zero());
  }
  EXPECT_TRUE(c.valid[0]);
  EXPECT_NEAR(c.k1[0], 1.0, test::kFloatRounding);  // float fits
  EXPECT_EQ(s.face_normals()[s.face_count() - 1], Vec3::Zero());
  // An empty mesh and a mesh without faces.
  for (TriangleMesh e : {TriangleMesh{}, TriangleMesh{{{1, 2, 3}}, {}}}) {
    Surface es(e);
    expect_no_nan(es);
  }
  // Out-of-range indices and NaN coordinates are rejected up front.
  TriangleMesh bad = test::make_plane(1, 3);
  bad.faces.push_back({0, 1, 99});
  EXPECT_THROW(Surface{bad}, InputError);
  bad = test::make_plane(1, 3);
  bad.positions[2].x() = std::nan("");
  EXPECT_THROW(Surface{bad}, InputError);
}

TEST(Robustness, SliverTrianglesStayFinite) {
  // Nearly collinear faces (sine ~1e-9, above the degeneracy threshold).
  TriangleMesh m = test::make_torus(16, 4.5, 24, 12, 0.0);
  m.positions.push_back({100, 0, 0});
  m.positions.push_back({101, 0, 0});
  m.positions.push_back({102, 1e-9, 0});
  m.positions.push_back({101, -1e-9, 1e-12});
  const auto n = static_cast<std::int32_t>(m.positions.size()) - 4;
  m.faces.push_back({n, n + 1, n + 2});
  m.faces.push_back({n, n + 3, n + 1});
  Surface s(m);
  expect_no_nan(s);
}

// ---------------------------------------------------------------- determinism

std::vector<std::uint8_t> bytes_of(const Surface& s) {
  std::vector<std::uint8_t> out;
  auto add = [&](const auto& vec) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(vec.data());
    out.insert(out.end(), p, p + vec.size() * sizeof(vec[0]));
  };
  add(s.vertex_normals());
  add(s.vertex_areas());
  add(s.corner_areas());
  const auto& c = s.curvature();
  add(c.k1), add(c.k2), add(c.e1), add(c.e2), add(c.valid);
  const auto& d = s.curvature_derivatives();
  add(d.a), add(d.b), add(d.c), add(d.d), add(d.valid);
  const double extra[] = {s.feature_size(), s.median_edge_length(), s.mean_edge_length(),
                          s.bounding_sphere_radius()};
  out.insert(out.end(), reinterpret_cast<const std::uint8_t*>(extra),
             reinterpret_cast<const std::uint8_t*>(extra + 4));
  return out;
}

TEST(Determinism, SameBitsAtOneAndTwoThreads) {
  SurfaceOptions o;
  o.curvature_smoothing_passes = 1;
  o.derivative_smoothing_passes = 1;
  for (const SurfaceOptions& opt : {SurfaceOptions{}, o}) {
    const TriangleMesh m = test::make_torus(16, 4.5, 256, 128, 0.2);
    std::vector<std::uint8_t> one, two;
    {
      tbb::global_control gc(tbb::global_control::max_allowed_parallelism, 1);
      Surface s(m, opt);
      s.precompute();
      one = bytes_of(s);
    }
    {
      tbb::global_control gc(tbb::global_control::max_allowed_parallelism, 2);
      Surface s(m, opt);
      s.precompute();
      two = bytes_of(s);
    }
    ASSERT_EQ(one.size(), two.size());
    EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size()), 0);
  }
}

// The single-precision curvature fits have a portable and an AVX2 version
// (core/src/curvature_fit_kernel.hpp); they must give the same bits, also
// on the partial last block of eight faces (37 x 19 x 2 = 1406 faces).
TEST(Determinism, Avx2CurvatureFitsMatchPortable) {
  if (!detail::curvature_avx2_enabled().load()) GTEST_SKIP() << "no AVX2 fits on this CPU/build";
  for (const TriangleMesh& m :
       {test::make_torus(16, 4.5, 256, 128, 0.2), test::make_torus(16, 4.5, 37, 19, 0.3)}) {
    Surface wide(m);
    wide.precompute();
    const auto expected = bytes_of(wide);
    detail::curvature_avx2_enabled() = false;
    Surface portable(m);
    portable.precompute();
    detail::curvature_avx2_enabled() = true;
    EXPECT_EQ(bytes_of(portable), expected);
  }
}

// The fits keep slots only for the vertices of one step of faces and those
// spread over several steps (curvature_internal.hpp, FitSchedule): the same
// bits at any step size, from one step (a slot for every corner) to steps
// of a few faces, on a mesh whose faces follow its vertices and on the same
// mesh with its faces and vertices shuffled (most vertices then spread).
TEST(Determinism, CurvatureFitStepsGiveTheSameBits) {
  std::atomic<std::size_t>& step = detail::curvature_fit_step_faces();
  const std::size_t saved = step.load();
  TriangleMesh ordered = test::make_torus(16, 4.5, 120, 60, 0.2);
  TriangleMesh shuffled = ordered;
  std::mt19937 rng(7);
  std::vector<std::int32_t> to(shuffled.positions.size());
  std::iota(to.begin(), to.end(), 0);
  std::shuffle(to.begin(), to.end(), rng);
  for (std::size_t v = 0; v < to.size(); ++v) shuffled.positions[to[v]] = ordered.positions[v];
  for (Face& f : shuffled.faces)
    for (int k = 0; k < 3; ++k) f[k] = to[static_cast<std::size_t>(f[k])];
  std::shuffle(shuffled.faces.begin(), shuffled.faces.end(), rng);
  for (const TriangleMesh* m : {&ordered, &shuffled}) {
    step = 0;
    Surface whole(*m);
    whole.precompute();
    const auto expected = bytes_of(whole);
    for (const std::size_t faces : {std::size_t{1}, std::size_t{37}, std::size_t{1000},
                                    std::size_t{4096}, m->faces.size() - 1}) {
      step = faces;
      for (const int threads : {1, 2}) {
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                               static_cast<std::size_t>(threads));
        Surface s(*m);
        s.precompute();
        EXPECT_EQ(bytes_of(s), expected) << faces << " faces a step, " << threads << " threads";
      }
    }
  }
  step = saved;
}

TEST(Determinism, ConcurrentLazyAccess) {
  const TriangleMesh m = test::make_torus(16, 4.5, 128, 64, 0.2);
  Surface ref(m);
  ref.precompute();
  const auto expected = bytes_of(ref);
  Surface s(m);
  std::vector<std::thread> threads;
  std::vector<std::vector<std::uint8_t>> got(4);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      if (t % 2) s.curvature_derivatives();
      got[t] = bytes_of(s);
    });
  for (auto& th : threads) th.join();
  for (const auto& g : got) EXPECT_EQ(g, expected);
}

// release_face_quantities frees only the face quantities that the Surface
// computed as curvature inputs and that no caller obtained, and only once
// the derivatives exist; asking for them later computes the same values.
TEST(Determinism, ReleasedFaceQuantitiesComeBackTheSame) {
  const TriangleMesh m = test::make_torus(16, 4.5, 64, 32, 0.2);
  Surface ref(m);
  ref.precompute();
  const std::vector<Vec3> normals = ref.face_normals(), corners = ref.corner_areas();
  const std::vector<double> areas = ref.face_areas();
  const auto same = [](const auto& a, const auto& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
  };
  {
    // Released before the curvature: pending until the derivatives exist,
    // which still read them and come out the same.
    Surface s(m);
    s.release_face_quantities();
    s.precompute();
    EXPECT_EQ(bytes_of(s), bytes_of(ref));
    EXPECT_TRUE(same(s.face_normals(), normals));
    EXPECT_TRUE(same(s.face_areas(), areas));
    EXPECT_TRUE(same(s.corner_areas(), corners));
  }
  {
    // Released after: the curvature and derivatives stay, and the face
    // quantities asked for again are the same.
    Surface s(m);
    s.curvature_derivatives();
    s.release_face_quantities();
    EXPECT_TRUE(same(s.face_normals(), normals));
    EXPECT_TRUE(same(s.corner_areas(), corners));
    EXPECT_TRUE(same(s.face_areas(), areas));
  }
  {
    // Arrays a caller holds are never freed: the same storage after.
    Surface s(m);
    const std::vector<Vec3>& held = s.face_normals();
    s.curvature_derivatives();
    s.release_face_quantities();
    EXPECT_TRUE(same(held, normals));  // (freed, it would be empty)
  }
}

// With the release asked for before the vertex normals (the one-shot
// draw_lines), the Surface does not keep the double face quantities: the
// fits read float records of them (FitArrays::face_records) and the face
// areas are not computed. The curvature and derivatives are the same bits
// as a Surface that keeps them, with the AVX2 and the portable fits, at one
// and two threads, on a mesh with degenerate faces (zero normals) and a
// partial last block of eight faces; the face quantities asked for
// afterwards come back the same.
TEST(Determinism, FitsFromFloatFaceRecordsGiveTheSameBits) {
  TriangleMesh m = test::make_torus(16, 4.5, 37, 19, 0.3);
  const auto n = static_cast<std::int32_t>(m.positions.size());
  m.positions.push_back(m.positions[0]);  // a zero-area face, and a repeated corner
  m.faces.push_back({0, 1, n});
  m.faces.push_back({2, 2, 3});
  Surface ref(m);
  ref.precompute();
  const auto expected = bytes_of(ref);
  const std::vector<Vec3> normals = ref.face_normals();
  const std::vector<double> areas = ref.face_areas();
  const bool had_avx2 = detail::curvature_avx2_enabled().load();
  for (const bool wide : {false, true}) {
    if (wide && !had_avx2) continue;
    detail::curvature_avx2_enabled() = wide;
    for (const int threads : {1, 2}) {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(threads));
      Surface s(m);
      s.release_face_quantities();
      s.precompute();
      EXPECT_EQ(bytes_of(s), expected) << (wide ? "AVX2" : "portable") << " " << threads;
      EXPECT_EQ(s.face_normals().size(), normals.size());
      EXPECT_EQ(
          std::memcmp(s.face_normals().data(), normals.data(), normals.size() * sizeof(normals[0])),
          0);
      EXPECT_EQ(s.face_areas(), areas);
    }
  }
  detail::curvature_avx2_enabled() = had_avx2;
}

// ---------------------------------------------------------------- misc

// The mesh check of every Surface: a fast pass over all coordinates and
// indices, then, only when it finds something, the first offender named.
// Odd coordinate counts (the last coordinate outside the two-wide loop)
// and each kind of error are covered.
TEST(MeshCheck, NamesTheFirstBadVertexOrFace) {
  auto strip = [](int n) {
    TriangleMesh m;
    for (int i = 0; i < n; ++i) m.positions.push_back(Vec3(i, i % 2, 0.1 * i));
    for (int i = 0; i + 2 < n; ++i) m.faces.push_back({i, i + 1, i + 2});
    return m;
  };
  auto message = [](const TriangleMesh& m) -> std::string {
    try {
      check_mesh_indices_and_values(m, "mesh");
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  for (int n : {3, 4, 7, 8}) {
    SCOPED_TRACE(n);
    const TriangleMesh ok = strip(n);
    EXPECT_EQ(message(ok), "");
    EXPECT_NO_THROW(Surface{TriangleMesh(ok)});
    for (int v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) {
        TriangleMesh m = ok;
        m.positions[v][k] = std::numeric_limits<double>::quiet_NaN();
        if (v + 1 < n) m.positions[v + 1][k] = 2e15;  // a later offender is not named
        EXPECT_NE(message(m).find("vertex " + std::to_string(v) + " has a coordinate that is not"),
                  std::string::npos);
        m.positions[v][k] = -std::numeric_limits<double>::infinity();
        EXPECT_NE(message(m).find("vertex " + std::to_string(v) + " has a coordinate that is not"),
                  std::string::npos);
        m.positions[v][k] = -2e15;
        EXPECT_NE(message(m).find("vertex " + std::to_string(v) + " has a coordinate beyond 1e15"),
                  std::string::npos);
        m.positions[v][k] = 1e15;  // the limit itself is allowed
        if (v + 1 < n) m.positions[v + 1][k] = ok.positions[v + 1][k];
        EXPECT_EQ(message(m), "");
      }
    for (std::size_t f = 0; f < ok.faces.size(); ++f)
      for (int k = 0; k < 3; ++k)
        for (int bad : {-1, n, std::numeric_limits<std::int32_t>::min()}) {
          TriangleMesh m = ok;
          m.faces[f][k] = bad;
          EXPECT_NE(message(m).find("face " + std::to_string(f) + " refers to vertex " +
                                    std::to_string(bad)),
                    std::string::npos);
          EXPECT_THROW(Surface{std::move(m)}, InputError);
        }
  }
}

TEST(Statistics, EdgesSphereFeatureSize) {
  Surface p(test::make_plane(4.0, 5));  // 4x4 cells of side 1, diagonals sqrt 2
  EXPECT_NEAR(p.median_edge_length(), 1.0, 1e-15);
  EXPECT_NEAR(p.mean_edge_length(), (40 + 16 * std::sqrt(2.0)) / 56, 1e-14);
  const TriangleMesh sph = test::make_icosphere(3.0, 3);
  Surface s(sph);
  for (const Vec3& q : s.positions())
    EXPECT_LE((q - s.bounding_sphere_center()).norm(), s.bounding_sphere_radius());
  EXPECT_LT(s.bounding_sphere_radius(), 3.0 * 1.05);
  // All |k| = 1/3: feature size = min(0.01 * 3, 0.05 * R).
  EXPECT_NEAR(s.feature_size(), 0.03, 0.03 * test::kFloatRounding);  // float fits
  FeatureSizeOptions rtsc;
  rtsc.rtsc_sampling = true;
  EXPECT_NEAR(feature_size(s.curvature(), s.bounding_sphere_radius(), rtsc), 0.03,
              0.03 * test::kFloatRounding);
  EXPECT_NEAR(curvature_derivative_along(1, 2, 3, 4, 1, 0), 1, 0);
  EXPECT_NEAR(curvature_derivative_along(1, 2, 3, 4, 0, 1), 4, 0);
  EXPECT_NEAR(curvature_derivative_along(1, 2, 3, 4, 0.6, 0.8),
              curvature_derivative_form(1, 2, 3, 4, Vec2(0.6, 0.8), Vec2(0.6, 0.8), Vec2(0.6, 0.8)),
              1e-14);
}

TEST(Statistics, LargeMeshSelectionsMatchSorting) {
  // Big enough for the parallel histogram selection (>= 65536 values).
  Surface s(test::make_torus(16, 4.5, 256, 128, 0.3));
  const auto& topo = s.topology();
  std::vector<double> len;
  for (std::size_t e = 0; e < topo.edge_count(); ++e)
    len.push_back((s.positions()[topo.edge(e)[0]] - s.positions()[topo.edge(e)[1]]).norm());
  ASSERT_GT(len.size(), 65536u);
  std::sort(len.begin(), len.end());
  EXPECT_EQ(s.median_edge_length(), len[len.size() / 2]);
  const auto& c = s.curvature();
  std::vector<double> k;
  for (std::size_t v = 0; v < s.vertex_count(); ++v) {
    k.push_back(std::abs(c.k1[v]));
    k.push_back(std::abs(c.k2[v]));
  }
  std::sort(k.begin(), k.end());
  const double k10 = k[static_cast<std::size_t>(0.1 * k.size())];
  EXPECT_EQ(s.feature_size(), std::min(0.01 / k10, 0.05 * s.bounding_sphere_radius()));
}

TEST(Smoothing, KeepsSphereReducesNoise) {
  SurfaceOptions o;
  o.curvature_smoothing_passes = 2;
  o.derivative_smoothing_passes = 1;
  Surface s(test::make_icosphere(2.0, 3), o);
  for (std::size_t v = 0; v < s.vertex_count(); ++v) {
    // Exact up to the float rounding of the fits (was 1e-12).
    EXPECT_NEAR(s.curvature().k1[v], 0.5, 0.5 * test::kFloatRounding);
    EXPECT_NEAR(s.curvature().k2[v], 0.5, 0.5 * test::kFloatRounding);
  }
  // Jittered torus: smoothing lowers the k1 error (noise, not bias).
  const auto torus = test::make_torus(16, 4.5, 192, 96, 0.25);
  const auto a = test::analytic_torus(16, 4.5);
  auto k1_rms = [&](const Surface& t) {
    double e = 0;
    for (std::size_t v = 0; v < t.vertex_count(); ++v)
      e += std::pow(t.curvature().k1[v] * 4.5 - 1, 2);
    return std::sqrt(e / t.vertex_count());
  };
  Surface raw(torus), smooth(torus, o);
  const double er = k1_rms(raw), es = k1_rms(smooth);
  std::printf("[smoothing] torus k1 rms %.3f%% raw, %.3f%% smoothed\n", 100 * er, 100 * es);
  EXPECT_LT(es, 0.6 * er);
}

}  // namespace
}  // namespace fabrica
