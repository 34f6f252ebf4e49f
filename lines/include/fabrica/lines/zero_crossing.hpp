// The zero-crossing kernel (docs/algorithms.md §0 "ZC" and "ZC-vec"): nearly every
// line family is the zero set of a per-vertex scalar, or the sign-free zero
// set of a per-vertex derivative along an unsigned direction, extracted face
// by face with linear interpolation along edges.
//
// Scalar variant (rtsc's draw_face_isoline): a face contributes when one
// vertex has a different sign from the other two (a vertex exactly at 0
// counts as positive against a negative one and negative against a positive
// one, as rtsc). The crossing on edge (i,j) is at t = s_i/(s_i - s_j), always
// computed from the lower vertex index so both faces of an edge produce
// bit-identical points. An optional test function N/D (per-vertex numerator
// and denominator, interpolated with the same t) keeps only the sub-segments
// where N/D > 0, clipped at the linear zeros of N and D; the fade gives each
// kept endpoint strength x/(x + fade) with x = N/D (fade 0: strength 1).
//
// Vector variant (rtsc's draw_face_ridges / draw_face_apparent_ridges): per
// vertex E_i = δ_i d_i with d_i an unsigned unit direction and δ_i the
// derivative along it. Edge (i,j) crosses iff E_i·E_j <= 0, at
// t = |δ_i|/(|δ_i|+|δ_j|); a face needs two crossing edges; with three, each
// crossing joins the centroid. Endpoint magnitude m (|k1| or q1) is
// interpolated; a segment is dropped when both ends are <= threshold, and
// strength = (m - t)/m. Maximum tests: `edge` (ridges: on edge i->j,
// E_i·(p_j-p_i) >= 0 or E_j·(p_j-p_i) <= 0) and `perpendicular` (Judd's
// figure-6 test for apparent ridges).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/lines/segments.hpp"

namespace fabrica {

struct ScalarCrossingOptions {
  std::span<const double> test_num;  ///< empty: no test
  std::span<const double> test_den;  ///< empty: denominator 1
  /// Per-vertex n·v: faces with all three values <= 0 are skipped (back-face
  /// culling). Empty: no culling.
  std::span<const double> cull;
  double fade = 0.0;  ///< strength x/(x + fade), x = N/D; 0 gives strength 1
  /// Only these faces, ascending (output order stays by face); empty: all.
  /// For callers that know which faces can matter (PELs, Laplacian lines).
  std::span<const std::int32_t> faces;
};

/// Appends the zero set of `values` (one per vertex) to `out`, deterministic
/// at any thread count. Precondition: spans sized vertex_count() or empty.
void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, std::vector<LineSegment>& out);

enum class ExtremumTest : std::uint8_t {
  none,           ///< any zero crossing (maxima and minima)
  edge,           ///< ridges/valleys (rtsc, Ohtake et al.): lenient OR test per edge
  perpendicular,  ///< apparent ridges (Judd et al. fig. 6)
};

struct VectorCrossingOptions {
  std::span<const double> cull;               ///< as ScalarCrossingOptions::cull
  std::span<const std::uint8_t> vertex_mask;  ///< faces need all three nonzero; empty = all
  ExtremumTest test = ExtremumTest::edge;
  double threshold = 0.0;  ///< on the interpolated magnitude
  /// Keep segments below the threshold and store the raw magnitude (not the
  /// fade) in SegmentEnd::strength (for precomputed view-independent lines
  /// whose threshold is applied later).
  bool keep_raw_magnitude = false;
};

/// Appends the zero set of the sign-free field E_i = derivative_i *
/// direction_i. `magnitude` is the thresholded quantity.
void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, std::vector<LineSegment>& out);

}  // namespace fabrica
