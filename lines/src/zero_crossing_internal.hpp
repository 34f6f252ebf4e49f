// Private to fabrica::lines: variants of the zero-crossing kernel
// (zero_crossing.hpp) that the per-view extractors use to avoid per-view
// temporaries.
#pragma once

#include <span>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/lines/segments.hpp"

namespace fabrica::detail {

/// scalar_zero_crossings(kr) with the suggestive-contour test N/D, where
/// D = ndotv and N_i = ±sc_num_i - shift * ndotv_i (minus sign when
/// `negate`) is evaluated only at the corners of faces that reach the test:
/// the same segments, bit for bit, as passing a stored N array.
void suggestive_zero_crossings(const Surface& surface, std::span<const double> kr,
                               std::span<const double> sc_num, bool negate, double shift,
                               std::span<const double> ndotv, bool cull, double fade,
                               std::vector<LineSegment>& out);

}  // namespace fabrica::detail
