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
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "curvature_fit_kernel.hpp"
#include "curvature_internal.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/geometry.hpp"
#include "geometry_kernels.hpp"

namespace fabrica {

namespace {

constexpr std::size_t kFaceGrain = 2048;
constexpr std::size_t kVertexGrain = 1024;

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

std::atomic<std::size_t>& curvature_fit_step_faces() {
  static std::atomic<std::size_t> faces{32768};
  return faces;
}

// The schedule (FitSchedule) and every corner's slot, in two parallel
// passes over fixed chunks of vertices: per chunk, how many slots its
// vertices take (per step for those in one step, in all for the others) and
// how many it completes per step; then, from these counts' prefix sums over
// the chunks, each vertex's first slot and place in the completion order,
// and its corners' slots. The same schedule as one serial pass in vertex
// order, at any thread count.
void fill_corner_slots(const Topology& topo, FaceFitScratch& scratch) {
  FitSchedule& out = scratch.schedule;
  out = FitSchedule{};
  const std::size_t nv = topo.vertex_count(), nf = topo.face_count();
  auto& slots = scratch.corner_slot;
  slots.resize(nf);
  if (nv == 0 || nf == 0) return;
  std::size_t step_faces = curvature_fit_step_faces().load();
  if (step_faces == 0 || step_faces > nf) step_faces = nf;
  const std::size_t steps = (nf + step_faces - 1) / step_faces;
  out.step_faces = step_faces;
  out.steps = steps;
  constexpr std::size_t kChunk = 8192;
  const std::size_t chunks = (nv + kChunk - 1) / kChunk;
  // Per chunk and step: local slots (and at step `steps`, the spread
  // vertices' slots), and completed vertices; made running sums below.
  std::vector<std::int32_t> local(chunks * (steps + 1), 0), done(chunks * steps, 0);
  // Per vertex, until replaced by its first slot: its last step, or -2 -
  // that step when it is spread over several; -1 without faces.
  out.start.resize(nv);
  const auto step_of = [&](std::int32_t face) {
    return static_cast<std::int32_t>(static_cast<std::size_t>(face) / step_faces);
  };
  parallel_chunks(chunks, 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      std::int32_t* const loc = local.data() + c * (steps + 1);
      std::int32_t* const dn = done.data() + c * steps;
      for (std::size_t v = c * kChunk, e = std::min(nv, v + kChunk); v < e; ++v) {
        const auto faces = topo.vertex_faces(v);
        if (faces.empty()) {
          out.start[v] = -1;
          continue;
        }
        const std::int32_t s0 = step_of(faces.front()), s1 = step_of(faces.back());
        const auto n = static_cast<std::int32_t>(faces.size());
        loc[s0 == s1 ? static_cast<std::size_t>(s1) : steps] += n;
        ++dn[s1];
        out.start[v] = s0 == s1 ? s1 : -2 - s1;
      }
    }
  });
  // Exclusive running sums over the chunks: the spread vertices' slots
  // first, then each step's region (the same for every step).
  std::int32_t spread = 0, region = 0;
  out.completed.assign(steps + 1, 0);
  for (std::size_t c = 0; c < chunks; ++c) {
    std::int32_t& n = local[c * (steps + 1) + steps];
    const std::int32_t here = n;
    n = spread;
    spread += here;
  }
  for (std::size_t s = 0; s < steps; ++s) {
    std::int32_t at = 0;
    std::size_t finished = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      std::int32_t& n = local[c * (steps + 1) + s];
      const std::int32_t here = n;
      n = at;
      at += here;
      std::int32_t& d = done[c * steps + s];
      const auto dhere = static_cast<std::size_t>(d);
      d = static_cast<std::int32_t>(finished);
      finished += dhere;
    }
    region = std::max(region, at);
    out.completed[s + 1] = out.completed[s] + finished;
  }
  out.capacity = static_cast<std::size_t>(spread + region);
  out.vertices.resize(out.completed[steps]);
  parallel_chunks(chunks, 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      std::int32_t* const loc = local.data() + c * (steps + 1);
      std::int32_t* const dn = done.data() + c * steps;
      for (std::size_t v = c * kChunk, e = std::min(nv, v + kChunk); v < e; ++v) {
        const std::int32_t code = out.start[v];
        const auto faces = topo.vertex_faces(v);
        const auto corners = topo.vertex_face_corners(v);
        if (code == -1) {
          out.start[v] = 0;  // (no slots)
          continue;
        }
        const bool spread_out = code < -1;
        const auto s1 = static_cast<std::size_t>(spread_out ? -2 - code : code);
        std::int32_t& at = loc[spread_out ? steps : s1];
        const std::int32_t first = spread_out ? at : spread + at;
        at += static_cast<std::int32_t>(faces.size());
        out.start[v] = first;
        out.vertices[out.completed[s1] + static_cast<std::size_t>(dn[s1]++)] =
            static_cast<std::int32_t>(v);
        for (std::size_t i = 0; i < faces.size(); ++i)
          slots[faces[i]][corners[i]] = first + static_cast<std::int32_t>(i);
      }
    }
  });
}

std::atomic<bool>& curvature_avx2_enabled() {
#if defined(FABRICA_CURVATURE_AVX2)
  static std::atomic<bool> on{__builtin_cpu_supports("avx2") != 0};
#else
  static std::atomic<bool> on{false};
#endif
  return on;
}

#if !defined(FABRICA_CURVATURE_AVX2)
// Without the AVX2 file: never called (curvature_avx2_enabled() is false).
void fit_second_fundamental_forms_avx2(const FitArrays& a, std::size_t begin, std::size_t end) {
  fitk::fit_second_fundamental_forms<fitk::FloatLanes>(a, begin, end);
}
void fit_curvature_derivatives_avx2(const FitArrays& a, std::size_t begin, std::size_t end) {
  fitk::fit_curvature_derivatives<fitk::FloatLanes>(a, begin, end);
}
#endif

namespace {

FitArrays fit_arrays(const CurvatureInputs& in, const std::uint8_t* valid,
                     FaceFitScratch& scratch) {
  // The fits address vertex records (12 floats each) and the corners of the
  // faces (3 each) with 32-bit offsets.
  constexpr std::size_t kMaxVertices = std::numeric_limits<std::int32_t>::max() / 12;
  constexpr std::size_t kMaxFaces = std::numeric_limits<std::int32_t>::max() / 3;
  if (in.mesh.positions.size() > kMaxVertices || in.mesh.faces.size() > kMaxFaces)
    throw InputError("surface mesh: " + std::to_string(in.mesh.positions.size()) +
                     " vertices and " + std::to_string(in.mesh.faces.size()) +
                     " faces; the curvature estimate handles at most " +
                     std::to_string(kMaxVertices) + " vertices and " + std::to_string(kMaxFaces) +
                     " faces (split the mesh)");
  return {in.mesh.positions.empty() ? nullptr : in.mesh.positions[0].data(),
          in.mesh.faces.data(),
          in.face_normals.empty() ? nullptr : in.face_normals[0].data(),
          in.corner_areas.empty() ? nullptr : in.corner_areas[0].data(),
          valid,
          scratch.vertices.data(),
          scratch.corner_slot.data(),
          scratch.fit_slots.data(),
          scratch.face_records.size() ? scratch.face_records.data() : nullptr};
}

/// One fit (II or C) step by step (FitSchedule): the face pass over the
/// step's faces, eight at a time, AVX2 where the CPU has it (both versions
/// give the same bits); then sum(v, slots) for each vertex the step
/// completes, `slots` its first slot. `beside` runs beside the first face
/// pass (the first touch of the outputs' memory).
template <class Portable, class Avx2, class Sum, class Beside>
void run_fit(std::size_t nf, const FitArrays& arrays, const FitSchedule& sch,
             const Portable& portable, const Avx2& avx2, const Sum& sum, const Beside& beside) {
  if (sch.steps == 0) {
    beside();
    return;
  }
  const bool wide = curvature_avx2_enabled().load(std::memory_order_relaxed);
  for (std::size_t s = 0; s < sch.steps; ++s) {
    const std::size_t f0 = s * sch.step_faces, f1 = std::min(nf, f0 + sch.step_faces);
    const auto face_pass = [&] {
      parallel_chunks(f1 - f0, kFaceGrain, [&](std::size_t begin, std::size_t end) {
        if (wide)
          avx2(arrays, f0 + begin, f0 + end);
        else
          portable(arrays, f0 + begin, f0 + end);
      });
    };
    if (s == 0)
      tbb::parallel_invoke(face_pass, beside);
    else
      face_pass();
    const std::int32_t* const done = sch.vertices.data() + sch.completed[s];
    parallel_chunks(sch.completed[s + 1] - sch.completed[s], kVertexGrain,
                    [&](std::size_t begin, std::size_t end) {
                      for (std::size_t i = begin; i < end; ++i) {
                        const auto v = static_cast<std::size_t>(done[i]);
                        sum(v, arrays.slots + sch.start[v]);
                      }
                    });
  }
}

}  // namespace

// Layout (for speed): per-vertex data the face passes need is packed into
// one record per vertex; each face pass fits its tensor and immediately
// re-expresses it in the frame of each of its three vertices, writing the
// weighted result into that corner's slot (each vertex's slots contiguous,
// ordered like topology().vertex_faces(v)). The vertex pass then sums a
// vertex's slots in that fixed order: no scattered reads, no atomics, same
// bits at any thread count. Faces go in steps (FitSchedule), after each of
// which the vertices it completes are summed, so slots exist only for one
// step's vertices and for those spread over several steps (igea: 256k of
// 806k corners).
PrincipalCurvatures estimate_curvature(const CurvatureInputs& in, FaceFitScratch& scratch) {
  const TriangleMesh& mesh = in.mesh;
  const Topology& topo = in.topology;
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();

  if (scratch.corner_slot.size() != nf || scratch.schedule.start.size() != nv)
    fill_corner_slots(topo, scratch);
  scratch.fit_slots.resize(scratch.schedule.capacity);

  // Per vertex: normal and reference tangent frame (x = u, y = v = n x u).
  // Usually already filled by the vertex-normal pass (surface.cpp).
  auto& frames = scratch.vertices;
  if (!scratch.frames_ready) {
    frames.resize(nv);
    parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t vi = begin; vi < end; ++vi) {
        Vec3 x = Vec3::Zero(), y = Vec3::Zero();
        if (in.normal_valid[vi]) vertex_frame(mesh, topo, vi, in.vertex_normals[vi], x, y);
        set_fit_vertex(frames[vi], in.vertex_normals[vi], x, y, 0.0, 0.0);
      }
    });
  }

  PrincipalCurvatures out;
  // Per vertex: the sum of its slots in CSR order, diagonalised.
  const auto sum = [&](std::size_t vi, const FitSlot* slots) {
    if (!in.normal_valid[vi]) return;
    const std::size_t count = topo.vertex_faces(vi).size();
    float ku = 0, kuv = 0, kv = 0, wsum = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const auto& c = slots[i];
      if (!(c[4] > 0.0f)) continue;
      ku += c[0];
      kuv += c[1];
      kv += c[2];
      wsum += c[4];
    }
    if (!(wsum > 0.0f)) return;
    const double inv = 1.0 / double(wsum);
    const FitVertex& F = frames[vi];
    const PrincipalFrame pf =
        diagonalize({ku * inv, kuv * inv, kv * inv}, Vec3(F.x[0], F.x[1], F.x[2]),
                    Vec3(F.y[0], F.y[1], F.y[2]), in.vertex_normals[vi]);
    if (!std::isfinite(pf.k1) || !std::isfinite(pf.k2)) return;
    // The float frame (u, v) is orthonormal to float rounding only:
    // e1 is made a unit tangent again in double, e2 = n x e1.
    const Vec3& n = in.vertex_normals[vi];
    const Vec3 e1 = (pf.e1 - pf.e1.dot(n) * n).normalized();
    out.k1[vi] = pf.k1;
    out.k2[vi] = pf.k2;
    out.e1[vi] = e1;
    out.e2[vi] = n.cross(e1);
    out.valid[vi] = 1;
  };
  // The outputs' fresh memory is filled while the first face pass runs.
  run_fit(nf, fit_arrays(in, in.normal_valid.data(), scratch), scratch.schedule,
          fitk::fit_second_fundamental_forms<fitk::FloatLanes>, fit_second_fundamental_forms_avx2,
          sum, [&] {
            assign_large(out.k1, nv, 0.0);
            assign_large(out.k2, nv, 0.0);
            assign_large(out.e1, nv, Vec3(Vec3::Zero()));
            assign_large(out.e2, nv, Vec3(Vec3::Zero()));
            out.valid.assign(nv, 0);
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

  CurvatureDerivatives out;
  // Per vertex, what the face pass reads (x = e1, y = e2), in the buffer the
  // II fit used for its frames; the outputs' fresh memory filled meanwhile.
  tbb::parallel_invoke(
      [&] {
        auto& vrec = scratch.vertices;
        vrec.resize(nv);
        scratch.frames_ready = false;
        parallel_chunks(nv, 8192, [&](std::size_t begin, std::size_t end) {
          for (std::size_t v = begin; v < end; ++v)
            set_fit_vertex(vrec[v], in.vertex_normals[v], curv.e1[v], curv.e2[v],
                           curv.valid[v] ? curv.k1[v] : 0.0, curv.valid[v] ? curv.k2[v] : 0.0);
        });
      },
      [&] {
        assign_large(out.a, nv, 0.0);
        assign_large(out.b, nv, 0.0);
        assign_large(out.c, nv, 0.0);
        assign_large(out.d, nv, 0.0);
        out.valid.assign(nv, 0);
      });
  const auto sum = [&](std::size_t vi, const FitSlot* slots) {
    if (!curv.valid[vi]) return;
    const std::size_t count = topo.vertex_faces(vi).size();
    float acc[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    float wsum = 0.0f;
    for (std::size_t i = 0; i < count; ++i) {
      const auto& c = slots[i];
      if (!(c[4] > 0.0f)) continue;
      for (int k = 0; k < 4; ++k) acc[k] += c[k];
      wsum += c[4];
    }
    if (!(wsum > 0.0f)) return;
    const double inv = 1.0 / double(wsum);
    out.a[vi] = acc[0] * inv;
    out.b[vi] = acc[1] * inv;
    out.c[vi] = acc[2] * inv;
    out.d[vi] = acc[3] * inv;
    out.valid[vi] = 1;
  };
  // The slot map and schedule of the II fit.
  run_fit(nf, fit_arrays(in, curv.valid.data(), scratch), scratch.schedule,
          fitk::fit_curvature_derivatives<fitk::FloatLanes>, fit_curvature_derivatives_avx2, sum,
          [] {});
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
