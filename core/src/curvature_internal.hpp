// Private entry points of the curvature estimator, called by the Surface
// cache (surface.cpp) with its already computed inputs. Not installed.
#pragma once

#include <cstdint>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"

namespace fabrica::detail {

struct CurvatureInputs {
  const TriangleMesh& mesh;
  const Topology& topology;
  const std::vector<Vec3>& face_normals;
  const std::vector<Vec3>& corner_areas;
  const std::vector<Vec3>& vertex_normals;
  const std::vector<std::uint8_t>& normal_valid;
};

/// Rusinkiewicz per-face fit of II and its re-expression at the vertices.
PrincipalCurvatures estimate_curvature(const CurvatureInputs& in);

/// Per-face fit of the derivative tensor C from `curvature` and its
/// re-expression at the vertices.
CurvatureDerivatives estimate_curvature_derivatives(const CurvatureInputs& in,
                                                    const PrincipalCurvatures& curvature);

/// Run `body(begin, end)` over [0, n) in parallel chunks, inside an isolated
/// task region (a thread waiting here never picks up unrelated outer tasks,
/// which could re-enter a std::call_once it already holds).
template <class Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body);

}  // namespace fabrica::detail

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace fabrica::detail {

template <class Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  tbb::this_task_arena::isolate([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
  });
}

}  // namespace fabrica::detail
