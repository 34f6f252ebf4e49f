// Contours, boundaries, creases, suggestive contours and suggestive
// highlights (docs/algorithms.md §3, §4, §8).
#include <cmath>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"
#include "zero_crossing_internal.hpp"

namespace fabrica {

namespace {

void require_field(const std::vector<double>& v, std::size_t n, const char* what) {
  if (v.size() != n)
    throw Error(ErrorKind::internal, std::string("line extraction: view field '") + what +
                                         "' was not computed for this surface");
}

// The segment along mesh edge `edge`, in its first face, from its lower
// vertex to its higher one (vertex ends).
LineSegment edge_segment(const Surface& s, std::size_t edge) {
  const Topology& topo = s.topology();
  const auto ev = topo.edge(edge);
  LineSegment seg;
  seg.face = topo.edge_faces(edge)[0];
  for (int i = 0; i < 2; ++i) {
    seg.kind[i] = EndKind::vertex;
    seg.end[i].element = ev[i];
  }
  return seg;
}

template <class Pred>
SegmentSoup edge_soup(const Surface& s, LineFamily family, Pred&& keep) {
  SegmentSoup soup;
  soup.family = family;
  soup.surface = &s;
  const Topology& topo = s.topology();
  detail::parallel_chunks<LineSegment>(
      topo.edge_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& out) {
        for (std::size_t i = b; i < e; ++i)
          if (keep(i)) out.push_back(edge_segment(s, i));
      },
      soup.segments);
  return soup;
}

// Interpolated contours: the zeros of n·v (trimmed by K_r >= 0), with the
// sign bits when the fields have them.
detail::SignBits contour_setup(const Surface& surface, const ViewFields& fields,
                               const ContourOptions& options, ScalarCrossingOptions& o) {
  const std::size_t nv = surface.vertex_count();
  require_field(fields.ndotv, nv, "ndotv");
  if (options.trim_concave) {
    require_field(fields.kr, nv, "kr");
    o.test_num = fields.kr;
  }
  detail::SignBits bits;
  if (fields.signs.size() == nv) bits = {fields.signs.data(), kNdotvNegative, kNdotvPositive, 0};
  return bits;
}

// Suggestive contours and highlights: the zeros of K_r with the test N/D,
// N = ±sc_num - t n·v and D = n·v, N evaluated only at the corners of faces
// where K_r changes sign.
detail::SignBits suggestive_setup(const Surface& surface, const ViewFields& fields, double fs,
                                  double threshold, double fade, bool cull, bool highlight,
                                  detail::SuggestiveTest& test) {
  const std::size_t nv = surface.vertex_count();
  require_field(fields.kr, nv, "kr");
  require_field(fields.sc_num, nv, "sc_num");
  require_field(fields.ndotv, nv, "ndotv");
  if (!(fs > 0.0)) throw InputError("feature size must be positive");
  const LineFamily family = highlight ? LineFamily::highlight : LineFamily::suggestive;
  detail::require_non_negative(threshold, family, "threshold");
  detail::require_non_negative(fade, family, "fade");
  test.kr = fields.kr;
  test.sc_num = fields.sc_num;
  test.ndotv = fields.ndotv;
  test.negate = highlight;
  test.shift = threshold / (fs * fs);
  test.cull = cull;
  test.fade = fade / (fs * fs);
  detail::SignBits bits;
  if (fields.signs.size() == nv) {
    bits = {fields.signs.data(), kKrNegative, kKrPositive, cull ? unsigned(kNdotvNotBack) : 0u};
    // The test's all-corner rejection from the bytes, when the fields were
    // computed for this very numerator (suggestive contours: not negated).
    if (!highlight && fields.suggestive_test_shift && *fields.suggestive_test_shift == test.shift)
      bits.reject = kScOffFront | kScOffBack;
  }
  return bits;
}

}  // namespace

SegmentSoup extract_contours(const Surface& surface, const ViewFields& fields,
                             const ContourOptions& options) {
  if (options.mesh_edges) {
    const auto& fn = surface.face_normals();
    const Topology& topo = surface.topology();
    const auto& pos = surface.positions();
    return edge_soup(surface, LineFamily::contour, [&](std::size_t e) {
      const auto fs = topo.edge_faces(e);
      if (fs.size() != 2) return false;
      const auto ev = topo.edge(e);
      const Vec3 v = fields.camera.view_vector(pos[static_cast<std::size_t>(ev[0])]);
      const double a = fn[static_cast<std::size_t>(fs[0])].dot(v);
      const double b = fn[static_cast<std::size_t>(fs[1])].dot(v);
      return (a > 0.0) != (b > 0.0);
    });
  }
  SegmentSoup soup;
  soup.family = LineFamily::contour;
  soup.surface = &surface;
  ScalarCrossingOptions o;
  const detail::SignBits bits = contour_setup(surface, fields, options, o);
  detail::scalar_zero_crossings(surface, fields.ndotv, o, bits, soup.segments);
  return soup;
}

SegmentSoup extract_boundaries(const Surface& surface) {
  const Topology& topo = surface.topology();
  return edge_soup(surface, LineFamily::boundary,
                   [&](std::size_t e) { return topo.is_boundary_edge(e); });
}

SegmentSoup extract_creases(const Surface& surface, const CreaseOptions& options) {
  if (!(options.angle_deg > 0.0 && options.angle_deg < 180.0))
    throw InputError("crease angle must be between 0 and 180 degrees");
  const double c = std::cos(options.angle_deg * M_PI / 180.0);
  const Topology& topo = surface.topology();
  const auto& fn = surface.face_normals();
  return edge_soup(surface, LineFamily::crease, [&](std::size_t e) {
    const auto fs = topo.edge_faces(e);
    if (fs.size() > 2) return true;  // non-manifold edges are drawn as creases
    if (fs.size() != 2) return false;
    const Vec3& a = fn[static_cast<std::size_t>(fs[0])];
    const Vec3& b = fn[static_cast<std::size_t>(fs[1])];
    if (a.squaredNorm() == 0.0 || b.squaredNorm() == 0.0) return false;
    return a.dot(b) < c;
  });
}

namespace {

SegmentSoup suggestive_like(const Surface& surface, const ViewFields& fields, double fs,
                            double threshold, double fade, bool cull, bool highlight) {
  detail::SuggestiveTest test;
  const detail::SignBits bits =
      suggestive_setup(surface, fields, fs, threshold, fade, cull, highlight, test);
  SegmentSoup soup;
  soup.family = highlight ? LineFamily::highlight : LineFamily::suggestive;
  soup.surface = &surface;
  detail::suggestive_zero_crossings(surface, test, bits, soup.segments);
  return soup;
}

}  // namespace

SegmentSoup extract_suggestive_contours(const Surface& surface, const ViewFields& fields,
                                        double feature_size, const SuggestiveOptions& options) {
  return suggestive_like(surface, fields, feature_size, options.threshold, options.fade,
                         options.cull_backfaces, false);
}

SegmentSoup extract_suggestive_highlights(const Surface& surface, const ViewFields& fields,
                                          double feature_size, const HighlightOptions& options) {
  return suggestive_like(surface, fields, feature_size, options.threshold, options.fade,
                         options.cull_backfaces, true);
}

namespace detail {

bool extract_contours_and_suggestive(const Surface& surface, const ViewFields& fields,
                                     const ContourOptions& contour, double feature_size,
                                     const SuggestiveOptions& suggestive, SegmentSoup& contours,
                                     SegmentSoup& suggestive_contours, FaceLists* apparent) {
  if (contour.mesh_edges) {
    contours = extract_contours(surface, fields, contour);
    suggestive_contours = extract_suggestive_contours(surface, fields, feature_size, suggestive);
    return false;
  }
  ScalarCrossingOptions o;
  const SignBits cbits = contour_setup(surface, fields, contour, o);
  SuggestiveTest test;
  const SignBits sbits = suggestive_setup(surface, fields, feature_size, suggestive.threshold,
                                          suggestive.fade, suggestive.cull_backfaces, false, test);
  contours = SegmentSoup{};
  contours.family = LineFamily::contour;
  contours.surface = &surface;
  suggestive_contours = SegmentSoup{};
  suggestive_contours.family = LineFamily::suggestive;
  suggestive_contours.surface = &surface;
  // The kQ1Above bits exist only with an apparent cull threshold.
  if (!fields.apparent_cull_threshold || fields.signs.size() != surface.vertex_count())
    apparent = nullptr;
  return contour_suggestive_zero_crossings(surface, fields.ndotv, o, cbits, test, sbits,
                                           contours.segments, suggestive_contours.segments,
                                           apparent, kQ1Above);
}

}  // namespace detail

}  // namespace fabrica
