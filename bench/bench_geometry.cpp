// Benchmarks of the geometry core on a real scan: c3d_igea.ply (134,345
// vertices, 268,686 triangles). Target (docs/PERFORMANCE.md): Surface
// precompute (normals, areas, curvature, derivative tensor) <= 40 ms on the
// 2-core build machines; rtsc single-threaded needs about 200 ms.
//
// The precompute benchmarks read the mesh once with a tiny local binary-PLY
// reader (vertex x,y,z + `tristrips` or `face` lists); BM_LoadValidatePrecompute
// measures the whole path with fabrica::io::read_mesh and validate_mesh.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "fabrica/core/curvature.hpp"
#include "fabrica/core/geometry.hpp"
#include "fabrica/core/laplacian.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/validate.hpp"

namespace {

using fabrica::Face;
using fabrica::TriangleMesh;
using fabrica::Vec3;

std::size_t type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  throw std::runtime_error("ply: unknown type " + t);
}

double read_scalar(const char*& p, const std::string& t) {
  double v = 0;
  if (t == "float" || t == "float32") {
    float f;
    std::memcpy(&f, p, 4);
    v = f;
  } else if (t == "double" || t == "float64") {
    std::memcpy(&v, p, 8);
  } else if (t == "int" || t == "int32") {
    std::int32_t i;
    std::memcpy(&i, p, 4);
    v = i;
  } else if (t == "uint" || t == "uint32") {
    std::uint32_t i;
    std::memcpy(&i, p, 4);
    v = i;
  } else if (t == "uchar" || t == "uint8") {
    v = static_cast<unsigned char>(*p);
  } else {
    throw std::runtime_error("ply: unsupported scalar " + t);
  }
  p += type_size(t);
  return v;
}

// Binary little-endian PLY: vertices (x, y, z first) and either `face`
// (list of indices) or `tristrips` (one list; -1 restarts a strip; winding
// alternates; triangles with a repeated vertex are skipped, as rtsc does).
TriangleMesh read_binary_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string line;
  struct Element {
    std::string name;
    std::size_t count = 0;
    std::vector<std::vector<std::string>> props;
  };
  std::vector<Element> elements;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "element") {
      Element e;
      ls >> e.name >> e.count;
      elements.push_back(e);
    } else if (word == "property") {
      std::vector<std::string> p;
      while (ls >> word) p.push_back(word);
      elements.back().props.push_back(p);
    } else if (word == "format") {
      ls >> word;
      if (word != "binary_little_endian") throw std::runtime_error("ply: not binary LE");
    } else if (word == "end_header") {
      break;
    }
  }
  std::vector<char> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const char* p = data.data();
  TriangleMesh m;
  for (const Element& e : elements) {
    for (std::size_t i = 0; i < e.count; ++i) {
      if (e.name == "vertex") {
        double xyz[3] = {0, 0, 0};
        for (std::size_t k = 0; k < e.props.size(); ++k) {
          const double v = read_scalar(p, e.props[k][0]);
          if (k < 3) xyz[k] = v;
        }
        m.positions.emplace_back(xyz[0], xyz[1], xyz[2]);
        continue;
      }
      for (const auto& prop : e.props) {
        if (prop[0] != "list") {
          read_scalar(p, prop[0]);
          continue;
        }
        const auto n = static_cast<std::size_t>(read_scalar(p, prop[1]));
        std::vector<std::int32_t> idx(n);
        for (auto& x : idx) x = static_cast<std::int32_t>(read_scalar(p, prop[2]));
        if (e.name == "face") {
          for (std::size_t k = 2; k < n; ++k) m.faces.push_back({idx[0], idx[k - 1], idx[k]});
        } else if (e.name == "tristrips") {
          std::size_t start = 0;
          for (std::size_t k = 0; k <= n; ++k) {
            if (k < n && idx[k] >= 0) continue;
            for (std::size_t j = start + 2; j < k; ++j) {
              Face f = (j - start) % 2 == 0 ? Face{idx[j - 2], idx[j - 1], idx[j]}
                                            : Face{idx[j - 1], idx[j - 2], idx[j]};
              if (f[0] != f[1] && f[1] != f[2] && f[0] != f[2]) m.faces.push_back(f);
            }
            start = k + 1;
          }
        }
      }
    }
  }
  return m;
}

const TriangleMesh& igea() {
  static const TriangleMesh mesh =
      read_binary_ply(std::string(FABRICA_BENCH_DATA) + "/meshes/classic/c3d_igea.ply");
  return mesh;
}

void set_counters(benchmark::State& state) {
  state.counters["vertices"] = static_cast<double>(igea().vertex_count());
  state.counters["faces"] = static_cast<double>(igea().face_count());
}

// Everything: topology + normals, areas, curvature, derivatives, feature size.
void BM_SurfacePrecomputeWithTopology(benchmark::State& state) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(state.range(0)));
  const TriangleMesh& mesh = igea();
  for (auto _ : state) {
    state.PauseTiming();
    auto s = std::make_unique<fabrica::Surface>(mesh);
    state.ResumeTiming();
    s->precompute();
    benchmark::DoNotOptimize(s->curvature_derivatives().a.data());
    state.PauseTiming();
    s.reset();
    state.ResumeTiming();
  }
  set_counters(state);
}

// The geometry alone (the Topology is built before the timer starts).
void BM_SurfacePrecompute(benchmark::State& state) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(state.range(0)));
  const TriangleMesh& mesh = igea();
  for (auto _ : state) {
    state.PauseTiming();
    auto s = std::make_unique<fabrica::Surface>(mesh);
    s->topology();
    state.ResumeTiming();
    s->precompute();
    benchmark::DoNotOptimize(s->curvature_derivatives().a.data());
    state.PauseTiming();
    s.reset();
    state.ResumeTiming();
  }
  set_counters(state);
}

void BM_Topology(benchmark::State& state) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    fabrica::Topology t(igea());
    benchmark::DoNotOptimize(t.edge_count());
  }
  set_counters(state);
}

// What `fabrica geometry` does before writing: read the file with the
// project's reader, validate it, build the Surface and precompute.
void BM_LoadValidatePrecompute(benchmark::State& state) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(state.range(0)));
  const std::string path = std::string(FABRICA_BENCH_DATA) + "/meshes/classic/c3d_igea.ply";
  for (auto _ : state) {
    fabrica::io::LoadedMesh loaded = fabrica::io::read_mesh(path);
    const auto report = fabrica::io::validate_mesh(loaded.mesh);
    benchmark::DoNotOptimize(report.faces);
    fabrica::Surface s(std::move(loaded.mesh));
    s.precompute();
    benchmark::DoNotOptimize(s.curvature_derivatives().a.data());
  }
  set_counters(state);
}

void BM_CotanLaplacianApply(benchmark::State& state) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(state.range(0)));
  fabrica::Surface s(igea());
  s.precompute();
  fabrica::CotanLaplacian L(s);
  std::vector<double> x(s.vertex_count());
  for (std::size_t v = 0; v < x.size(); ++v) x[v] = s.positions()[v].x();
  for (auto _ : state) benchmark::DoNotOptimize(L.apply(x).data());
  set_counters(state);
}

void BM_SmoothingPass(benchmark::State& state) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism,
                         static_cast<std::size_t>(state.range(0)));
  fabrica::Surface s(igea());
  s.precompute();
  for (auto _ : state) {
    fabrica::PrincipalCurvatures c = s.curvature();
    fabrica::smooth_curvature(s, c, s.median_edge_length(), 1);
    benchmark::DoNotOptimize(c.k1.data());
  }
  set_counters(state);
}

}  // namespace

BENCHMARK(BM_SurfacePrecomputeWithTopology)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_SurfacePrecompute)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Topology)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LoadValidatePrecompute)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CotanLaplacianApply)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SmoothingPass)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
