// Hidden-line removal on igea v1 at SIZE² (default 1024²): the depth buffer
// from GL (render/gl_depth.hpp: draw + read back) against the CPU raster
// (render_depth) at 1 and 2 threads, interleaved in every round, and the
// visibility samples given each buffer; medians and minima in ms per view,
// then how many line vertices the two buffers mark differently.
//   bench_gl_depth [rounds=20] [size=1024]
// The GL context is the headless one (FABRICA_GL_BACKEND=egl|osmesa; Mesa's
// llvmpipe on a machine without a GPU, with LP_NUM_THREADS threads).
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/render/context.hpp"
#include "fabrica/render/gl_depth.hpp"
#include "igea_view.hpp"

int main(int argc, char** argv) {
  using namespace fabrica;
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 20;
  const int size = argc > 2 ? std::atoi(argv[2]) : 1024;
  if (rounds < 1 || size < 16 || size > 8192) {
    std::fprintf(stderr, "bench_gl_depth: ROUNDS must be >= 1 and SIZE in [16, 8192]\n");
    return 2;
  }
  const auto surface = bench::load_igea();
  Camera camera = bench::igea_v1_camera();
  camera.width = camera.height = size;
  DrawLinesOptions o;
  o.lines.families = reference_families();
  o.lines.feature_size = bench::kIgeaV1FeatureSize;
  o.visibility = false;
  const LineDrawing drawing = draw_lines(*surface, camera, o);
  auto context = render::create_headless_context();
  render::GlDepthRenderer gl(*context, surface->mesh());
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  enum { kCpu1, kCpu2, kGl, kVisCpu, kVisGl, kN };
  const char* names[kN] = {"CPU raster 1T", "CPU raster 2T", "GL draw + read back",
                           "visibility samples given the CPU buffer (2T)",
                           "visibility samples given the GL buffer (2T)"};
  std::vector<double> t[kN];
  DepthBuffer cpu, from_gl;
  LineSet with_cpu, with_gl;
  for (int r = 0; r < rounds + 1; ++r) {  // round 0 warms up
    for (int threads : {1, 2}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(threads));
      const auto a = clock::now();
      render_depth(surface->mesh(), camera, cpu);
      if (r > 0) t[threads == 1 ? kCpu1 : kCpu2].push_back(ms(a, clock::now()));
    }
    const auto b = clock::now();
    gl.render(camera, from_gl);
    const auto c = clock::now();
    with_cpu = drawing.lines;
    const auto d = clock::now();
    compute_visibility(with_cpu, *surface, camera, {}, &cpu);
    const auto e = clock::now();
    with_gl = drawing.lines;
    const auto f = clock::now();
    compute_visibility(with_gl, *surface, camera, {}, &from_gl);
    const auto g = clock::now();
    if (r == 0) continue;
    t[kGl].push_back(ms(b, c));
    t[kVisCpu].push_back(ms(d, e));
    t[kVisGl].push_back(ms(f, g));
  }
  std::printf("igea v1, %dx%d, %d rounds, GL: %s\n", size, size, rounds,
              context->renderer().c_str());
  for (int k = 0; k < kN; ++k) {
    std::sort(t[k].begin(), t[k].end());
    std::printf("%-46s median %7.2f ms  min %7.2f ms\n", names[k], t[k][t[k].size() / 2],
                t[k].front());
  }
  std::size_t vertices = 0, differ = 0;
  for (std::size_t p = 0; p < with_cpu.polylines.size(); ++p)
    for (std::size_t i = 0; i < with_cpu.polylines[p].vertices.size(); ++i) {
      ++vertices;
      differ +=
          with_cpu.polylines[p].vertices[i].visible != with_gl.polylines[p].vertices[i].visible;
    }
  std::size_t covered = 0, one_side = 0;
  for (std::size_t i = 0; i < cpu.depth.size(); ++i) {
    const bool x = std::isfinite(cpu.depth[i]), y = std::isfinite(from_gl.depth[i]);
    covered += x || y;
    one_side += x != y;
  }
  std::printf("line vertices %zu, marked differently %zu; pixels covered %zu, by one only %zu\n",
              vertices, differ, covered, one_side);
  return 0;
}
