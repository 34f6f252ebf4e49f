// A plain driver for profilers (callgrind, perf) of what the viewer's lines
// worker does with a moving camera's lines after extraction: chaining the
// soups into polylines (fabrica::chain_segments, chains under 3 px dropped,
// as render::structure_line_options) and merging their near-collinear
// vertices (viewer::merge_collinear, 0.5 px and 0.1 of strength, as while
// the camera moves). The igea at 1280x800 with contours, suggestive
// contours and apparent ridges, the camera turning 3 degrees a frame about
// the reference view's up axis.
//
//   drive_viewer_lines [FRAMES=30] [THREADS=1]
//
// Prints a hash of the chained lines and one of the merged lines over all
// frames (every field of every polyline and vertex: the output must not
// change with an optimisation), their sizes, and the wall time of the two
// phases summed over the frames. For callgrind, collect only the phases:
//   valgrind --tool=callgrind --toggle-collect='fabrica::chain_segments*'
//     --toggle-collect='fabrica::viewer::merge_collinear*' build/bench/drive_viewer_lines 10
#include <tbb/global_control.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numbers>
#include <vector>

#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "igea_view.hpp"
#include "structure_lines.hpp"

namespace {

using namespace fabrica;

// FNV-1a over the bytes of every field (not of padding).
struct Hash {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  }
  template <class T>
  void add(const T& v) {
    bytes(&v, sizeof v);
  }
  void add(const LineSet& set) {
    add(set.polylines.size());
    for (const Polyline& pl : set.polylines) {
      add(pl.family);
      add(pl.closed);
      add(pl.vertices.size());
      for (const LineVertex& v : pl.vertices) {
        add(v.anchor.face);
        for (int k = 0; k < 3; ++k) add(v.anchor.bary[k]);
        for (int k = 0; k < 3; ++k) add(v.position[k]);
        add(v.strength);
        add(v.visible);
      }
      add(pl.edge_faces.size());
      for (std::int32_t f : pl.edge_faces) add(f);
    }
  }
};

std::size_t vertex_count(const LineSet& set) {
  std::size_t n = 0;
  for (const Polyline& pl : set.polylines) n += pl.vertices.size();
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 30;
  const int threads = argc > 2 ? std::atoi(argv[2]) : 1;
  if (frames < 1 || threads < 1) {
    std::fprintf(stderr, "usage: drive_viewer_lines [FRAMES >= 1] [THREADS >= 1]\n");
    return 2;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  const auto surface = bench::load_igea();
  LineOptions options;
  options.families = {LineFamily::contour, LineFamily::suggestive, LineFamily::apparent};
  LineExtractor extractor(*surface, options);
  Camera v1 = bench::igea_v1_camera();
  v1.width = 1280;
  v1.height = 800;
  const Vec3 axis = v1.up.normalized();
  Hash chained, merged;
  std::size_t polylines = 0, vertices = 0, after = 0, removed = 0;
  double chain_ms = 0.0, merge_ms = 0.0;
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  for (int k = 0; k < frames; ++k) {
    Camera c = v1;
    c.eye = v1.center +
            Eigen::AngleAxisd(k * 3.0 * std::numbers::pi / 180.0, axis) * (v1.eye - v1.center);
    const std::vector<SegmentSoup> soups = extractor.extract(c);
    ChainOptions co;
    co.camera = c;
    co.min_length_px = 3.0;
    const auto t0 = Clock::now();
    LineSet lines = chain_segments(soups, co);
    const auto t1 = Clock::now();
    chained.add(lines);
    polylines += lines.polylines.size();
    vertices += vertex_count(lines);
    const auto t2 = Clock::now();
    removed += viewer::merge_collinear(lines, c, 0.5, 0.1);
    const auto t3 = Clock::now();
    merged.add(lines);
    after += vertex_count(lines);
    chain_ms += ms(t1 - t0);
    merge_ms += ms(t3 - t2);
  }
  std::printf(
      "frames %d, threads %d: %zu polylines, %zu vertices chained, %zu merged (%zu removed)\n",
      frames, threads, polylines, vertices, after, removed);
  std::printf("hash chained %016llx merged %016llx\n", static_cast<unsigned long long>(chained.h),
              static_cast<unsigned long long>(merged.h));
  std::printf("ms chain %.3f merge %.3f (sums over the frames)\n", chain_ms, merge_ms);
  return 0;
}
