// Analytic reference geometry for the curvature tests: for a point on (or
// near) a surface, the closest/radial surface point, the outward normal, the
// principal curvatures |k1| >= |k2| (convex positive) and directions, and
// the curvature-derivative tensor (a, b, c, d) obtained by central finite
// differences of the analytic principal curvatures along the analytic
// principal directions (a = D_e1 k1, b = D_e2 k1, c = D_e1 k2, d = D_e2 k2,
// valid away from umbilics).
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>

#include "fabrica/core/types.hpp"

namespace fabrica::test {

// The Rusinkiewicz fits run in single precision (issue 22; rtsc computes
// them in float too): where a test expects an exact value or an exact
// invariance, the error is float rounding, not double's.
constexpr double kFloatRounding = 1e-6;  // II, k1, k2: relative, measured <= 3e-7
constexpr double kFloatRoundingC =
    2e-4;  // C: relative, measured <= 1.5e-5 (sphere), 5.1e-5 (moved torus)
constexpr double kFloatDirectionDeg = 0.01;  // principal directions, degrees

struct AnalyticCurvature {
  Vec3 n;
  double k1, k2;
  Vec3 e1, e2;  // e2 = n x e1
};

struct AnalyticSurface {
  std::function<Vec3(const Vec3&)> project;
  std::function<AnalyticCurvature(const Vec3&)> curvature;  // at a surface point

  /// (a, b, c, d) at surface point p in the analytic frame (e1, e2).
  Eigen::Vector4d derivatives(const Vec3& p, double h) const {
    const AnalyticCurvature c0 = curvature(p);
    auto k_at = [&](const Vec3& dir, double s) {
      const AnalyticCurvature c = curvature(project(p + s * dir));
      return std::make_pair(c.k1, c.k2);
    };
    const auto p1 = k_at(c0.e1, h), m1 = k_at(c0.e1, -h);
    const auto p2 = k_at(c0.e2, h), m2 = k_at(c0.e2, -h);
    return {(p1.first - m1.first) / (2 * h), (p2.first - m2.first) / (2 * h),
            (p1.second - m1.second) / (2 * h), (p2.second - m2.second) / (2 * h)};
  }
};

inline AnalyticCurvature ordered(const Vec3& n, double ka, Vec3 ea, double kb, Vec3 eb) {
  AnalyticCurvature c;
  c.n = n;
  if (std::abs(kb) > std::abs(ka)) {
    std::swap(ka, kb);
    std::swap(ea, eb);
  }
  c.k1 = ka;
  c.k2 = kb;
  c.e1 = ea.normalized();
  c.e2 = n.cross(c.e1);
  return c;
}

inline AnalyticSurface analytic_sphere(double r) {
  AnalyticSurface s;
  s.project = [r](const Vec3& p) { return Vec3(r * p.normalized()); };
  s.curvature = [r](const Vec3& p) {
    const Vec3 n = p.normalized();
    Vec3 a = n.cross(Vec3::UnitX());
    if (a.norm() < 0.5) a = n.cross(Vec3::UnitY());
    Vec3 e1 = a.normalized();
    return ordered(n, 1.0 / r, e1, 1.0 / r, n.cross(e1));
  };
  return s;
}

/// Infinite cylinder of radius r around the z axis.
inline AnalyticSurface analytic_cylinder(double r) {
  AnalyticSurface s;
  s.project = [r](const Vec3& p) {
    const Eigen::Vector2d xy(p.x(), p.y());
    const Eigen::Vector2d q = r * xy.normalized();
    return Vec3(q.x(), q.y(), p.z());
  };
  s.curvature = [r](const Vec3& p) {
    const Vec3 n = Vec3(p.x(), p.y(), 0).normalized();
    const Vec3 around = Vec3::UnitZ().cross(n);
    return ordered(n, 1.0 / r, around, 0.0, Vec3::UnitZ());
  };
  return s;
}

/// Torus around the z axis, major radius R, minor r.
inline AnalyticSurface analytic_torus(double R, double r) {
  AnalyticSurface s;
  s.project = [R, r](const Vec3& p) {
    const double u = std::atan2(p.y(), p.x());
    const double rho = std::hypot(p.x(), p.y());
    const double v = std::atan2(p.z(), rho - R);
    return Vec3((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                r * std::sin(v));
  };
  s.curvature = [R, r](const Vec3& p) {
    const double u = std::atan2(p.y(), p.x());
    const double rho = std::hypot(p.x(), p.y());
    const double v = std::atan2(p.z(), rho - R);
    const Vec3 n(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
    const Vec3 ev(-std::sin(v) * std::cos(u), -std::sin(v) * std::sin(u), std::cos(v));
    const Vec3 eu(-std::sin(u), std::cos(u), 0.0);
    return ordered(n, 1.0 / r, ev, std::cos(v) / (R + r * std::cos(v)), eu);
  };
  return s;
}

/// Ellipsoid x²/a² + y²/b² + z²/c² = 1 (points projected radially).
inline AnalyticSurface analytic_ellipsoid(double a, double b, double c) {
  AnalyticSurface s;
  const Vec3 inv2(1 / (a * a), 1 / (b * b), 1 / (c * c));
  s.project = [inv2](const Vec3& p) { return Vec3(p / std::sqrt(p.cwiseProduct(p).dot(inv2))); };
  s.curvature = [inv2](const Vec3& p) {
    const Vec3 g = 2.0 * p.cwiseProduct(inv2);
    const double gl = g.norm();
    const Vec3 n = g / gl;
    const Mat3 P = Mat3::Identity() - n * n.transpose();
    const Mat3 S = P * Mat3(2.0 * inv2.asDiagonal()) * P / gl;
    Eigen::SelfAdjointEigenSolver<Mat3> es(S);
    // Drop the eigenvector along n.
    int drop = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(es.eigenvectors().col(i).dot(n)) > std::abs(es.eigenvectors().col(drop).dot(n)))
        drop = i;
    int i0 = (drop + 1) % 3, i1 = (drop + 2) % 3;
    return ordered(n, es.eigenvalues()[i0], es.eigenvectors().col(i0), es.eigenvalues()[i1],
                   es.eigenvectors().col(i1));
  };
  return s;
}

}  // namespace fabrica::test
