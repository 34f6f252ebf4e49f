// Illumination fields of ViewFields (PELs and Laplacian lines): f = n·l,
// its gradient and Laplacian, and the PEL derivatives D_w|∇f| and
// -D_w D_w|∇f| (ALGORITHMS.md §7). Split from view_fields.cpp so the
// illumination and the radial/apparent fields can be worked on separately.
//
// f, ∇f and Δf are computed everywhere. The thresholds leave only a small
// part of the surface where a line can be kept (on the igea view of the
// benchmark, 8% of the faces): those faces are listed for the extractors,
// and the two further gradient applications of the PEL test are computed
// only around them (ViewFields states where). The extracted lines are the
// same, bit for bit, as with the fields computed everywhere.
#include <atomic>
#include <cmath>
#include <cstdint>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/precompute.hpp"
#include "gradient_row.hpp"
#include "parallel.hpp"
#include "view_fields_light.hpp"

namespace fabrica::detail {

namespace {

// Marks element i of a byte array from a parallel loop (several faces may
// mark the same vertex; they all store 1).
inline void mark(std::vector<std::uint8_t>& m, std::size_t i) {
  std::atomic_ref<std::uint8_t>(m[i]).store(1, std::memory_order_relaxed);
}

// w = ∇f/|∇f| as the PEL derivatives use it (0 where ∇f = 0).
inline Vec3 light_direction_of_gradient(const Vec3& grad, double g) {
  return g > 0.0 ? Vec3(grad / g) : Vec3::Zero();
}

// Faces whose three corners have |∇f| <= light_cull_limit(t) cannot carry
// a line kept with threshold t: the interpolated |∇f| at an endpoint is a
// convex combination of the corners' values, and the relative margin 1e-9
// covers its rounding (a few ulps). For t <= 0 nothing is culled that
// could be kept (|∇f| >= 0).
inline double light_cull_limit(double threshold) {
  return threshold * (1.0 - 1e-9);
}

}  // namespace

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
  detail::resize_or_clear(fields.light_gradient_norm, light, nv);
  detail::resize_or_clear(fields.light_laplacian, light, nv);
  detail::resize_or_clear(fields.pel_h, request.pel, nv);
  detail::resize_or_clear(fields.pel_maximum, request.pel, nv);
  fields.light_faces.clear();
  fields.light_threshold = request.light_threshold;
  fields.light_cull_backfaces = request.light_cull_backfaces;
  if (!light) return;
  if (!precompute)
    throw Error(ErrorKind::internal, "view fields: light fields need a LinePrecompute");
  if (std::isnan(request.light_threshold))
    throw InputError("the PEL / Laplacian-line threshold must be a number");
  const auto& lap_n = precompute->normal_laplacian();
  const GradientOperator& grad = precompute->gradient_operator();
  Vec3 fixed = Vec3::Zero();
  if (request.light_direction) {
    if (!(request.light_direction->norm() > 0.0) || !request.light_direction->allFinite())
      throw InputError("light direction must be a non-zero finite vector");
    fixed = request.light_direction->normalized();
  }
  const bool headlight = !request.light_direction.has_value();
  const bool fill_ndotv = fields.ndotv.size() == nv && !radial;
  double* f = fields.light.data();
  double* lap = fields.light_laplacian.data();
  double* g = fields.light_gradient_norm.data();
  const double* ndotv = fields.ndotv.data();

  // f, Δf = ΔN·l (Zhang et al.'s shortcut), and n·v when the radial group
  // did not compute it (for the headlight it is f itself).
  detail::parallel_range(nv, [&](std::size_t i) {
    const Vec3 l = headlight ? camera.view_vector(pos[i]) : fixed;
    f[i] = normals[i].dot(l);
    if (fill_ndotv) fields.ndotv[i] = headlight ? f[i] : camera.view_vector(pos[i]).dot(normals[i]);
    lap[i] = lap_n[i].dot(l);
  });
  // ∇f and |∇f|.
  detail::parallel_range(
      nv,
      [&](std::size_t i) {
        const Vec3 gi = gradient_row(grad, i, f);
        fields.light_gradient[i] = gi;
        g[i] = gi.norm();
      },
      4096);

  // The faces that can carry a kept line, and their corners.
  const auto& faces = surface.faces();
  const double limit = light_cull_limit(request.light_threshold);
  const bool cull = request.light_cull_backfaces && fields.ndotv.size() == nv;
  std::vector<std::uint8_t> corner(nv, 0);
  std::vector<std::int32_t>& line_faces = fields.light_faces;
  detail::parallel_chunks<std::int32_t>(
      faces.size(),
      [&](std::size_t b, std::size_t e, std::vector<std::int32_t>& part) {
        for (std::size_t t = b; t < e; ++t) {
          const Face& fc = faces[t];
          if (g[fc[0]] <= limit && g[fc[1]] <= limit && g[fc[2]] <= limit) continue;
          if (cull && ndotv[fc[0]] <= 0.0 && ndotv[fc[1]] <= 0.0 && ndotv[fc[2]] <= 0.0) continue;
          part.push_back(static_cast<std::int32_t>(t));
          for (int k = 0; k < 3; ++k) mark(corner, static_cast<std::size_t>(fc[k]));
        }
      },
      line_faces, 16384);

  if (!request.pel) return;

  // D_w h at a corner needs h = D_w|∇f| on its whole row: mark the rows.
  const std::int32_t* col = grad.column.data();
  std::vector<std::uint8_t> ring(nv, 0);
  detail::parallel_range(nv, [&](std::size_t i) {
    if (!corner[i]) return;
    for (std::int32_t k = grad.offset[i]; k < grad.offset[i + 1]; ++k)
      mark(ring, static_cast<std::size_t>(col[k]));
  });
  double* h = fields.pel_h.data();
  detail::parallel_range(
      nv,
      [&](std::size_t i) {
        if (!ring[i]) {
          h[i] = 0.0;
          return;
        }
        const Vec3 w = light_direction_of_gradient(fields.light_gradient[i], g[i]);
        h[i] = gradient_row(grad, i, g).dot(w);
      },
      4096);

  // The maximum test -D_w D_w|∇f| = -<∇h, w> at the corners.
  double* smax = fields.pel_maximum.data();
  detail::parallel_range(
      nv,
      [&](std::size_t i) {
        if (!corner[i]) {
          smax[i] = 0.0;
          return;
        }
        const Vec3 w = light_direction_of_gradient(fields.light_gradient[i], g[i]);
        smax[i] = -gradient_row(grad, i, h).dot(w);
      },
      4096);
}

}  // namespace fabrica::detail
