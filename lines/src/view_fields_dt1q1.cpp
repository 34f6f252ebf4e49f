// D_t1 q1 (ViewFields::dt1q1), the second pass of the apparent-ridge
// fields: see view_fields_light.hpp.
#include <cmath>
#include <cstdint>

#include "fabrica/lines/precompute.hpp"
#include "parallel.hpp"
#include "view_fields_light.hpp"

namespace fabrica::detail {

void update_dt1q1(ViewFields& fields, const Surface& surface, bool cull,
                  const LinePrecompute* precompute) {
  const std::size_t nv = surface.vertex_count();
  const auto& pos = surface.positions();
  const auto& normals = surface.vertex_normals();
  // Pass 2: D_t1 q1 by Judd's finite differences (ALGORITHMS.md §6.2):
  // along the line through p_i in direction t1, find the crossing with
  // the opposite edge of each incident face, and average the (at most
  // two) one-sided differences, measured in projected (screen) distance.
  // With LinePrecompute the ring comes precomputed in each vertex's
  // tangent frame; without, from the topology. With a cull threshold,
  // vertices whose incident faces all have q1 <= threshold at every
  // corner are skipped (the apparent-ridge extractor rejects those faces
  // before reading t1 or D_t1 q1).
  const Topology& topo = surface.topology();
  const auto& faces = surface.faces();
  const double* q1 = fields.q1.data();
  const std::uint8_t* sg = fields.signs.data();
  if (precompute) {
    // With the precomputed tangent ring: each incident face's opposite
    // corners as offsets (x, y) in the vertex's principal frame, so with
    // t1 = (c, s) in that frame, t2 = n × t1 = ±(-s, c) (the sign cancels
    // in w1) and every product is two-dimensional; one streamed array
    // instead of gathered positions. Same formulas as below, evaluated
    // from float offsets (relative differences ~1e-7).
    const LinePrecompute::TangentRing& tr = precompute->tangent_ring();
    const auto* ent = tr.entry.data();
    const std::int32_t* off = tr.offset.data();
    detail::parallel_range(nv, [&](std::size_t i) {
      const std::int32_t jb = off[i], je = off[i + 1];
      if (cull && !(sg[i] & kQ1Above)) {
        unsigned any = 0;  // branch-free over the ring (bytes)
        for (std::int32_t j = jb; j < je; ++j)
          any |= unsigned(sg[ent[j].i1]) | unsigned(sg[ent[j].i2]);
        if (!(any & kQ1Above)) {
          fields.dt1q1[i] = 0.0;
          return;
        }
      }
      if (fields.t1_world[i].squaredNorm() == 0.0) {
        fields.dt1q1[i] = 0.0;
        return;
      }
      const double c = fields.t1[i][0], sn = fields.t1[i][1];
      const double q0 = q1[i];
      const double an = std::abs(fields.ndotv[i]);
      double result = 0.0;
      int n = 0;
      for (std::int32_t j = jb; j < je; ++j) {
        const auto& e = ent[j];
        const double x1 = e.x1, y1 = e.y1, x2 = e.x2, y2 = e.y2;
        const double p1_t2 = c * y1 - sn * x1, p2_t2 = c * y2 - sn * x2;
        const double num = p2_t2, den = p2_t2 - p1_t2;
        if (!(std::abs(num) < std::abs(den))) continue;
        if ((num < 0.0) != (den < 0.0) && std::abs(num) > std::abs(den) * 0x1p-900) continue;
        const double w1 = num / den;
        if (!(w1 >= 0.0 && w1 < 1.0)) continue;
        const double w2 = 1.0 - w1;
        const double dist = (c * (w1 * x1 + w2 * x2) + sn * (w1 * y1 + w2 * y2)) * an;
        if (dist == 0.0) continue;
        const double q = w1 * q1[e.i1] + w2 * q1[e.i2];
        result += (q - q0) / dist;
        if (++n == 2) {
          result *= 0.5;
          break;
        }
      }
      fields.dt1q1[i] = std::isfinite(result) ? result : 0.0;
    });
  } else {
    detail::parallel_range(nv, [&](std::size_t i) {
      if (cull && !(sg[i] & kQ1Above)) {
        // Branch-free over the ring (bytes, not q1: a small array).
        unsigned any = 0;
        const auto fs = topo.vertex_faces(i);
        const auto cs = topo.vertex_face_corners(i);
        for (std::size_t j = 0; j < fs.size(); ++j) {
          const Face& f = faces[static_cast<std::size_t>(fs[j])];
          const int c = cs[j];
          any |= unsigned(sg[f[(c + 1) % 3]]) | unsigned(sg[f[(c + 2) % 3]]);
        }
        if (!(any & kQ1Above)) {
          fields.dt1q1[i] = 0.0;
          return;
        }
      }
      const Vec3& p0 = pos[i];
      const double ndotv = fields.ndotv[i];
      const Vec3& t1w = fields.t1_world[i];
      double result = 0.0;
      if (t1w.squaredNorm() == 0.0) {
        fields.dt1q1[i] = 0.0;
        return;
      }
      const Vec3 t2w = normals[i].cross(t1w);
      const double p0_t2 = p0.dot(t2w);
      const double q0 = q1[i];
      const double an = std::abs(ndotv);
      int n = 0;
      // Returns true when two one-sided differences have been averaged.
      auto corner = [&](int i1, int i2) {
        const Vec3& p1 = pos[i1];
        const Vec3& p2 = pos[i2];
        const double p1_t2 = p1.dot(t2w), p2_t2 = p2.dot(t2w);
        const double num = p2_t2 - p0_t2, den = p2_t2 - p1_t2;
        // Exact early rejections of w1 = num/den outside [0, 1) before the
        // division: |num| >= |den| (also den == 0 or NaN) gives |w1| >= 1,
        // and opposite signs give w1 < 0 unless the quotient underflows to
        // -0 (only possible when |num| <= |den| 2^-900).
        if (!(std::abs(num) < std::abs(den))) return false;
        if ((num < 0.0) != (den < 0.0) && std::abs(num) > std::abs(den) * 0x1p-900) return false;
        const double w1 = num / den;
        if (!(w1 >= 0.0 && w1 < 1.0)) return false;
        const double w2 = 1.0 - w1;
        const Vec3 p = w1 * p1 + w2 * p2;
        const double q = w1 * q1[i1] + w2 * q1[i2];
        const double dist = (p - p0).dot(t1w) * an;
        if (dist == 0.0) return false;
        result += (q - q0) / dist;
        if (++n == 2) {
          result *= 0.5;
          return true;
        }
        return false;
      };
      {
        const auto fs = topo.vertex_faces(i);
        const auto cs = topo.vertex_face_corners(i);
        for (std::size_t j = 0; j < fs.size(); ++j) {
          const Face& f = faces[static_cast<std::size_t>(fs[j])];
          const int c = cs[j];
          if (corner(f[(c + 1) % 3], f[(c + 2) % 3])) break;
        }
      }
      fields.dt1q1[i] = std::isfinite(result) ? result : 0.0;
    });
  }
}

}  // namespace fabrica::detail
