// Rusinkiewicz (2004) curvature and curvature-derivative estimation, written
// from the paper and ALGORITHMS.md §2 (not from trimesh2's code).
//
// Layout for speed and determinism: one parallel pass over faces writes
// per-face results into flat arrays, then one parallel pass over vertices
// gathers from topology().vertex_faces(v) in increasing face order. Every
// output element is computed by exactly one task in a fixed order, so the
// bits do not depend on the thread count.
#include "fabrica/core/curvature.hpp"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "curvature_internal.hpp"
#include "fabrica/core/geometry.hpp"
#include "geometry_kernels.hpp"

namespace fabrica {

namespace {

constexpr std::size_t kFaceGrain = 2048;
constexpr std::size_t kVertexGrain = 1024;

/// Solves the SPD system A x = b (row-major N x N) by LDLᵀ without pivoting.
/// Returns false when a pivot is not clearly positive (rank-deficient fit).
template <int N>
bool solve_spd(const double (&A)[N][N], const double (&b)[N], double (&x)[N]) {
  double L[N][N] = {};
  double d[N];
  double max_diag = 0.0;
  for (int i = 0; i < N; ++i) max_diag = std::max(max_diag, A[i][i]);
  if (!(max_diag > 0.0)) return false;
  for (int j = 0; j < N; ++j) {
    double dj = A[j][j];
    for (int k = 0; k < j; ++k) dj -= L[j][k] * L[j][k] * d[k];
    if (!(dj > 1e-12 * max_diag)) return false;
    d[j] = dj;
    for (int i = j + 1; i < N; ++i) {
      double s = A[i][j];
      for (int k = 0; k < j; ++k) s -= L[i][k] * L[j][k] * d[k];
      L[i][j] = s / dj;
    }
  }
  double y[N];
  for (int i = 0; i < N; ++i) {
    double s = b[i];
    for (int k = 0; k < i; ++k) s -= L[i][k] * y[k];
    y[i] = s;
  }
  for (int i = N - 1; i >= 0; --i) {
    double s = y[i] / d[i];
    for (int k = i + 1; k < N; ++k) s -= L[k][i] * x[k];
    x[i] = s;
  }
  return true;
}

/// An orthonormal tangent frame (u, v = n x u) at vertex `v`: u is the first
/// incident edge projected onto the tangent plane, or any perpendicular.
void vertex_frame(const TriangleMesh& mesh, const Topology& topo, std::size_t vtx, const Vec3& n,
                  Vec3& u, Vec3& v) {
  const auto faces = topo.vertex_faces(vtx);
  const auto corners = topo.vertex_face_corners(vtx);
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const Face& f = mesh.faces[faces[i]];
    const Vec3 e = mesh.positions[f[(corners[i] + 1) % 3]] - mesh.positions[vtx];
    const Vec3 t = e - e.dot(n) * n;
    const double len = t.norm();
    if (len > 1e-8 * e.norm() && len > 0.0) {
      u = t / len;
      v = n.cross(u);
      return;
    }
  }
  // Any perpendicular: cross with the axis least aligned with n.
  Vec3 axis = Vec3::UnitX();
  if (std::abs(n.y()) < std::abs(n.x()) && std::abs(n.y()) <= std::abs(n.z()))
    axis = Vec3::UnitY();
  else if (std::abs(n.z()) < std::abs(n.x()))
    axis = Vec3::UnitZ();
  u = n.cross(axis).normalized();
  v = n.cross(u);
}

/// Second fundamental form of principal values k1, k2 whose e1 has unit
/// coordinates (c, s) in some frame: k1 (c,s)(c,s)ᵀ + k2 (-s,c)(-s,c)ᵀ.
inline TangentTensor2 tensor_from_principal(double k1, double k2, double c, double s) {
  return {k1 * c * c + k2 * s * s, (k1 - k2) * c * s, k1 * s * s + k2 * c * c};
}

/// Coefficients of the cubic form C (a,b,c,d in a frame F) in a new frame
/// whose axes have coordinates x = (x1,x2), y = (y1,y2) in F.
inline void cubic_reexpress(const double (&C)[4], const Vec2& x, const Vec2& y, double (&out)[4]) {
  out[0] = curvature_derivative_form(C[0], C[1], C[2], C[3], x, x, x);
  out[1] = curvature_derivative_form(C[0], C[1], C[2], C[3], x, x, y);
  out[2] = curvature_derivative_form(C[0], C[1], C[2], C[3], x, y, y);
  out[3] = curvature_derivative_form(C[0], C[1], C[2], C[3], y, y, y);
}

}  // namespace

PrincipalFrame diagonalize(const TangentTensor2& t, const Vec3& u, const Vec3& v,
                           const Vec3& normal) {
  const double m = 0.5 * (t.xx + t.yy);
  const double d = 0.5 * (t.xx - t.yy);
  const double r = std::hypot(d, t.xy);
  double x1, x2;  // eigenvector of m + r
  if (d >= 0.0) {
    x1 = r + d;
    x2 = t.xy;
  } else {
    x1 = t.xy;
    x2 = r - d;
  }
  const double len = std::hypot(x1, x2);
  if (len > 0.0) {
    x1 /= len;
    x2 /= len;
  } else {
    x1 = 1.0;
    x2 = 0.0;
  }
  PrincipalFrame out;
  const double la = m + r, lb = m - r;
  if (std::abs(lb) > std::abs(la)) {
    out.k1 = lb;
    out.k2 = la;
    const double y1 = -x2, y2 = x1;  // the perpendicular eigenvector
    x1 = y1;
    x2 = y2;
  } else {
    out.k1 = la;
    out.k2 = lb;
  }
  out.e1 = x1 * u + x2 * v;
  out.e2 = normal.cross(out.e1);
  return out;
}

namespace detail {

PrincipalCurvatures estimate_curvature(const CurvatureInputs& in) {
  const TriangleMesh& mesh = in.mesh;
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();

  // Per face: frame axis t, fitted II = (e, f, g) in (t, n x t), fit ok.
  struct FaceFit {
    Vec3 t;
    double e, f, g;
  };
  std::vector<FaceFit> fits(nf);
  std::vector<std::uint8_t> fit_ok(nf);
  parallel_chunks(nf, kFaceGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t fi = begin; fi < end; ++fi) {
      const Face& face = mesh.faces[fi];
      const Vec3& nT = in.face_normals[fi];
      fit_ok[fi] = 0;
      fits[fi] = FaceFit{Vec3::Zero(), 0.0, 0.0, 0.0};
      if (nT.isZero() || !in.normal_valid[face[0]] || !in.normal_valid[face[1]] ||
          !in.normal_valid[face[2]])
        continue;
      const Vec3& p0 = mesh.positions[face[0]];
      const Vec3& p1 = mesh.positions[face[1]];
      const Vec3& p2 = mesh.positions[face[2]];
      const Vec3 e[3] = {p2 - p1, p0 - p2, p1 - p0};
      const Vec3 t = e[0].normalized();
      const Vec3 b = nT.cross(t);
      const Vec3* n[3] = {&in.vertex_normals[face[0]], &in.vertex_normals[face[1]],
                          &in.vertex_normals[face[2]]};
      // Normal equations of: e u + f v = dn.t, f u + g v = dn.b per edge.
      double suu = 0, suv = 0, svv = 0, r0 = 0, r1 = 0, r2 = 0;
      for (int j = 0; j < 3; ++j) {
        const double u = e[j].dot(t), v = e[j].dot(b);
        const Vec3 dn = *n[(j + 2) % 3] - *n[(j + 1) % 3];
        const double dnt = dn.dot(t), dnb = dn.dot(b);
        suu += u * u;
        suv += u * v;
        svv += v * v;
        r0 += u * dnt;
        r1 += v * dnt + u * dnb;
        r2 += v * dnb;
      }
      const double A[3][3] = {{suu, suv, 0.0}, {suv, suu + svv, suv}, {0.0, suv, svv}};
      const double rhs[3] = {r0, r1, r2};
      double x[3];
      if (!solve_spd<3>(A, rhs, x)) continue;
      fits[fi] = FaceFit{t, x[0], x[1], x[2]};
      fit_ok[fi] = 1;
    }
  });

  PrincipalCurvatures out;
  out.k1.assign(nv, 0.0);
  out.k2.assign(nv, 0.0);
  out.e1.assign(nv, Vec3::Zero());
  out.e2.assign(nv, Vec3::Zero());
  out.valid.assign(nv, 0);
  parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t vi = begin; vi < end; ++vi) {
      if (!in.normal_valid[vi]) continue;
      const Vec3& n = in.vertex_normals[vi];
      Vec3 u, v;
      vertex_frame(mesh, in.topology, vi, n, u, v);
      const auto faces = in.topology.vertex_faces(vi);
      const auto corners = in.topology.vertex_face_corners(vi);
      double ku = 0, kuv = 0, kv = 0, wsum = 0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const auto fi = static_cast<std::size_t>(faces[i]);
        if (!fit_ok[fi]) continue;
        const double w = in.corner_areas[fi][corners[i]];
        if (!(w > 0.0)) continue;
        const FaceFit& F = fits[fi];
        const Vec3& nT = in.face_normals[fi];
        const Vec3 bT = nT.cross(F.t);
        const Vec3 ru = rotate_tangent(u, n, nT);
        const Vec3 rv = rotate_tangent(v, n, nT);
        const double a1 = ru.dot(F.t), b1 = ru.dot(bT);
        const double a2 = rv.dot(F.t), b2 = rv.dot(bT);
        ku += w * (a1 * a1 * F.e + 2.0 * a1 * b1 * F.f + b1 * b1 * F.g);
        kuv += w * (a1 * a2 * F.e + (a1 * b2 + a2 * b1) * F.f + b1 * b2 * F.g);
        kv += w * (a2 * a2 * F.e + 2.0 * a2 * b2 * F.f + b2 * b2 * F.g);
        wsum += w;
      }
      if (!(wsum > 0.0)) continue;
      const PrincipalFrame pf = diagonalize({ku / wsum, kuv / wsum, kv / wsum}, u, v, n);
      if (!std::isfinite(pf.k1) || !std::isfinite(pf.k2)) continue;
      out.k1[vi] = pf.k1;
      out.k2[vi] = pf.k2;
      out.e1[vi] = pf.e1;
      out.e2[vi] = pf.e2;
      out.valid[vi] = 1;
    }
  });
  return out;
}

CurvatureDerivatives estimate_curvature_derivatives(const CurvatureInputs& in,
                                                    const PrincipalCurvatures& curv) {
  const TriangleMesh& mesh = in.mesh;
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();

  struct FaceFit {
    Vec3 t;
    double C[4];
  };
  std::vector<FaceFit> fits(nf);
  std::vector<std::uint8_t> fit_ok(nf);
  parallel_chunks(nf, kFaceGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t fi = begin; fi < end; ++fi) {
      const Face& face = mesh.faces[fi];
      const Vec3& nT = in.face_normals[fi];
      fit_ok[fi] = 0;
      fits[fi] = FaceFit{Vec3::Zero(), {0.0, 0.0, 0.0, 0.0}};
      if (nT.isZero() || !curv.valid[face[0]] || !curv.valid[face[1]] || !curv.valid[face[2]])
        continue;
      const Vec3& p0 = mesh.positions[face[0]];
      const Vec3& p1 = mesh.positions[face[1]];
      const Vec3& p2 = mesh.positions[face[2]];
      const Vec3 e[3] = {p2 - p1, p0 - p2, p1 - p0};
      const Vec3 t = e[0].normalized();
      const Vec3 b = nT.cross(t);
      TangentTensor2 II[3];
      for (int k = 0; k < 3; ++k) {
        const auto v = static_cast<std::size_t>(face[k]);
        const Vec3 E1 = rotate_tangent(curv.e1[v], in.vertex_normals[v], nT);
        II[k] = tensor_from_principal(curv.k1[v], curv.k2[v], E1.dot(t), E1.dot(b));
      }
      // Per edge: de = a u + b v, df = b u + c v (counted twice), dg = c u + d v.
      double A[4][4] = {};
      double rhs[4] = {};
      for (int j = 0; j < 3; ++j) {
        const double u = e[j].dot(t), v = e[j].dot(b);
        const TangentTensor2& h = II[(j + 2) % 3];
        const TangentTensor2& l = II[(j + 1) % 3];
        const double de = h.xx - l.xx, df = h.xy - l.xy, dg = h.yy - l.yy;
        const double uu = u * u, uv = u * v, vv = v * v;
        A[0][0] += uu;
        A[0][1] += uv;
        A[1][1] += vv + 2.0 * uu;
        A[1][2] += 2.0 * uv;
        A[2][2] += 2.0 * vv + uu;
        A[2][3] += uv;
        A[3][3] += vv;
        rhs[0] += u * de;
        rhs[1] += v * de + 2.0 * u * df;
        rhs[2] += 2.0 * v * df + u * dg;
        rhs[3] += v * dg;
      }
      A[1][0] = A[0][1];
      A[2][1] = A[1][2];
      A[3][2] = A[2][3];
      double x[4];
      if (!solve_spd<4>(A, rhs, x)) continue;
      fits[fi] = FaceFit{t, {x[0], x[1], x[2], x[3]}};
      fit_ok[fi] = 1;
    }
  });

  CurvatureDerivatives out;
  out.a.assign(nv, 0.0);
  out.b.assign(nv, 0.0);
  out.c.assign(nv, 0.0);
  out.d.assign(nv, 0.0);
  out.valid.assign(nv, 0);
  parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t vi = begin; vi < end; ++vi) {
      if (!curv.valid[vi]) continue;
      const Vec3& n = in.vertex_normals[vi];
      const auto faces = in.topology.vertex_faces(vi);
      const auto corners = in.topology.vertex_face_corners(vi);
      double acc[4] = {0.0, 0.0, 0.0, 0.0};
      double wsum = 0.0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const auto fi = static_cast<std::size_t>(faces[i]);
        if (!fit_ok[fi]) continue;
        const double w = in.corner_areas[fi][corners[i]];
        if (!(w > 0.0)) continue;
        const FaceFit& F = fits[fi];
        const Vec3& nT = in.face_normals[fi];
        const Vec3 bT = nT.cross(F.t);
        const Vec3 r1 = rotate_tangent(curv.e1[vi], n, nT);
        const Vec3 r2 = rotate_tangent(curv.e2[vi], n, nT);
        double C[4];
        cubic_reexpress(F.C, Vec2(r1.dot(F.t), r1.dot(bT)), Vec2(r2.dot(F.t), r2.dot(bT)), C);
        for (int k = 0; k < 4; ++k) acc[k] += w * C[k];
        wsum += w;
      }
      if (!(wsum > 0.0)) continue;
      const double inv = 1.0 / wsum;
      out.a[vi] = acc[0] * inv;
      out.b[vi] = acc[1] * inv;
      out.c[vi] = acc[2] * inv;
      out.d[vi] = acc[3] * inv;
      out.valid[vi] = 1;
    }
  });
  return out;
}

}  // namespace detail

namespace {

/// Per-thread scratch for the neighbourhood flood fill of the smoothing.
struct FloodScratch {
  std::vector<std::uint32_t> stamp;
  std::uint32_t current = 0;
  std::vector<std::int32_t> queue;
};

/// Calls visit(j, d2) for every vertex reachable from i through edges
/// without leaving the ball of radius `radius` around p_i (i included), in
/// breadth-first order (deterministic). Vertices for which `pass` is false
/// are neither visited nor crossed.
template <class Pass, class Visit>
void flood_ball(const Surface& s, std::size_t i, double radius, FloodScratch& scratch,
                const Pass& pass, const Visit& visit) {
  const auto& pos = s.positions();
  const auto& topo = s.topology();
  if (scratch.stamp.size() != pos.size()) {
    scratch.stamp.assign(pos.size(), 0);
    scratch.current = 0;
  }
  if (++scratch.current == 0) {
    std::fill(scratch.stamp.begin(), scratch.stamp.end(), 0);
    scratch.current = 1;
  }
  const double r2 = radius * radius;
  scratch.queue.clear();
  scratch.queue.push_back(static_cast<std::int32_t>(i));
  scratch.stamp[i] = scratch.current;
  for (std::size_t head = 0; head < scratch.queue.size(); ++head) {
    const auto j = static_cast<std::size_t>(scratch.queue[head]);
    visit(j, (pos[j] - pos[i]).squaredNorm());
    for (const auto k : topo.vertex_neighbors(j)) {
      if (scratch.stamp[k] == scratch.current) continue;
      scratch.stamp[k] = scratch.current;
      if ((pos[k] - pos[i]).squaredNorm() > r2 || !pass(static_cast<std::size_t>(k))) continue;
      scratch.queue.push_back(k);
    }
  }
}

}  // namespace

void smooth_curvature(const Surface& surface, PrincipalCurvatures& curv, double sigma, int passes) {
  if (!(sigma > 0.0) || passes <= 0) return;
  const std::size_t nv = surface.vertex_count();
  const auto& normals = surface.vertex_normals();
  const auto& areas = surface.vertex_areas();
  tbb::enumerable_thread_specific<FloodScratch> scratch;
  const double inv2s2 = 1.0 / (2.0 * sigma * sigma);
  for (int pass = 0; pass < passes; ++pass) {
    PrincipalCurvatures next = curv;
    detail::parallel_chunks(nv, 256, [&](std::size_t begin, std::size_t end) {
      FloodScratch& sc = scratch.local();
      for (std::size_t i = begin; i < end; ++i) {
        if (!curv.valid[i]) continue;
        const Vec3& ni = normals[i];
        const Vec3& u = curv.e1[i];
        const Vec3& v = curv.e2[i];
        TangentTensor2 acc;
        double wsum = 0.0;
        flood_ball(
            surface, i, 2.5 * sigma, sc,
            [&](std::size_t j) { return curv.valid[j] && normals[j].dot(ni) > 0.0; },
            [&](std::size_t j, double d2) {
              const double w = std::exp(-d2 * inv2s2) * areas[j] * normals[j].dot(ni);
              if (!(w > 0.0)) return;
              const Vec3 E1 = detail::rotate_tangent(curv.e1[j], normals[j], ni);
              const TangentTensor2 t =
                  tensor_from_principal(curv.k1[j], curv.k2[j], E1.dot(u), E1.dot(v));
              acc.xx += w * t.xx;
              acc.xy += w * t.xy;
              acc.yy += w * t.yy;
              wsum += w;
            });
        if (!(wsum > 0.0)) continue;
        const PrincipalFrame pf =
            diagonalize({acc.xx / wsum, acc.xy / wsum, acc.yy / wsum}, u, v, ni);
        next.k1[i] = pf.k1;
        next.k2[i] = pf.k2;
        next.e1[i] = pf.e1;
        next.e2[i] = pf.e2;
      }
    });
    curv = std::move(next);
  }
}

void smooth_curvature_derivatives(const Surface& surface, const PrincipalCurvatures& curv,
                                  CurvatureDerivatives& deriv, double sigma, int passes) {
  if (!(sigma > 0.0) || passes <= 0) return;
  const std::size_t nv = surface.vertex_count();
  const auto& normals = surface.vertex_normals();
  const auto& areas = surface.vertex_areas();
  tbb::enumerable_thread_specific<FloodScratch> scratch;
  const double inv2s2 = 1.0 / (2.0 * sigma * sigma);
  for (int pass = 0; pass < passes; ++pass) {
    CurvatureDerivatives next = deriv;
    detail::parallel_chunks(nv, 256, [&](std::size_t begin, std::size_t end) {
      FloodScratch& sc = scratch.local();
      for (std::size_t i = begin; i < end; ++i) {
        if (!deriv.valid[i]) continue;
        const Vec3& ni = normals[i];
        double acc[4] = {0.0, 0.0, 0.0, 0.0};
        double wsum = 0.0;
        flood_ball(
            surface, i, 2.5 * sigma, sc,
            [&](std::size_t j) { return deriv.valid[j] && normals[j].dot(ni) > 0.0; },
            [&](std::size_t j, double d2) {
              const double w = std::exp(-d2 * inv2s2) * areas[j] * normals[j].dot(ni);
              if (!(w > 0.0)) return;
              // Centre's principal axes, rotated into j's plane, in j's frame.
              const Vec3 r1 = detail::rotate_tangent(curv.e1[i], ni, normals[j]);
              const Vec3 r2 = detail::rotate_tangent(curv.e2[i], ni, normals[j]);
              const double Cj[4] = {deriv.a[j], deriv.b[j], deriv.c[j], deriv.d[j]};
              double C[4];
              cubic_reexpress(Cj, Vec2(r1.dot(curv.e1[j]), r1.dot(curv.e2[j])),
                              Vec2(r2.dot(curv.e1[j]), r2.dot(curv.e2[j])), C);
              for (int k = 0; k < 4; ++k) acc[k] += w * C[k];
              wsum += w;
            });
        if (!(wsum > 0.0)) continue;
        next.a[i] = acc[0] / wsum;
        next.b[i] = acc[1] / wsum;
        next.c[i] = acc[2] / wsum;
        next.d[i] = acc[3] / wsum;
      }
    });
    deriv = std::move(next);
  }
}

double feature_size(const PrincipalCurvatures& curv, double radius,
                    const FeatureSizeOptions& options) {
  const double cap = options.bounding_sphere_fraction * radius;
  const std::size_t nv = curv.k1.size();
  std::vector<double> samples;
  auto add = [&](std::size_t v) {
    if (!curv.valid[v]) return;
    samples.push_back(std::abs(curv.k1[v]));
    samples.push_back(std::abs(curv.k2[v]));
  };
  if (options.rtsc_sampling) {
    std::uint32_t r = 0;
    for (int s = 0; s < 500 && nv > 0; ++s) {
      r = 1664525u * r + 1013904223u;
      add(r % nv);
    }
  } else {
    samples.reserve(2 * nv);
    for (std::size_t v = 0; v < nv; ++v) add(v);
  }
  // Nothing to measure (no points, or all at one place): 1 mm keeps every
  // threshold finite.
  if (!(cap > 0.0)) return 1.0;
  if (samples.empty()) return cap;
  const double p = std::clamp(options.percentile, 0.0, 1.0);
  const auto idx = std::min(samples.size() - 1, static_cast<std::size_t>(p * samples.size()));
  std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(idx),
                   samples.end());
  const double kp = samples[idx];
  if (!(kp > 0.0)) return cap;
  return std::min(options.numerator / kp, cap);
}

}  // namespace fabrica
