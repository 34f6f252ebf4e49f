// The AVX-512 apparent-ridge kernel (docs/algorithms.md §0 "ZC-vec"):
// kept_segments eight faces per register, each lane evaluating the scalar
// kernel's operations in the same order (no FMA), so the same bits as the
// AVX2 kernel (zero_crossing_avx2.cpp) and the portable one. Compiled for
// AVX-512 F, VL, DQ and BW by target attributes, not by flags for the whole
// file: the inline helpers it shares with the other files (the headers'
// and the standard library's) stay x86-64 baseline code, so the linker can
// never keep an AVX-512 copy of one for the portable callers. Also
// -ffp-contract=off (its targets have no FMA anyway). Called by
// zero_crossing_scalar.cpp only when detail::cpu_has_avx512(). (An AVX-512
// keep_crossed was no faster than the AVX2 one, and a four-vertex D_t1 q1
// batch slower than the two-vertex one: docs/PERFORMANCE.md.)
// GCC 12's AVX-512 intrinsics start from _mm512_undefined_pd(), which it
// then reports as maybe uninitialized (GCC bug 105593, fixed in 13).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <algorithm>
#include <bit>
#include <cstring>

#include "simd_avx2.hpp"
#include "zero_crossing_kernel.hpp"

#if defined(FABRICA_LINES_AVX512)

namespace fabrica::zc {

namespace {

// Eight 64-byte records (rows) as their eight columns, lane l from row l.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline void transpose8x8(
    const double* const r[8], __m512d col[8]) {
  __m512d t[8];
  for (int i = 0; i < 4; ++i) {
    const __m512d a = _mm512_load_pd(r[2 * i]), b = _mm512_load_pd(r[2 * i + 1]);
    t[2 * i] = _mm512_unpacklo_pd(a, b);      // (a0 b0 a2 b2 a4 b4 a6 b6)
    t[2 * i + 1] = _mm512_unpackhi_pd(a, b);  // (a1 b1 a3 b3 a5 b5 a7 b7)
  }
  const __m512i even = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
  const __m512i odd = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
  // s[k]: rows 0-3 (k < 4) or 4-7 of columns c and c + 4, c = 0, 2, 1, 3.
  __m512d s[8];
  for (int h = 0; h < 2; ++h) {
    const __m512d* u = t + 4 * h;
    s[4 * h + 0] = _mm512_permutex2var_pd(u[0], even, u[2]);  // columns 0, 4
    s[4 * h + 1] = _mm512_permutex2var_pd(u[0], odd, u[2]);   // 2, 6
    s[4 * h + 2] = _mm512_permutex2var_pd(u[1], even, u[3]);  // 1, 5
    s[4 * h + 3] = _mm512_permutex2var_pd(u[1], odd, u[3]);   // 3, 7
  }
  const int column_of[4] = {0, 2, 1, 3};
  for (int i = 0; i < 4; ++i) {
    col[column_of[i]] = _mm512_shuffle_f64x2(s[i], s[4 + i], 0x44);
    col[column_of[i] + 4] = _mm512_shuffle_f64x2(s[i], s[4 + i], 0xEE);
  }
}

// mask ? x : y per lane.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m512d when8(__mmask8 mask,
                                                                             __m512d x, __m512d y) {
  return _mm512_mask_blend_pd(mask, y, x);
}

// Per lane: x1 where r1, else x2 where r2, else x0.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m512d select8(
    __mmask8 r1, __mmask8 r2, __m512d x0, __m512d x1, __m512d x2) {
  return when8(r1, x1, when8(r2, x2, x0));
}

// Eigen's Vec3 dot, (x x' + y y') + z z', per lane.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m512d dot8(const __m512d a[3],
                                                                            __m512d bx, __m512d by,
                                                                            __m512d bz) {
  return _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(a[0], bx), _mm512_mul_pd(a[1], by)),
                       _mm512_mul_pd(a[2], bz));
}

// One face corner's record (ApparentVertex) for eight faces, one lane
// each: E (x, y, z), D_t1 q1, q1, position (x, y, z), and the vertex index.
struct Corner8 {
  __m512d e[3], d, q, p[3], id;
};
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline Corner8 load_corner8(
    const double* field, const int v[8]) {
  const double* r[8];
  for (int l = 0; l < 8; ++l) r[l] = field + std::size_t(v[l]) * kApparentStride;
  __m512d col[8];
  transpose8x8(r, col);
  Corner8 c;
  c.e[0] = col[0], c.e[1] = col[1], c.e[2] = col[2], c.d = col[3];
  c.q = col[4], c.p[0] = col[5], c.p[1] = col[6], c.p[2] = col[7];
  // (built in registers: a vector load of the indices just stored one by
  // one would wait for the stores, store forwarding failing)
  c.id = _mm512_cvtepi32_pd(_mm256_setr_epi32(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]));
  return c;
}

// One end of a cut (its derivative, magnitude and position), per lane.
struct End8 {
  __m512d d, q, p[3];
};
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline End8 pick_end8(__mmask8 m,
                                                                              const End8& a,
                                                                              const End8& b) {
  End8 r;
  r.d = when8(m, a.d, b.d);
  r.q = when8(m, a.q, b.q);
  for (int k = 0; k < 3; ++k) r.p[k] = when8(m, a.p[k], b.p[k]);
  return r;
}

// vector_edge and cut_point for eight cuts (ends ordered lo, hi): t from
// the lower vertex, the magnitude m, k = max(m - th, 0) and the point, in
// vector_segment's operations.
struct Cut8 {
  __m512d t, m, k, p[3];
};
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline Cut8 cut8(const End8& lo,
                                                                         const End8& hi,
                                                                         __m512d th) {
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
  const __m512d da = _mm512_abs_pd(lo.d), db = _mm512_abs_pd(hi.d);
  const __m512d sum = _mm512_add_pd(da, db);
  Cut8 c;
  c.t = _mm512_mask_div_pd(_mm512_set1_pd(0.5), _mm512_cmp_pd_mask(sum, zero, _CMP_GT_OQ), da, sum);
  const __m512d u = _mm512_sub_pd(one, c.t);
  c.m = _mm512_abs_pd(_mm512_add_pd(_mm512_mul_pd(u, lo.q), _mm512_mul_pd(c.t, hi.q)));
  c.k = _mm512_max_pd(zero, _mm512_sub_pd(c.m, th));
  for (int k = 0; k < 3; ++k)
    c.p[k] = _mm512_add_pd(_mm512_mul_pd(u, lo.p[k]), _mm512_mul_pd(c.t, hi.p[k]));
  return c;
}

// The lanes' kept segments: the two ends' fractions t from the lower
// corner, their strengths and their edges' slots in the face.
struct RidgeLanes8 {
  alignas(64) double ta[8], tb[8];
  alignas(32) float sa[8], sb[8];
  alignas(32) std::int32_t slot_a[8], slot_b[8];
};

}  // namespace

// kept_segments_avx2 eight faces at a time: each lane evaluates
// vector_segment<false>'s expressions in the same operations (so the same
// bits), from the eight faces' records transposed into lanes; faces
// crossed on all three edges (the centroid case) and the output records
// stay scalar, in face order.
[[gnu::target(FABRICA_AVX512_ISA)]] void kept_segments_avx512(const VectorInputs& in,
                                                              const double* field,
                                                              const KeptFaces& kept,
                                                              std::vector<LineSegment>& out) {
  const SegmentParams sp{in.o.threshold, in.o.test == ExtremumTest::perpendicular,
                         in.o.keep_raw_magnitude};
  const Face* faces = in.m.faces;
  const Topology& topo = *in.m.topo;
  const __m512d zero = _mm512_setzero_pd();
  const __m512d th = _mm512_set1_pd(sp.threshold);
  const bool fade = sp.raw || sp.threshold > 0.0;
  const __m256i corner_table = _mm256_set1_epi32(0x1919);
  for (std::size_t j = 0; j < kept.n; j += 8) {
    const int lanes = static_cast<int>(std::min<std::size_t>(8, kept.n - j));
    const auto live = static_cast<__mmask8>((1u << lanes) - 1);
    // Unused lanes repeat lane 0.
    alignas(32) int v[3][8];
    for (int l = 0; l < 8; ++l) {
      const Face& fg = faces[kept.f[j + (l < lanes ? l : 0)]];
      for (int c = 0; c < 3; ++c) v[c][l] = fg[c];
    }
    // The crossing bits per lane, and first_corner of them: the rotation.
    const __m256i z = _mm256_cvtepu8_epi32(_mm_maskz_loadu_epi8(live, kept.z + j));
    const __m256i c0 = _mm256_and_si256(_mm256_srlv_epi32(corner_table, _mm256_add_epi32(z, z)),
                                        _mm256_set1_epi32(3));
    const __mmask8 r1 = _mm256_cmpeq_epi32_mask(c0, _mm256_set1_epi32(1));
    const __mmask8 r2 = _mm256_cmpeq_epi32_mask(c0, _mm256_set1_epi32(2));
    const auto centroid =
        static_cast<__mmask8>(_mm256_cmpeq_epi32_mask(z, _mm256_set1_epi32(7)) & live);
    const Corner8 C[3] = {load_corner8(field, v[0]), load_corner8(field, v[1]),
                          load_corner8(field, v[2])};
    // The corners c0, c1, c2 of the segment (rotations of 0, 1, 2).
    End8 e[3];
    __m512d id[3];
    for (int s = 0; s < 3; ++s) {
      const Corner8 &x0 = C[s], &x1 = C[(s + 1) % 3], &x2 = C[(s + 2) % 3];
      e[s].d = select8(r1, r2, x0.d, x1.d, x2.d);
      e[s].q = select8(r1, r2, x0.q, x1.q, x2.q);
      for (int k = 0; k < 3; ++k) e[s].p[k] = select8(r1, r2, x0.p[k], x1.p[k], x2.p[k]);
      id[s] = select8(r1, r2, x0.id, x1.id, x2.id);
    }
    // Edge a joins c0 and c1, edge b c1 and c2; each from its lower vertex.
    const __mmask8 swap_a = _mm512_cmp_pd_mask(id[0], id[1], _CMP_GT_OQ);
    const __mmask8 swap_b = _mm512_cmp_pd_mask(id[1], id[2], _CMP_GT_OQ);
    const Cut8 a = cut8(pick_end8(swap_a, e[1], e[0]), pick_end8(swap_a, e[0], e[1]), th);
    const Cut8 b = cut8(pick_end8(swap_b, e[2], e[1]), pick_end8(swap_b, e[1], e[2]), th);
    __mmask8 reject =
        _mm512_cmp_pd_mask(a.k, zero, _CMP_EQ_OQ) & _mm512_cmp_pd_mask(b.k, zero, _CMP_EQ_OQ);
    if (sp.perpendicular) {
      // perpendicular_rejects: n from the face's corners in face order,
      // q = n × (pa - pb), and E·q at c0, c1, c2.
      const __m512d u0 = _mm512_sub_pd(C[1].p[0], C[0].p[0]);
      const __m512d u1 = _mm512_sub_pd(C[1].p[1], C[0].p[1]);
      const __m512d u2 = _mm512_sub_pd(C[1].p[2], C[0].p[2]);
      const __m512d w0 = _mm512_sub_pd(C[2].p[0], C[0].p[0]);
      const __m512d w1 = _mm512_sub_pd(C[2].p[1], C[0].p[1]);
      const __m512d w2 = _mm512_sub_pd(C[2].p[2], C[0].p[2]);
      const __m512d n0 = _mm512_sub_pd(_mm512_mul_pd(u1, w2), _mm512_mul_pd(u2, w1));
      const __m512d n1 = _mm512_sub_pd(_mm512_mul_pd(u2, w0), _mm512_mul_pd(u0, w2));
      const __m512d n2 = _mm512_sub_pd(_mm512_mul_pd(u0, w1), _mm512_mul_pd(u1, w0));
      const __m512d d0 = _mm512_sub_pd(a.p[0], b.p[0]), d1 = _mm512_sub_pd(a.p[1], b.p[1]),
                    d2 = _mm512_sub_pd(a.p[2], b.p[2]);
      const __m512d q0 = _mm512_sub_pd(_mm512_mul_pd(n1, d2), _mm512_mul_pd(n2, d1));
      const __m512d q1 = _mm512_sub_pd(_mm512_mul_pd(n2, d0), _mm512_mul_pd(n0, d2));
      const __m512d q2 = _mm512_sub_pd(_mm512_mul_pd(n0, d1), _mm512_mul_pd(n1, d0));
      __m512d D[3];
      for (int c = 0; c < 3; ++c) D[c] = dot8(C[c].e, q0, q1, q2);
      reject |= _mm512_cmp_pd_mask(select8(r1, r2, D[0], D[1], D[2]), zero, _CMP_LE_OQ);
      reject |= _mm512_cmp_pd_mask(select8(r1, r2, D[1], D[2], D[0]), zero, _CMP_GE_OQ);
      reject |= _mm512_cmp_pd_mask(select8(r1, r2, D[2], D[0], D[1]), zero, _CMP_LE_OQ);
    }
    // The lanes that give output, in lane (face) order: kept segments and
    // centroid faces (visited by their set bits: no branch per lane).
    const unsigned emit = (static_cast<unsigned>(~reject) & live) | centroid;
    if (!emit) continue;
    // The ends: their fractions t from the lower corner (the barycentrics
    // and points are recomputed from them, segments.hpp), ridge_strength,
    // and the slots 3 - lo - hi of their edges in the face.
    RidgeLanes8 lp;
    if (sp.raw) {
      _mm256_store_ps(lp.sa, _mm512_cvtpd_ps(a.m));
      _mm256_store_ps(lp.sb, _mm512_cvtpd_ps(b.m));
    } else if (fade) {
      _mm256_store_ps(lp.sa, _mm512_cvtpd_ps(_mm512_div_pd(a.k, _mm512_add_pd(a.k, th))));
      _mm256_store_ps(lp.sb, _mm512_cvtpd_ps(_mm512_div_pd(b.k, _mm512_add_pd(b.k, th))));
    }
    _mm512_store_pd(lp.ta, a.t);
    _mm512_store_pd(lp.tb, b.t);
    // The corner numbers c0, c1, c2 (k + o mod 3 for rotation k) and the
    // slots (exact small integers).
    const __m256i k1 = _mm256_set1_epi32(1), k2 = _mm256_set1_epi32(2);
    const __m256i cn0 = c0;
    const __m256i cn1 =
        _mm256_mask_blend_epi32(r2, _mm256_mask_blend_epi32(r1, k1, k2), _mm256_setzero_si256());
    const __m256i cn2 =
        _mm256_mask_blend_epi32(r2, _mm256_mask_blend_epi32(r1, k2, _mm256_setzero_si256()), k1);
    const __m256i three = _mm256_set1_epi32(3);
    // (3 - lo - hi does not depend on the order of lo and hi)
    _mm256_store_si256(reinterpret_cast<__m256i*>(lp.slot_a),
                       _mm256_sub_epi32(_mm256_sub_epi32(three, cn0), cn1));
    _mm256_store_si256(reinterpret_cast<__m256i*>(lp.slot_b),
                       _mm256_sub_epi32(_mm256_sub_epi32(three, cn1), cn2));
    for (unsigned bits = emit; bits; bits &= bits - 1) {
      const int l = std::countr_zero(bits);
      const std::size_t f = kept.f[j + l];
      if (centroid >> l & 1) {
        const Face& fg = faces[f];
        const int vv[3] = {fg[0], fg[1], fg[2]};
        const Vec3 E[3] = {field_at(field, fg[0]), field_at(field, fg[1]), field_at(field, fg[2])};
        vector_centroid_segments(in, sp, f, vv, E, out);
        continue;
      }
      SegmentEnd ea, eb;
      ea.t = lp.ta[l];
      ea.element = topo.face_edge(f, lp.slot_a[l]);
      ea.strength = fade ? lp.sa[l] : 1.0f;
      eb.t = lp.tb[l];
      eb.element = topo.face_edge(f, lp.slot_b[l]);
      eb.strength = fade ? lp.sb[l] : 1.0f;
      out.emplace_back(
          LineSegment{static_cast<std::int32_t>(f), {EndKind::edge, EndKind::edge}, {ea, eb}});
    }
  }
}

}  // namespace fabrica::zc

#endif
