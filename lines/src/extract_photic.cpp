// Photic extremum lines (Xie et al. 2007) and Laplacian lines (Zhang et al.
// 2009/2011), ALGORITHMS.md §7, on f = n·l (headlight or a fixed light).
#include <cmath>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"

namespace fabrica {

namespace {

// Drops segments whose interpolated `magnitude` is <= t at both ends and
// sets strength to the fade (m - t)/m, multiplied into the existing one.
void threshold_by_field(const Surface& surface, std::vector<LineSegment>& segs,
                        const std::vector<double>& magnitude, double t) {
  const auto& faces = surface.faces();
  std::vector<LineSegment> kept;
  kept.reserve(segs.size());
  for (auto& s : segs) {
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
    kept.push_back(s);
  }
  segs.swap(kept);
}

}  // namespace

SegmentSoup extract_pels(const Surface& surface, const ViewFields& fields, double feature_size,
                         const PhoticOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  const std::size_t nv = surface.vertex_count();
  if (fields.pel_h.size() != nv || fields.pel_s.size() != nv || fields.pel_g.size() != nv)
    throw Error(ErrorKind::internal, "PELs: view fields lack the illumination derivatives");
  std::vector<double> maximum(nv);
  detail::parallel_range(nv, [&](std::size_t i) { maximum[i] = -fields.pel_s[i]; });
  SegmentSoup soup;
  soup.family = LineFamily::pel;
  ScalarCrossingOptions o;
  o.test_num = maximum;  // D_w D_w |∇f| < 0: a maximum of the gradient magnitude
  if (options.cull_backfaces) o.cull = fields.ndotv;
  scalar_zero_crossings(surface, fields.pel_h, o, soup.segments);
  threshold_by_field(surface, soup.segments, fields.pel_g, options.threshold / feature_size);
  return soup;
}

SegmentSoup extract_laplacian_lines(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const LaplacianOptions& options) {
  if (!(feature_size > 0.0)) throw InputError("feature size must be positive");
  const std::size_t nv = surface.vertex_count();
  if (fields.light_laplacian.size() != nv || fields.light_gradient.size() != nv)
    throw Error(ErrorKind::internal, "Laplacian lines: view fields lack the illumination");
  std::vector<double> g(nv);
  detail::parallel_range(nv, [&](std::size_t i) { g[i] = fields.light_gradient[i].norm(); });
  SegmentSoup soup;
  soup.family = LineFamily::laplacian;
  ScalarCrossingOptions o;
  if (options.cull_backfaces) o.cull = fields.ndotv;
  scalar_zero_crossings(surface, fields.light_laplacian, o, soup.segments);
  threshold_by_field(surface, soup.segments, g, options.threshold / feature_size);
  return soup;
}

}  // namespace fabrica
