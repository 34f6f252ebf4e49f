// The AVX-512 zero-crossing kernels (docs/algorithms.md §0 "ZC" and
// "ZC-vec"): the scalar kernel's listed faces (scalar_faces: contours,
// suggestive contours, highlights) and the apparent ridges' segments
// (kept_segments), eight faces per register, each lane evaluating the
// scalar kernel's operations in the same order (no FMA), so the same bits
// as the AVX2 kernels (zero_crossing_avx2.cpp) and the portable ones. Compiled for
// AVX-512 F, VL, DQ and BW by target attributes, not by flags for the whole
// file: the inline helpers it shares with the other files (the headers'
// and the standard library's) stay x86-64 baseline code, so the linker can
// never keep an AVX-512 copy of one for the portable callers. Also
// -ffp-contract=off, which the bits need: GCC's avx512f target implies FMA,
// and without the flag GCC 12 -O3 fuses an _mm512_mul_pd feeding an
// _mm512_add_pd into vfmadd (one rounding instead of two). Called by
// zero_crossing_scalar.cpp only when detail::cpu_has_avx512(). (An AVX-512
// keep_crossed was no faster than the AVX2 one, and a four-vertex D_t1 q1
// batch slower than the two-vertex one: docs/PERFORMANCE.md.)
// GCC 12's AVX-512 intrinsics start from _mm512_undefined_pd(), which it
// then reports as maybe uninitialized (GCC bug 105593, fixed in 13); only
// in this file (popped at its end, for unity builds).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
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

// a[v[l]] in lane l.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m512d gather8(const double* a,
                                                                               const int v[8]) {
  return _mm512_set_pd(a[v[7]], a[v[6]], a[v[5]], a[v[4]], a[v[3]], a[v[2]], a[v[1]], a[v[0]]);
}

// The test numerator at the lanes' vertices, as Num computes it.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m512d num8(const StoredNum& n,
                                                                            const int v[8]) {
  return gather8(n.n, v);
}
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m512d num8(const ShiftedNum& n,
                                                                            const int v[8]) {
  __m512d sc = gather8(n.sc, v);
  if (n.negate) sc = _mm512_xor_pd(sc, _mm512_set1_pd(-0.0));
  return _mm512_sub_pd(sc, _mm512_mul_pd(_mm512_set1_pd(n.shift), gather8(n.den, v)));
}

// fade_strength per lane (fade > 0), as floats.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __m256 fade_strength8(__m512d num,
                                                                                     __m512d den,
                                                                                     __m512d fade) {
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
  const __m512d d = _mm512_add_pd(_mm512_mul_pd(den, fade), num);
  const __m512d q = _mm512_div_pd(num, d);
  __m512d r =
      when8(_mm512_cmp_pd_mask(_mm512_abs_pd(q), _mm512_set1_pd(HUGE_VAL), _CMP_LT_OQ), q, zero);
  r = when8(_mm512_cmp_pd_mask(r, zero, _CMP_LT_OQ), zero, r);
  r = when8(_mm512_cmp_pd_mask(one, r, _CMP_LT_OQ), one, r);
  r = when8(_mm512_cmp_pd_mask(d, zero, _CMP_EQ_OQ), zero, r);
  return _mm512_cvtpd_ps(r);
}

// lone_sign per lane.
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline __mmask8 lone_sign8(__m512d a,
                                                                                   __m512d b,
                                                                                   __m512d c) {
  const __m512d zero = _mm512_setzero_pd();
  const __mmask8 lo = _mm512_cmp_pd_mask(a, zero, _CMP_LT_OQ) &
                      _mm512_cmp_pd_mask(b, zero, _CMP_GE_OQ) &
                      _mm512_cmp_pd_mask(c, zero, _CMP_GE_OQ);
  const __mmask8 hi = _mm512_cmp_pd_mask(a, zero, _CMP_GT_OQ) &
                      _mm512_cmp_pd_mask(b, zero, _CMP_LE_OQ) &
                      _mm512_cmp_pd_mask(c, zero, _CMP_LE_OQ);
  return lo | hi;
}

// x rotated by k per lane (r1: k = 1, r2: k = 2, else 0).
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline void rotate8(__mmask8 r1,
                                                                            __mmask8 r2,
                                                                            const __m512d x[3],
                                                                            __m512d out[3]) {
  for (int o = 0; o < 3; ++o) out[o] = select8(r1, r2, x[o], x[(o + 1) % 3], x[(o + 2) % 3]);
}

// Eight faces' corners in lanes, rotated so that corner o is corner k + o
// (mod 3) of the face, k its first lone-sign corner: the value, vertex
// index, corner number, test numerator and denominator.
struct Corners8 {
  __m512d s[3], id[3], corner[3], na[3], da[3];
};

// scalar_edge from corner 0 to corner o (of the rotated corners): the ends
// ordered by vertex index (corners lo, hi), t from the lower (u = 1 - t),
// the ends' test numerators and denominators.
struct Edge8 {
  __m512d lo, hi, t, u, n_lo, n_hi, d_lo, d_hi;
};
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline Edge8 edge8(const Corners8& c,
                                                                           int o) {
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
  const __mmask8 sw = _mm512_cmp_pd_mask(c.id[0], c.id[o], _CMP_GT_OQ);
  const __m512d va = when8(sw, c.s[o], c.s[0]), vb = when8(sw, c.s[0], c.s[o]);
  Edge8 e;
  e.lo = when8(sw, c.corner[o], c.corner[0]);
  e.hi = when8(sw, c.corner[0], c.corner[o]);
  const __m512d d = _mm512_sub_pd(va, vb);
  __m512d t =
      _mm512_mask_div_pd(_mm512_set1_pd(0.5), _mm512_cmp_pd_mask(d, zero, _CMP_NEQ_UQ), va, d);
  t = when8(_mm512_cmp_pd_mask(t, zero, _CMP_LT_OQ), zero, t);
  t = when8(_mm512_cmp_pd_mask(one, t, _CMP_LT_OQ), one, t);
  e.t = t;
  e.u = _mm512_sub_pd(one, t);
  e.n_lo = when8(sw, c.na[o], c.na[0]);
  e.n_hi = when8(sw, c.na[0], c.na[o]);
  e.d_lo = when8(sw, c.da[o], c.da[0]);
  e.d_hi = when8(sw, c.da[0], c.da[o]);
  return e;
}

// An edge end's first two barycentrics per lane (u at corner lo, t at
// corner hi, 0 at the third; the third is never stored).
[[gnu::target(FABRICA_AVX512_ISA), gnu::always_inline]] inline void edge_bary8(const Edge8& e,
                                                                               __m512d bary[2]) {
  const __m512d zero = _mm512_setzero_pd();
  for (int k = 0; k < 2; ++k) {
    const __m512d ck = _mm512_set1_pd(double(k));
    bary[k] = when8(_mm512_cmp_pd_mask(e.lo, ck, _CMP_EQ_OQ), e.u,
                    when8(_mm512_cmp_pd_mask(e.hi, ck, _CMP_EQ_OQ), e.t, zero));
  }
}

}  // namespace

// scalar_faces_avx2 eight faces at a time: each lane evaluates
// scalar_face_body's expressions in the same operations (so the same
// bits); the segments are then written lane by lane, in face order.
template <class Num>
[[gnu::target(FABRICA_AVX512_ISA)]] void scalar_faces_avx512(const ScalarInputs& in, const Num& num,
                                                             const std::size_t* list, int n,
                                                             std::vector<LineSegment>& out) {
  const Face* faces = in.m.faces;
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
  const bool test = in.test, fade = in.fade > 0.0;
  const __m512d vfade = _mm512_set1_pd(in.fade);
  const Topology& topo = *in.m.topo;
  for (int j = 0; j < n; j += 8) {
    const int lanes = std::min(8, n - j);
    const auto in_group = static_cast<__mmask8>((1u << lanes) - 1);
    int v[3][8];  // unused lanes repeat lane 0
    for (int l = 0; l < 8; ++l) {
      const Face& fc = faces[list[j + (l < lanes ? l : 0)]];
      for (int c = 0; c < 3; ++c) v[c][l] = fc[c];
    }
    __m512d s[3], id[3];
    for (int c = 0; c < 3; ++c) {
      s[c] = gather8(in.val, v[c]);
      id[c] = _mm512_cvtepi32_pd(_mm256_setr_epi32(v[c][0], v[c][1], v[c][2], v[c][3], v[c][4],
                                                   v[c][5], v[c][6], v[c][7]));
    }
    // lone_sign at corner 0, 1, 2; the first one is k.
    const __mmask8 l0 = lone_sign8(s[0], s[1], s[2]), l1 = lone_sign8(s[1], s[2], s[0]);
    const __mmask8 l2 = lone_sign8(s[2], s[0], s[1]);
    __mmask8 live = (l0 | l1 | l2) & in_group;
    const auto r1 = static_cast<__mmask8>(~l0 & l1);         // k = 1
    const auto r2 = static_cast<__mmask8>(~(l0 | l1) & l2);  // k = 2
    if (in.cull) {
      __mmask8 culled = 0xFF;
      for (int c = 0; c < 3; ++c)
        culled &= _mm512_cmp_pd_mask(gather8(in.cull, v[c]), zero, _CMP_LE_OQ);
      live &= static_cast<__mmask8>(~culled);
    }
    __m512d na[3] = {one, one, one}, da[3] = {one, one, one};
    if (test) {
      for (int c = 0; c < 3; ++c) na[c] = num8(num, v[c]);
      __mmask8 reject;
      if (!in.den) {
        reject = 0xFF;
        for (int c = 0; c < 3; ++c) reject &= _mm512_cmp_pd_mask(na[c], zero, _CMP_LE_OQ);
      } else {
        __mmask8 below = 0xFF, above = 0xFF;
        for (int c = 0; c < 3; ++c) {
          da[c] = gather8(in.den, v[c]);
          below &= _mm512_cmp_pd_mask(na[c], zero, _CMP_LE_OQ) &
                   _mm512_cmp_pd_mask(da[c], zero, _CMP_GE_OQ);
          above &= _mm512_cmp_pd_mask(na[c], zero, _CMP_GE_OQ) &
                   _mm512_cmp_pd_mask(da[c], zero, _CMP_LE_OQ);
        }
        reject = below | above;
      }
      live &= static_cast<__mmask8>(~reject);
    }
    if (!live) continue;
    Corners8 cs;
    rotate8(r1, r2, s, cs.s);
    rotate8(r1, r2, id, cs.id);
    const __m512d corner[3] = {zero, one, _mm512_set1_pd(2.0)};
    rotate8(r1, r2, corner, cs.corner);
    // (ones, not rotated, without a test function or denominator)
    for (int o = 0; o < 3; ++o) cs.na[o] = cs.da[o] = one;
    if (test) rotate8(r1, r2, na, cs.na);
    if (test && in.den) rotate8(r1, r2, da, cs.da);
    const Edge8 e1 = edge8(cs, 1), e2 = edge8(cs, 2);
    __m512d num1 = one, num2 = one, den1 = one, den2 = one, z1 = zero, z2 = zero;
    __mmask8 valid1 = 0xFF;
    if (test) {
      num1 = _mm512_add_pd(_mm512_mul_pd(e1.u, e1.n_lo), _mm512_mul_pd(e1.t, e1.n_hi));
      num2 = _mm512_add_pd(_mm512_mul_pd(e2.u, e2.n_lo), _mm512_mul_pd(e2.t, e2.n_hi));
      if (in.den) {
        den1 = _mm512_add_pd(_mm512_mul_pd(e1.u, e1.d_lo), _mm512_mul_pd(e1.t, e1.d_hi));
        den2 = _mm512_add_pd(_mm512_mul_pd(e2.u, e2.d_lo), _mm512_mul_pd(e2.t, e2.d_hi));
      }
      const __mmask8 n1p = _mm512_cmp_pd_mask(num1, zero, _CMP_GE_OQ);
      const __mmask8 n2p = _mm512_cmp_pd_mask(num2, zero, _CMP_GE_OQ);
      const __mmask8 d1p = _mm512_cmp_pd_mask(den1, zero, _CMP_GE_OQ);
      const __mmask8 d2p = _mm512_cmp_pd_mask(den2, zero, _CMP_GE_OQ);
      valid1 = static_cast<__mmask8>(~(n1p ^ d1p));
      const __m512d a = _mm512_maskz_div_pd(n1p ^ n2p, num1, _mm512_sub_pd(num1, num2));
      const __m512d b = _mm512_maskz_div_pd(d1p ^ d2p, den1, _mm512_sub_pd(den1, den2));
      const __mmask8 a_zero = _mm512_cmp_pd_mask(a, zero, _CMP_EQ_OQ);
      const __mmask8 b_first = _mm512_cmp_pd_mask(b, a, _CMP_LT_OQ);
      z1 = when8(a_zero, b, when8(b_first, b, a));
      z2 = when8(a_zero, zero, when8(b_first, a, b));
      const __mmask8 none = static_cast<__mmask8>(~valid1) &
                            _mm512_cmp_pd_mask(z1, zero, _CMP_EQ_OQ) &
                            _mm512_cmp_pd_mask(z2, zero, _CMP_EQ_OQ);
      live &= static_cast<__mmask8>(~none);
    }
    if (!live) continue;
    // The ends' barycentrics (u at lo, t at hi, 0 at the third corner),
    // the clip points at z1 and z2, and the strengths.
    __m512d b1[2], b2[2];
    edge_bary8(e1, b1);
    edge_bary8(e2, b2);
    LanePoints<8> lp;
    alignas(64) double zv[2][8];
    alignas(32) std::int32_t slot[2][8];
    _mm256_store_si256(
        reinterpret_cast<__m256i*>(slot[0]),
        _mm512_cvtpd_epi32(_mm512_sub_pd(_mm512_sub_pd(_mm512_set1_pd(3.0), e1.lo), e1.hi)));
    _mm256_store_si256(
        reinterpret_cast<__m256i*>(slot[1]),
        _mm512_cvtpd_epi32(_mm512_sub_pd(_mm512_sub_pd(_mm512_set1_pd(3.0), e2.lo), e2.hi)));
    lp.fade = fade;
    _mm512_store_pd(lp.t[0], e1.t);
    _mm512_store_pd(lp.t[3], e2.t);
    const __m512d zs[2] = {z1, z2};
    for (int i = 0; i < 2; ++i) {
      const __m512d z = zs[i], u = _mm512_sub_pd(one, z);
      for (int k = 0; k < 2; ++k)  // the third is 1 - the others (segments.hpp)
        _mm512_store_pd(lp.bary[1 + i][k],
                        _mm512_add_pd(_mm512_mul_pd(u, b1[k]), _mm512_mul_pd(z, b2[k])));
      _mm512_store_pd(zv[i], z);
      if (fade)
        _mm256_store_ps(
            lp.st[1 + i],
            fade_strength8(_mm512_add_pd(_mm512_mul_pd(u, num1), _mm512_mul_pd(z, num2)),
                           _mm512_add_pd(_mm512_mul_pd(u, den1), _mm512_mul_pd(z, den2)), vfade));
    }
    if (fade) {
      _mm256_store_ps(lp.st[0], fade_strength8(num1, den1, vfade));
      _mm256_store_ps(lp.st[3], fade_strength8(num2, den2, vfade));
    }
    emit_lanes(lp, live, valid1, zv, slot, list + j, topo, out);
  }
}

template void scalar_faces_avx512<StoredNum>(const ScalarInputs&, const StoredNum&,
                                             const std::size_t*, int, std::vector<LineSegment>&);
template void scalar_faces_avx512<ShiftedNum>(const ScalarInputs&, const ShiftedNum&,
                                              const std::size_t*, int, std::vector<LineSegment>&);

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

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
