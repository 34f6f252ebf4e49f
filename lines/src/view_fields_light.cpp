// Illumination fields of ViewFields (PELs and Laplacian lines): f = n·l,
// its gradient and Laplacian, and the PEL derivatives D_w|∇f|, D_w D_w|∇f|
// (ALGORITHMS.md §7). Split from view_fields.cpp so the illumination and
// the radial/apparent fields can be worked on separately.
#include <cmath>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/precompute.hpp"
#include "parallel.hpp"
#include "view_fields_light.hpp"

namespace fabrica::detail {

void update_light_fields(ViewFields& fields, const Surface& surface, const Camera& camera,
                         const ViewFieldsRequest& request, const LinePrecompute* precompute,
                         bool radial) {
  const std::size_t nv = surface.vertex_count();
  const auto& pos = surface.positions();
  const auto& normals = surface.vertex_normals();
  // Illumination f = n·l and its derivatives (PELs, Laplacian lines).
  const bool light = request.light || request.pel;
  detail::resize_or_clear(fields.light, light, nv);
  detail::resize_or_clear(fields.light_gradient, light, nv);
  detail::resize_or_clear(fields.light_laplacian, light, nv);
  detail::resize_or_clear(fields.pel_g, request.pel, nv);
  detail::resize_or_clear(fields.pel_h, request.pel, nv);
  detail::resize_or_clear(fields.pel_s, request.pel, nv);
  if (light) {
    if (!precompute)
      throw Error(ErrorKind::internal, "view fields: light fields need a LinePrecompute");
    const auto& lap_n = precompute->normal_laplacian();
    const auto& grad = precompute->gradient_operator();
    Vec3 fixed = Vec3::Zero();
    if (request.light_direction) {
      if (!(request.light_direction->norm() > 0.0) || !request.light_direction->allFinite())
        throw InputError("light direction must be a non-zero finite vector");
      fixed = request.light_direction->normalized();
    }
    const bool headlight = !request.light_direction.has_value();
    detail::parallel_range(nv, [&](std::size_t i) {
      const Vec3 l = headlight ? camera.view_vector(pos[i]) : fixed;
      const double f = normals[i].dot(l);
      fields.light[i] = f;
      if (fields.ndotv.size() == nv && !radial)
        fields.ndotv[i] = camera.view_vector(pos[i]).dot(normals[i]);
      fields.light_laplacian[i] = lap_n[i].dot(l);
    });
    grad.apply(fields.light, fields.light_gradient);
    if (request.pel) {
      std::vector<Vec3> w(nv), gg(nv);
      detail::parallel_range(nv, [&](std::size_t i) {
        const double g = fields.light_gradient[i].norm();
        fields.pel_g[i] = g;
        w[i] = g > 0.0 ? Vec3(fields.light_gradient[i] / g) : Vec3::Zero();
      });
      grad.apply(fields.pel_g, gg);
      detail::parallel_range(nv, [&](std::size_t i) { fields.pel_h[i] = gg[i].dot(w[i]); });
      grad.apply(fields.pel_h, gg);
      detail::parallel_range(nv, [&](std::size_t i) { fields.pel_s[i] = gg[i].dot(w[i]); });
    }
  }
}

}  // namespace fabrica::detail
