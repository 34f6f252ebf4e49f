// Photic extremum lines (Xie et al. 2007) and Laplacian lines (Zhang et al.
// 2009/2011), ALGORITHMS.md §7, on f = n·l (headlight or a fixed light).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"
#include "view_fields_light.hpp"

namespace fabrica {

namespace {

// Drops segments whose interpolated `magnitude` is <= t at both ends and
// sets strength to the fade (m - t)/m, multiplied into the existing one.
// In place (no per-view copy of the soup), order kept.
void threshold_by_field(const Surface& surface, std::vector<LineSegment>& segs,
                        const std::vector<double>& magnitude, double t) {
  const auto& faces = surface.faces();
  std::size_t kept = 0;
  for (std::size_t j = 0; j < segs.size(); ++j) {
    LineSegment& s = segs[j];
    const Face& f = faces[static_cast<std::size_t>(s.face)];
    double k[2];
    for (int e = 0; e < 2; ++e) {
      const Vec3& b = s.end[e].anchor.bary;
      const double m = b[0] * magnitude[f[0]] + b[1] * magnitude[f[1]] + b[2] * magnitude[f[2]];
      k[e] = std::max(m - t, 0.0);
    }
    if (k[0] == 0.0 && k[1] == 0.0) continue;
    for (int e = 0; e < 2; ++e)
      s.end[e].strength *= t > 0.0 ? static_cast<float>(k[e] / (k[e] + t)) : 1.0f;
    if (kept != j) segs[kept] = s;
    ++kept;
  }
  segs.resize(kept);
}

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
  const double t = options.threshold / feature_size;
  require_support(fields, t, options.cull_backfaces, "PELs");
  SegmentSoup soup;
  soup.family = LineFamily::pel;
  ScalarCrossingOptions o;
  o.test_num = fields.pel_maximum;  // -D_w D_w |∇f| > 0: a maximum of the gradient magnitude
  if (options.cull_backfaces) o.cull = fields.ndotv;
  if (fields.light_faces.empty()) return soup;  // no face can carry a kept line
  o.faces = fields.light_faces;
  scalar_zero_crossings(surface, fields.pel_h, o, soup.segments);
  threshold_by_field(surface, soup.segments, fields.light_gradient_norm, t);
  return soup;
}

SegmentSoup extract_laplacian_lines(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const LaplacianOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  const std::size_t nv = surface.vertex_count();
  if (fields.light_laplacian.size() != nv || fields.light_gradient_norm.size() != nv)
    throw Error(ErrorKind::internal, "Laplacian lines: view fields lack the illumination");
  const double t = options.threshold / feature_size;
  require_support(fields, t, options.cull_backfaces, "Laplacian lines");
  SegmentSoup soup;
  soup.family = LineFamily::laplacian;
  ScalarCrossingOptions o;
  if (options.cull_backfaces) o.cull = fields.ndotv;
  if (fields.light_faces.empty()) return soup;  // no face can carry a kept line
  o.faces = fields.light_faces;
  scalar_zero_crossings(surface, fields.light_laplacian, o, soup.segments);
  threshold_by_field(surface, soup.segments, fields.light_gradient_norm, t);
  return soup;
}

}  // namespace fabrica
