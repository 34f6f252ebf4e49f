// The portable reference zero-crossing kernel (docs/algorithms.md §0 "ZC"
// and "ZC-vec"): the public entry points and the vector kernel one face at
// a time. The tuned scans are in zero_crossing_scalar.cpp, the AVX2 ones in
// zero_crossing_avx2.cpp; zero_crossing_kernel.hpp holds what they share.
#include "fabrica/lines/zero_crossing.hpp"

#include <algorithm>
#include <cmath>

#include "parallel.hpp"
#include "zero_crossing_internal.hpp"
#include "zero_crossing_kernel.hpp"

namespace fabrica {

namespace zc {

[[gnu::noinline]] void vector_centroid_segments(const VectorInputs& in, const SegmentParams& sp,
                                                std::size_t f, const int v[3], const Vec3 E[3],
                                                std::vector<LineSegment>& out) {
  const double *p0 = in.p(v[0]), *p1 = in.p(v[1]), *p2 = in.p(v[2]);
  CentroidEnd ce;
  ce.m = std::abs(in.mg(v[0]) + in.mg(v[1]) + in.mg(v[2])) / 3.0;
  ce.k = std::max(ce.m - sp.threshold, 0.0);
  for (int k = 0; k < 3; ++k) ce.p[k] = (p0[k] + p1[k] + p2[k]) / 3.0;
  // (c0,c1,c2) = (1,2,0), (2,0,1), (0,1,2), in this order.
  for (int k = 0; k < 3; ++k) {
    const int c0 = next_corner(k), c1 = next_corner(c0);
    vector_segment<true>(in, sp, f, v, c0, c1, next_corner(c1), E, ce, out);
  }
}

// The segments of face f (vertices v, E_i = delta_i dir_i) given which
// edges cross (crossing bits z as crossing_bits_of, with the maximum test
// where it applies): at least two of them.
[[gnu::noinline]] void vector_face_segments(const VectorInputs& in, std::size_t f, const int v[3],
                                            const Vec3 E[3], unsigned z,
                                            std::vector<LineSegment>& out) {
  const SegmentParams sp{in.o.threshold, in.o.test == ExtremumTest::perpendicular,
                         in.o.keep_raw_magnitude};
  if (z == 7) {
    vector_centroid_segments(in, sp, f, v, E, out);
    return;
  }
  const int c0 = first_corner(z), c1 = next_corner(c0);
  vector_segment<false>(in, sp, f, v, c0, c1, next_corner(c1), E, CentroidEnd{}, out);
}

// The rest of vector_face for a face with a corner above the threshold.
[[gnu::noinline]] void vector_face(const VectorInputs& in, std::size_t f,
                                   std::vector<LineSegment>& out) {
  const Face& face = in.m.faces[f];
  const int v[3] = {face[0], face[1], face[2]};
  const auto& o = in.o;
  if (!o.cull.empty() && o.cull[v[0]] <= 0.0 && o.cull[v[1]] <= 0.0 && o.cull[v[2]] <= 0.0) return;
  if (!o.vertex_mask.empty() &&
      (!o.vertex_mask[v[0]] || !o.vertex_mask[v[1]] || !o.vertex_mask[v[2]]))
    return;
  const Vec3 E[3] = {in.d(v[0]) * in.dir[v[0]], in.d(v[1]) * in.dir[v[1]],
                     in.d(v[2]) * in.dir[v[2]]};
  unsigned z = crossing_bits_of(E[0], E[1], E[2]);
  if (!two_crossings(z)) return;
  if (o.test == ExtremumTest::edge) {
    const Vec3* pos = in.m.pos;
    const Vec3 d01 = pos[v[1]] - pos[v[0]], d12 = pos[v[2]] - pos[v[1]],
               d20 = pos[v[0]] - pos[v[2]];
    const bool z01 = (z & 1) && (E[0].dot(d01) >= 0.0 || E[1].dot(d01) <= 0.0);
    const bool z12 = (z & 2) && (E[1].dot(d12) >= 0.0 || E[2].dot(d12) <= 0.0);
    const bool z20 = (z & 4) && (E[2].dot(d20) >= 0.0 || E[0].dot(d20) <= 0.0);
    z = unsigned(z01) | unsigned(z12) << 1 | unsigned(z20) << 2;
    if (!two_crossings(z)) return;
  }
  vector_face_segments(in, f, v, E, z, out);
}

}  // namespace zc

void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, std::vector<LineSegment>& out) {
  detail::scalar_zero_crossings(surface, values, options, detail::SignBits{}, out);
}

void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, std::vector<LineSegment>& out) {
  const zc::VectorInputs in{zc::MeshArrays(surface), derivative.data(), direction.data(),
                            magnitude.data(), options};
  detail::parallel_chunks<LineSegment>(
      surface.face_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
        const Face* faces = in.m.faces;
        const double* mag = in.mag;
        const double th = options.threshold;
        for (std::size_t f = b; f < e; ++f) {
          const Face& face = faces[f];
          if (mag[face[0]] <= th && mag[face[1]] <= th && mag[face[2]] <= th) continue;
          zc::vector_face(in, f, part);
        }
      },
      out);
}

}  // namespace fabrica
