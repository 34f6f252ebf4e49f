// Unit tests of the line engine on analytic shapes: contour geometry on a
// sphere, suggestive contours (none on a sphere, inner side of a torus),
// ridges on a Gaussian crest, closed contour loops after chaining, the
// zero-crossing kernel's edge sharing, the comparison metric.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/compare.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/precompute.hpp"
#include "fabrica/lines/view_fields.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

Camera camera_at(const Vec3& eye, const Vec3& center = Vec3::Zero(),
                 const Vec3& up = Vec3::UnitY()) {
  Camera c;
  c.eye = eye;
  c.center = center;
  c.up = up;
  c.fov_deg = 40.0;
  c.width = c.height = 512;
  return c;
}

std::vector<SegmentSoup> extract(const Surface& s, const Camera& c, std::vector<LineFamily> fams,
                                 LineOptions o = {}) {
  o.families = std::move(fams);
  if (o.feature_size <= 0.0) o.feature_size = 0.05;
  LineExtractor ex(s, o);
  return ex.extract(c);
}

}  // namespace

TEST(Contours, SphereContourIsTheCircleFacingTheEye) {
  const double R = 1.0, d = 5.0;
  Surface sphere(test::make_icosphere(R, 5));
  const auto soups = extract(sphere, camera_at({0, 0, d}), {LineFamily::contour});
  ASSERT_EQ(soups.size(), 1u);
  const auto& segs = soups[0].resolved();
  ASSERT_GT(segs.size(), 50u);
  // The tangent cone from the eye touches the sphere on the circle z = R²/d,
  // radius R sqrt(1 - R²/d²).
  const double z0 = R * R / d, r0 = R * std::sqrt(1.0 - R * R / (d * d));
  double length = 0.0;
  for (const auto& s : segs) {
    for (const auto& e : s.end) {
      EXPECT_NEAR(e.position.z(), z0, 5e-3);
      EXPECT_NEAR(std::hypot(e.position.x(), e.position.y()), r0, 5e-3);
      EXPECT_EQ(e.kind, EndKind::edge);
    }
    length += (s.end[1].position - s.end[0].position).norm();
  }
  EXPECT_NEAR(length, 2.0 * M_PI * r0, 0.01 * 2.0 * M_PI * r0);
  // One closed loop after chaining.
  const auto chains = chain_segments(soups[0]);
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_TRUE(chains[0].closed);
  EXPECT_EQ(chains[0].vertices.size(), segs.size());
}

TEST(Contours, OrthographicSphereContourIsTheGreatCircle) {
  Surface sphere(test::make_icosphere(2.0, 4));
  Camera c = camera_at({0, 0, 10});
  c.projection = Projection::orthographic;
  const auto soups = extract(sphere, c, {LineFamily::contour});
  ASSERT_GT(soups[0].segments.size(), 20u);
  for (const auto& s : soups[0].resolved())
    for (const auto& e : s.end) {
      EXPECT_NEAR(e.position.z(), 0.0, 0.02);
      EXPECT_NEAR(e.position.norm(), 2.0, 0.02);
    }
}

TEST(Contours, MeshEdgeContoursFollowMeshEdges) {
  Surface sphere(test::make_icosphere(1.0, 3));
  LineOptions o;
  o.contour.mesh_edges = true;
  const auto soups = extract(sphere, camera_at({0, 0, 5}), {LineFamily::contour}, o);
  ASSERT_GT(soups[0].segments.size(), 10u);
  for (const auto& s : soups[0].resolved()) {
    EXPECT_EQ(s.end[0].kind, EndKind::vertex);
    EXPECT_NEAR(s.end[0].position.z(), 0.2, 0.15);
  }
}

TEST(Suggestive, SphereHasNoSuggestiveContoursOrHighlights) {
  Surface sphere(test::make_icosphere(1.0, 4));
  for (const Vec3& eye : {Vec3(0, 0, 5), Vec3(3, 2, 4), Vec3(-4, 0.5, -1)}) {
    const auto soups =
        extract(sphere, camera_at(eye), {LineFamily::suggestive, LineFamily::highlight});
    EXPECT_EQ(soups[0].segments.size(), 0u);
    EXPECT_EQ(soups[1].segments.size(), 0u);
  }
}

TEST(Suggestive, TorusHasSuggestiveContoursOnItsInnerSide) {
  const double R = 2.0, r = 0.7;
  Surface torus(test::make_torus(R, r, 160, 64, 0.05));
  // An oblique view: the inner (saddle-shaped) side faces the eye.
  LineOptions o;
  // rtsc's rule gives s_f = 0.063 here (k2 ~ 0 on top), so the default test
  // 0.01/s_f² = 2.5 removes everything at this scale; s_f = 0.5 gives 0.04.
  o.feature_size = 0.5;
  const auto soups = extract(torus, camera_at({0, -5, 4}), {LineFamily::suggestive}, o);
  const auto& segs = soups[0].resolved();
  ASSERT_GT(segs.size(), 20u);
  for (const auto& s : segs)
    for (const auto& e : s.end)
      EXPECT_LT(std::hypot(e.position.x(), e.position.y()), R + 0.05)
          << "suggestive contour on the convex outer side";
}

TEST(Ridges, GaussianCrestHasItsRidgeOnTheCrestLine) {
  // z = h exp(-x²/s²) over [-2,2]x[-2,2]: a crest along the y axis (convex,
  // k1 > 0, maximal at x = 0), valleys at its feet on both sides.
  TriangleMesh m = test::make_plane(4.0, 81);
  const double h = 0.5, sg = 0.5;
  for (auto& p : m.positions) {
    p.x() -= 2.0;
    p.y() -= 2.0;
    p.z() = h * std::exp(-p.x() * p.x() / (sg * sg));
  }
  Surface s(std::move(m));
  LineOptions o;
  o.feature_size = 0.5;
  const auto soups = extract(s, camera_at({0.3, -1.0, 8.0}, Vec3::Zero(), Vec3::UnitY()),
                             {LineFamily::ridge, LineFamily::valley}, o);
  const auto& ridges = soups[0].resolved();
  ASSERT_GT(ridges.size(), 40u);
  double length = 0.0;
  for (const auto& seg : ridges) {
    for (const auto& e : seg.end) {
      if (std::abs(e.position.y()) > 1.85) continue;  // boundary rows are one-sided
      EXPECT_LT(std::abs(e.position.x()), 0.03);
    }
    length += (seg.end[1].position - seg.end[0].position).norm();
  }
  EXPECT_GT(length, 3.5);  // nearly the whole crest (4 long)
  // Valleys lie on both feet, symmetric: mean x close to 0, |x| well away from the crest.
  const auto& valleys = soups[1].resolved();
  ASSERT_GT(valleys.size(), 20u);
  double mean_x = 0.0;
  for (const auto& seg : valleys) {
    EXPECT_GT(std::abs(seg.end[0].position.x()), 0.3);
    mean_x += seg.end[0].position.x();
  }
  EXPECT_NEAR(mean_x / valleys.size(), 0.0, 0.1);
}

// The per-view threshold visits only LinePrecompute::raw_above's list: the
// raw segments above the threshold at an end, in order, per family and
// threshold (a changed threshold gives its own list), and extraction keeps
// exactly the listed segments that survive the view's back-face culling.
TEST(Ridges, ThresholdListIsTheRawSegmentsAboveItAndExtractionUsesIt) {
  TriangleMesh m = test::make_plane(4.0, 81);
  for (auto& p : m.positions) {
    p.x() -= 2.0;
    p.y() -= 2.0;
    p.z() = 0.5 * std::exp(-p.x() * p.x() / 0.25) * (1.0 + 0.3 * std::sin(2.0 * p.y()));
  }
  Surface s(std::move(m));
  const LinePrecompute pre(s);
  const auto& keys = pre.raw_ridge_keys();
  ASSERT_GT(keys.size(), 40u);
  std::vector<float> mags;
  for (const auto& k : keys) mags.push_back(std::max(k.m0, k.m1));
  std::sort(mags.begin(), mags.end());
  // A threshold between the raw magnitudes: some pass, some do not.
  const double t = mags[mags.size() / 2];
  const auto above = pre.raw_above(LineFamily::ridge, t);
  std::vector<std::uint32_t> expect;
  for (std::size_t i = 0; i < keys.size(); ++i)
    if (double(keys[i].m0) > t || double(keys[i].m1) > t) expect.push_back(std::uint32_t(i));
  EXPECT_EQ(above->index, expect);
  ASSERT_EQ(above->segments.size(), expect.size());
  ASSERT_EQ(above->corners.size(), expect.size());
  for (std::size_t j = 0; j < expect.size(); ++j)
    EXPECT_EQ(above->corners[j], keys[expect[j]].corners);
  EXPECT_GT(expect.size(), 0u);
  EXPECT_LT(expect.size(), keys.size());
  // Cached while the threshold stays; a new threshold, a new list.
  EXPECT_EQ(pre.raw_above(LineFamily::ridge, t), above);
  EXPECT_EQ(pre.raw_above(LineFamily::ridge, 0.0)->index.size(), keys.size());
  EXPECT_EQ(above->index, expect);  // the old list is still whole
  EXPECT_THROW((void)pre.raw_above(LineFamily::contour, t), Error);
  // A threshold that is NaN or negative is an input error, not NaN strengths.
  {
    const ViewFields f = compute_view_fields(s, camera_at({0.0, 0.0, 6.0}), {}, &pre);
    for (double bad : {std::nan(""), -1.0}) {
      // Each family's function, and the extractor (which checks every
      // family up front).
      const std::function<void()> calls[] = {[&] {
                                               RidgeOptions r;
                                               r.threshold = bad;
                                               (void)extract_ridges(pre, f, 0.5, r);
                                             },
                                             [&] {
                                               RidgeOptions r;
                                               r.threshold = bad;
                                               (void)extract_valleys(pre, f, 0.5, r);
                                             },
                                             [&] {
                                               DemarcatingOptions d;
                                               d.threshold = bad;
                                               (void)extract_demarcating_curves(pre, f, 0.5, d);
                                             },
                                             [&] {
                                               SuggestiveOptions o;
                                               o.threshold = bad;
                                               (void)extract_suggestive_contours(s, f, 0.5, o);
                                             },
                                             [&] {
                                               SuggestiveOptions o;
                                               o.fade = bad;
                                               (void)extract_suggestive_contours(s, f, 0.5, o);
                                             },
                                             [&] {
                                               HighlightOptions o;
                                               o.threshold = bad;
                                               (void)extract_suggestive_highlights(s, f, 0.5, o);
                                             },
                                             [&] {
                                               ApparentOptions o;
                                               o.threshold = bad;
                                               (void)extract_apparent_ridges(s, f, 0.5, o);
                                             }};
      for (std::size_t k = 0; k < std::size(calls); ++k)
        EXPECT_THROW(calls[k](), InputError) << "function " << k << ", " << bad;
      // The precomputed list itself (public API) refuses it too.
      for (LineFamily fam : {LineFamily::ridge, LineFamily::valley, LineFamily::demarcating})
        EXPECT_THROW((void)pre.raw_above(fam, bad), InputError) << family_name(fam) << ", " << bad;
      for (int k = 0; k < 10; ++k) {
        LineOptions o;
        o.families = all_families();
        double* field[10] = {&o.suggestive.threshold, &o.suggestive.fade, &o.highlight.threshold,
                             &o.highlight.fade,       &o.ridge.threshold, &o.valley.threshold,
                             &o.apparent.threshold,   &o.pel.threshold,   &o.laplacian.threshold,
                             &o.demarcating.threshold};
        *field[k] = bad;
        try {
          LineExtractor ex(s, o);
          ADD_FAILURE() << "option " << k << " = " << bad << " was accepted";
        } catch (const InputError& e) {
          // The message names the family.
          const std::string what = e.what();
          const char* names[10] = {"suggestive", "suggestive", "highlight", "highlight",
                                   "ridge",      "valley",     "apparent",  "pel",
                                   "laplacian",  "demarcating"};
          EXPECT_NE(what.find(names[k]), std::string::npos) << what;
        }
      }
    }
    // Zero is allowed (no threshold, no fade).
    LineOptions zero;
    zero.families = all_families();
    zero.suggestive.threshold = zero.suggestive.fade = zero.apparent.threshold = 0.0;
    zero.pel.threshold = zero.laplacian.threshold = 0.0;
    EXPECT_NO_THROW({ LineExtractor ex(s, zero); });
  }
  // Seen along the crest (its slopes alternately towards and away from the
  // eye: part back-facing), ridges keep the listed segments with a corner
  // facing the eye, in list order.
  const Camera c = camera_at({0.0, 6.0, 0.5}, Vec3::Zero(), Vec3::UnitZ());
  ViewFieldsRequest req;
  const ViewFields fields = compute_view_fields(s, c, req, &pre);
  RidgeOptions ro;
  const double fs = 0.5;
  ro.threshold = t * fs;
  const SegmentSoup ridges = extract_ridges(pre, fields, fs, ro);
  const std::vector<ResolvedSegment> got_all = ridges.resolved();
  SegmentSoup raw_soup;
  raw_soup.surface = &s;
  raw_soup.segments = pre.raw_ridges();
  const std::vector<ResolvedSegment> raw_all = raw_soup.resolved();
  std::size_t kept = 0;
  for (std::uint32_t i : expect) {
    const auto& corner = keys[i].corners;
    if (!(fields.ndotv[corner[0]] > 0.0 || fields.ndotv[corner[1]] > 0.0 ||
          fields.ndotv[corner[2]] > 0.0))
      continue;
    ASSERT_LT(kept, ridges.segments.size());
    // The raw segment, with each end's strength the fade (m - t)/m.
    const ResolvedSegment& got = got_all[kept];
    const ResolvedSegment& raw = raw_all[i];
    EXPECT_EQ(got.face, raw.face);
    const float m[2] = {keys[i].m0, keys[i].m1};
    for (int e = 0; e < 2; ++e) {
      EXPECT_EQ(got.end[e].position, raw.end[e].position);
      EXPECT_EQ(got.end[e].anchor.bary, raw.end[e].anchor.bary);
      EXPECT_EQ(got.end[e].element, raw.end[e].element);
      const double k = std::max(double(m[e]) - t, 0.0);
      EXPECT_EQ(got.end[e].strength, static_cast<float>(k / (k + t)));
    }
    ++kept;
  }
  EXPECT_EQ(kept, ridges.segments.size());
  EXPECT_GT(kept, 0u);
  EXPECT_LT(kept, expect.size());
}

TEST(Chaining, TorusContoursFormClosedLoops) {
  Surface torus(test::make_torus(2.0, 0.7, 120, 48, 0.1));
  LineOptions o;
  o.contour.trim_concave = false;  // the whole zero set of n·v: closed curves
  const auto soups = extract(torus, camera_at({0.3, -6, 3}), {LineFamily::contour}, o);
  const auto chains = chain_segments(soups[0]);
  ASSERT_GE(chains.size(), 2u);
  std::size_t vertices = 0;
  for (const auto& c : chains) {
    EXPECT_TRUE(c.closed);
    vertices += c.vertices.size();
  }
  EXPECT_EQ(vertices, soups[0].segments.size());
}

TEST(Chaining, ShortChainsAreDropped) {
  Surface sphere(test::make_icosphere(1.0, 4));
  const auto soups = extract(sphere, camera_at({0, 0, 5}), {LineFamily::contour});
  ChainOptions o;
  o.min_length = 100.0;
  EXPECT_TRUE(chain_segments(soups[0], o).empty());
  o.min_length = 1.0;
  EXPECT_EQ(chain_segments(soups[0], o).size(), 1u);
}

// The lean records of two soups, field by field (an end's t or float
// barycentrics as their 8 bytes).
bool same_records(const SegmentSoup& a, const SegmentSoup& b) {
  if (a.family != b.family || a.segments.size() != b.segments.size()) return false;
  for (std::size_t i = 0; i < a.segments.size(); ++i) {
    const LineSegment &x = a.segments[i], &y = b.segments[i];
    if (x.face != y.face) return false;
    for (int k = 0; k < 2; ++k)
      if (x.kind[k] != y.kind[k] || x.end[k].element != y.end[k].element ||
          std::memcmp(&x.end[k].t, &y.end[k].t, sizeof(double)) != 0 ||
          x.end[k].strength != y.end[k].strength)
        return false;
  }
  return true;
}

// A one-shot extractor frees the vertex blocks, the tangent ring, the
// apparent ridges' fields and the raw lines during extract() (draw_lines'
// lower peak memory): the segments are those of a
// kept extractor, at one thread (the pipelined D_t1 q1 path) and two, and a
// second view rebuilds what was freed.
TEST(LineExtractor, OneShotGivesTheSameSegments) {
  const Surface torus(test::make_torus(2.0, 0.7, 96, 48, 0.05));
  LineOptions o;
  o.families = reference_families();
  const Camera views[2] = {camera_at({0.5, -5, 3}), camera_at({3, 2, 4})};
  // One-shot mode runs the families one after another, the apparent ridges
  // first (q1, t1 and D_t1 q1 freed before their kernel reads the packed
  // records) and frees kr and sc_num after the fused scan unless
  // highlights read them: the reference families, and a list in another
  // order with highlights and without the fused scan's partner.
  LineOptions other = o;
  other.families = {LineFamily::ridge, LineFamily::highlight, LineFamily::apparent,
                    LineFamily::suggestive, LineFamily::valley};
  for (const LineOptions& opt : {o, other})
    for (const int threads : {1, 2}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(threads));
      LineExtractor kept(torus, opt), once(torus, opt);
      once.set_one_shot(true);
      for (const Camera& c : views) {
        const auto want = kept.extract(c);
        const auto got = once.extract(c);
        ASSERT_EQ(want.size(), got.size());
        std::size_t total = 0;
        for (std::size_t k = 0; k < want.size(); ++k) {
          EXPECT_TRUE(same_records(want[k], got[k])) << family_name(want[k].family);
          total += got[k].segments.size();
        }
        EXPECT_GT(total, 200u);
      }
    }
  // Released and built again: the same blocks and ring.
  LinePrecompute pre(torus);
  const auto blocks = pre.vertex_blocks().block;
  const auto ring = pre.tangent_ring().x;
  pre.release_vertex_blocks();
  pre.release_tangent_ring();
  const auto& again = pre.vertex_blocks().block;
  ASSERT_EQ(again.size(), blocks.size());
  EXPECT_EQ(std::memcmp(again.data(), blocks.data(), blocks.size() * sizeof(blocks[0])), 0);
  EXPECT_EQ(pre.tangent_ring().x, ring);
  // The raw lines (freed by a one-shot extraction once its ridges, valleys
  // and demarcating curves are through): built again, the same bits; a
  // list held from raw_above() stays valid.
  SegmentSoup ridges, valleys, demarcating;
  ridges.segments = pre.raw_ridges();
  valleys.segments = pre.raw_valleys();
  demarcating.segments = pre.raw_demarcating();
  const std::vector<double> k1 = pre.abs_k1();
  const auto above = pre.raw_above(LineFamily::ridge, 0.1);
  const auto above_copy = above->segments;
  EXPECT_GT(ridges.segments.size(), 100u);
  EXPECT_GT(above_copy.size(), 10u);
  EXPECT_FALSE(pre.raw_lines_released());
  pre.release_raw_lines();
  EXPECT_TRUE(pre.raw_lines_released());
  SegmentSoup again_above;
  again_above.segments = above->segments;
  SegmentSoup held_above;
  held_above.segments = above_copy;
  EXPECT_TRUE(same_records(held_above, again_above));
  SegmentSoup r2, v2, d2;
  r2.segments = pre.raw_ridges();
  v2.segments = pre.raw_valleys();
  d2.segments = pre.raw_demarcating();
  EXPECT_TRUE(same_records(ridges, r2));
  EXPECT_TRUE(same_records(valleys, v2));
  EXPECT_TRUE(same_records(demarcating, d2));
  EXPECT_EQ(pre.abs_k1(), k1);
  SegmentSoup rebuilt_above;
  rebuilt_above.segments = pre.raw_above(LineFamily::ridge, 0.1)->segments;
  EXPECT_TRUE(same_records(held_above, rebuilt_above));
  EXPECT_EQ(pre.raw_ridge_keys().size(), ridges.segments.size());
}

TEST(Kernel, NeighbouringFacesShareBitIdenticalEdgePoints) {
  Surface torus(test::make_torus(2.0, 0.7, 90, 40, 0.2));
  const auto soups =
      extract(torus, camera_at({1, -5, 3}), {LineFamily::contour, LineFamily::apparent});
  for (const auto& soup : soups) {
    std::map<std::int32_t, Vec3> at_edge;
    std::size_t shared = 0;
    for (const auto& s : soup.resolved())
      for (const auto& e : s.end) {
        if (e.kind != EndKind::edge) continue;
        auto [it, inserted] = at_edge.emplace(e.element, e.position);
        if (!inserted) {
          ++shared;
          EXPECT_EQ(it->second, e.position);
        }
      }
    EXPECT_GT(shared, 10u);
  }
}

TEST(Compare, MetricSeparatesMatchingFromShiftedLines) {
  std::vector<Segment3> a, b, c;
  for (int i = 0; i < 100; ++i) {
    const Vec3 p(i * 0.01, 0, 0), q((i + 1) * 0.01, 0, 0);
    a.push_back({p, q});
    b.push_back({p + Vec3(0, 0.001, 0), q + Vec3(0, 0.001, 0)});
    c.push_back({p + Vec3(0, 0.1, 0), q + Vec3(0, 0.1, 0)});
  }
  EXPECT_NEAR(compare_segments(b, a, 0.005, 0.001).f, 1.0, 1e-12);
  EXPECT_NEAR(compare_segments(c, a, 0.005, 0.001).f, 0.0, 1e-12);
  // Half of the reference missing: recall 0.5, precision 1.
  std::vector<Segment3> half(a.begin(), a.begin() + 50);
  const auto s = compare_segments(half, a, 0.005, 0.001);
  EXPECT_NEAR(s.precision, 1.0, 1e-9);
  EXPECT_NEAR(s.recall, 0.5, 0.02);
}

TEST(Families, NamesRoundTrip) {
  for (auto f : all_families()) EXPECT_EQ(parse_family(family_name(f)), f);
  EXPECT_FALSE(parse_family("nonsense"));
}
