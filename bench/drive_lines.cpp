// A plain driver for profiling the per-view cost of the rtsc set on igea v1
// (the camera of bench_lines): repeats LineExtractor::extract(camera) and
// prints the median and 10th percentile per view. Under callgrind
// (valgrind --tool=callgrind --collect-atstart=no) only the timed views are
// collected, so the instruction count per view can be read off directly.
// It also prints a hash of every field of every segment of the last view:
// an output-preserving change keeps it.
//   drive_lines [views=50] [threads=2] [set=rtsc|light] [view=igea_v1|bunny_v1] [first_reps=3]
// (rtsc: contour, suggestive, apparent, ridge, valley; light: PELs and
// Laplacian lines with the headlight; views: bench/igea_view.hpp)
// The time to the first lines comes first, load excluded, as the median of
// first_reps fresh starts on a copy of the loaded mesh: precompute_ms is the
// Surface and everything Surface::precompute() computes (topology,
// normals, areas, curvature, derivative tensor, feature size, edge
// statistics, bounding sphere); first_view_ms is a new LineExtractor's first
// view (its view-independent line precompute included). Compare with
// rtsc_bench's pre_with_adjfaces + view5 (bench/rtsc_side_by_side.sh).
// With DRIVE_LINES_CALLGRIND=first in the environment, callgrind collects
// the first-lines region (all first_reps of it) instead of the timed views.
// With DRIVE_LINES_HIDDEN=1 every timed view also renders the depth buffer
// that hidden-line removal tests against (render_depth into a buffer kept
// between views, as LineDrawer's callers do), and the line prints the
// raster's own median (raster_ms) and a hash of the last view's depth
// buffer (depth_hash); DRIVE_LINES_RASTER=portable runs the portable raster
// instead of the AVX2 one (the two give the same bits).
#include <tbb/global_control.h>
#include <valgrind/callgrind.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "fabrica/core/depth_raster.hpp"
#include "fabrica/lines/extract.hpp"
#include "igea_view.hpp"

int main(int argc, char** argv) {
  using namespace fabrica;
  const int views = argc > 1 ? std::atoi(argv[1]) : 50;
  const int threads = argc > 2 ? std::atoi(argv[2]) : 2;
  if (views < 1 || threads < 1) {
    std::fprintf(stderr, "drive_lines: VIEWS and THREADS must be positive integers\n");
    return 2;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  LineOptions o;
  const std::string set = argc > 3 ? argv[3] : "rtsc";
  const std::string view_name = argc > 4 ? argv[4] : "igea_v1";
  const int first_reps = argc > 5 ? std::atoi(argv[5]) : 3;
  const bench::ReferenceView* view = bench::find_reference_view(view_name);
  if (!view) {
    std::fprintf(stderr, "drive_lines: the view is igea_v1 or bunny_v1 (got '%s')\n",
                 view_name.c_str());
    return 2;
  }
  if (first_reps < 1) {
    std::fprintf(stderr, "drive_lines: FIRST_REPS must be a positive integer\n");
    return 2;
  }
  if (set == "light") {
    o.families = {LineFamily::pel, LineFamily::laplacian};
  } else if (set == "rtsc") {
    o.families = reference_families();
  } else {
    std::fprintf(stderr, "drive_lines: the set is rtsc or light (got '%s')\n", set.c_str());
    return 2;
  }
  o.feature_size = view->feature_size;
  const Camera c = bench::reference_camera(*view);
  const TriangleMesh loaded = bench::load_prepared_mesh(view->mesh);
  // Time to the first lines, on fresh Surfaces (the mesh copy not timed).
  using clock = std::chrono::steady_clock;
  auto ms_between = [](clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  std::vector<double> pre_ms, first_ms;
  std::unique_ptr<Surface> surface_ptr;
  std::vector<SegmentSoup> soups;
  const char* collect = std::getenv("DRIVE_LINES_CALLGRIND");
  const char* hidden_env = std::getenv("DRIVE_LINES_HIDDEN");
  const bool hidden = hidden_env && std::string(hidden_env) == "1";
  const char* raster_env = std::getenv("DRIVE_LINES_RASTER");
  if (raster_env && std::string(raster_env) == "portable") {
    detail::depth_raster_avx2_enabled() = false;
  } else if (raster_env && *raster_env) {
    std::fprintf(stderr, "drive_lines: DRIVE_LINES_RASTER is 'portable' or unset (got '%s')\n",
                 raster_env);
    return 2;
  }
  const bool collect_first = collect && std::string(collect) == "first";
  for (int r = 0; r < first_reps; ++r) {
    surface_ptr.reset();
    TriangleMesh copy = loaded;
    if (collect_first) CALLGRIND_START_INSTRUMENTATION;
    const auto t0 = clock::now();
    surface_ptr = std::make_unique<Surface>(std::move(copy));
    surface_ptr->precompute();
    const auto t1 = clock::now();
    LineExtractor first(*surface_ptr, o);
    first.extract(c, soups);
    const auto t2 = clock::now();
    if (collect_first) CALLGRIND_STOP_INSTRUMENTATION;
    pre_ms.push_back(ms_between(t0, t1));
    first_ms.push_back(ms_between(t1, t2));
  }
  std::sort(pre_ms.begin(), pre_ms.end());
  std::sort(first_ms.begin(), first_ms.end());
  const Surface& surface = *surface_ptr;
  LineExtractor ex(surface, o);
  ex.extract(c, soups);
  ex.extract(c, soups);
  DepthBuffer depth;
  if (hidden) render_depth(surface.mesh(), c, depth);
  std::vector<double> ms, raster_ms;
  std::size_t segments = 0;
  if (!collect_first) CALLGRIND_START_INSTRUMENTATION;
  for (int v = 0; v < views; ++v) {
    const auto t0 = std::chrono::steady_clock::now();
    ex.extract(c, soups);
    const auto t1 = std::chrono::steady_clock::now();
    if (hidden) render_depth(surface.mesh(), c, depth);
    const auto t2 = std::chrono::steady_clock::now();
    ms.push_back(ms_between(t0, t2));
    raster_ms.push_back(ms_between(t1, t2));
  }
  if (!collect_first) CALLGRIND_STOP_INSTRUMENTATION;
  // FNV-1a over every field of every segment, in order, for the timed view
  // and four more (the eye turned about the vertical axis, and one
  // orthographic view): equal hashes mean bit-identical output.
  std::uint64_t hash = 1469598103934665603ull;
  auto mix = [&](const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) hash = (hash ^ b[k]) * 1099511628211ull;
  };
  auto mix_soups = [&] {
    // (the ends as the consumers see them: barycentrics and positions
    // recomputed from the lean records)
    for (const auto& s : soups) {
      if (s.segments.empty()) continue;
      const SegmentGeometry geo = s.geometry();
      for (const auto& seg : s.segments) {
        mix(&seg.face, sizeof seg.face);
        for (int i = 0; i < 2; ++i) {
          const SegmentEnd& e = seg.end[i];
          const ResolvedEnd r = geo.resolve(seg, i);
          mix(&r.anchor.face, sizeof r.anchor.face);
          mix(r.anchor.bary.data(), 3 * sizeof(double));
          mix(r.position.data(), 3 * sizeof(double));
          mix(&e.element, sizeof e.element);
          mix(&seg.kind[i], sizeof seg.kind[i]);
          mix(&e.strength, sizeof e.strength);
        }
      }
    }
  };
  for (const auto& s : soups) segments += s.segments.size();
  mix_soups();
  for (int k = 1; k <= 4; ++k) {
    Camera turned = c;
    const double a = 1.1 * k;
    const Vec3 d = c.eye - c.center;
    turned.eye = c.center + Vec3(std::cos(a) * d[0] + std::sin(a) * d[2], d[1] + 0.02 * k,
                                 -std::sin(a) * d[0] + std::cos(a) * d[2]);
    if (k == 4) turned.projection = Projection::orthographic;
    ex.extract(turned, soups);
    mix_soups();
  }
  std::sort(ms.begin(), ms.end());
  std::string raster;
  if (hidden) {
    // (FNV-1a over the depth bits of the timed view's buffer)
    std::uint64_t dh = 1469598103934665603ull;
    for (const float z : depth.depth) {
      std::uint32_t b;
      std::memcpy(&b, &z, sizeof b);
      for (int k = 0; k < 4; ++k) dh = (dh ^ ((b >> (8 * k)) & 0xffu)) * 1099511628211ull;
    }
    std::sort(raster_ms.begin(), raster_ms.end());
    char text[96];
    std::snprintf(text, sizeof text, " raster_ms %.2f depth_hash %016llx",
                  raster_ms[raster_ms.size() / 2], static_cast<unsigned long long>(dh));
    raster = text;
  }
  std::printf(
      "views %d threads %d segments %zu hash %016llx median %.2f ms p10 %.2f ms precompute_ms %.2f "
      "first_view_ms %.2f%s\n",
      views, threads, segments, static_cast<unsigned long long>(hash), ms[ms.size() / 2],
      ms[ms.size() / 10], pre_ms[pre_ms.size() / 2], first_ms[first_ms.size() / 2], raster.c_str());
  return 0;
}
