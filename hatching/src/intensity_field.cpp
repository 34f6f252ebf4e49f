// Diffuse intensity field and face gradients; see the header.
#include "fabrica/hatching/intensity_field.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica::hatching {

Vec3 barycentric_gradient(const Surface& surface, std::size_t face, int k) {
  const double area = surface.face_areas()[face];
  if (!(area > 0.0)) return Vec3::Zero();
  const Face& t = surface.faces()[face];
  const auto& p = surface.positions();
  const Vec3 e =
      p[static_cast<std::size_t>(t[(k + 2) % 3])] - p[static_cast<std::size_t>(t[(k + 1) % 3])];
  return surface.face_normals()[face].cross(e) / (2.0 * area);
}

std::vector<Vec3> face_gradients(const Surface& surface, const std::vector<double>& values) {
  const auto& positions = surface.positions();
  const auto& faces = surface.faces();
  const auto& face_normals = surface.face_normals();
  const auto& areas = surface.face_areas();
  const std::size_t nf = faces.size();
  if (values.size() != positions.size())
    throw InputError("hatching: a per-vertex field needs one value per vertex (got " +
                     std::to_string(values.size()) + " for " + std::to_string(positions.size()) +
                     " vertices)");
  std::vector<Vec3> gradients(nf, Vec3::Zero());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf), [&](const auto& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const double area = areas[f];
      if (!(area > 0.0)) continue;
      const Face& t = faces[f];
      Vec3 g = Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        const Vec3 e = positions[static_cast<std::size_t>(t[(k + 2) % 3])] -
                       positions[static_cast<std::size_t>(t[(k + 1) % 3])];
        g += values[static_cast<std::size_t>(t[k])] * face_normals[f].cross(e);
      }
      g /= 2.0 * area;
      if (g.allFinite()) gradients[f] = g;
    }
  });
  return gradients;
}

IntensityField compute_intensity_field(const Surface& surface, const Camera& camera,
                                       const Light& light) {
  if (light.kind == LightKind::direction &&
      !(light.vector.norm() > 0.0 && light.vector.allFinite()))
    throw InputError("hatching: the light direction must be a finite, non-zero vector");
  if (light.kind == LightKind::point && !light.vector.allFinite())
    throw InputError("hatching: the point light position must be finite");
  const Vec3 light_direction =
      light.kind == LightKind::direction ? Vec3(light.vector.normalized()) : Vec3::Zero();

  const auto& positions = surface.positions();
  const auto& normals = surface.vertex_normals();
  const std::size_t nv = positions.size();

  IntensityField field;
  field.vertex_intensity.resize(nv);
  field.vertex_facing.resize(nv);
  std::atomic<bool> light_on_vertex{false};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const Vec3 view = camera.view_vector(positions[v]);
      Vec3 l = view;
      if (light.kind == LightKind::direction) {
        l = light_direction;
      } else if (light.kind == LightKind::point) {
        const Vec3 d = light.vector - positions[v];
        const double len = d.norm();
        if (!(len > 0.0)) {
          light_on_vertex.store(true, std::memory_order_relaxed);
          l = Vec3::Zero();
        } else {
          l = d / len;
        }
      }
      field.vertex_intensity[v] = normals[v].dot(l);
      field.vertex_facing[v] = normals[v].dot(view);
    }
  });
  if (light_on_vertex.load())
    throw InputError("hatching: the point light lies on a mesh vertex; move it off the surface");

  field.face_gradient = face_gradients(surface, field.vertex_intensity);
  return field;
}

}  // namespace fabrica::hatching
