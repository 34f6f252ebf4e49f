// Rendering benchmarks (docs/PERFORMANCE.md "Rendering"): per-frame cost of
// the hybrid apparent ridges of seed 000 (stage 1 into the (q, t1) target,
// stage 2 filter, readback of the RGBA image) at 512², 1024² and 2048² on
// noisy spheres of about 50k, 300k and 1M vertices, against the same two
// passes with trivial shaders (Renderer::render_hybrid(..., bare = true)) in
// the same run (BM_HybridOverBare; BM_HybridStages splits both per stage
// with GL timer queries); and the object-space apparent ridges
// (fabrica::lines extraction + chaining for the same camera) on the same
// meshes.
//
// Surface LIC (issue 21, docs/lic.md): BM_LicIgea renders igea (134k
// vertices, the rtsc reference view at 1280 x 800) shaded with the LIC pass
// and BM_LicIgeaOff the same scene without it, in the same run; the LIC
// pass costs the difference (the target: <= 50 ms on llvmpipe).
// BM_LicIgeaBuffer times the pass alone (render_lic_buffer: stage 1 into
// the LIC target, mark, convolution, readback).
//
// The spheres are generated here: a latitude-longitude sphere of radius 50 mm
// with smooth bumps r = R (1 + 0.05 sin 5θ sin 4φ + 0.02 sin 11θ cos 7φ), so
// every size shows the same lines. Times are wall clock (the software
// rasteriser runs on its own threads). Keep runs short:
//   bench_render --benchmark_min_time=0.2
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <utility>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/render/renderer.hpp"
#include "igea_view.hpp"

namespace fr = fabrica::render;
using fabrica::Vec3;

namespace {

// Rings x segments chosen for about 50k, 300k and 1M vertices.
struct SphereSize {
  int rings, segments;
};
const std::map<int, SphereSize> kSizes = {{50, {158, 316}}, {300, {387, 774}}, {1000, {707, 1414}}};

fabrica::TriangleMesh noisy_sphere(int rings, int segments) {
  const double R = 50.0;
  fabrica::TriangleMesh m;
  auto point = [&](double theta, double phi) {
    const double r = R * (1.0 + 0.05 * std::sin(5 * theta) * std::sin(4 * phi) +
                          0.02 * std::sin(11 * theta) * std::cos(7 * phi));
    return Vec3(r * std::sin(theta) * std::cos(phi), r * std::sin(theta) * std::sin(phi),
                r * std::cos(theta));
  };
  m.positions.push_back(point(0.0, 0.0));  // north pole
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j)
      m.positions.push_back(point(M_PI * i / rings, 2.0 * M_PI * j / segments));
  m.positions.push_back(point(M_PI, 0.0));  // south pole
  const int south = static_cast<int>(m.positions.size()) - 1;
  auto id = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) m.faces.push_back({0, id(1, j), id(1, j + 1)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  for (int j = 0; j < segments; ++j)
    m.faces.push_back({south, id(rings - 1, j + 1), id(rings - 1, j)});
  return m;
}

struct Input {
  std::unique_ptr<fabrica::Surface> surface;
  std::shared_ptr<const fr::RenderMesh> mesh;
};

Input& input(int kilo_vertices) {
  static std::map<int, Input> cache;
  auto it = cache.find(kilo_vertices);
  if (it != cache.end()) return it->second;
  const SphereSize s = kSizes.at(kilo_vertices);
  Input in;
  in.surface = std::make_unique<fabrica::Surface>(noisy_sphere(s.rings, s.segments));
  in.mesh = std::make_shared<fr::RenderMesh>(fr::make_render_mesh(*in.surface, true));
  return cache.emplace(kilo_vertices, std::move(in)).first->second;
}

fr::Renderer& renderer() {
  static fr::Renderer r(fr::create_headless_context());
  return r;
}

fabrica::Camera camera(int size) {
  fabrica::Camera c;
  c.eye = Vec3(0.0, -220.0, 60.0);
  c.center = Vec3::Zero();
  c.up = Vec3::UnitZ();
  c.fov_deg = 30.0;
  c.width = c.height = size;
  return c;
}

// args: kilo-vertices, image side
void run_hybrid(benchmark::State& state, bool bare) {
  Input& in = input(static_cast<int>(state.range(0)));
  const auto cam = camera(static_cast<int>(state.range(1)));
  fr::HybridOptions o;
  renderer().render_hybrid(in.mesh, cam, o, false, bare);  // upload, compile, allocate
  for (auto _ : state) {
    fr::Image img = renderer().render_hybrid(in.mesh, cam, o, false, bare);
    benchmark::DoNotOptimize(img.rgba.data());
  }
  state.counters["vertices"] = static_cast<double>(in.mesh->vertex_count());
  state.SetLabel(renderer().context().renderer());
}

void BM_Hybrid(benchmark::State& state) {
  run_hybrid(state, false);
}
void BM_HybridBare(benchmark::State& state) {
  run_hybrid(state, true);
}

// Both in the same iterations, alternating (the machine is shared: separate
// runs drift): counters hybrid_ms, bare_ms and their ratio.
void BM_HybridOverBare(benchmark::State& state) {
  Input& in = input(static_cast<int>(state.range(0)));
  const auto cam = camera(static_cast<int>(state.range(1)));
  fr::HybridOptions o;
  renderer().render_hybrid(in.mesh, cam, o, false, false);
  renderer().render_hybrid(in.mesh, cam, o, false, true);
  double hybrid = 0.0, bare = 0.0;
  using clock = std::chrono::steady_clock;
  bool hybrid_first = true;  // alternate the order: the first of a pair may pay for the switch
  auto timed = [&](bool bare_pass) {
    const auto t0 = clock::now();
    fr::Image img = renderer().render_hybrid(in.mesh, cam, o, false, bare_pass);
    benchmark::DoNotOptimize(img.rgba.data());
    return std::chrono::duration<double, std::milli>(clock::now() - t0).count();
  };
  for (auto _ : state) {
    if (hybrid_first) {
      hybrid += timed(false);
      bare += timed(true);
    } else {
      bare += timed(true);
      hybrid += timed(false);
    }
    hybrid_first = !hybrid_first;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["hybrid_ms"] = hybrid / n;
  state.counters["bare_ms"] = bare / n;
  state.counters["ratio"] = hybrid / bare;
}

// Where the time goes: the pair as above, each frame profiled
// (HybridFrameProfile: GL_TIME_ELAPSED per stage and the wall clock of each
// stage with a glFinish after it). Counters in ms per frame: h_/b_ prefix for
// hybrid/bare, s1/s2 wall clock of the stages, rb the readback, s1gpu/s2gpu
// the timer queries.
void BM_HybridStages(benchmark::State& state) {
  Input& in = input(static_cast<int>(state.range(0)));
  const auto cam = camera(static_cast<int>(state.range(1)));
  fr::HybridOptions o;
  renderer().render_hybrid(in.mesh, cam, o, false, false);
  renderer().render_hybrid(in.mesh, cam, o, false, true);
  fr::HybridFrameProfile h, b;
  bool hybrid_first = true;
  for (auto _ : state) {
    for (int k = 0; k < 2; ++k) {
      const bool bare = (k == 0) != hybrid_first;
      fr::Image img = renderer().render_hybrid(in.mesh, cam, o, false, bare, bare ? &b : &h);
      benchmark::DoNotOptimize(img.rgba.data());
    }
    hybrid_first = !hybrid_first;
  }
  const double n = static_cast<double>(state.iterations());
  for (const auto& [prefix, p] : {std::pair{"h_", &h}, std::pair{"b_", &b}}) {
    const std::string s = prefix;
    state.counters[s + "s1"] = p->stage1_ms / n;
    state.counters[s + "s2"] = p->stage2_ms / n;
    state.counters[s + "rb"] = p->readback_ms / n;
    state.counters[s + "s1gpu"] = p->stage1_gpu_ms / n;
    state.counters[s + "s2gpu"] = p->stage2_gpu_ms / n;
  }
}

// Object-space apparent ridges for the same camera: view-dependent fields,
// zero crossings, chaining (view-independent precomputation done once).
void BM_ObjectSpaceApparent(benchmark::State& state) {
  Input& in = input(static_cast<int>(state.range(0)));
  const auto cam = camera(static_cast<int>(state.range(1)));
  fabrica::LineOptions lo;
  lo.families = {fabrica::LineFamily::apparent};
  fabrica::LineExtractor extractor(*in.surface, lo);
  extractor.extract(cam);
  std::size_t polylines = 0;
  for (auto _ : state) {
    fabrica::LineSet lines = fabrica::chain_segments(extractor.extract(cam));
    polylines = lines.polylines.size();
    benchmark::DoNotOptimize(lines.polylines.data());
  }
  state.counters["vertices"] = static_cast<double>(in.mesh->vertex_count());
  state.counters["polylines"] = static_cast<double>(polylines);
}

// Igea with its LIC field (prepared once) and the rtsc view at 1280 x 800.
struct LicInput {
  std::unique_ptr<fabrica::Surface> surface;
  std::shared_ptr<fr::RenderMesh> mesh;
  fabrica::Camera camera;
};

LicInput& lic_input() {
  static LicInput in = [] {
    LicInput i;
    i.surface = fabrica::bench::load_igea();
    i.mesh = std::make_shared<fr::RenderMesh>(fr::make_render_mesh(*i.surface, false));
    fr::set_lic_field(*i.mesh, *i.surface);
    i.camera = fabrica::bench::igea_v1_camera();
    i.camera.width = 1280;
    i.camera.height = 800;
    return i;
  }();
  return in;
}

void run_lic_scene(benchmark::State& state, bool lic) {
  LicInput& in = lic_input();
  fr::Scene scene;
  fr::Structure s;
  s.name = "igea";
  s.style = fr::default_style(fr::Role::focus);
  s.style.lic = lic;
  s.mesh = in.mesh;
  scene.structures.push_back(s);
  renderer().render(scene, in.camera);  // upload, compile, allocate
  for (auto _ : state) {
    fr::Image img = renderer().render(scene, in.camera);
    benchmark::DoNotOptimize(img.rgba.data());
  }
  state.counters["vertices"] = static_cast<double>(in.mesh->vertex_count());
  state.SetLabel(renderer().context().renderer());
}

void BM_LicIgea(benchmark::State& state) {
  run_lic_scene(state, true);
}
void BM_LicIgeaOff(benchmark::State& state) {
  run_lic_scene(state, false);
}
void BM_LicIgeaBuffer(benchmark::State& state) {
  LicInput& in = lic_input();
  const fr::LicOptions o;
  renderer().render_lic_buffer(in.mesh, in.camera, o);
  for (auto _ : state) {
    fr::Image img = renderer().render_lic_buffer(in.mesh, in.camera, o);
    benchmark::DoNotOptimize(img.rgba.data());
  }
  state.counters["vertices"] = static_cast<double>(in.mesh->vertex_count());
}

void sizes(benchmark::internal::Benchmark* b) {
  for (int kv : {50, 300, 1000})
    for (int px : {512, 1024, 2048}) b->Args({kv, px});
}

BENCHMARK(BM_Hybrid)->Apply(sizes)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_HybridBare)->Apply(sizes)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_HybridOverBare)->Apply(sizes)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_HybridStages)->Apply(sizes)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LicIgeaOff)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LicIgea)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LicIgeaBuffer)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ObjectSpaceApparent)
    ->Args({50, 1024})
    ->Args({300, 1024})
    ->Args({1000, 1024})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
