// Per-view cost of the feature-line engine on a real scan: c3d_igea.ply
// (134,345 vertices, 268,686 triangles), camera and feature size of the
// reference view c3d_igea_v1 (tests/data: reference/rtsc/index.tsv), image
// 1024x1024. Targets (issue 3, docs/PERFORMANCE.md): the set {contour,
// suggestive, ridge, valley, apparent} <= 5 ms per view at 2 threads (rtsc
// single-threaded ~25 ms, ~6 ms for contours + suggestive contours); PELs +
// Laplacian lines together <= 5 ms.
//
// The Surface geometry (normals, curvature, derivative tensor) and the
// LinePrecompute (raw ridges/valleys/demarcating, gradient operator, ΔN)
// are view-independent: computed once before timing. The BM_Family and
// BM_Set* "families only" benchmarks also reuse one ViewFields; BM_ViewFields
// times the fields alone, and the BM_*PerView benchmarks time the whole
// LineExtractor::extract(camera) (fields + extraction), which is what a new
// camera costs (BM_PerViewReused: extract(camera, soups), recycling the
// previous view's segment storage; BM_PerViewOrbit: the same with a new
// camera each iteration, turning about the model). Chaining and visibility
// are timed separately.
// Argument: TBB thread count.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/view_fields.hpp"
#include "fabrica/lines/visibility.hpp"
#include "igea_view.hpp"

namespace {

using namespace fabrica;

struct Fixture {
  std::unique_ptr<Surface> surface;
  Camera camera;
  double feature_size = 0.0;
  std::unique_ptr<LineExtractor> extractor;  // every family; owns the precompute
};

Fixture& fixture() {
  static Fixture f = [] {
    Fixture x;
    x.surface = bench::load_igea();
    x.camera = bench::igea_v1_camera();
    x.feature_size = bench::kIgeaV1FeatureSize;
    LineOptions o;
    o.families = all_families();
    o.feature_size = x.feature_size;
    x.extractor = std::make_unique<LineExtractor>(*x.surface, o);
    x.extractor->extract(x.camera);  // fills every cache and the fields
    return x;
  }();
  return f;
}

SegmentSoup extract_one(Fixture& f, LineFamily family) {
  const Surface& s = *f.surface;
  const ViewFields& v = f.extractor->fields();
  const LinePrecompute& pre = f.extractor->precompute();
  const LineOptions& o = f.extractor->options();
  const double fs = f.feature_size;
  switch (family) {
    case LineFamily::contour:
      return extract_contours(s, v, o.contour);
    case LineFamily::boundary:
      return extract_boundaries(s);
    case LineFamily::crease:
      return extract_creases(s, o.crease);
    case LineFamily::suggestive:
      return extract_suggestive_contours(s, v, fs, o.suggestive);
    case LineFamily::highlight:
      return extract_suggestive_highlights(s, v, fs, o.highlight);
    case LineFamily::ridge:
      return extract_ridges(pre, v, fs, o.ridge);
    case LineFamily::valley:
      return extract_valleys(pre, v, fs, o.valley);
    case LineFamily::apparent:
      return extract_apparent_ridges(s, v, fs, o.apparent);
    case LineFamily::pel:
      return extract_pels(s, v, fs, o.pel);
    case LineFamily::laplacian:
      return extract_laplacian_lines(s, v, fs, o.laplacian);
    case LineFamily::demarcating:
      return extract_demarcating_curves(pre, v, fs, o.demarcating);
  }
  return {};
}

std::vector<LineFamily> reference_set() {
  return reference_families();
}

void count_segments(benchmark::State& state, const std::vector<SegmentSoup>& soups) {
  std::size_t n = 0;
  for (const auto& s : soups) n += s.segments.size();
  state.counters["segments"] = static_cast<double>(n);
}

// One family, fields reused (extraction only).
void BM_Family(benchmark::State& state, LineFamily family) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  std::size_t n = 0;
  for (auto _ : state) {
    SegmentSoup soup = extract_one(f, family);
    n = soup.segments.size();
    benchmark::DoNotOptimize(soup.segments.data());
  }
  state.counters["segments"] = static_cast<double>(n);
}

// A set of families, fields reused.
void BM_SetFamiliesOnly(benchmark::State& state, std::vector<LineFamily> families) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  std::vector<SegmentSoup> soups;
  for (auto _ : state) {
    soups.clear();
    for (LineFamily fam : families) soups.push_back(extract_one(f, fam));
    benchmark::DoNotOptimize(soups.data());
  }
  count_segments(state, soups);
}

// The view-dependent fields alone, for the request a family set needs.
void BM_ViewFields(benchmark::State& state, bool apparent, bool light) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  ViewFieldsRequest req;
  req.sc_test = !light;
  req.apparent = apparent;
  // As LineExtractor::extract: D_t1 q1 only where an apparent ridge can be
  // drawn with the default threshold.
  if (apparent)
    req.apparent_cull_threshold =
        f.extractor->options().apparent.threshold / (f.feature_size * f.feature_size);
  req.light = req.pel = light;
  if (light) {           // as LineExtractor asks for PELs + Laplacian lines (default thresholds)
    req.radial = false;  // n·v comes with the illumination
    req.light_threshold = f.extractor->options().pel.threshold / f.feature_size;
    req.light_cull_backfaces = true;
  }
  ViewFields fields;
  update_view_fields(fields, *f.surface, f.camera, req, &f.extractor->precompute());
  for (auto _ : state) {
    update_view_fields(fields, *f.surface, f.camera, req, &f.extractor->precompute());
    benchmark::DoNotOptimize(fields.ndotv.data());
  }
}

// Whole per-view cost: LineExtractor::extract (fields + families).
void BM_PerView(benchmark::State& state, std::vector<LineFamily> families) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  LineOptions o;
  o.families = std::move(families);
  o.feature_size = f.feature_size;
  LineExtractor ex(*f.surface, o);
  ex.extract(f.camera);  // sizes the buffers, fills the precompute caches
  std::vector<SegmentSoup> soups;
  for (auto _ : state) {
    soups = ex.extract(f.camera);
    benchmark::DoNotOptimize(soups.data());
  }
  count_segments(state, soups);
}

// The same, recycling the previous view's soups (extract(camera, soups)),
// as a redraw loop would.
// LineExtractor::extract(camera, soups) over `cameras` in turn, recycling
// the previous view's storage. BM_PerViewReused: the v1 camera every time.
// BM_PerViewOrbit: a turning view, the v1 camera swung about its up axis
// (through its centre) in 15 degree steps (24 cameras, a full turn), so no
// two consecutive views are alike, as when a user turns the model. The
// counter is the mean segment count per view.
void per_view_reused(benchmark::State& state, std::vector<LineFamily> families,
                     const std::vector<Camera>& cameras) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  LineOptions o;
  o.families = std::move(families);
  o.feature_size = f.feature_size;
  LineExtractor ex(*f.surface, o);
  std::vector<SegmentSoup> soups;
  for (const Camera& c : cameras) ex.extract(c, soups);
  std::size_t k = 0, total = 0, views = 0;
  for (auto _ : state) {
    ex.extract(cameras[k], soups);
    benchmark::DoNotOptimize(soups.data());
    for (const auto& soup : soups) total += soup.segments.size();
    ++views;
    k = (k + 1) % cameras.size();
  }
  state.counters["segments"] = views ? static_cast<double>(total) / views : 0.0;
}

void BM_PerViewReused(benchmark::State& state, std::vector<LineFamily> families) {
  per_view_reused(state, std::move(families), {fixture().camera});
}

void BM_PerViewOrbit(benchmark::State& state, std::vector<LineFamily> families) {
  const Camera& v1 = fixture().camera;
  const Vec3 axis = v1.up.normalized();
  std::vector<Camera> cameras;
  for (int k = 0; k < 24; ++k) {
    Camera c = v1;
    c.eye = v1.center +
            Eigen::AngleAxisd(k * 15.0 * std::numbers::pi / 180.0, axis) * (v1.eye - v1.center);
    cameras.push_back(c);
  }
  per_view_reused(state, std::move(families), cameras);
}

// Chaining the reference set's soups into polylines.
void BM_Chain(benchmark::State& state) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  std::vector<SegmentSoup> soups;
  for (LineFamily fam : reference_set()) soups.push_back(extract_one(f, fam));
  ChainOptions co;
  co.camera = f.camera;
  co.min_length_px = 3.0;
  std::size_t n = 0;
  for (auto _ : state) {
    LineSet lines = chain_segments(soups, co);
    n = lines.polylines.size();
    benchmark::DoNotOptimize(lines.polylines.data());
  }
  state.counters["polylines"] = static_cast<double>(n);
}

// Hidden-line removal of the chained reference set: depth buffer rendered
// per view (BM_Visibility) or reused (BM_VisibilityGivenDepth), and the
// depth rasterisation alone (BM_RenderDepth).
void BM_Visibility(benchmark::State& state, bool with_depth) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  std::vector<SegmentSoup> soups;
  for (LineFamily fam : reference_set()) soups.push_back(extract_one(f, fam));
  ChainOptions co;
  co.camera = f.camera;
  co.min_length_px = 3.0;
  const LineSet chained = chain_segments(soups, co);
  const DepthBuffer depth = render_depth(f.surface->mesh(), f.camera);
  for (auto _ : state) {
    state.PauseTiming();
    LineSet lines = chained;
    state.ResumeTiming();
    compute_visibility(lines, *f.surface, f.camera, {}, with_depth ? nullptr : &depth);
    benchmark::DoNotOptimize(lines.polylines.data());
  }
}

void BM_RenderDepth(benchmark::State& state) {
  Fixture& f = fixture();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    DepthBuffer d = render_depth(f.surface->mesh(), f.camera);
    benchmark::DoNotOptimize(d.depth.data());
  }
}

// Registers a benchmark at 1 and 2 threads (its argument), in ms, wall clock.
template <class Fn>
void register_1t_2t(const std::string& name, Fn fn) {
  benchmark::RegisterBenchmark(name.c_str(), fn)
      ->Arg(1)
      ->Arg(2)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
}

void register_all() {
  for (int i = 0; i < kLineFamilyCount; ++i) {
    const auto fam = static_cast<LineFamily>(i);
    register_1t_2t(std::string("BM_Family/") + family_name(fam),
                   [fam](benchmark::State& s) { BM_Family(s, fam); });
  }
  const std::vector<LineFamily> cs = {LineFamily::contour, LineFamily::suggestive};
  const std::vector<LineFamily> pl = {LineFamily::pel, LineFamily::laplacian};
  struct Set {
    const char* name;
    std::vector<LineFamily> families;
    bool apparent, light;
  };
  for (const Set& set :
       {Set{"reference_set", reference_set(), true, false},
        Set{"contour_suggestive", cs, false, false}, Set{"pel_laplacian", pl, false, true}}) {
    const auto fams = set.families;
    register_1t_2t(std::string("BM_SetFamiliesOnly/") + set.name,
                   [fams](benchmark::State& s) { BM_SetFamiliesOnly(s, fams); });
    const bool ap = set.apparent, li = set.light;
    register_1t_2t(std::string("BM_ViewFields/") + set.name,
                   [ap, li](benchmark::State& s) { BM_ViewFields(s, ap, li); });
    register_1t_2t(std::string("BM_PerView/") + set.name,
                   [fams](benchmark::State& s) { BM_PerView(s, fams); });
    register_1t_2t(std::string("BM_PerViewReused/") + set.name,
                   [fams](benchmark::State& s) { BM_PerViewReused(s, fams); });
    register_1t_2t(std::string("BM_PerViewOrbit/") + set.name,
                   [fams](benchmark::State& s) { BM_PerViewOrbit(s, fams); });
  }
  register_1t_2t("BM_Chain/reference_set", BM_Chain);
  register_1t_2t("BM_Visibility/reference_set",
                 [](benchmark::State& s) { BM_Visibility(s, true); });
  register_1t_2t("BM_VisibilityGivenDepth/reference_set",
                 [](benchmark::State& s) { BM_Visibility(s, false); });
  register_1t_2t("BM_RenderDepth", BM_RenderDepth);
}

}  // namespace

int main(int argc, char** argv) {
  register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
