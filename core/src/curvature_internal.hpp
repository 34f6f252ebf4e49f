// Private entry points of the curvature estimator, called by the Surface
// cache (surface.cpp) with its already computed inputs. Not installed.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

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

/// Per-vertex data a face pass reads, packed together: the normal n and a
/// tangent frame (x, y = n x x): the reference frame (u, v) for the II fit,
/// the principal frame (e1, e2) and k1, k2 for the derivative fit.
struct VertexRecord {
  Vec3 n;
  Vec3 x;
  Vec3 y;
  double k1, k2;
};

/// Buffers shared by the passes of one Surface (allocated once, reused, so
/// that fresh memory, whose first touch is expensive, is touched once): each
/// (face, corner)'s position in the vertex -> faces CSR list, one slot per
/// such position holding that corner's weighted, re-expressed quantity
/// (normal: 3 values + weight + area; II: 3 values; C: 4) and its weight
/// (entry 4 for the fits; 0 = not used), and one record per vertex.
struct FaceFitScratch {
  ScratchArray<std::array<std::int32_t, 3>> corner_slot;
  ScratchArray<std::array<double, 5>> slots;
  ScratchArray<VertexRecord> vertices;
  bool frames_ready = false;  ///< vertices hold (n, u, v) for the II fit
};

/// An orthonormal tangent frame (u, v = n x u) at vertex `vtx` with unit
/// normal n: u is its first incident edge projected onto the tangent plane,
/// or any perpendicular.
void vertex_frame(const TriangleMesh& mesh, const Topology& topo, std::size_t vtx, const Vec3& n,
                  Vec3& u, Vec3& v);

/// For every (face, corner), its position in the vertex -> faces CSR list
/// of `topo`, so a face pass can write per-corner results where a vertex
/// pass reads them contiguously, in vertex_faces(v) order.
void fill_corner_slots(const Topology& topo, ScratchArray<std::array<std::int32_t, 3>>& slots);

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
