// Surface: the lazily filled geometry cache. Each item has its own
// std::once_flag, so concurrent readers block only until that item exists.
// Each item is computed inside one tbb::this_task_arena::isolate region
// (`isolated`), so a thread waiting inside a call_once never steals an outer
// task that could ask for the same item again; inside a region, nested
// parallel loops and invokes share all threads.
#include "fabrica/core/surface.hpp"

#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <mutex>
#include <string>

#include "curvature_internal.hpp"
#include "fabrica/core/curvature.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/geometry.hpp"
#include "geometry_kernels.hpp"

namespace fabrica {

struct Surface::Cache {
  std::once_flag topology_once;
  Topology topology;

  // The face quantities: filled by the first of face_normals() (or
  // face_areas(), corner_areas()) and vertex_normals() (whose face pass
  // gives them too), under face_mutex. Once a caller has asked for them
  // (face_public) they stay; until then they are the curvature fits'
  // inputs, and release_face_quantities() frees them once the derivatives
  // exist (face_held false: a later call computes them again).
  std::mutex face_mutex;
  std::atomic<bool> face_public{false};
  bool face_held = false;
  bool face_release_pending = false;
  bool derivatives_done = false;
  std::vector<Vec3> face_normals;
  std::vector<double> face_areas;
  std::vector<Vec3> corner_areas;

  std::once_flag vertex_once;
  std::vector<Vec3> vertex_normals;
  std::vector<std::uint8_t> normal_valid;
  std::vector<double> vertex_areas;

  std::once_flag curvature_once;
  PrincipalCurvatures curvature;
  detail::FaceFitScratch
      fit_scratch;  ///< per-corner slots (normals, fits), freed after the derivatives

  std::once_flag derivative_once;
  CurvatureDerivatives derivatives;

  std::once_flag edge_once;
  EdgeLengthStatistics edges;

  std::once_flag sphere_once;
  BoundingSphere sphere;

  std::once_flag feature_once;
  double feature_size = 0.0;
};

namespace {
constexpr std::size_t kFaceGrain = 2048;

template <class F>
void isolated(const F& f) {
  tbb::this_task_arena::isolate(f);
}
constexpr std::size_t kVertexGrain = 2048;
}  // namespace

Surface::Surface(TriangleMesh mesh, SurfaceOptions options)
    : mesh_(std::move(mesh)), options_(options), cache_(std::make_unique<Cache>()) {
  check_mesh_indices_and_values(mesh_, "surface mesh");
}

void Surface::release_topology_edges() const {
  (void)topology();
  // The edge-length statistics first (hidden-line removal reads the
  // median): from the edges, which they would otherwise rebuild.
  (void)median_edge_length();
  cache_->topology.release_edges();
}

namespace {

// The cheap checks that a handed topology was built for `mesh`: the counts,
// and the face edges of up to kSampledFaces faces spread over the mesh.
void check_handed_topology(const Topology& topology, const TriangleMesh& mesh) {
  const std::size_t nv = mesh.positions.size(), nf = mesh.faces.size();
  if (topology.vertex_count() != nv || topology.face_count() != nf)
    throw InputError("surface mesh: the topology given was built for a mesh of " +
                     std::to_string(topology.vertex_count()) + " vertices and " +
                     std::to_string(topology.face_count()) + " faces, not this one of " +
                     std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces");
  constexpr std::size_t kSampledFaces = 64;
  const std::size_t samples = std::min(nf, kSampledFaces);
  for (std::size_t i = 0; i < samples; ++i) {
    // Evenly spaced, first and last face included.
    const std::size_t f = samples == 1 ? 0 : i * (nf - 1) / (samples - 1);
    const Face& face = mesh.faces[f];
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = face[(k + 1) % 3], b = face[(k + 2) % 3];
      const std::int32_t e = topology.face_edge(f, k);
      const bool ok = a == b ? e == -1
                             : e >= 0 && static_cast<std::size_t>(e) < topology.edge_count() &&
                                   topology.edge(static_cast<std::size_t>(e)) ==
                                       std::array<std::int32_t, 2>{std::min(a, b), std::max(a, b)};
      if (!ok)
        throw InputError("surface mesh: the topology given does not match face " +
                         std::to_string(f) + " (" + std::to_string(face[0]) + ", " +
                         std::to_string(face[1]) + ", " + std::to_string(face[2]) +
                         "): it was built for another mesh or before the faces changed");
    }
  }
}

}  // namespace

Surface::Surface(TriangleMesh mesh, Topology topology, SurfaceOptions options)
    : Surface(std::move(mesh), options) {
  check_handed_topology(topology, mesh_);
  Cache& c = *cache_;
  std::call_once(c.topology_once, [&] { c.topology = std::move(topology); });
}

Surface::~Surface() = default;
Surface::Surface(Surface&&) noexcept = default;
Surface& Surface::operator=(Surface&&) noexcept = default;

const Topology& Surface::topology() const {
  Cache& c = *cache_;
  std::call_once(c.topology_once,
                 [&] { tbb::this_task_arena::isolate([&] { c.topology = Topology(mesh_); }); });
  return c.topology;
}

namespace {

// Faces [begin, end): normal, area, corner areas and, with `weights`, the
// normal weight of each corner.
// (kRecords: the fits' float records instead of the face areas.)
template <bool kRecords>
FABRICA_MULTIVERSION void face_geometry_range(const TriangleMesh& mesh, const SurfaceOptions& opt,
                                              Vec3* face_normals, double* face_areas,
                                              Vec3* corner_areas, std::array<double, 3>* weights,
                                              float* records, std::size_t begin, std::size_t end) {
  for (std::size_t f = begin; f < end; ++f) {
    const auto t = detail::triangle_shape(mesh, mesh.faces[f]);
    if constexpr (!kRecords) face_areas[f] = 0.5 * t.twice_area;
    const Vec3 n = t.degenerate ? Vec3::Zero() : Vec3(t.cross / t.twice_area);
    face_normals[f] = n;
    corner_areas[f] = detail::corner_areas(t, opt.mixed_areas);
    if constexpr (kRecords) {
      // The fits' face record (FitArrays::face_records): what they would
      // round the doubles to.
      float* r = records + detail::kFaceRecord * f;
      for (int k = 0; k < 3; ++k) {
        r[k] = static_cast<float>(n[k]);
        r[3 + k] = static_cast<float>(corner_areas[f][k]);
      }
    }
    if (!weights) continue;
    const Vec3 w = detail::normal_corner_weights(t, opt.normal_weighting);
    weights[f] = {w[0], w[1], w[2]};
  }
}

// One pass over faces (normals, areas, corner areas, normal weights), then
// one gather per vertex (normals, areas) over its faces in vertex_faces(v)
// order. (The corner's weighted normal w n is formed in the gather: 24
// bytes of weights per face instead of 40 bytes per corner of products,
// the same IEEE products and sums in the same order.)
void compute_face_and_vertex(const TriangleMesh& mesh, const Topology& topo,
                             const SurfaceOptions& opt, std::vector<Vec3>& face_normals,
                             std::vector<double>& face_areas, std::vector<Vec3>& corner_areas,
                             std::vector<Vec3>* vertex_normals,
                             std::vector<std::uint8_t>* normal_valid,
                             std::vector<double>* vertex_areas, detail::FaceFitScratch* scratch,
                             bool records = false) {
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();
  detail::ScratchArray<std::array<double, 3>> weights;
  // Fresh memory is slow to touch the first time (page faults, and in a VM
  // the host backing it): the arrays are filled concurrently, and the
  // vertex outputs while the face pass runs.
  tbb::parallel_invoke([&] { detail::assign_large(face_normals, nf, Vec3(Vec3::Zero())); },
                       [&] {
                         // (With records, the face areas are not kept: no one reads them.)
                         if (!records) detail::assign_large(face_areas, nf, 0.0);
                       },
                       [&] { detail::assign_large(corner_areas, nf, Vec3(Vec3::Zero())); },
                       [&] {
                         if (!vertex_normals) return;
                         // The fits' CSR slot of each corner (kept for them; with
                         // records, filled after the face arrays are freed).
                         if (!records) detail::fill_corner_slots(topo, *scratch);
                         weights.resize(nf);
                         scratch->vertices.resize(nv);
                         if (records) {
                           // (+2: the fits' eight-float loads of the last record)
                           scratch->face_records.resize(detail::kFaceRecord * nf + 2);
                           scratch->face_records[detail::kFaceRecord * nf] = 0.0f;
                           scratch->face_records[detail::kFaceRecord * nf + 1] = 0.0f;
                         }
                       });
  auto face_pass = [&] {
    detail::parallel_chunks(nf, kFaceGrain, [&](std::size_t begin, std::size_t end) {
      if (records)
        face_geometry_range<true>(mesh, opt, face_normals.data(), nullptr, corner_areas.data(),
                                  weights.data(), scratch->face_records.data(), begin, end);
      else
        face_geometry_range<false>(mesh, opt, face_normals.data(), face_areas.data(),
                                   corner_areas.data(), vertex_normals ? weights.data() : nullptr,
                                   nullptr, begin, end);
    });
  };
  if (!vertex_normals) {
    face_pass();
    return;
  }
  tbb::parallel_invoke(
      face_pass, [&] { detail::assign_large(*vertex_normals, nv, Vec3(Vec3::Zero())); },
      [&] {
        normal_valid->assign(nv, 0);
        detail::assign_large(*vertex_areas, nv, 0.0);
      });
  scratch->frames_ready = true;
  detail::parallel_chunks(nv, kVertexGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const auto faces = topo.vertex_faces(v);
      const auto corners = topo.vertex_face_corners(v);
      Vec3 n = Vec3::Zero();
      double wsum = 0.0, area = 0.0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const auto f = static_cast<std::size_t>(faces[i]);
        const int k = corners[i];
        const Vec3& fn = face_normals[f];
        const double w = weights[f][k];
        n += Vec3(w * fn.x(), w * fn.y(), w * fn.z());
        wsum += w;
        area += corner_areas[f][k];
      }
      (*vertex_areas)[v] = area;
      const double len = n.norm();
      // The reference frame of the curvature fit, computed here so its
      // memory is first touched alongside real work.
      Vec3 unit = Vec3::Zero(), x = Vec3::Zero(), y = Vec3::Zero();
      if (wsum > 0.0 && len > 1e-10 * wsum) {
        unit = n / len;
        (*vertex_normals)[v] = unit;
        (*normal_valid)[v] = 1;
        detail::vertex_frame(mesh, topo, v, unit, x, y);
      }
      detail::set_fit_vertex(scratch->vertices[v], unit, x, y, 0.0, 0.0);
    }
  });
  if (records) {
    // The fits read the records: the doubles and the weights go first, and
    // the slots take their place.
    weights.release();
    std::vector<Vec3>().swap(face_normals);
    std::vector<Vec3>().swap(corner_areas);
    detail::fill_corner_slots(topo, *scratch);
  }
}

}  // namespace

// Frees the face quantities that no caller holds (under face_mutex).
void Surface::free_face_quantities(Cache& c) {
  if (c.face_public.load(std::memory_order_relaxed)) return;
  // (Assigning {} would keep the capacity.)
  std::vector<Vec3>().swap(c.face_normals);
  std::vector<double>().swap(c.face_areas);
  std::vector<Vec3>().swap(c.corner_areas);
  c.face_held = false;
}

const std::vector<Vec3>& Surface::face_normals() const {
  Cache& c = *cache_;
  if (c.face_public.load(std::memory_order_acquire)) return c.face_normals;
  std::lock_guard lock(c.face_mutex);
  if (!c.face_held) {
    isolated([&] {
      compute_face_and_vertex(mesh_, c.topology, options_, c.face_normals, c.face_areas,
                              c.corner_areas, nullptr, nullptr, nullptr, nullptr);
    });
    c.face_held = true;
  }
  c.face_public.store(true, std::memory_order_release);
  return c.face_normals;
}

const std::vector<double>& Surface::face_areas() const {
  face_normals();
  return cache_->face_areas;
}

const std::vector<Vec3>& Surface::corner_areas() const {
  face_normals();
  return cache_->corner_areas;
}

const std::vector<Vec3>& Surface::vertex_normals() const {
  Cache& c = *cache_;
  const Topology& topo = topology();
  std::call_once(c.vertex_once, [&] {
    // Recomputes the (cheap) face pass fused with the weights, unless the
    // face quantities already exist, in which case only the gather runs.
    // When their release was asked for (and no caller holds them), they are
    // not kept: the fits read float records of them (24 bytes per face
    // instead of 56) and the doubles are freed here, before the fits.
    bool release;
    {
      std::lock_guard lock(c.face_mutex);
      release = c.face_release_pending && !c.face_public.load(std::memory_order_relaxed);
    }
    std::vector<Vec3> fn, ca;
    std::vector<double> fa;
    isolated([&] {
      compute_face_and_vertex(mesh_, topo, options_, fn, fa, ca, &c.vertex_normals, &c.normal_valid,
                              &c.vertex_areas, &c.fit_scratch, release);
    });
    std::lock_guard lock(c.face_mutex);
    if (!c.face_held && !release) {
      c.face_normals = std::move(fn);
      c.face_areas = std::move(fa);
      c.corner_areas = std::move(ca);
      c.face_held = true;
    }
  });
  return c.vertex_normals;
}

const std::vector<double>& Surface::vertex_areas() const {
  vertex_normals();
  return cache_->vertex_areas;
}

const PrincipalCurvatures& Surface::curvature() const {
  Cache& c = *cache_;
  vertex_normals();
  std::call_once(c.curvature_once, [&] {
    const detail::CurvatureInputs in{mesh_,          c.topology,       c.face_normals,
                                     c.corner_areas, c.vertex_normals, c.normal_valid};
    isolated([&] {
      c.curvature = detail::estimate_curvature(in, c.fit_scratch);
      if (options_.curvature_smoothing_passes > 0)
        smooth_curvature(*this, c.curvature,
                         options_.curvature_smoothing_sigma * median_edge_length(),
                         options_.curvature_smoothing_passes);
    });
  });
  return c.curvature;
}

const CurvatureDerivatives& Surface::curvature_derivatives() const {
  Cache& c = *cache_;
  const PrincipalCurvatures& curv = curvature();
  std::call_once(c.derivative_once, [&] {
    const detail::CurvatureInputs in{mesh_,          c.topology,       c.face_normals,
                                     c.corner_areas, c.vertex_normals, c.normal_valid};
    isolated([&] {
      c.derivatives = detail::estimate_curvature_derivatives(in, curv, c.fit_scratch);
      c.fit_scratch = {};
      if (options_.derivative_smoothing_passes > 0)
        smooth_curvature_derivatives(*this, curv, c.derivatives,
                                     options_.curvature_smoothing_sigma * median_edge_length(),
                                     options_.derivative_smoothing_passes);
    });
    std::lock_guard lock(c.face_mutex);
    c.derivatives_done = true;
    if (c.face_release_pending) free_face_quantities(c);
  });
  return c.derivatives;
}

void Surface::release_face_quantities() const {
  Cache& c = *cache_;
  std::lock_guard lock(c.face_mutex);
  if (c.face_public.load(std::memory_order_relaxed)) return;
  if (c.derivatives_done)
    free_face_quantities(c);
  else
    c.face_release_pending = true;
}

double Surface::median_edge_length() const {
  Cache& c = *cache_;
  const Topology& topo = topology();
  std::call_once(c.edge_once,
                 [&] { isolated([&] { c.edges = edge_length_statistics(mesh_, topo); }); });
  return c.edges.median;
}

double Surface::mean_edge_length() const {
  median_edge_length();
  return cache_->edges.mean;
}

Vec3 Surface::bounding_sphere_center() const {
  Cache& c = *cache_;
  std::call_once(c.sphere_once, [&] { c.sphere = bounding_sphere(mesh_.positions); });
  return c.sphere.center;
}

double Surface::bounding_sphere_radius() const {
  bounding_sphere_center();
  return cache_->sphere.radius;
}

double Surface::feature_size() const {
  Cache& c = *cache_;
  const PrincipalCurvatures& curv = curvature();
  const double radius = bounding_sphere_radius();
  std::call_once(c.feature_once, [&] { c.feature_size = fabrica::feature_size(curv, radius); });
  return c.feature_size;
}

void Surface::precompute() const {
  topology();
  // Two independent chains; the feature size (a selection over all
  // curvatures) overlaps the derivative pass. Deliberately not isolated: a
  // thread waiting here must be free to help with the (isolated) work of
  // the other branch, or the second core only spins (measured: 2-thread
  // precompute 108 ms instead of 47 ms on igea). Re-entrancy is safe
  // without it: each cached item is computed inside its own isolated
  // region, so a thread holding an item's once_flag never picks up outer
  // work that asks for that item.
  tbb::parallel_invoke(
      [&] {
        curvature();
        tbb::parallel_invoke([&] { curvature_derivatives(); }, [&] { feature_size(); });
      },
      [&] {
        bounding_sphere_center();
        median_edge_length();
      });
}

}  // namespace fabrica
