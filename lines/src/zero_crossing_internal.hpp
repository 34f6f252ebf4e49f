// Private to fabrica::lines: variants of the zero-crossing kernel
// (zero_crossing.hpp) that the per-view extractors use to avoid per-view
// temporaries.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/lines/segments.hpp"
#include "fabrica/lines/view_fields.hpp"
#include "fabrica/lines/zero_crossing.hpp"

namespace fabrica {
struct ContourOptions;
struct ApparentOptions;
struct SuggestiveOptions;
}  // namespace fabrica

namespace fabrica::detail {

/// InputError naming the family unless `value` (one of its thresholds or
/// fade constants, as given in its options) is a finite number >= 0: a NaN
/// or negative one would keep segments with NaN or out-of-range strengths.
void require_non_negative(double value, LineFamily family, const char* what);

/// Per-vertex sign bytes (ViewFields::signs) for the quick face rejection
/// of the scalar kernel: the bits meaning value < 0 and value > 0, and
/// optionally the bit meaning "not culled" (!(cull <= 0)). Exactly the
/// rejections the kernel makes from the doubles; signs == nullptr: unused.
struct SignBits {
  const std::uint8_t* signs = nullptr;
  unsigned negative = 0, positive = 0, cull = 0;
  /// Bits meaning "the test function rejects this corner": a face with one
  /// of them at all three corners is rejected (exactly the kernel's
  /// all-corner test-function rejection for those bits); 0: none.
  unsigned reject = 0;
};

/// scalar_zero_crossings with sign bytes for `values` (and options.cull).
void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, const SignBits& bits,
                           std::vector<LineSegment>& out);

/// scalar_zero_crossings (list path) with the magnitude threshold of PELs
/// and Laplacian lines applied to each segment as it is made: a segment is
/// dropped when the magnitude interpolated at both ends (by their
/// barycentric coordinates) is <= threshold, and each end's strength is
/// multiplied by k/(k + threshold), k = max(m - threshold, 0) (by 1 when
/// threshold <= 0). The same segments, bit for bit, as thresholding the
/// output afterwards.
void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, std::span<const double> magnitude,
                           double threshold, std::vector<LineSegment>& out);

/// The suggestive-contour test N/D of scalar_zero_crossings(kr), where
/// D = ndotv and N_i = ±sc_num_i - shift * ndotv_i (minus sign when
/// `negate`) is evaluated only at the corners of faces that reach the test:
/// the same segments, bit for bit, as passing a stored N array.
struct SuggestiveTest {
  std::span<const double> kr, sc_num, ndotv;
  bool negate = false;
  double shift = 0.0;
  bool cull = false;
  double fade = 0.0;
};

void suggestive_zero_crossings(const Surface& surface, const SuggestiveTest& test,
                               const SignBits& bits, std::vector<LineSegment>& out);

/// Per chunk of detail::kFaceChunk faces (chunk c: faces from c ·
/// kFaceChunk), the faces with a given sign-byte bit at some corner,
/// ascending: face[c · kFaceChunk + j] for j < count[c]. The contour and
/// suggestive-contour scan lists the apparent-ridge kernel's candidates
/// (kQ1Above) this way, so the faces are scanned once for the three.
struct FaceLists {
  std::vector<std::uint32_t> face;
  std::vector<std::uint32_t> count;
  /// Per chunk, its faces' largest corner index (view-independent: filled
  /// once by the extractor, for the chunk gate below).
  std::vector<std::int32_t> top_vertex;
};

/// Called by the apparent-ridge kernel with a face chunk's index before it
/// reads that chunk's corners (so D_t1 q1 can still be running for later
/// vertices): chunk by chunk on the packed path, for every chunk up front
/// on the others.
using ChunkReady = std::function<void(std::size_t chunk)>;

/// Contours (scalar_zero_crossings of ndotv with `contour`, sign bits
/// `contour_bits`) and suggestive_zero_crossings(test, suggestive_bits) in
/// one scan over the faces' sign bytes; the two outputs are those of the
/// separate calls. Both bits must use the same sign array (otherwise the
/// separate calls are made). With `listed`, the same scan also fills it
/// with the faces having `listed_bit` at some corner (returns false, and
/// leaves it alone, when it could not: the separate calls were made).
bool contour_suggestive_zero_crossings(const Surface& surface, std::span<const double> ndotv,
                                       const ScalarCrossingOptions& contour,
                                       const SignBits& contour_bits, const SuggestiveTest& test,
                                       const SignBits& suggestive_bits,
                                       std::vector<LineSegment>& contours,
                                       std::vector<LineSegment>& suggestive,
                                       FaceLists* listed = nullptr, unsigned listed_bit = 0);

/// vector_zero_crossings where `above_bit` of signs[v] is set exactly when
/// !(magnitude[v] <= options.threshold): faces without it are skipped from
/// the bytes. signs == nullptr: the plain kernel. `packed`, when given
/// (ViewFields::apparent_vertex; only without culling, vertex mask or edge
/// test), holds E_v = derivative[v] · direction[v], the derivative, the
/// magnitude and the position at least at the corners of those faces, and
/// is read instead of the arrays; `lists`, when given with it, are those
/// faces (FaceLists of above_bit), which then are not scanned for.
void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, const std::uint8_t* signs,
                           unsigned above_bit, std::vector<LineSegment>& out,
                           const ApparentVertex* packed = nullptr, const FaceLists* lists = nullptr,
                           const ChunkReady* ready = nullptr);

/// extract_contours and extract_suggestive_contours (the same soups) with
/// one scan over the faces when the contours are interpolated. With
/// `apparent`, and fields with the kQ1Above bits, the scan also lists the
/// apparent-ridge kernel's candidate faces there (returns whether it did).
bool extract_contours_and_suggestive(const Surface& surface, const ViewFields& fields,
                                     const ContourOptions& contour, double feature_size,
                                     const SuggestiveOptions& suggestive, SegmentSoup& contours,
                                     SegmentSoup& suggestive_contours,
                                     FaceLists* apparent = nullptr);

/// Whether extract_apparent_ridges(surface, fields, feature_size, options)
/// reads only the fields' packed records (apparent_vertex) and sign bytes:
/// the fields were computed with this very threshold as their cull
/// threshold and hold the records. q1, dt1q1, t1 and t1_world may then be
/// freed before it (the one-shot extraction).
bool apparent_reads_records_only(const Surface& surface, const ViewFields& fields,
                                 double feature_size, const ApparentOptions& options);

/// extract_apparent_ridges, with the candidate faces listed by
/// extract_contours_and_suggestive for the same fields when `listed`, and
/// `ready` (see ChunkReady) before the face chunks are read.
SegmentSoup extract_apparent_ridges(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const ApparentOptions& options,
                                    const FaceLists* listed, const ChunkReady* ready = nullptr);

}  // namespace fabrica::detail
