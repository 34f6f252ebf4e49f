// Private to fabrica::lines: variants of the zero-crossing kernel
// (zero_crossing.hpp) that the per-view extractors use to avoid per-view
// temporaries.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/lines/segments.hpp"
#include "fabrica/lines/zero_crossing.hpp"

namespace fabrica::detail {

/// Per-vertex sign bytes (ViewFields::signs) for the quick face rejection
/// of the scalar kernel: the bits meaning value < 0 and value > 0, and
/// optionally the bit meaning "not culled" (!(cull <= 0)). Exactly the
/// rejections the kernel makes from the doubles; signs == nullptr: unused.
struct SignBits {
  const std::uint8_t* signs = nullptr;
  unsigned negative = 0, positive = 0, cull = 0;
};

/// scalar_zero_crossings with sign bytes for `values` (and options.cull).
void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, const SignBits& bits,
                           std::vector<LineSegment>& out);

/// scalar_zero_crossings(kr) with the suggestive-contour test N/D, where
/// D = ndotv and N_i = ±sc_num_i - shift * ndotv_i (minus sign when
/// `negate`) is evaluated only at the corners of faces that reach the test:
/// the same segments, bit for bit, as passing a stored N array.
void suggestive_zero_crossings(const Surface& surface, std::span<const double> kr,
                               std::span<const double> sc_num, bool negate, double shift,
                               std::span<const double> ndotv, bool cull, double fade,
                               const SignBits& bits, std::vector<LineSegment>& out);

/// vector_zero_crossings where `above_bit` of signs[v] is set exactly when
/// !(magnitude[v] <= options.threshold): faces without it are skipped from
/// the bytes. signs == nullptr: the plain kernel. `field`, when given, holds
/// E_v = derivative[v] · direction[v] at least at the corners of those
/// faces (ViewFields::apparent_field), so the kernel does not form it.
void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, const std::uint8_t* signs,
                           unsigned above_bit, std::vector<LineSegment>& out,
                           const Vec3* field = nullptr);

}  // namespace fabrica::detail
