// Illumination fields of ViewFields (PELs and Laplacian lines): f = n·l,
// its gradient and Laplacian, and the PEL derivatives D_w|∇f| and
// -D_w D_w|∇f| (docs/algorithms.md §7). Split from view_fields.cpp so the
// illumination and the radial/apparent fields can be worked on separately.
//
// f, ∇f and Δf are computed everywhere. The thresholds leave only a small
// part of the surface where a line can be kept (on the igea view of the
// benchmark, 8% of the faces): those faces are listed for the extractors,
// and the two further gradient applications of the PEL test are computed
// only around them (ViewFields states where). The extracted lines are the
// same, bit for bit, as with the fields computed everywhere.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <atomic>
#include <cmath>
#include <cstdint>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/precompute.hpp"
#include "gradient_row.hpp"
#include "parallel.hpp"
#include "simd_avx2.hpp"
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

// Per-vertex bits for listing the faces that can carry a line: bit 1 when
// !(|∇f| <= limit), bit 2 when !(n·v <= 0) (ndotv == nullptr: never).
inline std::uint8_t light_byte(double g, const double* ndotv, std::size_t i, double limit) {
  return static_cast<std::uint8_t>(unsigned(!(g <= limit)) | unsigned(ndotv && !(ndotv[i] <= 0.0))
                                                                 << 1);
}

#if defined(FABRICA_LINES_AVX2)
// f = n·l, Δf = ΔN·l and (when `ndotv` is given) n·v for the full blocks
// [b0, b1) of LinePrecompute::vertex_blocks(), four vertices at a time:
// the same operations as the portable loop in update_light_fields.
[[gnu::target("avx2")]] void light_pass_avx2(const LinePrecompute::VertexBlock* blocks,
                                             std::size_t b0, std::size_t b1,
                                             const ViewVector4& view, const Vec3* fixed,
                                             const Vec3* lap_n, double* f, double* lap,
                                             double* ndotv) {
  for (std::size_t b = b0; b < b1; ++b) {
    const LinePrecompute::VertexBlock& k = blocks[b];
    const std::size_t i = 4 * b;
    const __m256d nx = _mm256_load_pd(k.n[0]), ny = _mm256_load_pd(k.n[1]),
                  nz = _mm256_load_pd(k.n[2]);
    __m256d vx, vy, vz, lx, ly, lz;
    if (!fixed || ndotv)
      view(_mm256_load_pd(k.p[0]), _mm256_load_pd(k.p[1]), _mm256_load_pd(k.p[2]), vx, vy, vz);
    if (fixed) {
      lx = _mm256_set1_pd((*fixed)[0]);
      ly = _mm256_set1_pd((*fixed)[1]);
      lz = _mm256_set1_pd((*fixed)[2]);
    } else {
      lx = vx;
      ly = vy;
      lz = vz;
    }
    const __m256d fi = dot4(nx, ny, nz, lx, ly, lz);
    _mm256_storeu_pd(f + i, fi);
    if (ndotv) _mm256_storeu_pd(ndotv + i, fixed ? dot4(vx, vy, vz, nx, ny, nz) : fi);
    __m256d ax, ay, az;
    load_vec3x4(lap_n[i].data(), ax, ay, az);
    _mm256_storeu_pd(lap + i, dot4(ax, ay, az, lx, ly, lz));
  }
}

// ∇f, |∇f| and the listing bytes (light_byte) for vertices [b, e).
[[gnu::target("avx2")]] void gradient_pass_avx2(const GradientOperator& grad, std::size_t b,
                                                std::size_t e, const double* f, Vec3* gradient,
                                                double* g, const double* ndotv, double limit,
                                                std::uint8_t* bytes) {
  std::size_t i = b;
  for (; i + 2 <= e; i += 2) {
    gradient_rows2_avx2(grad, i, f, gradient + i);
    for (std::size_t j = i; j < i + 2; ++j) {
      g[j] = gradient[j].norm();
      bytes[j] = light_byte(g[j], ndotv, j, limit);
    }
  }
  for (; i < e; ++i) {
    gradient[i] = gradient_row_avx2(grad, i, f);
    g[i] = gradient[i].norm();
    bytes[i] = light_byte(g[i], ndotv, i, limit);
  }
}
#endif

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
  auto light_at = [&](std::size_t i) {
    const Vec3 l = headlight ? camera.view_vector(pos[i]) : fixed;
    f[i] = normals[i].dot(l);
    if (fill_ndotv) fields.ndotv[i] = headlight ? f[i] : camera.view_vector(pos[i]).dot(normals[i]);
    lap[i] = lap_n[i].dot(l);
  };
  // ∇f and |∇f|, and the listing bytes.
  const double limit = light_cull_limit(request.light_threshold);
  const bool cull = request.light_cull_backfaces && fields.ndotv.size() == nv;
  std::vector<std::uint8_t> bytes(nv);
  auto gradient_at = [&](std::size_t i) {
    const Vec3 gi = gradient_row(grad, i, f);
    fields.light_gradient[i] = gi;
    g[i] = gi.norm();
    bytes[i] = light_byte(g[i], cull ? ndotv : nullptr, i, limit);
  };
#if defined(FABRICA_LINES_AVX2)
  if (detail::cpu_has_avx2()) {
    const auto& vb = precompute->vertex_blocks();
    const ViewVector4 view(camera);
    const std::size_t full = nv / 4;  // blocks of four; the rest one by one
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, full, 512),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        light_pass_avx2(vb.block.data(), r.begin(), r.end(), view,
                                        headlight ? nullptr : &fixed, lap_n.data(), f, lap,
                                        fill_ndotv ? fields.ndotv.data() : nullptr);
                      });
    for (std::size_t i = 4 * full; i < nv; ++i) light_at(i);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        gradient_pass_avx2(grad, r.begin(), r.end(), f,
                                           fields.light_gradient.data(), g, cull ? ndotv : nullptr,
                                           limit, bytes.data());
                      });
  } else
#endif
  {
    detail::parallel_range(nv, light_at);
    detail::parallel_range(nv, gradient_at, 4096);
  }

  // The faces that can carry a kept line (a corner with |∇f| above the
  // limit and, with culling, a corner facing the eye), and their corners.
  const auto& faces = surface.faces();
  std::vector<std::uint8_t> corner(nv, 0);
  std::vector<std::int32_t>& line_faces = fields.light_faces;
  const unsigned need = cull ? 3u : 1u;
  detail::parallel_chunks<std::int32_t>(
      faces.size(),
      [&](std::size_t b, std::size_t e, std::vector<std::int32_t>& part) {
        for (std::size_t t = b; t < e; ++t) {
          const Face& fc = faces[t];
          const unsigned any = unsigned(bytes[fc[0]]) | bytes[fc[1]] | bytes[fc[2]];
          if ((any & need) != need) continue;
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
