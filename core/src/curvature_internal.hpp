// Private entry points of the curvature estimator, called by the Surface
// cache (surface.cpp) with its already computed inputs. Not installed.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "curvature_fit_kernel.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"
#include "geometry_kernels.hpp"

namespace fabrica::detail {

struct CurvatureInputs {
  const TriangleMesh& mesh;
  const Topology& topology;
  const std::vector<Vec3>& face_normals;
  const std::vector<Vec3>& corner_areas;
  const std::vector<Vec3>& vertex_normals;
  const std::vector<std::uint8_t>& normal_valid;
};

/// Where the fits keep the per-corner slots, and in which order they visit
/// the faces and vertices, so that fewer slots than corners exist at once:
/// the faces go in steps of `step_faces` consecutive faces; after step s,
/// the vertices whose last face is in it (all of their slots written) are
/// summed. A vertex whose faces all lie in one step has its slots in a
/// region that every step reuses; the others (faces in several steps) keep
/// theirs, after one another, until the end. Vertex v's slots are
/// [start[v], start[v] + its face count), in its vertex_faces order, which
/// its sum reads in that order, as one pass over all faces and then all
/// vertices would: the same bits at any step size (0: one step, a slot for
/// every corner). On a mesh whose faces follow its vertices' order (igea,
/// scans) most vertices are in one step.
struct FitSchedule {
  std::size_t step_faces = 0, steps = 0;
  std::vector<std::int32_t> start;     ///< per vertex: its first slot
  std::vector<std::int32_t> vertices;  ///< the vertices with faces, by their last step
  std::vector<std::size_t> completed;  ///< step s sums vertices[completed[s], completed[s + 1])
  std::size_t capacity = 0;            ///< slots in all
};

/// The faces per step of the fits (FitSchedule; tests set other sizes: the
/// bits do not depend on it).
std::atomic<std::size_t>& curvature_fit_step_faces();

/// Buffers shared by the passes of one Surface (allocated once, reused, so
/// that fresh memory, whose first touch is expensive, is touched once): the
/// slot schedule and each (face, corner)'s slot; the slots (II: 3 values,
/// C: 4, then the weight, 0 = not used; float, curvature_fit_kernel.hpp);
/// and one float record per vertex.
struct FaceFitScratch {
  FitSchedule schedule;
  ScratchArray<std::array<std::int32_t, 3>> corner_slot;
  ScratchArray<FitSlot> fit_slots;
  ScratchArray<FitVertex> vertices;
  /// Empty, or the fits' face inputs as float (FitArrays::face_records:
  /// kFaceRecord floats per face and two more), when the Surface frees its
  /// double face quantities before the fits (release_face_quantities asked
  /// for before the vertex normals).
  ScratchArray<float> face_records;
  bool frames_ready = false;  ///< vertices hold (n, u, v) for the II fit
};

/// Stores a vertex's normal, frame and principal values in a fit record.
inline void set_fit_vertex(FitVertex& r, const Vec3& n, const Vec3& x, const Vec3& y, double k1,
                           double k2) {
  for (int i = 0; i < 3; ++i) {
    r.n[i] = static_cast<float>(n[i]);
    r.x[i] = static_cast<float>(x[i]);
    r.y[i] = static_cast<float>(y[i]);
  }
  r.k1 = static_cast<float>(k1);
  r.k2 = static_cast<float>(k2);
  r.pad = 0.0f;
}

/// Whether the AVX2 fits run: whether the CPU has AVX2 (and the build has
/// them), unless set to false (tests compare them with the portable ones).
std::atomic<bool>& curvature_avx2_enabled();

/// An orthonormal tangent frame (u, v = n x u) at vertex `vtx` with unit
/// normal n: u is its first incident edge projected onto the tangent plane,
/// or any perpendicular.
void vertex_frame(const TriangleMesh& mesh, const Topology& topo, std::size_t vtx, const Vec3& n,
                  Vec3& u, Vec3& v);

/// The fits' schedule (FitSchedule, with curvature_fit_step_faces()) and,
/// for every (face, corner), its slot, so a face pass can write per-corner
/// results where a vertex pass reads them contiguously, in vertex_faces(v)
/// order.
void fill_corner_slots(const Topology& topo, FaceFitScratch& scratch);

/// Rusinkiewicz per-face fit of II and its re-expression at the vertices.
/// Fills scratch (kept for the derivative fit).
PrincipalCurvatures estimate_curvature(const CurvatureInputs& in, FaceFitScratch& scratch);

/// Per-face fit of the derivative tensor C from `curvature` and its
/// re-expression at the vertices. Uses scratch from estimate_curvature.
CurvatureDerivatives estimate_curvature_derivatives(const CurvatureInputs& in,
                                                    const PrincipalCurvatures& curvature,
                                                    FaceFitScratch& scratch);

/// The k-th smallest value (0-based) of `values`, which must be finite: the
/// value std::nth_element would put at position k, found with a parallel
/// histogram pass and a selection inside one bin (O(n), same result at any
/// thread count). Precondition: k < values.size().
double kth_smallest(const std::vector<double>& values, std::size_t k);

/// Run `body(begin, end)` over [0, n) in parallel chunks. Not isolated by
/// itself: code that holds a std::once_flag (the Surface cache) runs its
/// whole computation inside one tbb::this_task_arena::isolate region, so a
/// thread waiting there never picks up unrelated outer tasks (which could
/// re-enter the call_once it holds), while all the parallel work spawned in
/// that region, nested or not, can still be shared by every thread.
template <class Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body);

}  // namespace fabrica::detail

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace fabrica::detail {

template <class Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

}  // namespace fabrica::detail
