// Ridges, valleys and demarcating curves (view-independent: precomputed once,
// culled and thresholded per view) and apparent ridges (docs/algorithms.md §5, §6, §8).
#include <cmath>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"
#include "zero_crossing_internal.hpp"

namespace fabrica {

namespace {

// Keeps raw segments (strength = magnitude) whose face is not back-facing
// and whose magnitude exceeds `t` at either end; strength becomes the fade
// (m - t)/m (rtsc's k/(k + t) with k = m - t). The threshold and the fade
// do not depend on the view: LinePrecompute::raw_above holds the segments
// that pass it, faded. Per view only the back-face cull is decided (from
// the listed faces' corners and the view's sign bytes, or n·v), and each
// run of consecutive kept segments is copied whole.
SegmentSoup threshold_raw(const LinePrecompute& pre, LineFamily family, const ViewFields& fields,
                          double t, bool cull) {
  SegmentSoup soup;
  soup.family = family;
  soup.surface = &pre.surface();
  const std::size_t nv = pre.surface().vertex_count();
  const bool do_cull = cull && fields.ndotv.size() == nv;
  const std::uint8_t* sg = fields.signs.size() == nv ? fields.signs.data() : nullptr;
  const double* ndotv = fields.ndotv.data();
  const auto above = pre.raw_above(family, t);  // rejects a NaN or negative t
  const LineSegment* seg = above->segments.data();
  const auto* corners = above->corners.data();
  auto kept = [&](std::size_t i) {
    if (!do_cull) return true;
    const auto& c = corners[i];
    return sg ? ((sg[c[0]] | sg[c[1]] | sg[c[2]]) & kNdotvNotBack) != 0
              : !(ndotv[c[0]] <= 0.0 && ndotv[c[1]] <= 0.0 && ndotv[c[2]] <= 0.0);
  };
  detail::parallel_chunks<LineSegment>(
      above->segments.size(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& out) {
        for (std::size_t i = b; i < e;) {
          while (i < e && !kept(i)) ++i;
          const std::size_t run = i;
          while (i < e && kept(i)) ++i;
          out.insert(out.end(), seg + run, seg + i);
        }
      },
      soup.segments, 4096);
  return soup;
}

}  // namespace

SegmentSoup extract_ridges(const LinePrecompute& pre, const ViewFields& fields, double feature_size,
                           const RidgeOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  return threshold_raw(pre, LineFamily::ridge, fields, options.threshold / feature_size,
                       options.cull_backfaces);
}

SegmentSoup extract_valleys(const LinePrecompute& pre, const ViewFields& fields,
                            double feature_size, const RidgeOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  return threshold_raw(pre, LineFamily::valley, fields, options.threshold / feature_size,
                       options.cull_backfaces);
}

SegmentSoup extract_demarcating_curves(const LinePrecompute& pre, const ViewFields& fields,
                                       double feature_size, const DemarcatingOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  return threshold_raw(pre, LineFamily::demarcating, fields,
                       options.threshold / (feature_size * feature_size), options.cull_backfaces);
}

SegmentSoup extract_apparent_ridges(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const ApparentOptions& options) {
  return detail::extract_apparent_ridges(surface, fields, feature_size, options, nullptr);
}

namespace detail {

void require_non_negative(double value, LineFamily family, const char* what) {
  if (!(value >= 0.0) || !std::isfinite(value))
    throw InputError(std::string(family_name(family)) + " " + what +
                     " must be a finite number >= 0 (got " + std::to_string(value) + ")");
}

namespace {

// Whether the fields' kQ1Above bits are the apparent-ridge kernel's
// per-face test for `threshold` (1/mm², scaled): computed for that very
// threshold.
bool threshold_bits(const ViewFields& fields, std::size_t nv, double threshold) {
  return fields.signs.size() == nv && fields.apparent_cull_threshold &&
         *fields.apparent_cull_threshold == threshold;
}

double scaled_threshold(const ApparentOptions& options, double feature_size) {
  return options.threshold / (feature_size * feature_size);
}

}  // namespace

bool apparent_reads_records_only(const Surface& surface, const ViewFields& fields,
                                 double feature_size, const ApparentOptions& options) {
  const std::size_t nv = surface.vertex_count();
  return fields.apparent_vertex.size() == nv &&
         threshold_bits(fields, nv, scaled_threshold(options, feature_size));
}

SegmentSoup extract_apparent_ridges(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const ApparentOptions& options,
                                    const FaceLists* listed, const ChunkReady* ready) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  require_non_negative(options.threshold, LineFamily::apparent, "threshold");
  const std::size_t nv = surface.vertex_count();
  SegmentSoup soup;
  soup.family = LineFamily::apparent;
  soup.surface = &surface;
  VectorCrossingOptions o;
  o.test = options.maximum_test ? ExtremumTest::perpendicular : ExtremumTest::none;
  o.threshold = scaled_threshold(options, feature_size);
  // No back-face culling: contour-like apparent ridges come from barely
  // back-facing faces (§6.3).
  // Fields computed with a cull threshold hold D_t1 q1 only around the
  // vertices above it (exact for any threshold at least as high); their
  // kQ1Above bits answer the per-face threshold test when it is the same.
  const auto& cull_t = fields.apparent_cull_threshold;
  if (cull_t && !(o.threshold >= *cull_t))
    throw Error(ErrorKind::internal,
                "apparent ridges: the view fields were computed for a higher threshold");
  const bool bits = threshold_bits(fields, nv, o.threshold);
  // A lower n·v limit lives in the kQ1Above bits (and D_t1 q1 is current
  // only around them): the fields must have been computed with it, and the
  // per-face test must be those bits.
  if (options.min_ndotv != fields.apparent_min_ndotv || (options.min_ndotv && !bits))
    throw InputError(
        "apparent ridges: min_ndotv needs view fields computed with the same limit and threshold "
        "(ViewFieldsRequest::apparent_min_ndotv, apparent_cull_threshold)");
  const bool packed = fields.apparent_vertex.size() == nv;
  // The packed path reads only the records and the sign bytes (the one-shot
  // extraction frees q1, t1 and D_t1 q1 before it).
  if (!apparent_reads_records_only(surface, fields, feature_size, options) &&
      (fields.q1.size() != nv || fields.dt1q1.size() != nv || fields.t1_world.size() != nv))
    throw Error(ErrorKind::internal, "apparent ridges: view fields lack q1/t1/Dt1q1");
  detail::vector_zero_crossings(surface, fields.dt1q1, fields.t1_world, fields.q1, o,
                                bits ? fields.signs.data() : nullptr, kQ1Above, soup.segments,
                                packed ? fields.apparent_vertex.data() : nullptr,
                                packed ? listed : nullptr, ready);
  return soup;
}

}  // namespace detail

}  // namespace fabrica
