// The AVX2 zero-crossing kernels (docs/algorithms.md §0 "ZC" and
// "ZC-vec"): four (or eight) faces per register, each lane evaluating the
// scalar kernel's operations in the same order (no FMA), so the same bits.
// Compiled for AVX2 by target attributes (the build stays x86-64 baseline)
// and called by zero_crossing_scalar.cpp only when detail::cpu_has_avx2().
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "simd_avx2.hpp"
#include "zero_crossing_kernel.hpp"

#if defined(FABRICA_LINES_AVX2)

namespace fabrica::zc {

// Rows a, b, c, d of a 4×4 block of doubles as its four columns.
[[gnu::target("avx2"), gnu::always_inline]] inline void transpose4(__m256d a, __m256d b, __m256d c,
                                                                   __m256d d, __m256d col[4]) {
  const __m256d t0 = _mm256_unpacklo_pd(a, b), t1 = _mm256_unpackhi_pd(a, b);
  const __m256d t2 = _mm256_unpacklo_pd(c, d), t3 = _mm256_unpackhi_pd(c, d);
  col[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  col[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  col[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  col[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// Per lane: x1 where r1, else x2 where r2, else x0.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d select3(__m256d r1, __m256d r2,
                                                                   __m256d x0, __m256d x1,
                                                                   __m256d x2) {
  return _mm256_blendv_pd(_mm256_blendv_pd(x0, x2, r2), x1, r1);
}

// mask ? x : y per lane.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d when(__m256d mask, __m256d x,
                                                                __m256d y) {
  return _mm256_blendv_pd(y, x, mask);
}

// a[v[l]] in lane l.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d gather4(const double* a,
                                                                   const int v[4]) {
  return _mm256_set_pd(a[v[3]], a[v[2]], a[v[1]], a[v[0]]);
}

// v[0..3] in the lanes, built in registers: a vector load of indices just
// stored one by one would wait for those stores (store forwarding fails;
// kept_segments_avx2 -8 % on igea).
[[gnu::target("avx2"), gnu::always_inline]] inline __m128i index4(const int v[4]) {
  return _mm_setr_epi32(v[0], v[1], v[2], v[3]);
}

// The test numerator at the lanes' vertices, as Num computes it.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d num4(const StoredNum& n,
                                                                const int v[4]) {
  return gather4(n.n, v);
}
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d num4(const ShiftedNum& n,
                                                                const int v[4]) {
  __m256d sc = gather4(n.sc, v);
  if (n.negate) sc = _mm256_xor_pd(sc, _mm256_set1_pd(-0.0));
  return _mm256_sub_pd(sc, _mm256_mul_pd(_mm256_set1_pd(n.shift), gather4(n.den, v)));
}

// fade_strength per lane (fade > 0), as a double holding the float.
[[gnu::target("avx2"), gnu::always_inline]] inline __m128 fade_strength4(__m256d num, __m256d den,
                                                                         __m256d fade) {
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d d = _mm256_add_pd(_mm256_mul_pd(den, fade), num);
  const __m256d q = _mm256_div_pd(num, d);
  const __m256d abs_q = _mm256_andnot_pd(_mm256_set1_pd(-0.0), q);
  __m256d r = when(_mm256_cmp_pd(abs_q, _mm256_set1_pd(HUGE_VAL), _CMP_LT_OQ), q, zero);
  r = when(_mm256_cmp_pd(r, zero, _CMP_LT_OQ), zero, r);
  r = when(_mm256_cmp_pd(one, r, _CMP_LT_OQ), one, r);
  r = when(_mm256_cmp_pd(d, zero, _CMP_EQ_OQ), zero, r);
  return _mm256_cvtpd_ps(r);
}

// lone_sign per lane.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d lone_sign4(__m256d a, __m256d b,
                                                                      __m256d c) {
  const __m256d zero = _mm256_setzero_pd();
  const __m256d lo = _mm256_and_pd(
      _mm256_cmp_pd(a, zero, _CMP_LT_OQ),
      _mm256_and_pd(_mm256_cmp_pd(b, zero, _CMP_GE_OQ), _mm256_cmp_pd(c, zero, _CMP_GE_OQ)));
  const __m256d hi = _mm256_and_pd(
      _mm256_cmp_pd(a, zero, _CMP_GT_OQ),
      _mm256_and_pd(_mm256_cmp_pd(b, zero, _CMP_LE_OQ), _mm256_cmp_pd(c, zero, _CMP_LE_OQ)));
  return _mm256_or_pd(lo, hi);
}

// Four faces' corners in lanes, rotated so that corner o is corner k + o
// (mod 3) of the face, k its first lone-sign corner: the value, vertex
// index, corner number, test numerator and denominator, and position.
struct Corners4 {
  __m256d s[3], id[3], corner[3], na[3], da[3], p[3][3];
};

// x rotated by k per lane (r1: k = 1, r2: k = 2, else 0).
[[gnu::target("avx2"), gnu::always_inline]] inline void rotate3(__m256d r1, __m256d r2,
                                                                const __m256d x[3],
                                                                __m256d out[3]) {
  for (int o = 0; o < 3; ++o) out[o] = select3(r1, r2, x[o], x[(o + 1) % 3], x[(o + 2) % 3]);
}

// scalar_edge and edge_end from corner 0 to corner o (of the rotated
// corners): the ends ordered by vertex index (corners lo, hi), t from the
// lower (u = 1 - t), the ends' test numerators and denominators, and the
// point.
struct Edge4 {
  __m256d lo, hi, t, u, n_lo, n_hi, d_lo, d_hi, p[3];
};
[[gnu::target("avx2"), gnu::always_inline]] inline Edge4 edge4(const Corners4& c, int o) {
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d sw = _mm256_cmp_pd(c.id[0], c.id[o], _CMP_GT_OQ);
  const __m256d va = when(sw, c.s[o], c.s[0]), vb = when(sw, c.s[0], c.s[o]);
  Edge4 e;
  e.lo = when(sw, c.corner[o], c.corner[0]);
  e.hi = when(sw, c.corner[0], c.corner[o]);
  const __m256d d = _mm256_sub_pd(va, vb);
  __m256d t = when(_mm256_cmp_pd(d, zero, _CMP_NEQ_UQ), _mm256_div_pd(va, d), _mm256_set1_pd(0.5));
  t = when(_mm256_cmp_pd(t, zero, _CMP_LT_OQ), zero, t);
  t = when(_mm256_cmp_pd(one, t, _CMP_LT_OQ), one, t);
  e.t = t;
  e.u = _mm256_sub_pd(one, t);
  e.n_lo = when(sw, c.na[o], c.na[0]);
  e.n_hi = when(sw, c.na[0], c.na[o]);
  e.d_lo = when(sw, c.da[o], c.da[0]);
  e.d_hi = when(sw, c.da[0], c.da[o]);
  for (int k = 0; k < 3; ++k)
    e.p[k] = _mm256_add_pd(_mm256_mul_pd(e.u, when(sw, c.p[o][k], c.p[0][k])),
                           _mm256_mul_pd(t, when(sw, c.p[0][k], c.p[o][k])));
  return e;
}

// An edge end's barycentrics per lane (u at corner lo, t at corner hi, 0
// at the third; edge_end and set_edge_end), and its edge's slot in the
// face, 3 - lo - hi.
[[gnu::target("avx2"), gnu::always_inline]] inline void edge_bary4(__m256d lo, __m256d hi,
                                                                   __m256d t, __m256d u,
                                                                   __m256d bary[3]) {
  const __m256d zero = _mm256_setzero_pd();
  for (int k = 0; k < 3; ++k) {
    const __m256d ck = _mm256_set1_pd(double(k));
    bary[k] = when(_mm256_cmp_pd(lo, ck, _CMP_EQ_OQ), u,
                   when(_mm256_cmp_pd(hi, ck, _CMP_EQ_OQ), t, zero));
  }
}
[[gnu::target("avx2"), gnu::always_inline]] inline void edge_slot4(__m256d lo, __m256d hi,
                                                                   std::int32_t slot[4]) {
  _mm_storeu_si128(reinterpret_cast<__m128i*>(slot),
                   _mm256_cvtpd_epi32(_mm256_sub_pd(_mm256_sub_pd(_mm256_set1_pd(3.0), lo), hi)));
}

// scalar_face_body for the listed faces (no magnitude threshold), four at
// a time: each lane evaluates its expressions in the same operations (so
// the same bits), the points
// and strengths of all four faces without branches; the segments are then
// written lane by lane, in face order, as scalar_face_body writes them.
template <class Num>
[[gnu::target("avx2")]] void scalar_faces_avx2(const ScalarInputs& in, const Num& num,
                                               const std::size_t* list, int n,
                                               std::vector<LineSegment>& out) {
  const Face* faces = in.m.faces;
  const Vec3* pos = in.m.pos;
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
  const bool test = in.test, fade = in.fade > 0.0;
  const __m256d vfade = _mm256_set1_pd(in.fade);
  for (int j = 0; j < n; j += 4) {
    const int lanes = std::min(4, n - j);
    alignas(16) int v[3][4];  // unused lanes repeat lane 0
    for (int l = 0; l < 4; ++l) {
      const Face& fc = faces[list[j + (l < lanes ? l : 0)]];
      for (int c = 0; c < 3; ++c) v[c][l] = fc[c];
    }
    __m256d s[3], id[3];
    for (int c = 0; c < 3; ++c) {
      s[c] = gather4(in.val, v[c]);
      id[c] = _mm256_cvtepi32_pd(index4(v[c]));
    }
    // lone_sign at corner 0, 1, 2; the first one is k.
    const __m256d l0 = lone_sign4(s[0], s[1], s[2]), l1 = lone_sign4(s[1], s[2], s[0]);
    const __m256d l2 = lone_sign4(s[2], s[0], s[1]);
    __m256d live = _mm256_or_pd(l0, _mm256_or_pd(l1, l2));
    const __m256d r1 = _mm256_andnot_pd(l0, l1);                    // k = 1
    const __m256d r2 = _mm256_andnot_pd(_mm256_or_pd(l0, l1), l2);  // k = 2
    if (in.cull) {
      __m256d culled = all;
      for (int c = 0; c < 3; ++c)
        culled = _mm256_and_pd(culled, _mm256_cmp_pd(gather4(in.cull, v[c]), zero, _CMP_LE_OQ));
      live = _mm256_andnot_pd(culled, live);
    }
    __m256d na[3] = {one, one, one}, da[3] = {one, one, one};
    if (test) {
      for (int c = 0; c < 3; ++c) na[c] = num4(num, v[c]);
      __m256d reject;
      if (!in.den) {
        reject = all;
        for (int c = 0; c < 3; ++c)
          reject = _mm256_and_pd(reject, _mm256_cmp_pd(na[c], zero, _CMP_LE_OQ));
      } else {
        __m256d below = all, above = all;
        for (int c = 0; c < 3; ++c) {
          da[c] = gather4(in.den, v[c]);
          below = _mm256_and_pd(below, _mm256_and_pd(_mm256_cmp_pd(na[c], zero, _CMP_LE_OQ),
                                                     _mm256_cmp_pd(da[c], zero, _CMP_GE_OQ)));
          above = _mm256_and_pd(above, _mm256_and_pd(_mm256_cmp_pd(na[c], zero, _CMP_GE_OQ),
                                                     _mm256_cmp_pd(da[c], zero, _CMP_LE_OQ)));
        }
        reject = _mm256_or_pd(below, above);
      }
      live = _mm256_andnot_pd(reject, live);
    }
    const int live_bits = _mm256_movemask_pd(live) & ((1 << lanes) - 1);
    if (!live_bits) continue;
    // Positions: per corner, the four rows (x, y, z, 0) as columns.
    __m256d P[3][4];
    for (int c = 0; c < 3; ++c)
      transpose4(_mm256_maskload_pd(pos[v[c][0]].data(), xyz),
                 _mm256_maskload_pd(pos[v[c][1]].data(), xyz),
                 _mm256_maskload_pd(pos[v[c][2]].data(), xyz),
                 _mm256_maskload_pd(pos[v[c][3]].data(), xyz), P[c]);
    Corners4 cs;
    rotate3(r1, r2, s, cs.s);
    rotate3(r1, r2, id, cs.id);
    const __m256d corner[3] = {zero, one, _mm256_set1_pd(2.0)};
    rotate3(r1, r2, corner, cs.corner);
    // (ones, not rotated, without a test function or denominator)
    for (int o = 0; o < 3; ++o) cs.na[o] = cs.da[o] = one;
    if (test) rotate3(r1, r2, na, cs.na);
    if (test && in.den) rotate3(r1, r2, da, cs.da);
    for (int k = 0; k < 3; ++k) {
      const __m256d pk[3] = {P[0][k], P[1][k], P[2][k]};
      __m256d rk[3];
      rotate3(r1, r2, pk, rk);
      for (int o = 0; o < 3; ++o) cs.p[o][k] = rk[o];
    }
    const Edge4 e1 = edge4(cs, 1), e2 = edge4(cs, 2);
    __m256d num1 = one, num2 = one, den1 = one, den2 = one, z1 = zero, z2 = zero;
    __m256d valid1 = all;
    if (test) {
      num1 = _mm256_add_pd(_mm256_mul_pd(e1.u, e1.n_lo), _mm256_mul_pd(e1.t, e1.n_hi));
      num2 = _mm256_add_pd(_mm256_mul_pd(e2.u, e2.n_lo), _mm256_mul_pd(e2.t, e2.n_hi));
      if (in.den) {
        den1 = _mm256_add_pd(_mm256_mul_pd(e1.u, e1.d_lo), _mm256_mul_pd(e1.t, e1.d_hi));
        den2 = _mm256_add_pd(_mm256_mul_pd(e2.u, e2.d_lo), _mm256_mul_pd(e2.t, e2.d_hi));
      }
      const __m256d n1p = _mm256_cmp_pd(num1, zero, _CMP_GE_OQ);
      const __m256d n2p = _mm256_cmp_pd(num2, zero, _CMP_GE_OQ);
      const __m256d d1p = _mm256_cmp_pd(den1, zero, _CMP_GE_OQ);
      const __m256d d2p = _mm256_cmp_pd(den2, zero, _CMP_GE_OQ);
      valid1 = _mm256_xor_pd(_mm256_xor_pd(n1p, d1p), all);
      const __m256d a =
          when(_mm256_xor_pd(n1p, n2p), _mm256_div_pd(num1, _mm256_sub_pd(num1, num2)), zero);
      const __m256d b =
          when(_mm256_xor_pd(d1p, d2p), _mm256_div_pd(den1, _mm256_sub_pd(den1, den2)), zero);
      const __m256d a_zero = _mm256_cmp_pd(a, zero, _CMP_EQ_OQ);
      const __m256d b_first = _mm256_cmp_pd(b, a, _CMP_LT_OQ);
      z1 = when(a_zero, b, when(b_first, b, a));
      z2 = when(a_zero, zero, when(b_first, a, b));
      const __m256d none = _mm256_andnot_pd(
          valid1,
          _mm256_and_pd(_mm256_cmp_pd(z1, zero, _CMP_EQ_OQ), _mm256_cmp_pd(z2, zero, _CMP_EQ_OQ)));
      live = _mm256_andnot_pd(none, live);
    }
    int emit = _mm256_movemask_pd(live) & ((1 << lanes) - 1);
    if (!emit) continue;
    // The ends' barycentrics (u at lo, t at hi, 0 at the third corner),
    // the clip points at z1 and z2, and the strengths.
    __m256d b1[3], b2[3];
    edge_bary4(e1.lo, e1.hi, e1.t, e1.u, b1);
    edge_bary4(e2.lo, e2.hi, e2.t, e2.u, b2);
    LanePoints<4> lp;
    alignas(32) double zv[2][4];
    std::int32_t slot[2][4];
    edge_slot4(e1.lo, e1.hi, slot[0]);
    edge_slot4(e2.lo, e2.hi, slot[1]);
    lp.fade = fade;
    _mm256_store_pd(lp.t[0], e1.t);
    _mm256_store_pd(lp.t[3], e2.t);
    const __m256d zs[2] = {z1, z2};
    for (int i = 0; i < 2; ++i) {
      const __m256d z = zs[i], u = _mm256_sub_pd(one, z);
      for (int k = 0; k < 2; ++k)  // the third is 1 - the others (segments.hpp)
        _mm256_store_pd(lp.bary[1 + i][k],
                        _mm256_add_pd(_mm256_mul_pd(u, b1[k]), _mm256_mul_pd(z, b2[k])));
      _mm256_store_pd(zv[i], z);
      if (fade)
        _mm_store_ps(
            lp.st[1 + i],
            fade_strength4(_mm256_add_pd(_mm256_mul_pd(u, num1), _mm256_mul_pd(z, num2)),
                           _mm256_add_pd(_mm256_mul_pd(u, den1), _mm256_mul_pd(z, den2)), vfade));
    }
    if (fade) {
      _mm_store_ps(lp.st[0], fade_strength4(num1, den1, vfade));
      _mm_store_ps(lp.st[3], fade_strength4(num2, den2, vfade));
    }
    emit_lanes(lp, static_cast<unsigned>(emit), static_cast<unsigned>(_mm256_movemask_pd(valid1)),
               zv, slot, list + j, *in.m.topo, out);
  }
}

template void scalar_faces_avx2<StoredNum>(const ScalarInputs&, const StoredNum&,
                                           const std::size_t*, int, std::vector<LineSegment>&);
template void scalar_faces_avx2<ShiftedNum>(const ScalarInputs&, const ShiftedNum&,
                                            const std::size_t*, int, std::vector<LineSegment>&);

// E (x, y, z) of four vertices from their records (ApparentVertex, whose
// first four doubles are E and D_t1 q1), one lane each.
[[gnu::target("avx2"), gnu::always_inline]] inline void load_field4(const double* E, int a, int b,
                                                                    int c, int d, __m256d e[4]) {
  transpose4(_mm256_load_pd(E + std::size_t(a) * kApparentStride),
             _mm256_load_pd(E + std::size_t(b) * kApparentStride),
             _mm256_load_pd(E + std::size_t(c) * kApparentStride),
             _mm256_load_pd(E + std::size_t(d) * kApparentStride), e);
}

// For each 8-bit mask, the indices of its set bits in ascending order, one
// byte each (unused bytes 0): the lane permutation that packs the selected
// lanes to the front.
constexpr std::array<std::uint64_t, 256> kPackLanes = [] {
  std::array<std::uint64_t, 256> t{};
  for (unsigned m = 0; m < 256; ++m) {
    int n = 0;
    for (unsigned l = 0; l < 8; ++l)
      if (m >> l & 1) t[m] |= std::uint64_t{l} << (8 * n++);
  }
  return t;
}();

// Appends the lanes of `idx` selected by `mask` to out[n...] (writing all
// eight lanes: out needs room for eight past n) and advances n.
// The permutation of kPackLanes[mask] as a vpermd index vector.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256i pack_lanes(unsigned mask) {
  return _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(&kPackLanes[mask])));
}

[[gnu::target("avx2"), gnu::always_inline]] inline void append_lanes(__m256i idx, unsigned mask,
                                                                     std::uint32_t* out,
                                                                     std::size_t& n) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + n),
                      _mm256_permutevar8x32_epi32(idx, pack_lanes(mask)));
  n += static_cast<std::size_t>(std::popcount(mask));
}

// Lanes where E_a·E_b <= 0 (Eigen's dot order), as a compare mask.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d dot_le0(const __m256d a[4],
                                                                   const __m256d b[4]) {
  return _mm256_cmp_pd(detail::dot4(a[0], a[1], a[2], b[0], b[1], b[2]), _mm256_setzero_pd(),
                       _CMP_LE_OQ);
}

// keep_if_crossed for n listed faces, four at a time: the crossing bits
// from the four faces' records in lanes, and the faces with two crossings
// packed onto the end of `kept`, in order, through kPackLanes (writing
// eight indices and four bytes; `kept` holds at most the faces before
// these four, and KeptFaces::f has eight entries of room past them).
[[gnu::target("avx2")]] void keep_crossed_avx2(const Face* faces, const std::uint32_t* face, int n,
                                               const double* E, const Topology& topo,
                                               KeptFaces& kept) {
  const __m256i bit[3] = {_mm256_set1_epi64x(1), _mm256_set1_epi64x(2), _mm256_set1_epi64x(4)};
  const __m256i low32 = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
  const __m128i low_bytes =
      _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const Face &f0 = faces[face[k]], &f1 = faces[face[k + 1]], &f2 = faces[face[k + 2]],
               &f3 = faces[face[k + 3]];
    for (int l = 0; l < 4; ++l) __builtin_prefetch(topo.face_edge_row(face[k + l]));
    __m256d e[3][4];
    for (int c = 0; c < 3; ++c) load_field4(E, f0[c], f1[c], f2[c], f3[c], e[c]);
    const __m256d c01 = dot_le0(e[0], e[1]), c12 = dot_le0(e[1], e[2]), c20 = dot_le0(e[2], e[0]);
    const __m256d two = _mm256_or_pd(_mm256_or_pd(_mm256_and_pd(c01, c12), _mm256_and_pd(c12, c20)),
                                     _mm256_and_pd(c20, c01));
    const unsigned m = static_cast<unsigned>(_mm256_movemask_pd(two));
    if (!m) continue;
    const __m256i z =
        _mm256_or_si256(_mm256_or_si256(_mm256_and_si256(_mm256_castpd_si256(c01), bit[0]),
                                        _mm256_and_si256(_mm256_castpd_si256(c12), bit[1])),
                        _mm256_and_si256(_mm256_castpd_si256(c20), bit[2]));
    // The kept lanes' bits (the low byte of each lane's 32-bit word, packed
    // as the face indices are) and face indices.
    const __m256i z32 =
        _mm256_permutevar8x32_epi32(_mm256_permutevar8x32_epi32(z, low32), pack_lanes(m));
    const int zb = _mm_cvtsi128_si32(_mm_shuffle_epi8(_mm256_castsi256_si128(z32), low_bytes));
    std::memcpy(kept.z + kept.n, &zb, 4);
    append_lanes(
        _mm256_zextsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(face + k))), m,
        kept.f, kept.n);
  }
  for (; k < n; ++k) keep_if_crossed(face[k], crossing_bits_of(faces[face[k]], E), topo, kept);
}

// Lanes passing SignTest::pass for (any, all), as a bit mask.
[[gnu::target("avx2"), gnu::always_inline]] inline unsigned pass_lanes(const SignTest& t,
                                                                       __m256i any, __m256i all) {
  const __m256i zero = _mm256_setzero_si256();
  const __m256i no_side = _mm256_cmpeq_epi32(
      _mm256_and_si256(_mm256_andnot_si256(all, any), _mm256_set1_epi32(int(t.sides))), zero);
  const __m256i culled_ok =
      _mm256_cmpeq_epi32(_mm256_andnot_si256(any, _mm256_set1_epi32(int(t.cull))), zero);
  const __m256i kept =
      _mm256_cmpeq_epi32(_mm256_and_si256(all, _mm256_set1_epi32(int(t.reject))), zero);
  return static_cast<unsigned>(_mm256_movemask_ps(
      _mm256_castsi256_ps(_mm256_and_si256(_mm256_andnot_si256(no_side, culled_ok), kept))));
}

// The face scan of fused_crossings eight faces at a time: the corners'
// sign bytes gathered (four bytes from each corner's, the other three
// masked off; a group with a corner among the last three vertices is
// scanned face by face, so nothing past the array is read), the three
// tests per lane, and the passing faces appended in order. Returns the
// first face not scanned (fewer than eight are left).
[[gnu::target("avx2")]] std::size_t scan_faces_avx2(const Face* faces, std::size_t b, std::size_t e,
                                                    std::size_t vertex_count,
                                                    const std::uint8_t* sg, const SignTest& ct,
                                                    const SignTest& stt, unsigned listed_bit,
                                                    std::uint32_t* cc, std::uint32_t* sc,
                                                    std::uint32_t* lf, std::size_t& nc,
                                                    std::size_t& ns, std::size_t& nl) {
  static_assert(sizeof(Face) == 3 * sizeof(std::int32_t));
  if (vertex_count < 4) return b;
  const __m256i last = _mm256_set1_epi32(static_cast<int>(vertex_count - 4));
  const __m256i byte = _mm256_set1_epi32(0xFF), lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i listed = _mm256_set1_epi32(int(listed_bit)), zero = _mm256_setzero_si256();
  // Corner k of the eight faces from the 24 indices in three registers:
  // blend the lanes holding it together, then put them in face order.
  const __m256i order0 = _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5);
  const __m256i order1 = _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6);
  const __m256i order2 = _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7);
  const auto* sg32 = reinterpret_cast<const int*>(sg);
  std::size_t f = b;
  for (; f + 8 <= e; f += 8) {
    const auto* q = reinterpret_cast<const __m256i*>(faces[f].data());
    const __m256i x = _mm256_loadu_si256(q), y = _mm256_loadu_si256(q + 1),
                  z = _mm256_loadu_si256(q + 2);
    const __m256i c0 = _mm256_permutevar8x32_epi32(
        _mm256_blend_epi32(_mm256_blend_epi32(x, y, 0x92), z, 0x24), order0);
    const __m256i c1 = _mm256_permutevar8x32_epi32(
        _mm256_blend_epi32(_mm256_blend_epi32(x, y, 0x24), z, 0x49), order1);
    const __m256i c2 = _mm256_permutevar8x32_epi32(
        _mm256_blend_epi32(_mm256_blend_epi32(x, y, 0x49), z, 0x92), order2);
    const __m256i past = _mm256_cmpgt_epi32(_mm256_max_epi32(_mm256_max_epi32(c0, c1), c2), last);
    if (!_mm256_testz_si256(past, past)) {
      for (std::size_t g = f; g < f + 8; ++g)
        scan_face(faces, g, sg, ct, stt, listed_bit, cc, sc, lf, nc, ns, nl);
      continue;
    }
    const __m256i a0 = _mm256_and_si256(_mm256_i32gather_epi32(sg32, c0, 1), byte);
    const __m256i a1 = _mm256_and_si256(_mm256_i32gather_epi32(sg32, c1, 1), byte);
    const __m256i a2 = _mm256_and_si256(_mm256_i32gather_epi32(sg32, c2, 1), byte);
    const __m256i any = _mm256_or_si256(_mm256_or_si256(a0, a1), a2);
    const __m256i all = _mm256_and_si256(_mm256_and_si256(a0, a1), a2);
    const __m256i idx = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(f)), lanes);
    append_lanes(idx, pass_lanes(ct, any, all), cc, nc);
    append_lanes(idx, pass_lanes(stt, any, all), sc, ns);
    const unsigned not_listed = static_cast<unsigned>(_mm256_movemask_ps(
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(any, listed), zero))));
    append_lanes(idx, ~not_listed & 0xFFu, lf, nl);
  }
  return f;
}

// One face corner's record (ApparentVertex) for four faces, one lane each:
// E (x, y, z), D_t1 q1, q1, position (x, y, z), and the vertex index.
struct Corner4 {
  __m256d e[3], d, q, p[3], id;
};
[[gnu::target("avx2"), gnu::always_inline]] inline Corner4 load_corner4(const double* field,
                                                                        const int v[4]) {
  const double* r[4];
  for (int l = 0; l < 4; ++l) r[l] = field + std::size_t(v[l]) * kApparentStride;
  __m256d lo[4], hi[4];
  transpose4(_mm256_load_pd(r[0]), _mm256_load_pd(r[1]), _mm256_load_pd(r[2]), _mm256_load_pd(r[3]),
             lo);
  transpose4(_mm256_load_pd(r[0] + 4), _mm256_load_pd(r[1] + 4), _mm256_load_pd(r[2] + 4),
             _mm256_load_pd(r[3] + 4), hi);
  Corner4 c;
  c.e[0] = lo[0], c.e[1] = lo[1], c.e[2] = lo[2], c.d = lo[3];
  c.q = hi[0], c.p[0] = hi[1], c.p[1] = hi[2], c.p[2] = hi[3];
  c.id = _mm256_cvtepi32_pd(index4(v));
  return c;
}

// One end of a cut (its derivative, magnitude and position), per lane.
struct End4 {
  __m256d d, q, p[3];
};
[[gnu::target("avx2"), gnu::always_inline]] inline End4 pick_end4(__m256d m, const End4& a,
                                                                  const End4& b) {
  End4 r;
  r.d = _mm256_blendv_pd(b.d, a.d, m);
  r.q = _mm256_blendv_pd(b.q, a.q, m);
  for (int k = 0; k < 3; ++k) r.p[k] = _mm256_blendv_pd(b.p[k], a.p[k], m);
  return r;
}

// vector_edge and cut_point for four cuts (ends ordered lo, hi): t from
// the lower vertex, the magnitude m, k = max(m - th, 0) and the point, in
// vector_segment's operations.
struct Cut4 {
  __m256d t, m, k, p[3];
};
[[gnu::target("avx2"), gnu::always_inline]] inline Cut4 cut4(const End4& lo, const End4& hi,
                                                             __m256d th) {
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
  const __m256d da = _mm256_and_pd(lo.d, abs_mask), db = _mm256_and_pd(hi.d, abs_mask);
  const __m256d sum = _mm256_add_pd(da, db);
  Cut4 c;
  c.t = detail::pick4(_mm256_cmp_pd(sum, zero, _CMP_GT_OQ), _mm256_div_pd(da, sum),
                      _mm256_set1_pd(0.5));
  const __m256d u = _mm256_sub_pd(one, c.t);
  c.m = _mm256_and_pd(_mm256_add_pd(_mm256_mul_pd(u, lo.q), _mm256_mul_pd(c.t, hi.q)), abs_mask);
  c.k = _mm256_max_pd(zero, _mm256_sub_pd(c.m, th));
  for (int k = 0; k < 3; ++k)
    c.p[k] = _mm256_add_pd(_mm256_mul_pd(u, lo.p[k]), _mm256_mul_pd(c.t, hi.p[k]));
  return c;
}

// The same segments, four faces at a time: each lane evaluates
// vector_segment<false>'s expressions in the same operations (so the same
// bits), from the four faces' records transposed into lanes; faces crossed
// on all three edges (the centroid case) and the output records stay
// scalar, in face order.
[[gnu::target("avx2")]] void kept_segments_avx2(const VectorInputs& in, const double* field,
                                                const KeptFaces& kept,
                                                std::vector<LineSegment>& out) {
  const SegmentParams sp{in.o.threshold, in.o.test == ExtremumTest::perpendicular,
                         in.o.keep_raw_magnitude};
  const Face* faces = in.m.faces;
  const Topology& topo = *in.m.topo;
  const __m256d zero = _mm256_setzero_pd();
  const __m256d th = _mm256_set1_pd(sp.threshold);
  for (std::size_t j = 0; j < kept.n; j += 4) {
    const int lanes = static_cast<int>(std::min<std::size_t>(4, kept.n - j));
    // Unused lanes repeat lane 0.
    alignas(16) int v[3][4];
    std::int64_t rot[2][4];
    for (int l = 0; l < 4; ++l) {
      const int src = l < lanes ? l : 0;
      const Face& fg = faces[kept.f[j + src]];
      for (int c = 0; c < 3; ++c) v[c][l] = fg[c];
      const int c0 = first_corner(kept.z[j + src]);
      rot[0][l] = -std::int64_t(c0 == 1);
      rot[1][l] = -std::int64_t(c0 == 2);
    }
    // (the masks built in registers, as index4)
    const __m256d r1 =
        _mm256_castsi256_pd(_mm256_setr_epi64x(rot[0][0], rot[0][1], rot[0][2], rot[0][3]));
    const __m256d r2 =
        _mm256_castsi256_pd(_mm256_setr_epi64x(rot[1][0], rot[1][1], rot[1][2], rot[1][3]));
    const Corner4 C[3] = {load_corner4(field, v[0]), load_corner4(field, v[1]),
                          load_corner4(field, v[2])};
    // The corners c0, c1, c2 of the segment (rotations of 0, 1, 2).
    End4 e[3];
    __m256d id[3];
    for (int s = 0; s < 3; ++s) {
      e[s].d = select3(r1, r2, C[s].d, C[(s + 1) % 3].d, C[(s + 2) % 3].d);
      e[s].q = select3(r1, r2, C[s].q, C[(s + 1) % 3].q, C[(s + 2) % 3].q);
      for (int k = 0; k < 3; ++k)
        e[s].p[k] = select3(r1, r2, C[s].p[k], C[(s + 1) % 3].p[k], C[(s + 2) % 3].p[k]);
      id[s] = select3(r1, r2, C[s].id, C[(s + 1) % 3].id, C[(s + 2) % 3].id);
    }
    // Edge a joins c0 and c1, edge b c1 and c2; each from its lower vertex.
    const __m256d swap_a = _mm256_cmp_pd(id[0], id[1], _CMP_GT_OQ);
    const __m256d swap_b = _mm256_cmp_pd(id[1], id[2], _CMP_GT_OQ);
    const Cut4 a = cut4(pick_end4(swap_a, e[1], e[0]), pick_end4(swap_a, e[0], e[1]), th);
    const Cut4 b = cut4(pick_end4(swap_b, e[2], e[1]), pick_end4(swap_b, e[1], e[2]), th);
    __m256d reject =
        _mm256_and_pd(_mm256_cmp_pd(a.k, zero, _CMP_EQ_OQ), _mm256_cmp_pd(b.k, zero, _CMP_EQ_OQ));
    if (sp.perpendicular) {
      // perpendicular_rejects: n from the face's corners in face order,
      // q = n × (pa - pb), and E·q at c0, c1, c2.
      const __m256d u0 = _mm256_sub_pd(C[1].p[0], C[0].p[0]);
      const __m256d u1 = _mm256_sub_pd(C[1].p[1], C[0].p[1]);
      const __m256d u2 = _mm256_sub_pd(C[1].p[2], C[0].p[2]);
      const __m256d w0 = _mm256_sub_pd(C[2].p[0], C[0].p[0]);
      const __m256d w1 = _mm256_sub_pd(C[2].p[1], C[0].p[1]);
      const __m256d w2 = _mm256_sub_pd(C[2].p[2], C[0].p[2]);
      const __m256d n0 = _mm256_sub_pd(_mm256_mul_pd(u1, w2), _mm256_mul_pd(u2, w1));
      const __m256d n1 = _mm256_sub_pd(_mm256_mul_pd(u2, w0), _mm256_mul_pd(u0, w2));
      const __m256d n2 = _mm256_sub_pd(_mm256_mul_pd(u0, w1), _mm256_mul_pd(u1, w0));
      const __m256d d0 = _mm256_sub_pd(a.p[0], b.p[0]), d1 = _mm256_sub_pd(a.p[1], b.p[1]),
                    d2 = _mm256_sub_pd(a.p[2], b.p[2]);
      const __m256d q0 = _mm256_sub_pd(_mm256_mul_pd(n1, d2), _mm256_mul_pd(n2, d1));
      const __m256d q1 = _mm256_sub_pd(_mm256_mul_pd(n2, d0), _mm256_mul_pd(n0, d2));
      const __m256d q2 = _mm256_sub_pd(_mm256_mul_pd(n0, d1), _mm256_mul_pd(n1, d0));
      __m256d D[3];
      for (int c = 0; c < 3; ++c) D[c] = detail::dot4(C[c].e[0], C[c].e[1], C[c].e[2], q0, q1, q2);
      reject =
          _mm256_or_pd(reject, _mm256_cmp_pd(select3(r1, r2, D[0], D[1], D[2]), zero, _CMP_LE_OQ));
      reject =
          _mm256_or_pd(reject, _mm256_cmp_pd(select3(r1, r2, D[1], D[2], D[0]), zero, _CMP_GE_OQ));
      reject =
          _mm256_or_pd(reject, _mm256_cmp_pd(select3(r1, r2, D[2], D[0], D[1]), zero, _CMP_LE_OQ));
    }
    // The lanes that give output, in lane (face) order: kept segments and
    // centroid faces (visited by their set bits: no branch per lane).
    int centroid = 0;
    for (int l = 0; l < lanes; ++l) centroid |= int(kept.z[j + l] == 7) << l;
    const int emit = ((~_mm256_movemask_pd(reject) & ((1 << lanes) - 1)) | centroid);
    if (!emit) continue;
    // The ends as LanePoints 0 (a) and 3 (b): their fractions t from the
    // lower corner (the barycentrics and points are recomputed from them,
    // segments.hpp), and ridge_strength.
    LanePoints<4> lp;
    lp.fade = sp.raw || sp.threshold > 0.0;
    if (sp.raw) {
      _mm_store_ps(lp.st[0], _mm256_cvtpd_ps(a.m));
      _mm_store_ps(lp.st[3], _mm256_cvtpd_ps(b.m));
    } else if (lp.fade) {
      _mm_store_ps(lp.st[0], _mm256_cvtpd_ps(_mm256_div_pd(a.k, _mm256_add_pd(a.k, th))));
      _mm_store_ps(lp.st[3], _mm256_cvtpd_ps(_mm256_div_pd(b.k, _mm256_add_pd(b.k, th))));
    }
    const __m256d corner[3] = {zero, _mm256_set1_pd(1.0), _mm256_set1_pd(2.0)};
    __m256d c[3];  // the corner numbers c0, c1, c2
    rotate3(r1, r2, corner, c);
    const __m256d alo = when(swap_a, c[1], c[0]), ahi = when(swap_a, c[0], c[1]);
    const __m256d blo = when(swap_b, c[2], c[1]), bhi = when(swap_b, c[1], c[2]);
    _mm256_store_pd(lp.t[0], a.t);
    _mm256_store_pd(lp.t[3], b.t);
    std::int32_t slot[2][4];
    edge_slot4(alo, ahi, slot[0]);
    edge_slot4(blo, bhi, slot[1]);
    for (int bits = emit; bits; bits &= bits - 1) {
      const int l = std::countr_zero(static_cast<unsigned>(bits));
      const std::size_t f = kept.f[j + l];
      if (centroid >> l & 1) {
        const Face& fg = faces[f];
        const int vv[3] = {fg[0], fg[1], fg[2]};
        const Vec3 E[3] = {field_at(field, fg[0]), field_at(field, fg[1]), field_at(field, fg[2])};
        vector_centroid_segments(in, sp, f, vv, E, out);
        continue;
      }
      lp.el[0] = topo.face_edge(f, slot[0][l]);
      lp.el[3] = topo.face_edge(f, slot[1][l]);
      out.emplace_back(LaneSegment<4>{lp, static_cast<std::int32_t>(f), l, 0, 3});
    }
  }
}

}  // namespace fabrica::zc

#endif
