// LinePrecompute: everything about a Surface that the line families need and
// that does not depend on the view, computed once on first use and cached
// (thread-safe): raw ridge, valley and demarcating segments (thresholds are
// applied per request, back-face culling per view), |k1|, the per-vertex
// gradient operator used by PELs and Laplacian lines, and the cotan
// Laplacian of the normals ΔN (Zhang et al. 2009's shortcut: Δ(n·l) = ΔN·l).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"  // detail::FilledVector
#include "fabrica/lines/segments.hpp"

namespace fabrica {

/// Sparse per-vertex gradient operator: ∇f_i = Σ_k coeff[k] f[column[k]],
/// k in [offset[i], offset[i+1]). Each face gradient (docs/algorithms.md §1) is
/// rotated into the vertex tangent plane and averaged with corner-area
/// weights. Coefficients are float (bandwidth), accumulation is double.
struct GradientOperator {
  std::vector<std::int32_t> offset, column;
  std::vector<float> coeff;  ///< 3 floats per entry (x, y, z), 1/mm
  /// out[i] = ∇f_i (parallel, deterministic). Sizes: f.size() == vertex count.
  void apply(const std::vector<double>& f, std::vector<Vec3>& out) const;
};

class LinePrecompute {
 public:
  explicit LinePrecompute(const Surface& surface);
  ~LinePrecompute();
  LinePrecompute(const LinePrecompute&) = delete;
  LinePrecompute& operator=(const LinePrecompute&) = delete;

  const Surface& surface() const { return *surface_; }
  /// |k1| per vertex.
  const std::vector<double>& abs_k1() const;
  /// Ridge (k1 > 0 at all corners) and valley (k1 < 0) segments with the
  /// maximum test, without threshold or culling; SegmentEnd::strength holds
  /// the interpolated |k1| (1/mm).
  const std::vector<LineSegment>& raw_ridges() const;
  const std::vector<LineSegment>& raw_valleys() const;
  /// Demarcating curves without threshold; strength holds C(g,g,g) (1/mm²).
  const std::vector<LineSegment>& raw_demarcating() const;
  /// One entry per segment of raw_ridges() / raw_valleys() /
  /// raw_demarcating(), same order: the segment face's corners and its two
  /// end strengths, so the per-view culling and thresholding read 20 bytes
  /// per segment instead of the whole segment.
  struct RawKey {
    std::array<std::int32_t, 3> corners;
    float m0, m1;
  };
  const std::vector<RawKey>& raw_ridge_keys() const;
  const std::vector<RawKey>& raw_valley_keys() const;
  const std::vector<RawKey>& raw_demarcating_keys() const;
  /// How far a raw end magnitude m exceeds the threshold t: max(m - t, 0)
  /// (NaN stays NaN). A raw segment is kept when either end's is not 0.
  static double raw_excess(float m, double t) { return std::max(double(m) - t, 0.0); }
  /// The raw segments of `family` (ridge, valley or demarcating) that pass
  /// the threshold t: their indices in raw_ridges() / raw_valleys() /
  /// raw_demarcating() (and the keys), ascending. The threshold does not
  /// depend on the view, so the per-view extraction visits only these
  /// (back-face culling stays per view). Cached for the last t of each
  /// family (thread-safe; the list stays valid while held).
  /// `segments` are those raw segments as the extraction returns them for
  /// t (each end's strength the fade (m - t)/m, rtsc's k/(k + t) with
  /// k = m - t; 1 for t = 0), and `corners` their faces' corners (for the
  /// per-view back-face culling): a view then copies runs of kept
  /// segments instead of rebuilding each one. Throws InputError when t is
  /// NaN, infinite or negative.
  struct RawAbove {
    double t = 0.0;
    std::vector<std::uint32_t> index;
    std::vector<LineSegment> segments;
    std::vector<std::array<std::int32_t, 3>> corners;
  };
  std::shared_ptr<const RawAbove> raw_above(LineFamily family, double t) const;
  const GradientOperator& gradient_operator() const;
  /// Cotan Laplacian of each normal component (1/mm²), per vertex.
  const std::vector<Vec3>& normal_laplacian() const;
  /// Per vertex i, the two other vertices (i1, i2) of each incident face in
  /// Topology::vertex_faces(i) order, corners in face order after i; CSR
  /// (offset has vertex count + 1 entries). Used by the per-view D_t1 q1
  /// finite differences so they skip the face indirection.
  struct CornerRing {
    std::vector<std::int32_t> offset;
    std::vector<std::array<std::int32_t, 2>> opposite;
  };
  const CornerRing& corner_ring() const;
  /// corner_ring() as neighbour offsets d = p_k - p_i in vertex i's
  /// principal frame, (d·e1, d·e2), as float (zeros where the curvature is
  /// invalid): the per-view D_t1 q1 differences then stream a few small
  /// arrays and work in the tangent plane instead of gathering positions.
  /// Neighbours of vertex i are [offset[i], offset[i+1]) of vertex, x, y
  /// (an odd count only on a fan). When fan[i] (a closed, consistently
  /// oriented fan of at most 63 faces, finite offsets) there are k + 1
  /// neighbours for k faces, n_0..n_{k-1}, n_0 in cyclic order: fan face j
  /// has the opposite corners (n_j, n_{j+1}) and is face rank[offset[i] + j]
  /// in corner_ring() order. Otherwise there are two neighbours per face,
  /// (i1, i2) of each face in corner_ring() order (rank unused). vertex,
  /// rank, x and y have kPad more entries after the last ring (vertex 0,
  /// zeros), so fixed-width reads of a short ring stay inside them.
  /// (detail::FilledVector: built without a zeroing pass before the
  /// parallel passes that write every entry.)
  struct TangentRing {
    static constexpr std::size_t kPad = 16;
    detail::FilledVector<std::int32_t> offset;
    detail::FilledVector<std::uint8_t> fan;
    detail::FilledVector<std::int32_t> vertex;
    detail::FilledVector<float> x, y;
    detail::FilledVector<std::uint8_t> rank;
  };
  const TangentRing& tangent_ring() const;
  /// The tangent ring a block of vertices at a time, for one view (the
  /// one-shot extraction: ~6 bytes per vertex and a block's entries at a
  /// time instead of ~90 bytes per vertex): streamed_tangent_ring() has
  /// tangent_ring()'s offset and fan and no entries (vertex, x, y, rank
  /// empty) unless tangent_ring() was built; tangent_ring_block(v0, v1, out)
  /// then writes the entries of vertices [v0, v1), which tangent_ring() has
  /// at [offset[v0], offset[v1]), to out's vertex, rank, x and y from 0 (and
  /// kPad more: vertex 0, zeros), the same bits (thread-safe; `out`'s offset
  /// and fan are not used). release_tangent_ring() frees the layout.
  const TangentRing& streamed_tangent_ring() const;
  void tangent_ring_block(std::size_t v0, std::size_t v1, TangentRing& out) const;
  /// The per-vertex inputs of the per-view vertex pass (view_fields.cpp:
  /// position, normal, principal frame, curvatures, derivative tensor)
  /// packed in blocks of four vertices, each quantity as four consecutive
  /// doubles, so a 256-bit SIMD pass loads them directly instead of
  /// gathering from nine arrays. The last block is padded with zeros.
  struct alignas(32) VertexBlock {
    double p[3][4], n[3][4], e1[3][4], e2[3][4];
    double k1[4], k2[4], a[4], b[4], c[4], d[4];
  };
  struct VertexBlocks {
    detail::FilledVector<VertexBlock> block;  ///< ceil(vertex count / 4)
    /// Per block: bit l set when vertex 4 b + l has valid curvature, bit
    /// 4 + l when it has valid curvature derivatives.
    detail::FilledVector<std::uint8_t> valid;
  };
  const VertexBlocks& vertex_blocks() const;
  /// Blocks [b0, b1) of vertex_blocks() and their valid bytes, written to
  /// block[0 .. b1 - b0) and valid[0 .. b1 - b0) without keeping them: the
  /// one-shot vertex pass packs a few at a time into a small buffer instead
  /// of holding all of them (the same bits).
  void pack_vertex_blocks(std::size_t b0, std::size_t b1, VertexBlock* block,
                          std::uint8_t* valid) const;
  /// Free vertex_blocks() / tangent_ring() (~144 and ~90 bytes per vertex)
  /// when no further view will read them, as in the one-shot draw_lines
  /// (LineExtractor::set_one_shot): the peak memory of one view is lower. A
  /// later call of vertex_blocks() / tangent_ring() builds them again; a
  /// reference obtained before the release must not be used after it.
  void release_vertex_blocks() const;
  void release_tangent_ring() const;
  /// Frees the raw lines (raw_ridges(), raw_valleys(), raw_demarcating(),
  /// their keys, abs_k1() and the raw_above() lists: ~110 bytes per raw
  /// segment and 8 per vertex), as the one-shot extraction does once its
  /// ridge, valley and demarcating families are through. A later call of
  /// any of those accessors builds them again (the same bits); a reference
  /// obtained before the release must not be used after it (a list held
  /// from raw_above() stays valid). Not to be called while another thread
  /// reads them.
  void release_raw_lines() const;
  /// Whether release_raw_lines() was called (tests, memory probes).
  bool raw_lines_released() const;

 private:
  struct Cache;
  const Surface* surface_;
  std::unique_ptr<Cache> cache_;
};

}  // namespace fabrica
