// Private to fabrica::lines: pieces of update_view_fields().
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "fabrica/lines/view_fields.hpp"

namespace fabrica {
struct PhoticOptions;
struct LaplacianOptions;
}  // namespace fabrica

namespace fabrica::detail {

template <class T>
void resize_or_clear(std::vector<T>& v, bool on, std::size_t n) {
  if (on)
    v.resize(n);
  else
    v.clear();
}

/// Sets request.light_threshold and light_cull_backfaces so the sparse
/// illumination fields serve the given families (nullptr: not extracted):
/// the smaller threshold (1/mm), culling only if every family culls.
void set_light_support(ViewFieldsRequest& request, const PhoticOptions* pel,
                       const LaplacianOptions* laplacian, double feature_size);

/// The illumination group (light, light_gradient, light_laplacian, pel_*):
/// sized or cleared per `request`; `radial` says whether ndotv was already
/// filled by the radial group.
void update_light_fields(ViewFields& fields, const Surface& surface, const Camera& camera,
                         const ViewFieldsRequest& request, const LinePrecompute* precompute,
                         bool radial);

/// update_view_fields(), optionally leaving fields.dt1q1 unset (sized, not
/// computed) so the caller can compute it with update_dt1q1() concurrently
/// with the families that do not need it. With `same_surface` the caller
/// guarantees that `fields` has only ever been updated for this `surface`
/// (a LineExtractor's own fields): the positions in fields.apparent_vertex
/// are then written for every vertex only when the array is (re)sized, and
/// the D_t1 q1 pass must be told not to write them again
/// (write_positions = false below); the deferred pass's caller does that.
/// With `stream_vertex_blocks` (one-shot extraction) the AVX2 vertex pass
/// packs its inputs a few blocks at a time (LinePrecompute::pack_vertex_blocks)
/// instead of reading (and building, and keeping)
/// LinePrecompute::vertex_blocks(): the same bits.
void update_view_fields(ViewFields& fields, const Surface& surface, const Camera& camera,
                        const ViewFieldsRequest& request, const LinePrecompute* precompute,
                        bool defer_dt1q1, bool same_surface = false,
                        bool stream_vertex_blocks = false);

/// D_t1 q1 (fields.dt1q1) and the apparent-ridge kernel's records
/// (fields.apparent_vertex: E = D_t1 q1 t1_world, D_t1 q1, q1, position)
/// from the filled q1, t1, t1_world, ndotv and signs: Judd's one-sided
/// finite differences along t1 (docs/algorithms.md §6.2).
/// With `cull`, only at vertices of faces with a corner carrying kQ1Above
/// (dt1q1 0 elsewhere, records left as they were). `precompute` supplies
/// the tangent ring; nullptr: from the topology. `write_positions` false:
/// the records' positions are current (update_view_fields' same_surface)
/// and are not written again (with `precompute` only). `stream_ring`: the
/// ring is built a block of vertices at a time (for one view: less memory,
/// LinePrecompute::streamed_tangent_ring), the same bits.
void update_dt1q1(ViewFields& fields, const Surface& surface, bool cull,
                  const LinePrecompute* precompute, bool write_positions = true,
                  bool stream_ring = false);

/// update_dt1q1 (with the precomputed tangent ring) in blocks of kBlock
/// vertices that any thread can claim, in increasing vertex order, so a
/// consumer can start on the vertices already done: ready_through(v)
/// returns once every vertex <= v is done, computing unclaimed blocks
/// itself while it waits (so nobody waits for work that no thread runs).
/// Same values as update_dt1q1, at any thread count and interleaving.
/// How many fan vertices the AVX2 D_t1 q1 pass handed to the double
/// candidate search (a float sign within its error bound, |t1| > 2, or more
/// than two candidate faces); for tests.
inline std::atomic<std::size_t>& dt1q1_double_path() {
  static std::atomic<std::size_t> n{0};
  return n;
}

class Dt1q1Blocks {
 public:
  static constexpr std::size_t kBlock = 2048;
  Dt1q1Blocks(ViewFields& fields, const Surface& surface, bool cull,
              const LinePrecompute& precompute, bool write_positions = true,
              bool stream_ring = false);
  ~Dt1q1Blocks();
  Dt1q1Blocks(const Dt1q1Blocks&) = delete;
  Dt1q1Blocks& operator=(const Dt1q1Blocks&) = delete;
  /// Runs unclaimed blocks until none is left (not waiting for blocks
  /// other threads are running).
  void run_all();
  /// Returns once vertices [0, v] are done.
  void ready_through(std::size_t v);

 private:
  struct State;
  std::unique_ptr<State> state_;
  bool run_one();
  void advance();
};

}  // namespace fabrica::detail
