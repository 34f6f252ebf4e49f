// Curvature, principal directions, mean/Gaussian curvature and the
// curvature-derivative tensor against analytic surfaces at three
// resolutions each: errors must be small and shrink with refinement.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "curvature_error.hpp"
#include "fabrica/core/surface.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

using test::CurvatureErrors;
using test::ErrorOptions;

using test::kFloatDirectionDeg;
using test::kFloatRounding;
using test::kFloatRoundingC;

CurvatureErrors run(const std::string& name, TriangleMesh mesh, const test::AnalyticSurface& a,
                    const ErrorOptions& o) {
  Surface s(std::move(mesh));
  const auto e = test::curvature_errors(s, a, o);
  test::print_errors(name, e);
  return e;
}

// Vertices moved along the sphere (a random tangent step, re-projected).
TriangleMesh jittered_sphere(double r, int sub, double amount) {
  TriangleMesh m = test::make_icosphere(r, sub);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  const double h = r * 1.1 / (1 << sub);  // about one edge length
  for (Vec3& p : m.positions) p = r * (p + amount * h * Vec3(u(rng), u(rng), u(rng))).normalized();
  return m;
}

// Open cylinder whose rings are twisted against each other (no mirror
// symmetry at any vertex), optionally jittered along the surface.
TriangleMesh twisted_cylinder(double r, double h, int rings, int segments, double jitter) {
  TriangleMesh m;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  const double dp = 2 * M_PI / segments, dz = h / rings;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double p = (j + 0.37 * i) * dp + jitter * dp * u(rng);
      const double z = -0.5 * h + i * dz + (i > 0 && i < rings ? jitter * dz * u(rng) : 0.0);
      m.positions.emplace_back(r * std::cos(p), r * std::sin(p), z);
    }
  auto idx = [&](int i, int j) { return i * segments + (j % segments); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.faces.push_back({idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)});
      m.faces.push_back({idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)});
    }
  return m;
}

TEST(Curvature, SphereIsExactForAnyInscribedTriangulation) {
  // Max's normal weights are exact for vertices on a sphere, so the normal
  // differences are exactly Δp / R and the fit gives II = I / R exactly,
  // whatever the triangulation: the error must be at rounding level. The
  // fits run in single precision (as rtsc's; ε = 6e-8, measured errors
  // ≤ 3e-7 for II and ≤ 1.5e-5 for C), so "rounding level" is float's, not
  // double's 1e-10 of the double-precision fits before issue 22.
  const double r = 3.0;
  ErrorOptions o;
  o.scale = 1.0 / r;
  o.directions = false;
  o.umbilic_gap = -1;  // C = 0 everywhere: compare to the zero tensor
  o.fd_step = 1e-3;
  for (int sub : {1, 3, 4}) {
    for (const auto& [name, mesh] :
         {std::pair{"icosphere", test::make_icosphere(r, sub)},
          std::pair{"uvsphere", test::make_sphere(r, 4 << sub, 8 << sub)},
          std::pair{"jittered icosphere", jittered_sphere(r, sub, 0.3)}}) {
      const auto e =
          run(std::string(name) + "/" + std::to_string(sub), mesh, test::analytic_sphere(r), o);
      EXPECT_LT(e.k1, kFloatRounding) << name;
      EXPECT_LT(e.k2, kFloatRounding) << name;
      EXPECT_LT(e.mean, kFloatRounding) << name;
      EXPECT_LT(e.gauss, kFloatRounding) << name;
      EXPECT_LT(e.deriv, kFloatRoundingC) << name;  // the exact C = 0
      EXPECT_EQ(e.invalid, 0u);
      EXPECT_GT(e.count, 40u);
    }
  }
}

TEST(Curvature, Cylinder) {
  const double r = 4.52;
  ErrorOptions o;
  o.scale = 1.0 / r;
  o.umbilic_gap = 0.5 / r;
  // Regular grid (as in the reference README's example): exact on the
  // middle rings, up to the single-precision rounding of the fits.
  const auto grid =
      run("cylinder 96x20", test::make_cylinder(r, 20.0, 19, 96), test::analytic_cylinder(r), o);
  EXPECT_LT(grid.k1, kFloatRounding);
  EXPECT_LT(grid.k2, kFloatRounding);
  EXPECT_LT(grid.deriv, kFloatRoundingC);
  // Twisted grid: a real discretisation error that shrinks with refinement.
  // Vertices within three rings of a boundary see one-sided (biased) data:
  // left out.
  std::vector<CurvatureErrors> e;
  for (int n : {24, 48, 96}) {
    const double dz = 20.0 / (n / 2);
    o.skip = [dz](const Vec3& p) { return std::abs(p.z()) > 10.0 - 3.01 * dz; };
    e.push_back(run("twisted cylinder/" + std::to_string(n),
                    twisted_cylinder(r, 20.0, n / 2, n, 0.0), test::analytic_cylinder(r), o));
  }
  for (std::size_t i = 1; i < e.size(); ++i) {
    EXPECT_LT(e[i].k1, e[i - 1].k1);
    EXPECT_LT(e[i].k2, e[i - 1].k2);
    EXPECT_LT(e[i].k2, 0.35 * e[i - 1].k2);  // second order
    EXPECT_LT(e[i].dir_deg, e[i - 1].dir_deg);
    // Every interior vertex is congruent to every other (helical lattice):
    // the estimated curvature field is constant, so C = 0 up to rounding
    // (single precision: measured ≤ 2e-6).
    EXPECT_LT(e[i].deriv, kFloatRoundingC);
  }
  EXPECT_LT(e.back().k1, 1e-4);
  EXPECT_LT(e.back().k2, 5e-4);
  EXPECT_LT(e.back().dir_deg, 0.05);
  // Jittered along the surface: bounded error.
  const auto j = run("jittered cylinder/96", twisted_cylinder(r, 20.0, 48, 96, 0.1),
                     test::analytic_cylinder(r), o);
  EXPECT_LT(j.k1, 0.02);
  EXPECT_LT(j.k2, 0.02);
  EXPECT_LT(std::abs(j.k1_bias), 0.003);
  EXPECT_LT(j.dir_deg, 0.6);
  EXPECT_LT(j.deriv, 0.25);
}

TEST(Curvature, TorusRegularGridConverges) {
  const double R = 16.0, r = 4.5;
  ErrorOptions o;
  o.scale = 1.0 / r;
  o.umbilic_gap = 0.2 / r;
  std::vector<CurvatureErrors> e;
  for (int n : {48, 96, 192})
    e.push_back(run("torus/" + std::to_string(2 * n) + "x" + std::to_string(n),
                    test::make_torus(R, r, 2 * n, n, 0.0), test::analytic_torus(R, r), o));
  for (std::size_t i = 1; i < e.size(); ++i) {
    // Second-order convergence: halving h divides the error by about 4.
    EXPECT_LT(e[i].k1, 0.35 * e[i - 1].k1);
    EXPECT_LT(e[i].k2, 0.35 * e[i - 1].k2);
    EXPECT_LT(e[i].mean, 0.35 * e[i - 1].mean);
    EXPECT_LT(e[i].gauss, 0.35 * e[i - 1].gauss);
    // Directions converge down to the floor of the single-precision fits
    // (measured 0.006-0.007 degrees on the two finer tori, from the
    // rounding of the vertex normals whose differences the II fit reads).
    EXPECT_LT(e[i].dir_deg, std::max(0.35 * e[i - 1].dir_deg, kFloatDirectionDeg));
    EXPECT_LT(e[i].deriv, 0.35 * e[i - 1].deriv);
  }
  EXPECT_LT(e[0].k1, 0.002);
  EXPECT_LT(e[0].k2, 0.003);
  EXPECT_LT(e[0].deriv, 0.005);
}

TEST(Curvature, JitteredTorusHasNoTrimesh2Bias) {
  // trimesh2 2.16's faulty 3x3 solve gives k1 about 10% low here; a correct
  // fit leaves only unbiased noise from the irregular sampling.
  const double R = 16.0, r = 4.5;
  ErrorOptions o;
  o.scale = 1.0 / r;
  o.umbilic_gap = 0.2 / r;
  const auto e = run("torus/192x96 jitter 0.1", test::make_torus(R, r, 192, 96, 0.1),
                     test::analytic_torus(R, r), o);
  EXPECT_LT(e.k1, 0.015);
  EXPECT_LT(e.k2, 0.007);
  EXPECT_LT(std::abs(e.k1_bias), 0.002);
  EXPECT_LT(e.dir_deg, 0.4);
  EXPECT_LT(e.normal_deg, 0.15);
  // Derivatives are third order: on irregular sampling their error does not
  // shrink with refinement (normal-difference noise / h), but stays bounded
  // at this resolution.
  EXPECT_LT(e.deriv, 0.25);
  const auto e2 = run("torus/192x96 jitter 0.25", test::make_torus(R, r, 192, 96, 0.25),
                      test::analytic_torus(R, r), o);
  EXPECT_LT(e2.k1, 0.05);
  EXPECT_LT(std::abs(e2.k1_bias), 0.003);
}

TEST(Curvature, EllipsoidConverges) {
  const double a = 6, b = 4, c = 3;
  ErrorOptions o;
  o.scale = 1.0 / 3.0;
  o.umbilic_gap = 0.05;  // the four umbilics lie in the xz plane
  std::vector<CurvatureErrors> e;
  for (int n : {24, 48, 96})
    e.push_back(run("ellipsoid/" + std::to_string(n), test::make_ellipsoid(a, b, c, n, 2 * n),
                    test::analytic_ellipsoid(a, b, c), o));
  for (std::size_t i = 1; i < e.size(); ++i) {
    EXPECT_LT(e[i].k1, 0.4 * e[i - 1].k1);
    EXPECT_LT(e[i].k2, 0.4 * e[i - 1].k2);
    EXPECT_LT(e[i].mean, 0.4 * e[i - 1].mean);
    EXPECT_LT(e[i].gauss, 0.4 * e[i - 1].gauss);
    EXPECT_LT(e[i].dir_deg, 0.4 * e[i - 1].dir_deg);
    EXPECT_LT(e[i].deriv, 0.6 * e[i - 1].deriv);
  }
  EXPECT_LT(e.back().k1, 0.003);
  EXPECT_LT(e.back().k2, 0.002);
  EXPECT_LT(e.back().dir_deg, 0.1);
  EXPECT_LT(e.back().deriv, 0.03);
  EXPECT_EQ(e.back().invalid, 0u);
}

}  // namespace
}  // namespace fabrica
