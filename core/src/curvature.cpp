// Rusinkiewicz (2004) curvature and curvature-derivative estimation, written
// from the paper and docs/algorithms.md §2 (not from trimesh2's code).
//
// Layout for speed and determinism: one parallel pass over faces writes
// per-face results into flat arrays, then one parallel pass over vertices
// gathers from topology().vertex_faces(v) in increasing face order. Every
// output element is computed by exactly one task in a fixed order, so the
// bits do not depend on the thread count.
#include "fabrica/core/curvature.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>

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

/// Solves the symmetric tridiagonal system with diagonal `diag` and
/// off-diagonal `off` (off[i] = A[i][i+1]) by LDLᵀ without pivoting (the
/// normal equations of both per-face fits are tridiagonal). Returns false
/// when a pivot is not clearly positive (rank-deficient fit).
template <int N>
bool solve_spd_tridiagonal(const double (&diag)[N], const double (&off)[N - 1],
                           const double (&b)[N], double (&x)[N]) {
  double max_diag = 0.0;
  for (int i = 0; i < N; ++i) max_diag = std::max(max_diag, diag[i]);
  if (!(max_diag > 0.0)) return false;
  const double tiny = 1e-12 * max_diag;
  double inv_d[N], l[N], y[N];
  double d = diag[0];
  if (!(d > tiny)) return false;
  inv_d[0] = 1.0 / d;
  y[0] = b[0];
  for (int i = 1; i < N; ++i) {
    l[i] = off[i - 1] * inv_d[i - 1];
    d = diag[i] - l[i] * off[i - 1];
    if (!(d > tiny)) return false;
    inv_d[i] = 1.0 / d;
    y[i] = b[i] - l[i] * y[i - 1];
  }
  x[N - 1] = y[N - 1] * inv_d[N - 1];
  for (int i = N - 2; i >= 0; --i) x[i] = y[i] * inv_d[i] - l[i + 1] * x[i + 1];
  return true;
}

/// Second fundamental form of principal values k1, k2 whose e1 has unit
/// coordinates (c, s) in some frame: k1 (c,s)(c,s)ᵀ + k2 (-s,c)(-s,c)ᵀ.
inline TangentTensor2 tensor_from_principal(double k1, double k2, double c, double s) {
  return {k1 * c * c + k2 * s * s, (k1 - k2) * c * s, k1 * s * s + k2 * c * c};
}

/// Coefficients of the cubic form C (a,b,c,d in a frame F) in a new frame
/// whose axes have coordinates x = (x1,x2), y = (y1,y2) in F:
/// C(x,x,x), C(x,x,y), C(x,y,y), C(y,y,y), expanded.
inline void cubic_reexpress(const double (&C)[4], const Vec2& x, const Vec2& y, double (&out)[4]) {
  const double a = C[0], b = C[1], c = C[2], d = C[3];
  const double x1 = x[0], x2 = x[1], y1 = y[0], y2 = y[1];
  // C(p, q, .) as a linear form in the last argument: (C(p,q,e1), C(p,q,e2)).
  const double xx1 = a * x1 * x1 + 2 * b * x1 * x2 + c * x2 * x2;  // C(x,x,e1)
  const double xx2 = b * x1 * x1 + 2 * c * x1 * x2 + d * x2 * x2;  // C(x,x,e2)
  const double yy1 = a * y1 * y1 + 2 * b * y1 * y2 + c * y2 * y2;  // C(y,y,e1)
  const double yy2 = b * y1 * y1 + 2 * c * y1 * y2 + d * y2 * y2;  // C(y,y,e2)
  out[0] = xx1 * x1 + xx2 * x2;
  out[1] = xx1 * y1 + xx2 * y2;
  out[2] = yy1 * x1 + yy2 * x2;
  out[3] = yy1 * y1 + yy2 * y2;
}

/// Coordinates, in the face frame (t, b), of the vertex tangent vectors x
/// and y after the minimal rotation from the vertex plane (normal n) into
/// the face plane (normal nT). Uses R x . t = x . t - (nT . x)(n . t)/(1+c),
/// which follows from R x = x - (nT . x)/(1+c) (n + nT) and t, b _|_ nT.
struct FrameInFace {
  double x1, x2, y1, y2;
};
inline FrameInFace frame_in_face(const Vec3& x, const Vec3& y, const Vec3& n, const Vec3& nT,
                                 const Vec3& t, const Vec3& b) {
  const double c = n.dot(nT);
  if (!(c > -1.0 + 1e-12)) {
    const Vec3 rx = detail::rotate_tangent(x, n, nT), ry = detail::rotate_tangent(y, n, nT);
    return {rx.dot(t), rx.dot(b), ry.dot(t), ry.dot(b)};
  }
  const double s = 1.0 / (1.0 + c);
  const double nt = n.dot(t) * s, nb = n.dot(b) * s;
  const double xn = nT.dot(x), yn = nT.dot(y);
  return {x.dot(t) - xn * nt, x.dot(b) - xn * nb, y.dot(t) - yn * nt, y.dot(b) - yn * nb};
}

}  // namespace

PrincipalFrame diagonalize(const TangentTensor2& t, const Vec3& u, const Vec3& v,
                           const Vec3& normal) {
  const double m = 0.5 * (t.xx + t.yy);
  const double d = 0.5 * (t.xx - t.yy);
  const double r = std::sqrt(d * d + t.xy * t.xy);
  double x1, x2;  // eigenvector of m + r
  if (d >= 0.0) {
    x1 = r + d;
    x2 = t.xy;
  } else {
    x1 = t.xy;
    x2 = r - d;
  }
  const double len = std::sqrt(x1 * x1 + x2 * x2);
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

namespace {

/// The least-squares fit of II on one face (docs/algorithms.md §2.1), in the
/// frame (t, b = nT x t); false if the normal equations are singular.
inline bool fit_second_fundamental_form(const Vec3 (&e)[3], const Vec3* const (&n)[3],
                                        const Vec3& t, const Vec3& b, double (&x)[3]) {
  // Per edge j (head corner j+2, tail j+1): e u + f v = dn.t, f u + g v = dn.b.
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
  // Normal equations [[suu, suv, 0], [suv, suu + svv, suv], [0, suv, svv]].
  const double diag[3] = {suu, suu + svv, svv};
  const double off[2] = {suv, suv};
  const double rhs[3] = {r0, r1, r2};
  return solve_spd_tridiagonal<3>(diag, off, rhs, x);
}

/// The least-squares fit of C on one face (§2.3) from the three vertices'
/// II in the face frame.
inline bool fit_curvature_derivative(const Vec3 (&e)[3], const TangentTensor2 (&II)[3],
                                     const Vec3& t, const Vec3& b, double (&x)[4]) {
  // Per edge: de = a u + b v, df = b u + c v (counted twice), dg = c u + d v.
  // The normal equations are tridiagonal:
  // [[uu, uv, 0, 0], [uv, vv + 2uu, 2uv, 0], [0, 2uv, 2vv + uu, uv], [0, 0, uv, vv]].
  double suu = 0, suv = 0, svv = 0;
  double rhs[4] = {0.0, 0.0, 0.0, 0.0};
  for (int j = 0; j < 3; ++j) {
    const double u = e[j].dot(t), v = e[j].dot(b);
    const TangentTensor2& h = II[(j + 2) % 3];
    const TangentTensor2& l = II[(j + 1) % 3];
    const double de = h.xx - l.xx, df = h.xy - l.xy, dg = h.yy - l.yy;
    suu += u * u;
    suv += u * v;
    svv += v * v;
    rhs[0] += u * de;
    rhs[1] += v * de + 2.0 * u * df;
    rhs[2] += 2.0 * v * df + u * dg;
    rhs[3] += v * dg;
  }
  const double diag[4] = {suu, svv + 2.0 * suu, 2.0 * svv + suu, svv};
  const double off[3] = {suv, 2.0 * suv, suv};
  return solve_spd_tridiagonal<4>(diag, off, rhs, x);
}

}  // namespace

void fill_corner_slots(const Topology& topo, ScratchArray<std::array<std::int32_t, 3>>& slots) {
  const std::size_t nv = topo.vertex_count();
  slots.resize(topo.face_count());
  if (nv == 0) return;
  const std::int32_t* base = topo.vertex_faces(0).data();
  parallel_chunks(nv, 8192, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const auto faces = topo.vertex_faces(v);
      const auto corners = topo.vertex_face_corners(v);
      const auto offset = static_cast<std::int32_t>(faces.data() - base);
      for (std::size_t i = 0; i < faces.size(); ++i)
        slots[faces[i]][corners[i]] = offset + static_cast<std::int32_t>(i);
    }
  });
}

/// Face pass of the II fit over faces [begin, end): fit, then write each
/// corner's weighted tensor in its vertex's reference frame into its slot.
FABRICA_MULTIVERSION
void fit_second_fundamental_forms(const CurvatureInputs& in, FaceFitScratch& scratch,
                                  std::size_t begin, std::size_t end) {
  const TriangleMesh& mesh = in.mesh;
  auto& slots = scratch.slots;
  const auto& frames = scratch.vertices;
  for (std::size_t fi = begin; fi < end; ++fi) {
    const Face& face = mesh.faces[fi];
    const Vec3& nT = in.face_normals[fi];
    const auto& slot = scratch.corner_slot[fi];
    for (int k = 0; k < 3; ++k) slots[slot[k]] = {0.0, 0.0, 0.0, 0.0, 0.0};
    const Vec3& p0 = mesh.positions[face[0]];
    const Vec3& p1 = mesh.positions[face[1]];
    const Vec3& p2 = mesh.positions[face[2]];
    const Vec3 e[3] = {p2 - p1, p0 - p2, p1 - p0};
    if (nT.isZero()) continue;
    const Vec3 t = e[0].normalized();
    if (!in.normal_valid[face[0]] || !in.normal_valid[face[1]] || !in.normal_valid[face[2]])
      continue;
    const VertexRecord* V[3] = {&frames[face[0]], &frames[face[1]], &frames[face[2]]};
    const Vec3* const n[3] = {&V[0]->n, &V[1]->n, &V[2]->n};
    const Vec3 b = nT.cross(t);
    double x[3];
    if (!fit_second_fundamental_form(e, n, t, b, x)) continue;
    const Vec3& ca = in.corner_areas[fi];
    for (int k = 0; k < 3; ++k) {
      const double w = ca[k];
      if (!(w > 0.0)) continue;
      const FrameInFace r = frame_in_face(V[k]->x, V[k]->y, V[k]->n, nT, t, b);
      const double a1 = r.x1, b1 = r.x2, a2 = r.y1, b2 = r.y2;
      slots[slot[k]] = {w * (a1 * a1 * x[0] + 2.0 * a1 * b1 * x[1] + b1 * b1 * x[2]),
                        w * (a1 * a2 * x[0] + (a1 * b2 + a2 * b1) * x[1] + b1 * b2 * x[2]),
                        w * (a2 * a2 * x[0] + 2.0 * a2 * b2 * x[1] + b2 * b2 * x[2]), 0.0, w};
    }
  }
}

/// Face pass of the C fit over faces [begin, end), as above.
FABRICA_MULTIVERSION
void fit_curvature_derivatives(const CurvatureInputs& in, const PrincipalCurvatures& curv,
                               FaceFitScratch& scratch, std::size_t begin, std::size_t end) {
  const TriangleMesh& mesh = in.mesh;
  auto& slots = scratch.slots;
  const auto& vrec = scratch.vertices;
  for (std::size_t fi = begin; fi < end; ++fi) {
    const Face& face = mesh.faces[fi];
    const Vec3& nT = in.face_normals[fi];
    const auto& slot = scratch.corner_slot[fi];
    for (int k = 0; k < 3; ++k) slots[slot[k]] = {0.0, 0.0, 0.0, 0.0, 0.0};
    if (nT.isZero() || !curv.valid[face[0]] || !curv.valid[face[1]] || !curv.valid[face[2]])
      continue;
    const Vec3& p0 = mesh.positions[face[0]];
    const Vec3& p1 = mesh.positions[face[1]];
    const Vec3& p2 = mesh.positions[face[2]];
    const Vec3 e[3] = {p2 - p1, p0 - p2, p1 - p0};
    const Vec3 t = e[0].normalized();  // the same frame as the II fit
    const Vec3 b = nT.cross(t);
    const VertexRecord* V[3] = {&vrec[face[0]], &vrec[face[1]], &vrec[face[2]]};
    FrameInFace r[3];
    TangentTensor2 II[3];
    for (int k = 0; k < 3; ++k) {
      r[k] = frame_in_face(V[k]->x, V[k]->y, V[k]->n, nT, t, b);
      II[k] = tensor_from_principal(V[k]->k1, V[k]->k2, r[k].x1, r[k].x2);
    }
    double x[4];
    if (!fit_curvature_derivative(e, II, t, b, x)) continue;
    const Vec3& ca = in.corner_areas[fi];
    for (int k = 0; k < 3; ++k) {
      const double w = ca[k];
      if (!(w > 0.0)) continue;
      double C[4];
      cubic_reexpress(x, Vec2(r[k].x1, r[k].x2), Vec2(r[k].y1, r[k].y2), C);
      slots[slot[k]] = {w * C[0], w * C[1], w * C[2], w * C[3], w};
    }
  }
}

// Layout (for speed): per-vertex data the face passes need is packed into
// one record per vertex; each face pass fits its tensor and immediately
// re-expresses it in the frame of each of its three vertices, writing the
// weighted result into that corner's slot of a CSR array ordered like
// topology().vertex_faces(v). The vertex pass then sums contiguous slots in
// that fixed order: no scattered reads, no atomics, same bits at any thread
// count.
PrincipalCurvatures estimate_curvature(const CurvatureInputs& in, FaceFitScratch& scratch) {
  const TriangleMesh& mesh = in.mesh;
  const Topology& topo = in.topology;
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();

  if (scratch.corner_slot.size() != nf) fill_corner_slots(topo, scratch.corner_slot);
  scratch.slots.resize(3 * nf);

  // Per vertex: normal and reference tangent frame (x = u, y = v = n x u).
  // Usually already filled by the vertex-normal pass (surface.cpp).
  auto& frames = scratch.vertices;
  if (!scratch.frames_ready) {
    frames.resize(nv);
    parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t vi = begin; vi < end; ++vi) {
        VertexRecord& F = frames[vi];
        F.n = in.vertex_normals[vi];
        F.k1 = F.k2 = 0.0;
        if (!in.normal_valid[vi]) {
          F.x = F.y = Vec3::Zero();
          continue;
        }
        vertex_frame(mesh, topo, vi, F.n, F.x, F.y);
      }
    });
  }

  auto& slots = scratch.slots;
  PrincipalCurvatures out;
  // The outputs' fresh memory is filled while the face pass runs.
  tbb::parallel_invoke(
      [&] {
        parallel_chunks(nf, kFaceGrain, [&](std::size_t begin, std::size_t end) {
          fit_second_fundamental_forms(in, scratch, begin, end);
        });
      },
      [&] {
        assign_large(out.k1, nv, 0.0);
        assign_large(out.k2, nv, 0.0);
        assign_large(out.e1, nv, Vec3(Vec3::Zero()));
        assign_large(out.e2, nv, Vec3(Vec3::Zero()));
        out.valid.assign(nv, 0);
      });
  const auto* base = nv ? topo.vertex_faces(0).data() : nullptr;
  parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t vi = begin; vi < end; ++vi) {
      if (!in.normal_valid[vi]) continue;
      const auto faces = topo.vertex_faces(vi);
      const std::size_t first = static_cast<std::size_t>(faces.data() - base);
      double ku = 0, kuv = 0, kv = 0, wsum = 0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const auto& c = slots[first + i];
        if (!(c[4] > 0.0)) continue;
        ku += c[0];
        kuv += c[1];
        kv += c[2];
        wsum += c[4];
      }
      if (!(wsum > 0.0)) continue;
      const double inv = 1.0 / wsum;
      const VertexRecord& F = frames[vi];
      const PrincipalFrame pf = diagonalize({ku * inv, kuv * inv, kv * inv}, F.x, F.y, F.n);
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
                                                    const PrincipalCurvatures& curv,
                                                    FaceFitScratch& scratch) {
  const TriangleMesh& mesh = in.mesh;
  const Topology& topo = in.topology;
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();

  auto& slots = scratch.slots;
  CurvatureDerivatives out;
  tbb::parallel_invoke(
      [&] {
        // Per vertex, what the face pass reads (x = e1, y = e2), in the buffer the
        // II fit used for its frames.
        auto& vrec = scratch.vertices;
        vrec.resize(nv);
        scratch.frames_ready = false;
        parallel_chunks(nv, 8192, [&](std::size_t begin, std::size_t end) {
          for (std::size_t v = begin; v < end; ++v)
            vrec[v] =
                VertexRecord{in.vertex_normals[v], curv.e1[v], curv.e2[v],
                             curv.valid[v] ? curv.k1[v] : 0.0, curv.valid[v] ? curv.k2[v] : 0.0};
        });

        // Face pass: re-uses the slot map of the II fit.
        parallel_chunks(nf, kFaceGrain, [&](std::size_t begin, std::size_t end) {
          fit_curvature_derivatives(in, curv, scratch, begin, end);
        });
      },
      [&] {
        assign_large(out.a, nv, 0.0);
        assign_large(out.b, nv, 0.0);
        assign_large(out.c, nv, 0.0);
        assign_large(out.d, nv, 0.0);
        out.valid.assign(nv, 0);
      });
  const auto* base = nv ? topo.vertex_faces(0).data() : nullptr;
  parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t vi = begin; vi < end; ++vi) {
      if (!curv.valid[vi]) continue;
      const auto faces = topo.vertex_faces(vi);
      const std::size_t first = static_cast<std::size_t>(faces.data() - base);
      double acc[4] = {0.0, 0.0, 0.0, 0.0};
      double wsum = 0.0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const auto& c = slots[first + i];
        if (!(c[4] > 0.0)) continue;
        for (int k = 0; k < 4; ++k) acc[k] += c[k];
        wsum += c[4];
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
  const double kp = detail::kth_smallest(samples, idx);
  if (!(kp > 0.0)) return cap;
  return std::min(options.numerator / kp, cap);
}

}  // namespace fabrica
