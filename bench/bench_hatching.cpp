// Per-frame cost of hatching (Singh & Schaefer 2010) at 800 × 800 on meshes
// of about 10k, 57k, 100k, 270k (igea: 134k vertices) and 330k faces, with and
// without intensity-ridge detection. The Surface's view-independent
// geometry (normals, areas, adjacency) is computed once beforehand, as in
// an interactive session; everything per view (field, depth buffer, ridges,
// proximity grid, tracing) is timed. Paper: 0.7–2.5 s per frame (2009).
//
// Side by side, the same meshes and views with ConFIS (issue 21,
// `--method confis`): BM_Confis times one view after the per-mesh
// precompute (curvature, direction field, feature regions; timed on its own
// by BM_ConfisPrecompute). Target: igea ≤ 30 ms per view at 2 threads.
//
//   bench_hatching --benchmark_min_time=1
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <map>
#include <memory>
#include <string>
#include <utility>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/confis.hpp"
#include "fabrica/hatching/depth_buffer.hpp"
#include "fabrica/hatching/hatching.hpp"
#include "fabrica/hatching/intensity_ridges.hpp"
#include "fabrica/io/mesh_io.hpp"

namespace {

using fabrica::Face;
using fabrica::TriangleMesh;
using fabrica::Vec3;

/// 1:4 midpoint subdivision (planar: same shape, four times the faces).
TriangleMesh subdivide(const TriangleMesh& mesh) {
  TriangleMesh out = mesh;
  out.faces.clear();
  std::map<std::pair<int, int>, int> midpoint;
  auto mid = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    const auto it = midpoint.find(key);
    if (it != midpoint.end()) return it->second;
    const int index = static_cast<int>(out.positions.size());
    out.positions.push_back(0.5 * (mesh.positions[a] + mesh.positions[b]));
    midpoint.emplace(key, index);
    return index;
  };
  for (const Face& f : mesh.faces) {
    const int ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
    out.faces.push_back({f[0], ab, ca});
    out.faces.push_back({ab, f[1], bc});
    out.faces.push_back({ca, bc, f[2]});
    out.faces.push_back({ab, bc, ca});
  }
  return out;
}

struct Case {
  const char* name;
  const char* path;
  int subdivisions;
};

const Case kCases[] = {
    {"teeth_10k", "meshes/anatomy/teeth/sofa_teeth.obj", 0},
    {"aneurysm_x4_57k", "meshes/anatomy/vessels/sofa_aneurysm3D_1.off", 1},
    {"lucy_100k", "meshes/classic/vtkdata_lucy.ply", 0},
    {"igea_269k", "meshes/classic/c3d_igea.ply", 0},
    {"cortex_x16_328k", "meshes/anatomy/brain/fsaverage5/pial_left.off", 2},
};

struct Loaded {
  std::unique_ptr<fabrica::Surface> surface;
  fabrica::Camera camera;
};

Loaded& load(int index) {
  static std::map<int, Loaded> cache;
  auto it = cache.find(index);
  if (it != cache.end()) return it->second;
  const Case& c = kCases[index];
  TriangleMesh mesh = fabrica::io::read_mesh(std::string(FABRICA_BENCH_DATA) + "/" + c.path).mesh;
  for (int k = 0; k < c.subdivisions; ++k) mesh = subdivide(mesh);
  Loaded loaded;
  loaded.camera =
      fabrica::anatomical_camera(fabrica::AnatomicalView::anterior,
                                 fabrica::bounding_box(mesh.positions), mesh.space, 800, 800);
  loaded.surface = std::make_unique<fabrica::Surface>(std::move(mesh));
  // View-independent geometry the hatcher reads, computed once.
  loaded.surface->topology();
  loaded.surface->vertex_normals();
  loaded.surface->face_areas();
  loaded.surface->mean_edge_length();
  return cache.emplace(index, std::move(loaded)).first->second;
}

void BM_Hatch(benchmark::State& state) {
  Loaded& l = load(static_cast<int>(state.range(0)));
  fabrica::hatching::HatchingOptions options;
  options.ridge_removal = state.range(1) != 0;
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(state.range(2)));
  std::size_t strokes = 0;
  for (auto _ : state) {
    const auto result = fabrica::hatching::hatch(*l.surface, l.camera, options);
    strokes = result.strokes.size();
    benchmark::DoNotOptimize(strokes);
  }
  state.SetLabel(std::string(kCases[state.range(0)].name) +
                 (options.ridge_removal ? " ridges" : " no-ridges") + " " +
                 std::to_string(state.range(2)) + "T");
  state.counters["faces"] = static_cast<double>(l.surface->face_count());
  state.counters["strokes"] = static_cast<double>(strokes);
}

/// ConFIS per view after the per-mesh precompute (made once per mesh).
void BM_Confis(benchmark::State& state) {
  Loaded& l = load(static_cast<int>(state.range(0)));
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(state.range(1)));
  const fabrica::hatching::ConfisOptions options;
  static std::map<int, fabrica::hatching::ConfisPrecompute> precomputed;
  auto it = precomputed.find(static_cast<int>(state.range(0)));
  if (it == precomputed.end())
    it = precomputed
             .emplace(static_cast<int>(state.range(0)),
                      fabrica::hatching::precompute_confis(*l.surface, options))
             .first;
  std::size_t strokes = 0;
  for (auto _ : state) {
    const auto result = fabrica::hatching::confis(*l.surface, l.camera, it->second, options);
    strokes = result.strokes.size();
    benchmark::DoNotOptimize(strokes);
  }
  state.SetLabel(std::string(kCases[state.range(0)].name) + " confis " +
                 std::to_string(state.range(1)) + "T");
  state.counters["faces"] = static_cast<double>(l.surface->face_count());
  state.counters["strokes"] = static_cast<double>(strokes);
}

/// The per-mesh part of ConFIS on a fresh Surface (curvature included).
void BM_ConfisPrecompute(benchmark::State& state) {
  Loaded& l = load(static_cast<int>(state.range(0)));
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  for (auto _ : state) {
    state.PauseTiming();
    auto fresh = std::make_unique<fabrica::Surface>(l.surface->mesh());
    fresh->topology();
    fresh->vertex_normals();
    state.ResumeTiming();
    auto pre = fabrica::hatching::precompute_confis(*fresh);
    benchmark::DoNotOptimize(pre.field.face_direction.data());
  }
  state.SetLabel(std::string(kCases[state.range(0)].name) + " confis precompute 2T");
}

/// Stages of one frame, for the breakdown: 0 field, 1 depth buffer, 2 ridges.
void BM_Stage(benchmark::State& state) {
  Loaded& l = load(static_cast<int>(state.range(0)));
  const int stage = static_cast<int>(state.range(1));
  const auto field = fabrica::hatching::compute_intensity_field(*l.surface, l.camera);
  for (auto _ : state) {
    if (stage == 0) {
      auto f = fabrica::hatching::compute_intensity_field(*l.surface, l.camera);
      benchmark::DoNotOptimize(f.face_gradient.data());
    } else if (stage == 1) {
      auto d = fabrica::render_depth(l.surface->mesh(), l.camera, /*faces=*/true);
      benchmark::DoNotOptimize(&d);
    } else {
      auto r = fabrica::hatching::detect_intensity_ridges(*l.surface, field);
      benchmark::DoNotOptimize(r.segments.data());
    }
  }
  static const char* const kStages[] = {"field", "depth", "ridges"};
  state.SetLabel(std::string(kCases[state.range(0)].name) + " " + kStages[stage]);
}

}  // namespace

BENCHMARK(BM_Stage)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1, 2}})
    ->ArgNames({"mesh", "stage"})
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.2);

BENCHMARK(BM_Hatch)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}, {2, 1}})
    ->ArgNames({"mesh", "ridges", "threads"})
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5);

// CPU column: the process's CPU time (all threads), which a loaded machine
// does not inflate as it does wall-clock time.
BENCHMARK(BM_Confis)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {2, 1}})
    ->ArgNames({"mesh", "threads"})
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5);

BENCHMARK(BM_ConfisPrecompute)
    ->ArgsProduct({{0, 3}})
    ->ArgNames({"mesh"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

BENCHMARK_MAIN();
