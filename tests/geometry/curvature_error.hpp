// Error of a Surface's curvature against an analytic surface, over the
// valid, non-boundary vertices.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

#include "analytic.hpp"
#include "fabrica/core/surface.hpp"

namespace fabrica::test {

struct CurvatureErrors {
  double k1 = 0, k2 = 0;       ///< rms |k - k_exact| / scale
  double mean = 0, gauss = 0;  ///< rms |H - H_exact| / scale, |K - K_exact| / scale²
  double normal_deg = 0;       ///< rms angle between normals, degrees
  double dir_deg = 0;          ///< rms angle between e1 and exact e1 (non-umbilic), degrees
  double deriv = 0;            ///< rms |(a,b,c,d) - exact| / scale²
  double k1_bias = 0;          ///< mean (k1 - k1_exact) / scale
  std::size_t count = 0, dir_count = 0, invalid = 0;
};

struct ErrorOptions {
  double scale = 1.0;        ///< curvature scale (1/mm) the errors are divided by
  double umbilic_gap = 0.0;  ///< |k1 - k2| below which directions and C are skipped
  bool directions = true;
  bool derivatives = true;
  double fd_step = 1e-4;  ///< finite-difference step for the exact C, mm
  /// Skip vertices for which this returns true (e.g. poles of a UV sphere).
  std::function<bool(const Vec3&)> skip;
};

inline CurvatureErrors curvature_errors(const Surface& s, const AnalyticSurface& a,
                                        const ErrorOptions& o) {
  const auto& curv = s.curvature();
  const auto& der = s.curvature_derivatives();
  const auto& nrm = s.vertex_normals();
  CurvatureErrors e;
  double sk1 = 0, sk2 = 0, sh = 0, sg = 0, sn = 0, sd = 0, sc = 0, bias = 0;
  for (std::size_t v = 0; v < s.vertex_count(); ++v) {
    if (s.topology().is_boundary_vertex(v)) continue;
    const Vec3 p = a.project(s.positions()[v]);
    if (o.skip && o.skip(p)) continue;
    if (!curv.valid[v]) {
      ++e.invalid;
      continue;
    }
    const AnalyticCurvature x = a.curvature(p);
    const double d1 = (curv.k1[v] - x.k1) / o.scale, d2 = (curv.k2[v] - x.k2) / o.scale;
    sk1 += d1 * d1;
    sk2 += d2 * d2;
    bias += d1;
    const double dh = (curv.mean(v) - 0.5 * (x.k1 + x.k2)) / o.scale;
    const double dg = (curv.gaussian(v) - x.k1 * x.k2) / (o.scale * o.scale);
    sh += dh * dh;
    sg += dg * dg;
    const double an = std::acos(std::min(1.0, nrm[v].dot(x.n))) * 180 / M_PI;
    sn += an * an;
    ++e.count;
    if (std::abs(x.k1 - x.k2) < o.umbilic_gap) continue;
    if (o.directions) {
      const double ad = std::acos(std::min(1.0, std::abs(curv.e1[v].dot(x.e1)))) * 180 / M_PI;
      sd += ad * ad;
    }
    if (o.derivatives) {
      const Eigen::Vector4d C = a.derivatives(p, o.fd_step);
      const double s1 = curv.e1[v].dot(x.e1) >= 0 ? 1.0 : -1.0;
      const double s2 = curv.e2[v].dot(x.e2) >= 0 ? 1.0 : -1.0;
      const Eigen::Vector4d m(der.a[v], der.b[v], der.c[v], der.d[v]);
      const Eigen::Vector4d exact(s1 * C[0], s2 * C[1], s1 * C[2], s2 * C[3]);
      sc += (m - exact).squaredNorm() / (o.scale * o.scale * o.scale * o.scale);
    }
    ++e.dir_count;
  }
  const double n = static_cast<double>(std::max<std::size_t>(e.count, 1));
  const double nd = static_cast<double>(std::max<std::size_t>(e.dir_count, 1));
  e.k1 = std::sqrt(sk1 / n);
  e.k2 = std::sqrt(sk2 / n);
  e.mean = std::sqrt(sh / n);
  e.gauss = std::sqrt(sg / n);
  e.normal_deg = std::sqrt(sn / n);
  e.dir_deg = std::sqrt(sd / nd);
  e.deriv = std::sqrt(sc / nd);
  e.k1_bias = bias / n;
  return e;
}

inline void print_errors(const std::string& name, const CurvatureErrors& e) {
  std::printf(
      "[curvature] %-28s n=%6zu k1 %.4f%% k2 %.4f%% H %.4f%% K %.4f%% bias %.4f%% normal %.4f deg "
      "e1 %.3f deg C %.4f%% invalid %zu\n",
      name.c_str(), e.count, 100 * e.k1, 100 * e.k2, 100 * e.mean, 100 * e.gauss, 100 * e.k1_bias,
      e.normal_deg, e.dir_deg, 100 * e.deriv, e.invalid);
}

}  // namespace fabrica::test
