// The maximal-curvature direction field and the ConFIS masks; see
// curvature_field.hpp and docs/algorithms.md §9a.
#include "fabrica/hatching/curvature_field.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica::hatching {

namespace {

/// An orthonormal frame (t, b) in the plane of face f: t along the edge
/// opposite corner 0 (as §2.1), b = n × t.
void face_frame(const Surface& surface, std::size_t f, Vec3& t, Vec3& b) {
  const Face& face = surface.faces()[f];
  const auto& p = surface.positions();
  const Vec3& n = surface.face_normals()[f];
  t = p[static_cast<std::size_t>(face[2])] - p[static_cast<std::size_t>(face[1])];
  t -= n.dot(t) * n;
  const double len = t.norm();
  t = len > 0.0 ? Vec3(t / len) : Vec3::Zero();
  b = n.cross(t);
}

/// Adds the line direction d (any length, projected into the frame) to a
/// doubled-angle sum with weight w.
/// Returns whether it counted (a direction normal to the face does not).
bool add_line(const Vec3& d, const Vec3& t, const Vec3& b, double w, Vec2& sum) {
  const double x = d.dot(t), y = d.dot(b);
  const double r2 = x * x + y * y;
  if (!(r2 > 0.0) || !(w > 0.0)) return false;
  sum += w * Vec2((x * x - y * y) / r2, 2.0 * x * y / r2);
  return true;
}

/// The unit direction whose doubled angle is that of `sum` (t if sum = 0).
Vec3 line_from_sum(const Vec2& sum, const Vec3& t, const Vec3& b) {
  if (!(sum.squaredNorm() > 0.0)) return t;
  const double half = 0.5 * std::atan2(sum.y(), sum.x());
  return std::cos(half) * t + std::sin(half) * b;
}

}  // namespace

void validate(const CurvatureFieldOptions& o) {
  if (!(o.umbilic_threshold >= 0.0) || !std::isfinite(o.umbilic_threshold))
    throw InputError("curvature field: the umbilic threshold must be a finite number >= 0");
  if (!(o.min_coherence >= 0.0 && o.min_coherence <= 1.0))
    throw InputError("curvature field: the minimum coherence must be in [0, 1]");
}

void validate(const FeatureRegionOptions& o) {
  if (!(o.convex_threshold > 0.0) || !std::isfinite(o.convex_threshold))
    throw InputError("feature regions: the convex threshold must be a finite number > 0");
  if (!(o.concave_threshold > 0.0) || !std::isfinite(o.concave_threshold))
    throw InputError("feature regions: the concave threshold must be a finite number > 0");
}

CurvatureField compute_curvature_field(const Surface& surface,
                                       const CurvatureFieldOptions& options) {
  validate(options);
  const std::size_t nv = surface.vertex_count(), nf = surface.face_count();
  CurvatureField field;
  field.face_direction.assign(nf, Vec3::Zero());
  field.face_reliable.assign(nf, 0);
  field.vertex_anisotropy.assign(nv, 0.0);
  if (nf == 0) return field;
  const PrincipalCurvatures& curv = surface.curvature();
  const double sf = surface.feature_size();
  field.feature_size = sf;
  const auto& faces = surface.faces();
  const auto& areas = surface.face_areas();

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v)
      if (curv.valid[v]) field.vertex_anisotropy[v] = std::abs(curv.k1[v] - curv.k2[v]) * sf;
  });

  // Raw per-face line directions and reliability.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf), [&](const auto& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      if (!(areas[f] > 0.0)) continue;
      Vec3 t, b;
      face_frame(surface, f, t, b);
      Vec2 sum = Vec2::Zero();
      double weight = 0.0, mean_aniso = 0.0;
      for (int k = 0; k < 3; ++k) {
        const std::size_t v = static_cast<std::size_t>(faces[f][k]);
        const double w = field.vertex_anisotropy[v];
        mean_aniso += w / 3.0;
        if (add_line(curv.e1[v], t, b, w, sum)) weight += w;
      }
      field.face_direction[f] = line_from_sum(sum, t, b);
      const double coherence = weight > 0.0 ? sum.norm() / weight : 0.0;
      field.face_reliable[f] = mean_aniso >= options.umbilic_threshold && weight > 0.0 &&
                               coherence >= options.min_coherence;
    }
  });

  // Fill unreliable faces ring by ring from filled neighbours (Jacobi rounds:
  // a round reads only faces filled in earlier rounds, so the order of faces
  // within a round does not matter).
  const Topology& topo = surface.topology();
  std::vector<std::uint8_t> filled(field.face_reliable);
  for (std::size_t f = 0; f < nf; ++f) {
    field.reliable_faces += field.face_reliable[f];
    if (!(areas[f] > 0.0)) filled[f] = 1;  // degenerate: zero, never a source
  }
  std::vector<std::size_t> frontier;
  for (;;) {
    frontier.clear();
    for (std::size_t f = 0; f < nf; ++f) {
      if (filled[f]) continue;
      for (int k = 0; k < 3; ++k) {
        const std::int32_t g = topo.face_neighbor(f, k);
        if (g >= 0 && filled[static_cast<std::size_t>(g)] &&
            field.face_direction[static_cast<std::size_t>(g)].squaredNorm() > 0.0) {
          frontier.push_back(f);
          break;
        }
      }
    }
    if (frontier.empty()) break;
    std::vector<Vec3> update(frontier.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, frontier.size()), [&](const auto& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) {
        const std::size_t f = frontier[i];
        Vec3 t, b;
        face_frame(surface, f, t, b);
        Vec2 sum = Vec2::Zero();
        for (int k = 0; k < 3; ++k) {
          const std::int32_t g = topo.face_neighbor(f, k);
          if (g >= 0 && filled[static_cast<std::size_t>(g)])
            add_line(field.face_direction[static_cast<std::size_t>(g)], t, b, 1.0, sum);
        }
        // Opposite neighbours may cancel; keep the face's own direction then.
        update[i] = sum.squaredNorm() > 1e-24 ? line_from_sum(sum, t, b) : field.face_direction[f];
      }
    });
    for (std::size_t i = 0; i < frontier.size(); ++i) {
      field.face_direction[frontier[i]] = update[i];
      filled[frontier[i]] = 1;
    }
  }

  // Pieces without any reliable face (a sphere): the z axis projected into
  // each face (x near the poles), smooth but for two poles.
  for (std::size_t f = 0; f < nf; ++f) {
    if (filled[f]) continue;
    const Vec3& n = surface.face_normals()[f];
    Vec3 d = Vec3::UnitZ() - n.z() * n;
    if (d.norm() < 0.3) d = Vec3::UnitX() - n.x() * n;
    field.face_direction[f] = d.normalized();
  }

  // Sign alignment: breadth-first from the lowest unvisited face.
  std::vector<std::uint8_t> visited(nf, 0);
  std::vector<std::size_t> queue;
  queue.reserve(nf);
  for (std::size_t root = 0; root < nf; ++root) {
    if (visited[root]) continue;
    visited[root] = 1;
    queue.clear();
    queue.push_back(root);
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const std::size_t f = queue[head];
      for (int k = 0; k < 3; ++k) {
        const std::int32_t g = topo.face_neighbor(f, k);
        if (g < 0 || visited[static_cast<std::size_t>(g)]) continue;
        const std::size_t gi = static_cast<std::size_t>(g);
        visited[gi] = 1;
        if (field.face_direction[gi].dot(field.face_direction[f]) < 0.0)
          field.face_direction[gi] = -field.face_direction[gi];
        queue.push_back(gi);
      }
    }
  }
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t g = topo.face_neighbor(f, k);
      if (g > static_cast<std::int32_t>(f) &&
          field.face_direction[f].dot(field.face_direction[static_cast<std::size_t>(g)]) < 0.0)
        ++field.seam_edges;
    }
  return field;
}

FeatureRegions compute_feature_regions(const Surface& surface, const FeatureRegionOptions& options,
                                       double umbilic_threshold) {
  validate(options);
  if (!(umbilic_threshold >= 0.0) || !std::isfinite(umbilic_threshold))
    throw InputError("feature regions: the umbilic threshold must be a finite number >= 0");
  const std::size_t nv = surface.vertex_count();
  FeatureRegions regions;
  regions.scalar.assign(nv, 0.0);
  regions.level.assign(nv, -1.0);
  regions.strength.assign(nv, 0.0);
  regions.mask.assign(nv, 0);
  regions.umbilic.assign(nv, 1);
  if (nv == 0) return regions;
  const PrincipalCurvatures& curv = surface.curvature();
  const double sf = surface.feature_size();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      if (!curv.valid[v]) continue;
      const double s = curv.k1[v] * sf;
      regions.scalar[v] = s;
      const bool umbilic = std::abs(curv.k1[v] - curv.k2[v]) * sf < umbilic_threshold;
      regions.umbilic[v] = umbilic;
      if (umbilic) continue;
      const double phi =
          std::max(s / options.convex_threshold, -s / options.concave_threshold) - 1.0;
      regions.level[v] = std::max(phi, -1.0);
      regions.strength[v] = std::clamp(phi, 0.0, 1.0);
      regions.mask[v] = phi >= 0.0;
    }
  });
  return regions;
}

ContourMargin compute_contour_margin(const Surface& surface, const Camera& camera, double epsilon) {
  if (!(epsilon > 0.0 && epsilon <= 1.0))
    throw InputError("contour margin: the margin width (epsilon on n.v) must be in (0, 1]");
  const std::size_t nv = surface.vertex_count();
  const auto& positions = surface.positions();
  const auto& normals = surface.vertex_normals();
  ContourMargin margin;
  margin.epsilon = epsilon;
  margin.facing.assign(nv, 0.0);
  margin.strength.assign(nv, 0.0);
  margin.mask.assign(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const double facing = normals[v].dot(camera.view_vector(positions[v]));
      margin.facing[v] = facing;
      const bool inside = facing >= 0.0 && facing < epsilon;
      margin.mask[v] = inside;
      margin.strength[v] = std::clamp(1.0 - facing / epsilon, 0.0, 1.0);
    }
  });
  return margin;
}

}  // namespace fabrica::hatching
