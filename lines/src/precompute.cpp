#include "fabrica/lines/precompute.hpp"

#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "fabrica/core/error.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"
#include "zero_crossing_internal.hpp"
#include "zero_crossing_kernel.hpp"

namespace fabrica {

namespace {

// std::call_once with `fn` run isolated: a thread that waits inside for its
// parallel loops takes no outer task, which could ask for the same part
// again while its once flag (or lock) is held: the parts are built lazily
// from tasks that run concurrently (LineExtractor::extract).
template <class Fn>
void call_once_isolated(std::once_flag& flag, Fn&& fn) {
  std::call_once(flag, [&] { tbb::this_task_arena::isolate(fn); });
}

}  // namespace

struct LinePrecompute::Cache {
  std::once_flag gradient_once, laplacian_once, ring_once;
  // The raw lines and their inputs, in one part that release_raw_lines()
  // replaces with a fresh one (never while another thread reads it): its
  // once flags then build them again on the next use.
  struct Raw {
    std::once_flag k1_once, ridge_once, demarcating_once, ridge_keys_once, demarcating_keys_once;
    std::vector<double> abs_k1;
    std::vector<LineSegment> ridges, valleys, demarcating;
    std::vector<RawKey> ridge_keys, valley_keys, demarcating_keys;
  };
  std::unique_ptr<Raw> raw = std::make_unique<Raw>();
  std::atomic<bool> raw_released{false};
  // The per-view passes' inputs can be released (release_view_inputs) and
  // are then rebuilt on the next use: a flag under a mutex, not a once_flag.
  std::mutex tangent_ring_mutex, blocks_mutex;
  bool tangent_ring_ready = false, blocks_ready = false;
  VertexBlocks blocks;
  TangentRing tangent_ring;
  // With a streamed ring (only its layout in tangent_ring): each corner's
  // rank in its vertex's fan (RingBuilder::layout).
  std::unique_ptr<std::uint8_t[]> ring_order;
  CornerRing ring;
  GradientOperator gradient;
  std::vector<Vec3> normal_laplacian;
  std::mutex above_mutex;
  std::shared_ptr<const RawAbove> above[3];  // ridge, valley, demarcating
};

LinePrecompute::LinePrecompute(const Surface& surface)
    : surface_(&surface), cache_(std::make_unique<Cache>()) {}
LinePrecompute::~LinePrecompute() = default;

const std::vector<double>& LinePrecompute::abs_k1() const {
  call_once_isolated(cache_->raw->k1_once, [&] {
    const auto& curv = surface_->curvature();
    cache_->raw->abs_k1.resize(curv.k1.size());
    for (std::size_t i = 0; i < curv.k1.size(); ++i) cache_->raw->abs_k1[i] = std::abs(curv.k1[i]);
  });
  return cache_->raw->abs_k1;
}

const LinePrecompute::CornerRing& LinePrecompute::corner_ring() const {
  call_once_isolated(cache_->ring_once, [&] {
    // A copy of Topology::vertex_face_opposite with its offsets.
    const Topology& topo = surface_->topology();
    const std::size_t nv = surface_->vertex_count();
    CornerRing& r = cache_->ring;
    r.offset.resize(nv + 1);
    r.offset[0] = 0;
    for (std::size_t i = 0; i < nv; ++i)
      r.offset[i + 1] = r.offset[i] + static_cast<std::int32_t>(topo.vertex_faces(i).size());
    r.opposite.resize(static_cast<std::size_t>(r.offset[nv]));
    detail::parallel_range(nv, [&](std::size_t i) {
      const auto o = topo.vertex_face_opposite(i);
      std::copy(o.begin(), o.end(), r.opposite.begin() + r.offset[i]);
    });
  });
  return cache_->ring;
}

namespace {

// Fan order of the faces of one vertex (LinePrecompute::TangentRing): the
// k faces' opposite corners o[0..k) form a closed fan when following each
// face's second opposite corner to the one face whose first opposite corner
// it is visits every face once and comes back to face 0. Writes the faces in
// that order into rank[0..k). Branch-free successor search (the matching
// face's position is random: a branch per comparison mispredicts).
bool fan_order(const std::array<std::int32_t, 2>* o, std::int32_t k, std::uint8_t* rank) {
  if (k < 1 || k > 63) return false;
  std::uint8_t next[64];
  unsigned bad = 0;
#if defined(__SSE2__)
  if (k <= 8) {
    // The first opposite corners in two 4-lane registers (-1 past k: no
    // vertex), one compare per face.
    alignas(16) std::int32_t first[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    for (std::int32_t g = 0; g < k; ++g) first[g] = o[g][0];
    const __m128i lo = _mm_load_si128(reinterpret_cast<const __m128i*>(first));
    const __m128i hi = _mm_load_si128(reinterpret_cast<const __m128i*>(first + 4));
    for (std::int32_t f = 0; f < k; ++f) {
      const __m128i want = _mm_set1_epi32(o[f][1]);
      const auto m =
          static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(lo, want))) |
                                _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(hi, want))) << 4);
      bad |= unsigned(m == 0 || (m & (m - 1)) != 0);  // no face, or two
      next[f] = static_cast<std::uint8_t>(__builtin_ctz(m | 0x100u));
    }
  } else
#endif
    for (std::int32_t f = 0; f < k; ++f) {
      const std::int32_t want = o[f][1];
      std::int32_t at = 0, count = 0;
      for (std::int32_t g = 0; g < k; ++g) {
        const std::int32_t m = o[g][0] == want;
        at += m * g;
        count += m;
      }
      bad |= unsigned(count != 1);  // no face, or a corner that opens two
      next[f] = static_cast<std::uint8_t>(at);
    }
  if (bad) return false;
  std::uint64_t used = 0;
  std::int32_t f = 0;
  for (std::int32_t j = 0; j < k; ++j) {
    if (used >> f & 1) return false;
    used |= std::uint64_t{1} << f;
    rank[j] = static_cast<std::uint8_t>(f);
    f = next[f];
  }
  return f == 0;  // the chain closes after k faces
}

}  // namespace

namespace {

// The two passes of the tangent ring (LinePrecompute::TangentRing): its
// layout (each vertex's fan order, entry count and offset), then the entries
// of each vertex, which depend on nothing else.
class RingBuilder {
 public:
  /// Room for one vertex's opposite corners when read from the faces (a
  /// fixed array for up to 64 faces, not initialised; more in `large`).
  struct Opposite {
    std::array<std::array<std::int32_t, 2>, 64> small;
    std::vector<std::array<std::int32_t, 2>> large;
  };

  /// With `from_faces`, each vertex's opposite corners are read from the
  /// mesh's faces (the same values as Topology::vertex_face_opposite, which
  /// is then not built: 8 bytes per corner less, for the one-shot streamed
  /// ring), else from the topology; by default from the topology only when
  /// it holds them.
  explicit RingBuilder(const Surface& surface)
      : RingBuilder(surface, !surface.topology().has_vertex_face_opposite()) {}
  RingBuilder(const Surface& surface, bool from_faces)
      : topo_(surface.topology()),
        pos_(surface.positions()),
        curv_(surface.curvature()),
        faces_(from_faces ? &surface.faces() : nullptr),
        face_base_(surface.vertex_count() ? topo_.vertex_faces(0).data() : nullptr),
        opposite_base_(!from_faces && surface.vertex_count() ? topo_.vertex_face_opposite(0).data()
                                                             : nullptr) {}

  // Vertex i's opposite corners, in `scratch` when read from the faces.
  std::span<const std::array<std::int32_t, 2>> opposite(std::size_t i, Opposite& scratch) const {
    const auto fs = topo_.vertex_faces(i);
    // (The topology's, read in place like vertex_faces.)
    if (!faces_) return {opposite_base_ + (fs.data() - face_base_), fs.size()};
    const std::uint8_t* const cs = topo_.vertex_face_corners(i).data();
    const std::size_t k = fs.size();
    std::array<std::int32_t, 2>* out = scratch.small.data();
    if (k > scratch.small.size()) {
      scratch.large.resize(k);
      out = scratch.large.data();
    }
    const Face* const faces = faces_->data();
    for (std::size_t j = 0; j < k; ++j) {
      const Face& f = faces[static_cast<std::size_t>(fs[j])];
      const int c = cs[j];
      out[j] = Topology::corners_after(f, c);
    }
    return {out, k};
  }

  // Topology::vertex_face_opposite read in place (CSR like vertex_faces:
  // the corner offset of vertex i is its vertex_faces(i) position).
  std::size_t corner_at(std::size_t i) const {
    return static_cast<std::size_t>(topo_.vertex_faces(i).data() - face_base_);
  }

  // t.fan and t.offset, and the rank of each fan face into `order` at the
  // vertex's corner offset (left uninitialised: the entries pass reads it
  // only for fans, whose entries this pass wrote). Returns `order`.
  std::unique_ptr<std::uint8_t[]> layout(LinePrecompute::TangentRing& t) const {
    const std::size_t nv = pos_.size();
    const std::size_t corners = nv ? corner_at(nv - 1) + topo_.vertex_faces(nv - 1).size() : 0;
    // A fan also needs finite offsets (d·e1, d·e2) where the curvature is
    // valid. They are when every position is finite and below 1e30 in
    // magnitude and e1, e2 are finite with components at most 2 (|d·e| <
    // 3 · 2e30 · 2, far below FLT_MAX; a non-finite e gives a non-finite
    // product): then the fan pass needs no gather of the ring's positions,
    // and the entries pass computes the offsets once, in place. Otherwise
    // they are computed to check (a Surface rejects coordinates beyond
    // 1e15, so only a frame that is not unit gets there).
    // (Every Surface's coordinates are at most 1e15 in magnitude:
    // check_mesh_indices_and_values, so positions_bounded always holds.)
    constexpr bool positions_bounded = true;
    auto unit_frame = [&](std::size_t i) {
      const Vec3 &e1 = curv_.e1[i], &e2 = curv_.e2[i];
      return positions_bounded && std::abs(e1[0]) <= 2.0 && std::abs(e1[1]) <= 2.0 &&
             std::abs(e1[2]) <= 2.0 && std::abs(e2[0]) <= 2.0 && std::abs(e2[1]) <= 2.0 &&
             std::abs(e2[2]) <= 2.0;
    };
    // The pass runs over fixed chunks of vertices, each also writing its
    // vertices' entry counts into t.offset[i + 1] and summing them; the
    // offsets are then these counts' prefix sums, chunk after chunk (the
    // same at any thread count, no serial pass over the vertices).
    std::unique_ptr<std::uint8_t[]> order(new std::uint8_t[corners]);
    t.fan.resize(nv);
    t.offset.resize(nv + 1);
    t.offset[0] = 0;
    constexpr std::size_t kChunk = 4096;
    const std::size_t chunks = (nv + kChunk - 1) / kChunk;
    std::vector<std::int32_t> chunk_entries(chunks + 1, 0);
    detail::parallel_range(
        chunks,
        [&](std::size_t c) {
          std::int32_t entries = 0;
          Opposite scratch;
          for (std::size_t i = c * kChunk, e = std::min(nv, i + kChunk); i < e; ++i) {
            const auto o = opposite(i, scratch);
            const auto k = static_cast<std::int32_t>(o.size());
            std::uint8_t* const rank = order.get() + corner_at(i);
            bool fan = fan_order(o.data(), k, rank);
            if (fan && curv_.valid[i] && !unit_frame(i)) {
              const Vec3 p = pos_[i], e1 = curv_.e1[i], e2 = curv_.e2[i];
              for (std::int32_t j = 0; j < k && fan; ++j) {
                const Vec3 d = pos_[static_cast<std::size_t>(o[rank[j]][0])] - p;
                fan = std::isfinite(static_cast<float>(d.dot(e1))) &&
                      std::isfinite(static_cast<float>(d.dot(e2)));
              }
            }
            t.fan[i] = fan;
            t.offset[i + 1] = fan ? k + 1 : 2 * k;
            entries += t.offset[i + 1];
          }
          chunk_entries[c + 1] = entries;
        },
        1);
    for (std::size_t c = 0; c < chunks; ++c) chunk_entries[c + 1] += chunk_entries[c];
    detail::parallel_range(
        chunks,
        [&](std::size_t c) {
          std::int32_t at = chunk_entries[c];
          for (std::size_t i = c * kChunk, e = std::min(nv, i + kChunk); i < e; ++i)
            t.offset[i + 1] = at += t.offset[i + 1];
        },
        1);
    return order;
  }

  // The entries of vertex i (its fan flag, its count n = offset[i + 1] -
  // offset[i] and, for a fan, its faces' ranks in order[corner_at(i)...])
  // at vertex, rank, x, y [0, n).
  void entries(std::size_t i, bool fan, std::size_t m, const std::uint8_t* order,
               std::int32_t* vertex, std::uint8_t* rank_out, float* x, float* y,
               Opposite& scratch) const {
    const auto o = opposite(i, scratch);
    const auto k = static_cast<std::int32_t>(o.size());
    if (fan) {
      // n_0 .. n_{k-1} in fan order, then n_0 again (the last face's
      // second opposite corner).
      const std::uint8_t* const rank = order + corner_at(i);
      std::copy(rank, rank + k, rank_out);
      rank_out[k] = 0;
      for (std::int32_t j = 0; j < k; ++j) vertex[j] = o[rank[j]][0];
      vertex[k] = o[rank[k - 1]][1];
      // (the last entry is n_0's offset again)
      offsets(i, static_cast<std::size_t>(k), vertex, x, y);
      x[k] = x[0];
      y[k] = y[0];
      return;
    }
    std::fill(rank_out, rank_out + m, std::uint8_t{0});
    for (std::int32_t j = 0; j < k; ++j) {
      vertex[2 * j] = o[j][0];
      vertex[2 * j + 1] = o[j][1];
    }
    offsets(i, m, vertex, x, y);
  }

 private:
  // Ring entries [0, m) of vertex i: offsets (d·e1, d·e2) of vertex[j],
  // d = p_vertex[j] - p_i, as float; zeros where the curvature is invalid.
  void offsets(std::size_t i, std::size_t m, const std::int32_t* vertex, float* x, float* y) const {
    if (!curv_.valid[i]) {
      std::fill(x, x + m, 0.0f);
      std::fill(y, y + m, 0.0f);
      return;
    }
    const Vec3 p = pos_[i], e1 = curv_.e1[i], e2 = curv_.e2[i];
    for (std::size_t j = 0; j < m; ++j) {
      const Vec3 d = pos_[static_cast<std::size_t>(vertex[j])] - p;
      x[j] = static_cast<float>(d.dot(e1));
      y[j] = static_cast<float>(d.dot(e2));
    }
  }

  const Topology& topo_;
  const std::vector<Vec3>& pos_;
  const PrincipalCurvatures& curv_;
  const std::vector<Face>* faces_;
  const std::int32_t* face_base_;
  const std::array<std::int32_t, 2>* opposite_base_;
};

// Sizes t's entry arrays for `total` entries and writes their kPad entries
// after them (vertex 0, zeros), so fixed-width reads past a short ring stay
// inside them; every other entry is written by RingBuilder::entries (no
// zeroing pass first).
void size_ring_entries(LinePrecompute::TangentRing& t, std::size_t total) {
  constexpr std::size_t kPad = LinePrecompute::TangentRing::kPad;
  t.vertex.resize(total + kPad);
  t.rank.resize(total + kPad);
  t.x.resize(total + kPad);
  t.y.resize(total + kPad);
  std::fill(t.vertex.begin() + total, t.vertex.end(), 0);
  std::fill(t.rank.begin() + total, t.rank.end(), 0);
  std::fill(t.x.begin() + total, t.x.end(), 0.0f);
  std::fill(t.y.begin() + total, t.y.end(), 0.0f);
}

}  // namespace

const LinePrecompute::TangentRing& LinePrecompute::tangent_ring() const {
  std::lock_guard lock(cache_->tangent_ring_mutex);
  if (cache_->tangent_ring_ready && !cache_->ring_order) return cache_->tangent_ring;
  // Isolated: a thread waiting inside takes no outer task that could ask
  // for the ring again (the mutex is held).
  tbb::this_task_arena::isolate([&] {
    // (From the topology's opposite corners unless they were released:
    // then from the faces, rather than building them.)
    const RingBuilder build(*surface_);
    TangentRing& t = cache_->tangent_ring;
    const std::unique_ptr<std::uint8_t[]> order = build.layout(t);
    cache_->ring_order.reset();
    const std::size_t nv = surface_->vertex_count();
    size_ring_entries(t, static_cast<std::size_t>(t.offset[nv]));
    // (Each vertex's entries depend on nothing else: any partition; the
    // scratch once per range.)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 2048),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        RingBuilder::Opposite scratch;
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                          const auto n = static_cast<std::size_t>(t.offset[i]);
                          build.entries(i, t.fan[i], static_cast<std::size_t>(t.offset[i + 1]) - n,
                                        order.get(), t.vertex.data() + n, t.rank.data() + n,
                                        t.x.data() + n, t.y.data() + n, scratch);
                        }
                      });
  });
  cache_->tangent_ring_ready = true;
  return cache_->tangent_ring;
}

const LinePrecompute::TangentRing& LinePrecompute::streamed_tangent_ring() const {
  std::lock_guard lock(cache_->tangent_ring_mutex);
  if (cache_->tangent_ring_ready) return cache_->tangent_ring;
  tbb::this_task_arena::isolate(
      [&] { cache_->ring_order = RingBuilder(*surface_).layout(cache_->tangent_ring); });
  cache_->tangent_ring_ready = true;
  return cache_->tangent_ring;
}

void LinePrecompute::tangent_ring_block(std::size_t v0, std::size_t v1, TangentRing& out) const {
  // Called while the layout exists (streamed_tangent_ring(), or
  // tangent_ring(), whose order is gone: then the entries are copied).
  const TangentRing& t = cache_->tangent_ring;
  const auto first = static_cast<std::size_t>(t.offset[v0]);
  size_ring_entries(out, static_cast<std::size_t>(t.offset[v1]) - first);
  if (!cache_->ring_order) {
    const std::size_t n = static_cast<std::size_t>(t.offset[v1]) - first;
    std::copy_n(t.vertex.data() + first, n, out.vertex.data());
    std::copy_n(t.rank.data() + first, n, out.rank.data());
    std::copy_n(t.x.data() + first, n, out.x.data());
    std::copy_n(t.y.data() + first, n, out.y.data());
    return;
  }
  const RingBuilder build(*surface_);
  RingBuilder::Opposite scratch;
  for (std::size_t i = v0; i < v1; ++i) {
    const auto n = static_cast<std::size_t>(t.offset[i]) - first;
    build.entries(i, t.fan[i], static_cast<std::size_t>(t.offset[i + 1] - t.offset[i]),
                  cache_->ring_order.get(), out.vertex.data() + n, out.rank.data() + n,
                  out.x.data() + n, out.y.data() + n, scratch);
  }
}

void LinePrecompute::pack_vertex_blocks(std::size_t b0, std::size_t b1, VertexBlock* block,
                                        std::uint8_t* valid_out) const {
  const auto& pos = surface_->positions();
  const auto& nrm = surface_->vertex_normals();
  const auto& curv = surface_->curvature();
  const auto& dcurv = surface_->curvature_derivatives();
  const std::size_t nv = surface_->vertex_count();
  for (std::size_t b = b0; b < b1; ++b) {
    // Every block is written whole (no zeroing pass first); the lanes past
    // the last vertex are zeros.
    VertexBlock& blk = block[b - b0];
    unsigned valid = 0;
    for (std::size_t l = 0; l < 4; ++l) {
      const std::size_t i = 4 * b + l;
      if (i >= nv) {
        for (int k = 0; k < 3; ++k) blk.p[k][l] = blk.n[k][l] = blk.e1[k][l] = blk.e2[k][l] = 0.0;
        blk.k1[l] = blk.k2[l] = blk.a[l] = blk.b[l] = blk.c[l] = blk.d[l] = 0.0;
        continue;
      }
      for (int k = 0; k < 3; ++k) {
        blk.p[k][l] = pos[i][k];
        blk.n[k][l] = nrm[i][k];
        blk.e1[k][l] = curv.e1[i][k];
        blk.e2[k][l] = curv.e2[i][k];
      }
      blk.k1[l] = curv.k1[i];
      blk.k2[l] = curv.k2[i];
      blk.a[l] = dcurv.a[i];
      blk.b[l] = dcurv.b[i];
      blk.c[l] = dcurv.c[i];
      blk.d[l] = dcurv.d[i];
      valid |= unsigned(curv.valid[i] != 0) << l;
      valid |= unsigned(dcurv.valid[i] != 0) << (4 + l);
    }
    valid_out[b - b0] = static_cast<std::uint8_t>(valid);
  }
}

const LinePrecompute::VertexBlocks& LinePrecompute::vertex_blocks() const {
  std::lock_guard lock(cache_->blocks_mutex);
  if (cache_->blocks_ready) return cache_->blocks;
  tbb::this_task_arena::isolate([&] {
    // The Surface's quantities first (computed once, outside the loop).
    (void)surface_->curvature_derivatives();
    const std::size_t nb = (surface_->vertex_count() + 3) / 4;
    VertexBlocks& vb = cache_->blocks;
    vb.block.resize(nb);
    vb.valid.resize(nb);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nb, 512),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        pack_vertex_blocks(r.begin(), r.end(), vb.block.data() + r.begin(),
                                           vb.valid.data() + r.begin());
                      });
  });
  cache_->blocks_ready = true;
  return cache_->blocks;
}

void LinePrecompute::release_vertex_blocks() const {
  std::lock_guard lock(cache_->blocks_mutex);
  cache_->blocks = VertexBlocks{};
  cache_->blocks_ready = false;
}

void LinePrecompute::release_raw_lines() const {
  Cache& c = *cache_;
  c.raw = std::make_unique<Cache::Raw>();
  c.raw_released.store(true, std::memory_order_release);
  std::lock_guard lock(c.above_mutex);
  for (auto& a : c.above) a.reset();
}

bool LinePrecompute::raw_lines_released() const {
  return cache_->raw_released.load(std::memory_order_acquire);
}

void LinePrecompute::release_tangent_ring() const {
  std::lock_guard lock(cache_->tangent_ring_mutex);
  cache_->tangent_ring = TangentRing{};
  cache_->ring_order.reset();
  cache_->tangent_ring_ready = false;
}

namespace {

// Raw ridges and valleys (docs/algorithms.md §3) in one pass over the faces:
// the segments, in order, of vector_zero_crossings over each family alone
// (δ = ±C(e1, e1, e1), direction e1, magnitude |k1|, threshold 0, the edge
// test, the vertex mask "curvature and derivatives valid, k1 > 0" for
// ridges, "k1 < 0" for valleys). A face is visited by the family whose
// mask holds at its three corners (never both), which also implies the
// magnitude test (|k1| > 0 there), so each face is read once instead of
// twice and the kernel (zc::vector_face, its own mask test skipped) runs
// only where a family can cross.
void compute_ridges_and_valleys(const Surface& surface, const std::vector<double>& abs_k1,
                                std::vector<LineSegment>& ridges,
                                std::vector<LineSegment>& valleys) {
  const auto& curv = surface.curvature();
  const auto& dcurv = surface.curvature_derivatives();
  const std::size_t nv = surface.vertex_count();
  detail::FilledVector<double> delta_ridge(nv), delta_valley(nv);
  detail::FilledVector<std::uint8_t> family(nv);  // bit 0: ridge mask, bit 1: valley mask
  detail::parallel_range(nv, [&](std::size_t i) {
    const bool ok = curv.valid[i] && dcurv.valid[i];
    delta_ridge[i] = ok ? dcurv.a[i] : 0.0;
    delta_valley[i] = ok ? -dcurv.a[i] : 0.0;
    family[i] = static_cast<std::uint8_t>(unsigned(ok && curv.k1[i] > 0.0) |
                                          unsigned(ok && curv.k1[i] < 0.0) << 1);
  });
  VectorCrossingOptions o;
  o.test = ExtremumTest::edge;
  o.threshold = 0.0;
  o.keep_raw_magnitude = true;
  const zc::MeshArrays m(surface);
  const zc::VectorInputs in_ridge{m, delta_ridge.data(), curv.e1.data(), abs_k1.data(), o};
  const zc::VectorInputs in_valley{m, delta_valley.data(), curv.e1.data(), abs_k1.data(), o};
  const Face* faces = m.faces;
  const std::uint8_t* fam = family.data();
  static const char site = 0;
  detail::ordered_chunks<2, LineSegment>(
      surface.face_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& r, std::vector<LineSegment>& v) {
        // vector_face's first test (at least two edges with E_i·E_j <= 0,
        // E = δ e1) without a branch per face, for a batch of faces, then
        // the kernel for the survivors in face order (the test's outcome
        // is hard to predict; the family mask is not: ridge and valley
        // regions are large). A valley's E is the ridge's negated (δ = -a),
        // which leaves every E_i·E_j as it is.
        constexpr std::size_t kBatch = 64;
        std::uint32_t keep[kBatch];
        const double* a = delta_ridge.data();
        const Vec3* e1 = curv.e1.data();
        for (std::size_t first = b; first < e; first += kBatch) {
          const std::size_t last = std::min(e, first + kBatch);
          int n = 0;
          for (std::size_t f = first; f < last; ++f) {
            const Face& face = faces[f];
            if ((fam[face[0]] & fam[face[1]] & fam[face[2]]) == 0) continue;
            const Vec3 E0 = a[face[0]] * e1[face[0]], E1 = a[face[1]] * e1[face[1]],
                       E2 = a[face[2]] * e1[face[2]];
            keep[n] = static_cast<std::uint32_t>(f);
            n += int(zc::two_crossings(zc::crossing_bits_of(E0, E1, E2)));
          }
          for (int k = 0; k < n; ++k) {
            const Face& face = faces[keep[k]];
            if (fam[face[0]] & fam[face[1]] & fam[face[2]] & 1u)
              zc::vector_face(in_ridge, keep[k], r);
            else
              zc::vector_face(in_valley, keep[k], v);
          }
        }
      },
      std::array<std::vector<LineSegment>*, 2>{&ridges, &valleys}, &site);
}

// Minimal rotation taking a vector tangent to the plane with normal `from`
// into the plane with normal `to` (Rodrigues about from x to), with what
// depends only on the two normals computed once.
class TangentRotation {
 public:
  TangentRotation(const Vec3& from, const Vec3& to)
      : to_(to), c_(from.dot(to)), axis_(from.cross(to)) {}
  Vec3 operator()(const Vec3& x) const {
    if (c_ <= -1.0 + 1e-12) return x - to_ * to_.dot(x);
    // R x = c x + axis × x + axis (axis·x) / (1 + c)
    return c_ * x + axis_.cross(x) + axis_ * (axis_.dot(x) / (1.0 + c_));
  }

 private:
  Vec3 to_;
  double c_;
  Vec3 axis_;
};

}  // namespace

const std::vector<LineSegment>& LinePrecompute::raw_ridges() const {
  call_once_isolated(cache_->raw->ridge_once, [&] {
    const auto& k1 = abs_k1();
    compute_ridges_and_valleys(*surface_, k1, cache_->raw->ridges, cache_->raw->valleys);
  });
  return cache_->raw->ridges;
}

const std::vector<LineSegment>& LinePrecompute::raw_valleys() const {
  (void)raw_ridges();
  return cache_->raw->valleys;
}

namespace {

std::vector<LinePrecompute::RawKey> raw_keys(const Surface& s,
                                             const std::vector<LineSegment>& raw) {
  std::vector<LinePrecompute::RawKey> keys(raw.size());
  const auto& faces = s.faces();
  detail::parallel_range(raw.size(), [&](std::size_t i) {
    const Face& f = faces[static_cast<std::size_t>(raw[i].face)];
    keys[i] = {{f[0], f[1], f[2]}, raw[i].end[0].strength, raw[i].end[1].strength};
  });
  return keys;
}

}  // namespace

const std::vector<LinePrecompute::RawKey>& LinePrecompute::raw_ridge_keys() const {
  call_once_isolated(cache_->raw->ridge_keys_once, [&] {
    cache_->raw->ridge_keys = raw_keys(*surface_, raw_ridges());
    cache_->raw->valley_keys = raw_keys(*surface_, raw_valleys());
  });
  return cache_->raw->ridge_keys;
}

const std::vector<LinePrecompute::RawKey>& LinePrecompute::raw_valley_keys() const {
  (void)raw_ridge_keys();
  return cache_->raw->valley_keys;
}

const std::vector<LinePrecompute::RawKey>& LinePrecompute::raw_demarcating_keys() const {
  call_once_isolated(cache_->raw->demarcating_keys_once, [&] {
    cache_->raw->demarcating_keys = raw_keys(*surface_, raw_demarcating());
  });
  return cache_->raw->demarcating_keys;
}

std::shared_ptr<const LinePrecompute::RawAbove> LinePrecompute::raw_above(LineFamily family,
                                                                          double t) const {
  int slot;
  const std::vector<RawKey>* keys;
  const std::vector<LineSegment>* raw;
  switch (family) {
    case LineFamily::ridge:
      slot = 0, keys = &raw_ridge_keys(), raw = &raw_ridges();
      break;
    case LineFamily::valley:
      slot = 1, keys = &raw_valley_keys(), raw = &raw_valleys();
      break;
    case LineFamily::demarcating:
      slot = 2, keys = &raw_demarcating_keys(), raw = &raw_demarcating();
      break;
    default:
      throw Error(ErrorKind::internal, "raw_above: not a precomputed family");
  }
  // A NaN or negative t would give NaN or out-of-range strengths.
  detail::require_non_negative(t, family, "threshold (per feature size)");
  // The same t bit for bit.
  auto same = [&](const std::shared_ptr<const RawAbove>& a) {
    return a && std::memcmp(&a->t, &t, sizeof t) == 0;
  };
  {
    std::lock_guard lock(cache_->above_mutex);
    if (same(cache_->above[slot])) return cache_->above[slot];
  }
  auto a = std::make_shared<RawAbove>();
  a->t = t;
  // Two parallel passes over fixed chunks of the keys (count, then fill
  // after the chunks before): the kept segments in increasing index order,
  // the same at any thread count.
  auto kept = [&](const RawKey& k) {
    return !(raw_excess(k.m0, t) == 0.0 && raw_excess(k.m1, t) == 0.0);
  };
  constexpr std::size_t kChunk = 8192;
  const std::size_t n = keys->size(), chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::size_t> first(chunks + 1, 0);
  detail::parallel_range(
      chunks,
      [&](std::size_t c) {
        std::size_t count = 0;
        for (std::size_t i = c * kChunk, e = std::min(n, i + kChunk); i < e; ++i)
          count += kept((*keys)[i]);
        first[c + 1] = count;
      },
      1);
  for (std::size_t c = 0; c < chunks; ++c) first[c + 1] += first[c];
  a->index.resize(first[chunks]);
  a->segments.resize(first[chunks]);
  a->corners.resize(first[chunks]);
  detail::parallel_range(
      chunks,
      [&](std::size_t c) {
        std::size_t at = first[c];
        for (std::size_t i = c * kChunk, e = std::min(n, i + kChunk); i < e; ++i) {
          const RawKey& k = (*keys)[i];
          if (!kept(k)) continue;
          const double k0 = raw_excess(k.m0, t), k1 = raw_excess(k.m1, t);
          a->index[at] = static_cast<std::uint32_t>(i);
          LineSegment& s = a->segments[at] = (*raw)[i];
          s.end[0].strength = t > 0.0 ? static_cast<float>(k0 / (k0 + t)) : 1.0f;
          s.end[1].strength = t > 0.0 ? static_cast<float>(k1 / (k1 + t)) : 1.0f;
          a->corners[at] = k.corners;
          ++at;
        }
      },
      1);
  std::lock_guard lock(cache_->above_mutex);
  cache_->above[slot] = a;
  return a;
}

const std::vector<LineSegment>& LinePrecompute::raw_demarcating() const {
  call_once_isolated(cache_->raw->demarcating_once, [&] {
    // Direction of maximal normal-curvature variation g = argmax C(u,u,u)
    // (Kolomenkin et al. 2008), by sampling 72 angles with parabolic
    // refinement; the scalar is the normal curvature along g.
    const Surface& s = *surface_;
    const auto& curv = s.curvature();
    const auto& dcurv = s.curvature_derivatives();
    const std::size_t nv = s.vertex_count();
    std::vector<double> kappa_g(nv, 0.0), cggg(nv, 0.0);
    std::vector<Vec3> g(nv, Vec3::Zero());
    constexpr int kSamples = 72;
    detail::parallel_range(nv, [&](std::size_t i) {
      if (!curv.valid[i] || !dcurv.valid[i]) return;
      const double a = dcurv.a[i], b = dcurv.b[i], c = dcurv.c[i], d = dcurv.d[i];
      auto C = [&](double th) {
        const double u1 = std::cos(th), u2 = std::sin(th);
        return u1 * u1 * (a * u1 + 3.0 * b * u2) + u2 * u2 * (3.0 * c * u1 + d * u2);
      };
      const double step = 2.0 * M_PI / kSamples;
      int best = 0;
      double best_v = -1e300;
      for (int k = 0; k < kSamples; ++k) {
        const double v = C(k * step);
        if (v > best_v) best_v = v, best = k;
      }
      const double ym = C((best - 1) * step), y0 = best_v, yp = C((best + 1) * step);
      const double den = ym - 2.0 * y0 + yp;
      double th = best * step;
      if (den < 0.0) th += step * std::clamp(0.5 * (ym - yp) / den, -0.5, 0.5);
      const double cth = std::cos(th), sth = std::sin(th);
      kappa_g[i] = curv.k1[i] * cth * cth + curv.k2[i] * sth * sth;
      cggg[i] = std::max(C(th), 0.0);
      g[i] = cth * curv.e1[i] + sth * curv.e2[i];
    });
    ScalarCrossingOptions o;
    std::vector<LineSegment> raw;
    scalar_zero_crossings(s, kappa_g, o, raw);
    // Face filter (Kolomenkin et al., as SynDraw): directions of g must agree
    // within 45 degrees at the three corners. Strength: interpolated C(g,g,g).
    const double cos45 = std::sqrt(0.5);
    auto& out = cache_->raw->demarcating;
    out.reserve(raw.size());
    const SegmentGeometry geo(s);
    for (auto& seg : raw) {
      const Face& f = s.faces()[static_cast<std::size_t>(seg.face)];
      if (std::abs(g[f[0]].dot(g[f[1]])) < cos45 || std::abs(g[f[1]].dot(g[f[2]])) < cos45 ||
          std::abs(g[f[2]].dot(g[f[0]])) < cos45)
        continue;
      for (int i = 0; i < 2; ++i) {
        const Vec3 bc = geo.anchor(seg, i).bary;
        seg.end[i].strength =
            static_cast<float>(bc[0] * cggg[f[0]] + bc[1] * cggg[f[1]] + bc[2] * cggg[f[2]]);
      }
      out.push_back(seg);
    }
  });
  return cache_->raw->demarcating;
}

const GradientOperator& LinePrecompute::gradient_operator() const {
  call_once_isolated(cache_->gradient_once, [&] {
    const Surface& s = *surface_;
    const Topology& topo = s.topology();
    const auto& pos = s.positions();
    const auto& faces = s.faces();
    const auto& fn = s.face_normals();
    const auto& vn = s.vertex_normals();
    const auto& corner = s.corner_areas();
    const std::size_t nv = s.vertex_count();
    GradientOperator& G = cache_->gradient;
    G.offset.assign(nv + 1, 0);
    for (std::size_t i = 0; i < nv; ++i)
      G.offset[i + 1] =
          G.offset[i] + 1 + static_cast<std::int32_t>(topo.vertex_neighbors(i).size());
    G.column.resize(static_cast<std::size_t>(G.offset[nv]));
    G.coeff.resize(3 * G.column.size());
    // Per face, first: whether it takes part (a normal and a positive
    // area) and the in-plane gradients of its three hat functions,
    // nT x e_k / 2A; each of its vertices reads them (computed once per
    // face instead of once per corner; the same expressions, so the same
    // bits). Transient: 72 bytes per face.
    struct FaceBasis {
      Vec3 b[3];
    };
    const std::size_t nf = faces.size();
    const std::unique_ptr<FaceBasis[]> face_basis(new FaceBasis[nf]);
    const std::unique_ptr<std::uint8_t[]> usable(new std::uint8_t[nf]);
    detail::parallel_range(nf, [&](std::size_t t) {
      const Face f = faces[t];
      const Vec3 nt = fn[t];
      const Vec3 p[3] = {pos[f[0]], pos[f[1]], pos[f[2]]};
      const double twice_area = (p[1] - p[0]).cross(p[2] - p[0]).norm();
      usable[t] = !(nt.squaredNorm() == 0.0 || !(twice_area > 0.0));
      if (!usable[t]) return;
      for (int k = 0; k < 3; ++k) {
        const Vec3 e = p[(k + 2) % 3] - p[(k + 1) % 3];
        face_basis[t].b[k] = nt.cross(e) / twice_area;
      }
    });
    detail::parallel_range(nv, [&](std::size_t i) {
      const auto nb = topo.vertex_neighbors(i);
      const std::size_t base = static_cast<std::size_t>(G.offset[i]);
      // The accumulators, reused by each thread (no allocation per vertex).
      thread_local std::vector<Vec3> acc_buffer;
      acc_buffer.assign(nb.size() + 1, Vec3::Zero());
      Vec3* const acc = acc_buffer.data();
      G.column[base] = static_cast<std::int32_t>(i);
      for (std::size_t j = 0; j < nb.size(); ++j) G.column[base + 1 + j] = nb[j];
      auto slot = [&](std::int32_t v) -> std::size_t {
        if (v == static_cast<std::int32_t>(i)) return 0;
        return 1 + static_cast<std::size_t>(std::lower_bound(nb.begin(), nb.end(), v) - nb.begin());
      };
      double wsum = 0.0;
      const auto fs = topo.vertex_faces(i);
      const auto cs = topo.vertex_face_corners(i);
      // Values, not references into the Surface's arrays: the compiler then
      // knows the stores into acc leave them alone, and the rotation into
      // n_i's plane is set up once per face, not per corner (the same
      // expressions, so the same bits).
      const Vec3 ni = vn[i];
      const bool rotate = ni.squaredNorm() > 0.0;
      for (std::size_t j = 0; j < fs.size(); ++j) {
        const auto t = static_cast<std::size_t>(fs[j]);
        if (!usable[t]) continue;
        const double w = corner[t][cs[j]];
        if (!(w > 0.0)) continue;
        wsum += w;
        const Face f = faces[t];
        const TangentRotation r(fn[t], ni);
        for (int k = 0; k < 3; ++k) {
          Vec3 basis = face_basis[t].b[k];
          if (rotate) basis = r(basis);
          acc[slot(f[k])] += w * basis;
        }
      }
      const double inv = wsum > 0.0 ? 1.0 / wsum : 0.0;
      for (std::size_t j = 0; j < acc_buffer.size(); ++j)
        for (int c = 0; c < 3; ++c)
          G.coeff[3 * (base + j) + c] = static_cast<float>(acc[j][c] * inv);
    });
  });
  return cache_->gradient;
}

const std::vector<Vec3>& LinePrecompute::normal_laplacian() const {
  call_once_isolated(cache_->laplacian_once, [&] {
    // (ΔN)_i = 1/A_i Σ_j w_ij (n_j - n_i), w_ij = (cot α + cot β)/2 (§1, §7).
    const Surface& s = *surface_;
    const Topology& topo = s.topology();
    const auto& pos = s.positions();
    const auto& faces = s.faces();
    const auto& vn = s.vertex_normals();
    const auto& area = s.vertex_areas();
    const std::size_t nv = s.vertex_count();
    auto& out = cache_->normal_laplacian;
    out.assign(nv, Vec3::Zero());
    // The cotangent at each corner x of each face, once per face (each is
    // read by the two vertices of the opposite edge): apex f[x], edge
    // vectors u = p_f[x+1] - p_apex, v = p_f[x+2] - p_apex. The vertex
    // whose corner is x + 2 would take u and v the other way round, which
    // gives the same bits (u × v is exactly -(v × u), the dot product is
    // symmetric). Transient: 24 bytes per face.
    auto cot_at = [&](int apex, int p, int q) {
      const Vec3 u = pos[p] - pos[apex], v = pos[q] - pos[apex];
      const double cr = u.cross(v).norm();
      return cr > 0.0 ? u.dot(v) / cr : 0.0;
    };
    const std::size_t nf = faces.size();
    const std::unique_ptr<std::array<double, 3>[]> cot(new std::array<double, 3>[nf]);
    detail::parallel_range(nf, [&](std::size_t t) {
      const Face& f = faces[t];
      for (int x = 0; x < 3; ++x) cot[t][x] = cot_at(f[x], f[(x + 1) % 3], f[(x + 2) % 3]);
    });
    detail::parallel_range(nv, [&](std::size_t i) {
      Vec3 acc = Vec3::Zero();
      const auto fs = topo.vertex_faces(i);
      const auto cs = topo.vertex_face_corners(i);
      for (std::size_t j = 0; j < fs.size(); ++j) {
        const auto t = static_cast<std::size_t>(fs[j]);
        const Face& f = faces[t];
        const int c = cs[j];
        const int a = f[(c + 1) % 3], b = f[(c + 2) % 3];
        // Edge i-a is opposite corner b; edge i-b opposite corner a.
        const double cot_b = cot[t][(c + 2) % 3];
        const double cot_a = cot[t][(c + 1) % 3];
        acc += 0.5 * cot_b * (vn[a] - vn[i]) + 0.5 * cot_a * (vn[b] - vn[i]);
      }
      out[i] = area[i] > 0.0 ? Vec3(acc / area[i]) : Vec3::Zero();
    });
  });
  return cache_->normal_laplacian;
}

}  // namespace fabrica
