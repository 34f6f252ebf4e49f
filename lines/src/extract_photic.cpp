// Photic extremum lines (Xie et al. 2007) and Laplacian lines (Zhang et al.
// 2009/2011), docs/algorithms.md §7, on f = n·l (headlight or a fixed light).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"
#include "view_fields_light.hpp"
#include "zero_crossing_internal.hpp"

namespace fabrica {

namespace {

// The sparse illumination fields must cover everything `threshold` and
// `cull` can keep (view_fields.hpp).
void require_support(const ViewFields& fields, double threshold, bool cull, const char* family) {
  if (threshold < fields.light_threshold || (fields.light_cull_backfaces && !cull))
    throw Error(ErrorKind::internal,
                std::string(family) +
                    ": the view fields were computed for a higher threshold or with back-face "
                    "culling; recompute them with ViewFieldsRequest::light_threshold <= " +
                    std::to_string(threshold) +
                    " and light_cull_backfaces = " + (cull ? "true" : "false"));
}

// The zero set of `values` on the lit faces (fields.light_faces), with
// back-face culling when `cull`; the threshold t on |∇f| (fade (m - t)/m) is
// applied as the segments are made.
SegmentSoup lit_zero_crossings(const Surface& surface, const ViewFields& fields, LineFamily family,
                               std::span<const double> values, ScalarCrossingOptions o, bool cull,
                               double t) {
  SegmentSoup soup;
  soup.family = family;
  soup.surface = &surface;
  if (cull) o.cull = fields.ndotv;
  if (fields.light_faces.empty()) return soup;  // no face can carry a kept line
  o.faces = fields.light_faces;
  detail::scalar_zero_crossings(surface, values, o, fields.light_gradient_norm, t, soup.segments);
  return soup;
}

}  // namespace

namespace detail {

void set_light_support(ViewFieldsRequest& request, const PhoticOptions* pel,
                       const LaplacianOptions* laplacian, double feature_size) {
  constexpr double everywhere = -std::numeric_limits<double>::infinity();
  double t = std::numeric_limits<double>::infinity();
  bool cull = true;
  auto add = [&](double threshold, bool c) {
    const double ti = threshold / feature_size;
    t = std::isnan(ti) || std::isnan(t) ? std::numeric_limits<double>::quiet_NaN()
                                        : std::min(t, ti);
    cull = cull && c;
  };
  if (pel) add(pel->threshold, pel->cull_backfaces);
  if (laplacian) add(laplacian->threshold, laplacian->cull_backfaces);
  // No family, or a NaN threshold: compute everything.
  request.light_threshold = (pel || laplacian) && !std::isnan(t) ? t : everywhere;
  request.light_cull_backfaces = (pel || laplacian) && cull;
}

}  // namespace detail

SegmentSoup extract_pels(const Surface& surface, const ViewFields& fields, double feature_size,
                         const PhoticOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  const std::size_t nv = surface.vertex_count();
  if (fields.pel_h.size() != nv || fields.pel_maximum.size() != nv ||
      fields.light_gradient_norm.size() != nv)
    throw Error(ErrorKind::internal, "PELs: view fields lack the illumination derivatives");
  detail::require_non_negative(options.threshold, LineFamily::pel, "threshold");
  const double t = options.threshold / feature_size;
  require_support(fields, t, options.cull_backfaces, "PELs");
  ScalarCrossingOptions o;
  o.test_num = fields.pel_maximum;  // -D_w D_w |∇f| > 0: a maximum of the gradient magnitude
  return lit_zero_crossings(surface, fields, LineFamily::pel, fields.pel_h, o,
                            options.cull_backfaces, t);
}

SegmentSoup extract_laplacian_lines(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const LaplacianOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  const std::size_t nv = surface.vertex_count();
  if (fields.light_laplacian.size() != nv || fields.light_gradient_norm.size() != nv)
    throw Error(ErrorKind::internal, "Laplacian lines: view fields lack the illumination");
  detail::require_non_negative(options.threshold, LineFamily::laplacian, "threshold");
  const double t = options.threshold / feature_size;
  require_support(fields, t, options.cull_backfaces, "Laplacian lines");
  return lit_zero_crossings(surface, fields, LineFamily::laplacian, fields.light_laplacian, {},
                            options.cull_backfaces, t);
}

}  // namespace fabrica
