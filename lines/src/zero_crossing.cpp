#include "fabrica/lines/zero_crossing.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "fabrica/core/error.hpp"
#include "parallel.hpp"
#include "simd_avx2.hpp"
#include "zero_crossing_internal.hpp"

namespace fabrica {

namespace {

// The mesh arrays every face kernel reads, looked up once per call (not per
// endpoint: Surface::topology() is a call_once).
struct MeshArrays {
  const Face* faces;
  const Vec3* pos;
  const Topology* topo;
  explicit MeshArrays(const Surface& s)
      : faces(s.faces().data()), pos(s.positions().data()), topo(&s.topology()) {}
};

// An endpoint of the scalar kernel before it is written to its segment:
// plain doubles (no Eigen temporaries, no default initialisation), copied
// once into the output record.
struct ScalarEnd {
  double bary[3];
  double pos[3];
  std::int32_t element;
  EndKind kind;
  float strength;
};

// Fraction along the edge from the vertex with the lower index, from values
// (va at ia, vb at ib): returns (corner of the lower vertex, t).
struct EdgeParam {
  int c_lo, c_hi;
  double t;
};
inline EdgeParam scalar_edge(const Face& face, int ca, int cb, double va, double vb) {
  if (face[ca] > face[cb]) {
    std::swap(ca, cb);
    std::swap(va, vb);
  }
  const double d = va - vb;
  double t = d != 0.0 ? va / d : 0.5;
  t = std::clamp(t, 0.0, 1.0);
  return {ca, cb, t};
}

// The endpoint on edge e of face f (vertices v): bary (1-t) at the lower
// corner and t at the other, position (1-t) p_lo + t p_hi per component.
[[gnu::always_inline]] inline void edge_end(const MeshArrays& m, std::size_t f, const int v[3],
                                            const EdgeParam& e, ScalarEnd& p) {
  const double u = 1.0 - e.t;
  p.bary[0] = p.bary[1] = p.bary[2] = 0.0;
  p.bary[e.c_lo] = u;
  p.bary[e.c_hi] = e.t;
  const Vec3& a = m.pos[v[e.c_lo]];
  const Vec3& b = m.pos[v[e.c_hi]];
  p.pos[0] = u * a[0] + e.t * b[0];
  p.pos[1] = u * a[1] + e.t * b[1];
  p.pos[2] = u * a[2] + e.t * b[2];
  p.element = m.topo->face_edge(f, 3 - e.c_lo - e.c_hi);
  p.kind = EndKind::edge;
}

// The point at fraction z from a to b inside the face (a test-function
// clip), each component (1-z) a_k + z b_k.
inline void lerp_end(const ScalarEnd& a, const ScalarEnd& b, double z, ScalarEnd& p) {
  const double u = 1.0 - z;
  for (int k = 0; k < 3; ++k) {
    p.bary[k] = u * a.bary[k] + z * b.bary[k];
    p.pos[k] = u * a.pos[k] + z * b.pos[k];
  }
  p.element = -1;
  p.kind = EndKind::interior;
}

inline float fade_strength(double num, double den, double fade) {
  if (fade <= 0.0) return 1.0f;
  const double d = den * fade + num;
  if (d == 0.0) return 0.0f;
  const double s = num / d;
  return static_cast<float>(std::clamp(std::isfinite(s) ? s : 0.0, 0.0, 1.0));
}

inline bool lone_sign(double a, double b, double c) {
  return (a < 0.0 && b >= 0.0 && c >= 0.0) || (a > 0.0 && b <= 0.0 && c <= 0.0);
}

// Test numerators: stored per vertex, or N_i = ±sc_i - shift * D_i computed
// at the few corners that need it (suggestive contours and highlights; the
// same expression as a stored array would hold, so the same bits).
struct StoredNum {
  const double* n;
  double operator()(std::size_t i) const { return n[i]; }
  void prefetch(std::size_t i) const {
    if (n) __builtin_prefetch(n + i);
  }
};
struct ShiftedNum {
  const double* sc;
  const double* den;
  bool negate;
  double shift;
  static ShiftedNum of(const detail::SuggestiveTest& t) {
    return ShiftedNum{t.sc_num.data(), t.ndotv.data(), t.negate, t.shift};
  }
  double operator()(std::size_t i) const {
    const double n = negate ? -sc[i] : sc[i];
    return n - shift * den[i];
  }
  void prefetch(std::size_t i) const { __builtin_prefetch(sc + i); }
};

// Faces that passed the quick rejection, processed in groups (in face
// order, so the output is unchanged) after their corners' data have been
// prefetched: the slow path's scattered loads then overlap instead of
// waiting one after another, and its first data-dependent rejection can be
// evaluated for the whole group without branches.
struct CandidateBatch {
  static constexpr int kSize = 16;
  std::size_t face[kSize];
  int n = 0;
  bool add(std::size_t f) {
    face[n++] = f;
    return n == kSize;
  }
};

struct ScalarInputs {
  MeshArrays m;
  const double* val;
  const double* cull;  // nullptr: no culling
  const double* den;   // nullptr: denominator 1
  bool test;
  double fade;
  // Optional threshold on a per-vertex magnitude interpolated at the ends
  // (PELs, Laplacian lines): a segment whose ends both have m <= mag_t is
  // dropped, and the strengths are multiplied by (m - t)/m. nullptr: none.
  const double* mag = nullptr;
  double mag_t = 0.0;
};

// Writes segment (a, b) of face f (vertices v), after the magnitude
// threshold if any.
[[gnu::always_inline]] inline void emit_segment(const ScalarInputs& in, std::size_t f,
                                                const int v[3], const ScalarEnd& a,
                                                const ScalarEnd& b, std::vector<LineSegment>& out) {
  float sa = a.strength, sb = b.strength;
  if (in.mag) {
    const double* mg = in.mag;
    const double t = in.mag_t;
    const double ma = a.bary[0] * mg[v[0]] + a.bary[1] * mg[v[1]] + a.bary[2] * mg[v[2]];
    const double mb = b.bary[0] * mg[v[0]] + b.bary[1] * mg[v[1]] + b.bary[2] * mg[v[2]];
    const double ka = std::max(ma - t, 0.0), kb = std::max(mb - t, 0.0);
    if (ka == 0.0 && kb == 0.0) return;
    sa *= t > 0.0 ? static_cast<float>(ka / (ka + t)) : 1.0f;
    sb *= t > 0.0 ? static_cast<float>(kb / (kb + t)) : 1.0f;
  }
  const auto fi = static_cast<std::int32_t>(f);
  LineSegment& seg = out.emplace_back();
  seg.face = fi;
  const ScalarEnd* src[2] = {&a, &b};
  const float strength[2] = {sa, sb};
  for (int i = 0; i < 2; ++i) {
    SegmentEnd& e = seg.end[i];
    const ScalarEnd& p = *src[i];
    e.anchor.face = fi;
    e.anchor.bary = Vec3(p.bary[0], p.bary[1], p.bary[2]);
    e.position = Vec3(p.pos[0], p.pos[1], p.pos[2]);
    e.element = p.element;
    e.kind = p.kind;
    e.strength = strength[i];
  }
}

// Up to four points, consumed in pairs (rtsc's GL_LINES logic): p1 when
// valid, the nq clip points (at z1 and z2, the nonzero ones), p2 when the
// count is odd.
[[gnu::always_inline]] inline void emit_points(const ScalarInputs& in, std::size_t f,
                                               const int v[3], bool valid1, const ScalarEnd& p1,
                                               const ScalarEnd* q, int nq, const ScalarEnd& p2,
                                               std::vector<LineSegment>& out) {
  const ScalarEnd* pts[4];
  int npts = 0;
  if (valid1) pts[npts++] = &p1;
  for (int i = 0; i < nq; ++i) pts[npts++] = &q[i];
  if (npts != 2) pts[npts++] = &p2;
  for (int i = 0; i + 1 < npts; i += 2) emit_segment(in, f, v, *pts[i], *pts[i + 1], out);
}

// One face of the scalar kernel. The rejections (no lone sign, back-facing,
// test function <= 0 at every corner) are independent predicates, so they
// are tried cheapest and most selective first; the endpoints are built only
// for faces that produce a segment.
template <class Num>
[[gnu::always_inline]] inline void scalar_face_body(const ScalarInputs& in, const Num& num,
                                                    std::size_t f, std::vector<LineSegment>& out) {
  const Face& face = in.m.faces[f];
  const int v[3] = {face[0], face[1], face[2]};
  const int i0 = v[0], i1 = v[1], i2 = v[2];
  const double s[3] = {in.val[i0], in.val[i1], in.val[i2]};
  // The first corner with a lone sign (short-circuit: in the PEL/Laplacian
  // face lists about half the faces have none, and stopping early there
  // saves more than the mispredictions a branch-free form avoids).
  int k;
  if (lone_sign(s[0], s[1], s[2]))
    k = 0;
  else if (lone_sign(s[1], s[2], s[0]))
    k = 1;
  else if (lone_sign(s[2], s[0], s[1]))
    k = 2;
  else
    return;
  const double* cull = in.cull;
  if (cull && cull[i0] <= 0.0 && cull[i1] <= 0.0 && cull[i2] <= 0.0) return;
  const bool test = in.test;
  const double* den = in.den;
  double n_at[3] = {1.0, 1.0, 1.0};
  if (test) {
    n_at[0] = num(static_cast<std::size_t>(i0));
    n_at[1] = num(static_cast<std::size_t>(i1));
    n_at[2] = num(static_cast<std::size_t>(i2));
    if (!den) {
      if (n_at[0] <= 0.0 && n_at[1] <= 0.0 && n_at[2] <= 0.0) return;
    } else {
      const double* d = den;
      if (n_at[0] <= 0.0 && d[i0] >= 0.0 && n_at[1] <= 0.0 && d[i1] >= 0.0 && n_at[2] <= 0.0 &&
          d[i2] >= 0.0)
        return;
      if (n_at[0] >= 0.0 && d[i0] <= 0.0 && n_at[1] >= 0.0 && d[i1] <= 0.0 && n_at[2] >= 0.0 &&
          d[i2] <= 0.0)
        return;
    }
  }
  const int c0 = k, c1 = k == 2 ? 0 : k + 1, c2 = k == 0 ? 2 : k - 1;
  const EdgeParam e1 = scalar_edge(face, c0, c1, s[c0], s[c1]);
  const EdgeParam e2 = scalar_edge(face, c0, c2, s[c0], s[c2]);

  double num1 = 1.0, num2 = 1.0, den1 = 1.0, den2 = 1.0;
  double z1 = 0.0, z2 = 0.0;
  bool valid1 = true;
  if (test) {
    num1 = (1.0 - e1.t) * n_at[e1.c_lo] + e1.t * n_at[e1.c_hi];
    num2 = (1.0 - e2.t) * n_at[e2.c_lo] + e2.t * n_at[e2.c_hi];
    if (den) {
      den1 = (1.0 - e1.t) * den[v[e1.c_lo]] + e1.t * den[v[e1.c_hi]];
      den2 = (1.0 - e2.t) * den[v[e2.c_lo]] + e2.t * den[v[e2.c_hi]];
    }
    valid1 = (num1 >= 0.0) == (den1 >= 0.0);
    if ((num1 >= 0.0) != (num2 >= 0.0)) z1 = num1 / (num1 - num2);
    if ((den1 >= 0.0) != (den2 >= 0.0)) z2 = den1 / (den1 - den2);
    if (z1 == 0.0) {
      z1 = z2;
      z2 = 0.0;
    } else if (z2 < z1) {
      std::swap(z1, z2);
    }
  }
  if (!valid1 && z1 == 0.0 && z2 == 0.0) return;

  ScalarEnd p1, p2, q[2];
  edge_end(in.m, f, v, e1, p1);
  edge_end(in.m, f, v, e2, p2);
  const double fade = in.fade;
  if (valid1) p1.strength = fade_strength(num1, den1, fade);
  int nq = 0;
  for (const double z : {z1, z2}) {
    if (z == 0.0) continue;
    ScalarEnd& c = q[nq++];
    lerp_end(p1, p2, z, c);
    c.strength = fade_strength((1.0 - z) * num1 + z * num2, (1.0 - z) * den1 + z * den2, fade);
  }
  if (int(valid1) + nq != 2) p2.strength = fade_strength(num2, den2, fade);
  emit_points(in, f, v, valid1, p1, q, nq, p2, out);
}

template <class Num>
[[gnu::noinline]] void scalar_face(const ScalarInputs& in, const Num& num, std::size_t f,
                                   std::vector<LineSegment>& out) {
  scalar_face_body(in, num, f, out);
}

#if defined(FABRICA_LINES_AVX2)
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

// The four points of scalar_faces_avx2's lanes (p1, the clips at z1 and
// z2, p2): barycentrics and positions per component and lane, strengths,
// and the edge ends' elements (of the lane being written).
struct LanePoints {
  alignas(32) double bary[4][3][4], at[4][3][4];
  alignas(16) float st[4][4];
  std::int32_t el[4] = {-1, -1, -1, -1};
  bool fade;
};

// Segment (points a, b) of lane l of face `face`, converted into the
// LineSegment in place by emplace_back (each field written once), as
// emit_segment writes it.
struct LaneSegment {
  const LanePoints& lp;
  std::int32_t face;
  int l, a, b;
  SegmentEnd end(int i) const {
    return SegmentEnd{
        SurfacePoint{face, Vec3(lp.bary[i][0][l], lp.bary[i][1][l], lp.bary[i][2][l])},
        Vec3(lp.at[i][0][l], lp.at[i][1][l], lp.at[i][2][l]), lp.el[i],
        i == 0 || i == 3 ? EndKind::edge : EndKind::interior, lp.fade ? lp.st[i][l] : 1.0f};
  }
  operator LineSegment() const { return LineSegment{face, {end(a), end(b)}}; }
};

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
      id[c] = _mm256_cvtepi32_pd(_mm_load_si128(reinterpret_cast<const __m128i*>(v[c])));
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
    LanePoints lp;
    alignas(32) double zv[2][4];
    std::int32_t slot[2][4];
    edge_slot4(e1.lo, e1.hi, slot[0]);
    edge_slot4(e2.lo, e2.hi, slot[1]);
    lp.fade = fade;
    for (int k = 0; k < 3; ++k) {
      _mm256_store_pd(lp.bary[0][k], b1[k]);
      _mm256_store_pd(lp.bary[3][k], b2[k]);
      _mm256_store_pd(lp.at[0][k], e1.p[k]);
      _mm256_store_pd(lp.at[3][k], e2.p[k]);
    }
    const __m256d zs[2] = {z1, z2};
    for (int i = 0; i < 2; ++i) {
      const __m256d z = zs[i], u = _mm256_sub_pd(one, z);
      for (int k = 0; k < 3; ++k) {
        _mm256_store_pd(lp.bary[1 + i][k],
                        _mm256_add_pd(_mm256_mul_pd(u, b1[k]), _mm256_mul_pd(z, b2[k])));
        _mm256_store_pd(lp.at[1 + i][k],
                        _mm256_add_pd(_mm256_mul_pd(u, e1.p[k]), _mm256_mul_pd(z, e2.p[k])));
      }
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
    const int valid_bits = _mm256_movemask_pd(valid1);
    const Topology& topo = *in.m.topo;
    for (; emit; emit &= emit - 1) {
      const int l = std::countr_zero(static_cast<unsigned>(emit));
      const std::size_t f = list[j + l];
      lp.el[0] = topo.face_edge(f, slot[0][l]);
      lp.el[3] = topo.face_edge(f, slot[1][l]);
      // emit_points' order: p1 when valid, the clip points at the nonzero
      // ones of z1, z2, p2 when the count is odd; consumed in pairs.
      int pts[4], npts = 0;
      if (valid_bits >> l & 1) pts[npts++] = 0;
      if (zv[0][l] != 0.0) pts[npts++] = 1;
      if (zv[1][l] != 0.0) pts[npts++] = 2;
      if (npts != 2) pts[npts++] = 3;
      const auto fi = static_cast<std::int32_t>(f);
      for (int i = 0; i + 1 < npts; i += 2)
        out.emplace_back(LaneSegment{lp, fi, l, pts[i], pts[i + 1]});
    }
  }
}
#endif

// Candidates of one family in a scan over the sign bytes: batched with
// their corners prefetched; at a flush, the batch goes to
// scalar_faces_avx2 (four faces at a time), or, without AVX2,
// scalar_face's test-function rejection (N <= 0 at every corner, or
// N/D <= 0 at every corner) is evaluated for the whole batch without
// branches and compacted, and scalar_face (which repeats it) runs on the
// survivors.
template <class Num>
struct ScalarBatch {
  const ScalarInputs& in;
  const Num& num;
  std::vector<LineSegment>& part;
  CandidateBatch batch;

  void prefetch(std::size_t f) const {
    const Face& face = in.m.faces[f];
    for (int k = 0; k < 3; ++k) {
      __builtin_prefetch(&in.m.pos[face[k]]);
      __builtin_prefetch(&in.val[face[k]]);
      if (in.den) __builtin_prefetch(&in.den[face[k]]);
      if (in.test) num.prefetch(static_cast<std::size_t>(face[k]));
    }
    __builtin_prefetch(in.m.topo->face_edge_row(f));
  }
  // The listed faces (ascending), a batch at a time, the next batch's
  // corners prefetched while the current one is processed.
  void run(const std::uint32_t* list, std::size_t n) {
    constexpr std::size_t kb = CandidateBatch::kSize;
    for (std::size_t j = 0; j < std::min(n, kb); ++j) prefetch(list[j]);
    for (std::size_t j = 0; j < n; j += kb) {
      const std::size_t je = std::min(n, j + kb);
      for (std::size_t k = je; k < std::min(n, je + kb); ++k) prefetch(list[k]);
      for (std::size_t k = j; k < je; ++k) batch.add(list[k]);
      flush();
    }
  }
  void flush() {
#if defined(FABRICA_LINES_AVX2)
    // The SIMD kernel tests every face itself, the test function included.
    if (!in.mag && detail::cpu_has_avx2()) {
      scalar_faces_avx2(in, num, batch.face, batch.n, part);
      batch.n = 0;
      return;
    }
#endif
    const Face* faces = in.m.faces;
    std::size_t keep[CandidateBatch::kSize];
    int nk = 0;
    for (int k = 0; k < batch.n; ++k) {
      const std::size_t g = batch.face[k];
      const Face& fg = faces[g];
      bool reject = false;
      if (in.test) {
        const double n0 = num(static_cast<std::size_t>(fg[0]));
        const double n1 = num(static_cast<std::size_t>(fg[1]));
        const double n2 = num(static_cast<std::size_t>(fg[2]));
        if (!in.den) {
          reject = (n0 <= 0.0) & (n1 <= 0.0) & (n2 <= 0.0);
        } else {
          const double* d = in.den;
          const double d0 = d[fg[0]], d1 = d[fg[1]], d2 = d[fg[2]];
          reject =
              ((n0 <= 0.0) & (d0 >= 0.0) & (n1 <= 0.0) & (d1 >= 0.0) & (n2 <= 0.0) & (d2 >= 0.0)) |
              ((n0 >= 0.0) & (d0 <= 0.0) & (n1 >= 0.0) & (d1 <= 0.0) & (n2 >= 0.0) & (d2 <= 0.0));
        }
      }
      keep[nk] = g;
      nk += int(!reject);
    }
    batch.n = 0;
    for (int k = 0; k < nk; ++k) scalar_face(in, num, keep[k], part);
  }
};

// The quick rejection from the sign bytes: with bits (negative, positive)
// of one value, which no vertex has both of, a face can have a lone sign
// only if one of them is set at some corner but not at all three:
// (a0 | a1 | a2) & ~(a0 & a1 & a2). `cull`: a face needs the bit at some
// corner. `reject`: a face with one of these bits at all three corners is
// rejected. From any = a0 | a1 | a2 and all = a0 & a1 & a2.
struct SignTest {
  unsigned sides, cull, reject;
  explicit SignTest(const detail::SignBits& b)
      : sides(b.negative | b.positive), cull(b.cull), reject(b.reject) {}
  bool pass(unsigned any, unsigned all) const {
    const unsigned mixed = any & ~all;
    return ((mixed & sides) != 0) & ((~any & cull) == 0) & ((all & reject) == 0);  // no branch
  }
};

template <class Num>
void scalar_crossings(const ScalarInputs& in, const Num& num, std::size_t face_count,
                      std::vector<LineSegment>& out, std::span<const std::int32_t> list = {},
                      const detail::SignBits& bits = {}) {
  detail::parallel_chunks<LineSegment>(
      list.empty() ? face_count : list.size(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
        const Face* faces = in.m.faces;
        if (bits.signs && list.empty()) {
          // The same rejections (and the culling) from one byte per corner.
          // Candidates compacted without branches, then in batches.
          const std::uint8_t* sg = bits.signs;
          const SignTest st(bits);
          std::uint32_t cand[detail::kFaceChunk];
          std::size_t nc = 0;
          for (std::size_t f = b; f < e; ++f) {
            const Face& face = faces[f];
            const unsigned a0 = sg[face[0]], a1 = sg[face[1]], a2 = sg[face[2]];
            const unsigned any = a0 | a1 | a2;
            cand[nc] = static_cast<std::uint32_t>(f);
            nc += st.pass(any, a0 & a1 & a2);
          }
          ScalarBatch<Num>{in, num, part, {}}.run(cand, nc);
          return;
        }
        if (list.empty()) {
          for (std::size_t f = b; f < e; ++f) scalar_face_body(in, num, f, part);
        } else {
          // Listed faces are scattered over the mesh: fetch the face kk
          // ahead and its corners' values k ahead, so the misses overlap.
          constexpr std::size_t k = 8, kk = 16;
          for (std::size_t j = b; j < e; ++j) {
            if (j + kk < e) __builtin_prefetch(&faces[list[j + kk]]);
            if (j + k < e) {
              const Face& ahead = faces[list[j + k]];
              for (int c = 0; c < 3; ++c) {
                __builtin_prefetch(&in.val[ahead[c]]);
                __builtin_prefetch(&in.m.pos[ahead[c]]);
              }
            }
            scalar_face_body(in, num, static_cast<std::size_t>(list[j]), part);
          }
        }
      },
      out);
}

// Crossing bits of the vector kernel for n faces from E per vertex: bit 0
// when E_0·E_1 <= 0, bit 1 when E_1·E_2 <= 0, bit 2 when E_2·E_0 <= 0
// (Eigen's dot: (x x' + y y') + z z').
inline unsigned crossing_bits_of(const Vec3& e0, const Vec3& e1, const Vec3& e2) {
  return unsigned(e0.dot(e1) <= 0.0) | unsigned(e1.dot(e2) <= 0.0) << 1 |
         unsigned(e2.dot(e0) <= 0.0) << 2;
}
// E of vertex v at E + v * kApparentStride (ViewFields::apparent_vertex).
constexpr std::size_t kApparentStride = sizeof(ApparentVertex) / sizeof(double);
inline Vec3 field_at(const double* E, std::size_t v) {
  const double* e = E + v * kApparentStride;
  return Vec3(e[0], e[1], e[2]);
}
inline unsigned crossing_bits_of(const Face& f, const double* E) {
  return crossing_bits_of(field_at(E, f[0]), field_at(E, f[1]), field_at(E, f[2]));
}

// The first corner c0 of the segment (c0, c1, c2) of a face with crossing
// bits z: the edge without a crossing is opposite c1, so c0 = 1 without
// z01, else 2 without z12, else 0 (a table of 2-bit entries, no branch);
// and the corner after c (0 -> 1 -> 2 -> 0).
inline int first_corner(unsigned z) {
  return (0x1919u >> (2 * (z & 7))) & 3;
}
inline int next_corner(int c) {
  return (0x09u >> (2 * c)) & 3;
}

// At least two of the three edges cross: z = 3, 5, 6 or 7 (a bit table,
// no branch).
inline bool two_crossings(unsigned z) {
  return (0xE8u >> (z & 7)) & 1;
}

// The kept faces of a packed chunk (at least two crossing edges) and
// their crossing bits.
struct KeptFaces {
  std::uint32_t f[detail::kFaceChunk + 8];  // + 8: keep_crossed_avx2 writes eight lanes
  std::uint8_t z[detail::kFaceChunk];
  std::size_t n = 0;
};

// Appends face f with crossing bits z to `kept` when two edges cross (no
// branch), and prefetches its edges for the segments.
inline void keep_if_crossed(std::uint32_t f, unsigned z, const Topology& topo, KeptFaces& kept) {
  kept.f[kept.n] = f;
  kept.z[kept.n] = static_cast<std::uint8_t>(z);
  __builtin_prefetch(topo.face_edge_row(f));
  kept.n += two_crossings(z);
}

#if defined(FABRICA_LINES_AVX2)
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
#endif

// One face of fused_crossings' scan: appended to the contour candidates
// (cc), the suggestive ones (sc) and the listed faces (lf) as it passes
// each test, without branches.
inline void scan_face(const Face* faces, std::size_t f, const std::uint8_t* sg, const SignTest& ct,
                      const SignTest& stt, unsigned listed_bit, std::uint32_t* cc,
                      std::uint32_t* sc, std::uint32_t* lf, std::size_t& nc, std::size_t& ns,
                      std::size_t& nl) {
  const Face& face = faces[f];
  const unsigned a0 = sg[face[0]], a1 = sg[face[1]], a2 = sg[face[2]];
  const unsigned any = a0 | a1 | a2, all = a0 & a1 & a2;
  cc[nc] = sc[ns] = lf[nl] = static_cast<std::uint32_t>(f);
  nc += ct.pass(any, all);
  ns += stt.pass(any, all);
  nl += (any & listed_bit) != 0;
}

#if defined(FABRICA_LINES_AVX2)
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
#endif

// Contours (zeros of n·v, StoredNum test) and suggestive contours or
// highlights (zeros of K_r, ShiftedNum test) in one scan over the faces'
// sign bytes: each family's candidates and segments exactly as its own scan
// makes them, in face order (two outputs of one ordered_chunks).
void fused_crossings(const ScalarInputs& ci, const StoredNum& cn, const detail::SignBits& cb,
                     const ScalarInputs& si, const ShiftedNum& sn, const detail::SignBits& sb,
                     std::size_t face_count, std::size_t vertex_count,
                     std::vector<LineSegment>& cout, std::vector<LineSegment>& sout,
                     detail::FaceLists* listed, unsigned listed_bit) {
  const std::size_t chunk = detail::kFaceChunk;
  const std::size_t chunks = (face_count + chunk - 1) / chunk;
  if (listed) {
    listed->face.resize(chunks * chunk);
    listed->count.resize(chunks);
  }
  static const char site = 0;
  detail::ordered_chunks<2, LineSegment>(
      face_count,
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part,
          std::vector<LineSegment>& spart) {
        const Face* faces = ci.m.faces;
        const std::uint8_t* sg = cb.signs;
        const SignTest ct(cb), stt(sb);
        // Each family's candidates compacted without branches, then in
        // batches.
        // With `listed`, the faces with listed_bit at some corner too.
        std::uint32_t cc[detail::kFaceChunk], sc[detail::kFaceChunk], scratch[detail::kFaceChunk];
        std::uint32_t* lf = listed ? listed->face.data() + (b / chunk) * chunk : scratch;
        std::size_t nc = 0, ns = 0, nl = 0;
        std::size_t f = b;
#if defined(FABRICA_LINES_AVX2)
        if (detail::cpu_has_avx2())
          f = scan_faces_avx2(faces, b, e, vertex_count, sg, ct, stt, listed_bit, cc, sc, lf, nc,
                              ns, nl);
#endif
        for (; f < e; ++f) scan_face(faces, f, sg, ct, stt, listed_bit, cc, sc, lf, nc, ns, nl);
        if (listed) listed->count[b / chunk] = static_cast<std::uint32_t>(nl);
        ScalarBatch<StoredNum>{ci, cn, part, {}}.run(cc, nc);
        ScalarBatch<ShiftedNum>{si, sn, spart, {}}.run(sc, ns);
      },
      std::array<std::vector<LineSegment>*, 2>{&cout, &sout}, &site);
}

// The vector kernel's per-vertex reads: derivative δ, magnitude m and
// position, from separate arrays or from ViewFields::apparent_vertex
// records (then with a stride of one record, so a corner's data are one
// cache line).
struct VectorInputs {
  MeshArrays m;
  const double* delta;
  const Vec3* dir;
  const double* mag;
  const VectorCrossingOptions& o;
  const double* pos = m.pos->data();
  std::size_t ds = 1, ps = 3;  // strides of delta and mag, and of pos (doubles)
  double d(std::size_t v) const { return delta[v * ds]; }
  double mg(std::size_t v) const { return mag[v * ds]; }
  const double* p(std::size_t v) const { return pos + v * ps; }
};

// The options the segment builder reads, copied out of VectorInputs once
// per face (stores into the output cannot make them stale).
struct SegmentParams {
  double threshold;
  bool perpendicular, raw;
};

// Crossing of the vector kernel on the edge joining corners ca and cb:
// corners (and their vertices) ordered by vertex index (lo < hi), fraction
// t from lo, and the interpolated magnitude m.
struct EdgeCut {
  int lo, hi;
  std::size_t vlo, vhi;
  double t, m;
};
[[gnu::always_inline]] inline EdgeCut vector_edge(const VectorInputs& in, const int v[3], int ca,
                                                  int cb) {
  const int va = v[ca], vb = v[cb];
  const bool s = va > vb;
  EdgeCut c;
  c.lo = s ? cb : ca;
  c.hi = s ? ca : cb;
  c.vlo = static_cast<std::size_t>(s ? vb : va);
  c.vhi = static_cast<std::size_t>(s ? va : vb);
  const double da = std::abs(in.d(c.vlo)), db = std::abs(in.d(c.vhi));
  const double sum = da + db;
  c.t = sum > 0.0 ? da / sum : 0.5;
  c.m = std::abs((1.0 - c.t) * in.mg(c.vlo) + c.t * in.mg(c.vhi));
  return c;
}

// The point of a cut, (1 - t) p_lo + t p_hi per component (as the Eigen
// expression evaluates it).
[[gnu::always_inline]] inline void cut_point(const VectorInputs& in, const EdgeCut& c,
                                             double p[3]) {
  const double s = 1.0 - c.t;
  const double *a = in.p(c.vlo), *b = in.p(c.vhi);
  p[0] = s * a[0] + c.t * b[0];
  p[1] = s * a[1] + c.t * b[1];
  p[2] = s * a[2] + c.t * b[2];
}

// rtsc's perpendicular maximum test for the segment pa-pb of face (p0,p1,p2):
// with n = (p1 - p0) x (p2 - p0) and q = n x (pa - pb), true (reject) when
// E0·q <= 0, E1·q >= 0 or E2·q <= 0 (the Eigen cross and dot products'
// operations, in the same order).
[[gnu::always_inline]] inline bool perpendicular_rejects(const double* p0, const double* p1,
                                                         const double* p2, const double pa[3],
                                                         const double pb[3], const Vec3& e0,
                                                         const Vec3& e1, const Vec3& e2) {
  const double u0 = p1[0] - p0[0], u1 = p1[1] - p0[1], u2 = p1[2] - p0[2];
  const double w0 = p2[0] - p0[0], w1 = p2[1] - p0[1], w2 = p2[2] - p0[2];
  const double n0 = u1 * w2 - u2 * w1, n1 = u2 * w0 - u0 * w2, n2 = u0 * w1 - u1 * w0;
  const double d0 = pa[0] - pb[0], d1 = pa[1] - pb[1], d2 = pa[2] - pb[2];
  const double q0 = n1 * d2 - n2 * d1, q1 = n2 * d0 - n0 * d2, q2 = n0 * d1 - n1 * d0;
  if ((e0[0] * q0 + e0[1] * q1) + e0[2] * q2 <= 0.0) return true;
  if ((e1[0] * q0 + e1[1] * q1) + e1[2] * q2 >= 0.0) return true;
  return (e2[0] * q0 + e2[1] * q1) + e2[2] * q2 <= 0.0;
}

[[gnu::always_inline]] inline float ridge_strength(const SegmentParams& sp, double m, double k) {
  if (sp.raw) return static_cast<float>(m);
  return sp.threshold > 0.0 ? static_cast<float>(k / (k + sp.threshold)) : 1.0f;
}

// An endpoint on the edge of a cut: barycentrics 1 - t at lo, t at hi.
[[gnu::always_inline]] inline SegmentEnd set_edge_end(std::int32_t f, const EdgeCut& c,
                                                      const double p[3], std::int32_t edge,
                                                      float strength) {
  SegmentEnd e{SurfacePoint{f, Vec3::Zero()}, Vec3(p[0], p[1], p[2]), edge, EndKind::edge,
               strength};
  e.anchor.bary[c.lo] = 1.0 - c.t;
  e.anchor.bary[c.hi] = c.t;
  return e;
}

// A kept segment's fields, converted into the LineSegment in place by
// emplace_back (aggregate initialisation: each field is written once,
// nothing is value-initialised first).
template <bool ToCenter>
struct SegmentRecord {
  std::int32_t face;
  const EdgeCut &a, &b;
  const double *pa, *pb;
  std::int32_t ea, eb;
  float sa, sb;
  operator LineSegment() const {
    if constexpr (ToCenter) {
      return LineSegment{face,
                         {set_edge_end(face, a, pa, ea, sa),
                          SegmentEnd{SurfacePoint{face, Vec3::Constant(1.0 / 3.0)},
                                     Vec3(pb[0], pb[1], pb[2]), face, EndKind::centroid, sb}}};
    } else {
      return LineSegment{face,
                         {set_edge_end(face, a, pa, ea, sa), set_edge_end(face, b, pb, eb, sb)}};
    }
  }
};

// The far end of a segment joined to the centroid, shared by the three
// segments of such a face: magnitude, threshold excess and position.
struct CentroidEnd {
  double m, k;
  double p[3];
};

// rtsc's draw_segment_ridge / draw_segment_app_ridge for corners (c0,c1,c2)
// of face f (vertices v): crossing on edge c0-c1 joined to the crossing on
// c1-c2 (or the centroid). The threshold and the maximum test are decided
// in plain doubles before the record is built.
template <bool ToCenter>
[[gnu::always_inline]] inline void vector_segment(const VectorInputs& in, const SegmentParams& sp,
                                                  std::size_t f, const int v[3], int c0, int c1,
                                                  int c2, const Vec3 E[3], const CentroidEnd& ce,
                                                  std::vector<LineSegment>& out) {
  const EdgeCut a = vector_edge(in, v, c0, c1);
  EdgeCut b{};
  double m12, k12;
  if constexpr (ToCenter) {
    m12 = ce.m;
    k12 = ce.k;
  } else {
    b = vector_edge(in, v, c1, c2);
    m12 = b.m;
    k12 = std::max(m12 - sp.threshold, 0.0);
  }
  const double m01 = a.m;
  const double k01 = std::max(m01 - sp.threshold, 0.0);
  if (k01 == 0.0 && k12 == 0.0) return;
  double pa[3], pb[3];
  cut_point(in, a, pa);
  if constexpr (ToCenter) {
    pb[0] = ce.p[0];
    pb[1] = ce.p[1];
    pb[2] = ce.p[2];
  } else {
    cut_point(in, b, pb);
  }
  if (sp.perpendicular &&
      perpendicular_rejects(in.p(v[0]), in.p(v[1]), in.p(v[2]), pa, pb, E[c0], E[c1], E[c2]))
    return;
  const auto fi = static_cast<std::int32_t>(f);
  const Topology& topo = *in.m.topo;
  const std::int32_t ea = topo.face_edge(f, 3 - a.lo - a.hi);
  const std::int32_t eb = ToCenter ? fi : topo.face_edge(f, 3 - b.lo - b.hi);
  out.emplace_back(SegmentRecord<ToCenter>{fi, a, b, pa, pb, ea, eb, ridge_strength(sp, m01, k01),
                                           ridge_strength(sp, m12, k12)});
}

// The three segments of a face crossed on all three edges, each joined to
// the centroid (rare: kept out of the common path).
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

// vector_face_segments for the kept faces, one at a time.
void kept_segments_scalar(const VectorInputs& in, const double* field, const KeptFaces& kept,
                          std::vector<LineSegment>& out) {
  for (std::size_t j = 0; j < kept.n; ++j) {
    const std::size_t f = kept.f[j];
    const Face& fg = in.m.faces[f];
    const int v[3] = {fg[0], fg[1], fg[2]};
    const Vec3 E[3] = {field_at(field, fg[0]), field_at(field, fg[1]), field_at(field, fg[2])};
    vector_face_segments(in, f, v, E, kept.z[j], out);
  }
}

#if defined(FABRICA_LINES_AVX2)
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
  c.id = _mm256_cvtepi32_pd(_mm_loadu_si128(reinterpret_cast<const __m128i*>(v)));
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
    alignas(32) std::int64_t rot[2][4];
    for (int l = 0; l < 4; ++l) {
      const int src = l < lanes ? l : 0;
      const Face& fg = faces[kept.f[j + src]];
      for (int c = 0; c < 3; ++c) v[c][l] = fg[c];
      const int c0 = first_corner(kept.z[j + src]);
      rot[0][l] = -std::int64_t(c0 == 1);
      rot[1][l] = -std::int64_t(c0 == 2);
    }
    const __m256d r1 = _mm256_load_pd(reinterpret_cast<const double*>(rot[0]));
    const __m256d r2 = _mm256_load_pd(reinterpret_cast<const double*>(rot[1]));
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
    // The ends as LanePoints 0 (a) and 3 (b): set_edge_end's barycentrics
    // (1 - t at the lower corner, t at the upper), the points, and
    // ridge_strength.
    LanePoints lp;
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
    const __m256d one = _mm256_set1_pd(1.0);
    __m256d ba[3], bb[3];
    edge_bary4(alo, ahi, a.t, _mm256_sub_pd(one, a.t), ba);
    edge_bary4(blo, bhi, b.t, _mm256_sub_pd(one, b.t), bb);
    for (int k = 0; k < 3; ++k) {
      _mm256_store_pd(lp.bary[0][k], ba[k]);
      _mm256_store_pd(lp.bary[3][k], bb[k]);
      _mm256_store_pd(lp.at[0][k], a.p[k]);
      _mm256_store_pd(lp.at[3][k], b.p[k]);
    }
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
      out.emplace_back(LaneSegment{lp, static_cast<std::int32_t>(f), l, 0, 3});
    }
  }
}
#endif

// The packed (apparent-ridge) kernel over faces [b, e): the faces with a
// corner above the threshold (`listed`, or compacted here without branches:
// about half pass, unpredictably); their crossing bits a batch at a time, the next batch's
// corner records prefetched; the faces with two crossings, then their
// segments.
void packed_chunk(const VectorInputs& in, const double* field, const std::uint8_t* signs,
                  unsigned above_bit, std::size_t b, std::size_t e, const std::uint32_t* listed,
                  std::size_t listed_count, std::vector<LineSegment>& out) {
  const Face* faces = in.m.faces;
  std::uint32_t scanned[detail::kFaceChunk];
  const std::uint32_t* cand = listed;
  std::size_t nc = listed_count;
  if (!listed) {
    nc = 0;
    for (std::size_t f = b; f < e; ++f) {
      const Face& face = faces[f];
      scanned[nc] = static_cast<std::uint32_t>(f);
      nc += ((signs[face[0]] | signs[face[1]] | signs[face[2]]) & above_bit) != 0;
    }
    cand = scanned;
  }
  auto prefetch = [&](std::size_t from, std::size_t to) {
    for (std::size_t j = from; j < to; ++j)
      for (int k = 0; k < 3; ++k)
        __builtin_prefetch(field + std::size_t(faces[cand[j]][k]) * kApparentStride);
  };
  constexpr std::size_t kb = CandidateBatch::kSize;
  KeptFaces kept;
  const Topology& topo = *in.m.topo;
  prefetch(0, std::min(nc, kb));
  for (std::size_t j = 0; j < nc; j += kb) {
    const std::size_t je = std::min(nc, j + kb);
    prefetch(je, std::min(nc, je + kb));
#if defined(FABRICA_LINES_AVX2)
    if (detail::cpu_has_avx2()) {
      keep_crossed_avx2(faces, cand + j, static_cast<int>(je - j), field, topo, kept);
      continue;
    }
#endif
    for (std::size_t k = j; k < je; ++k)
      keep_if_crossed(cand[k], crossing_bits_of(faces[cand[k]], field), topo, kept);
  }
#if defined(FABRICA_LINES_AVX2)
  if (detail::cpu_has_avx2()) {
    kept_segments_avx2(in, field, kept, out);
    return;
  }
#endif
  kept_segments_scalar(in, field, kept, out);
}

}  // namespace

void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, std::vector<LineSegment>& out) {
  detail::scalar_zero_crossings(surface, values, options, detail::SignBits{}, out);
}

namespace detail {

namespace {

ScalarInputs scalar_inputs(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options) {
  return ScalarInputs{MeshArrays(surface),
                      values.data(),
                      options.cull.empty() ? nullptr : options.cull.data(),
                      options.test_den.empty() ? nullptr : options.test_den.data(),
                      !options.test_num.empty(),
                      options.fade};
}

ScalarInputs suggestive_inputs(const Surface& surface, const SuggestiveTest& s) {
  return ScalarInputs{MeshArrays(surface), s.kr.data(), s.cull ? s.ndotv.data() : nullptr,
                      s.ndotv.data(),      true,        s.fade};
}

}  // namespace

void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, const SignBits& bits,
                           std::vector<LineSegment>& out) {
  scalar_crossings(scalar_inputs(surface, values, options), StoredNum{options.test_num.data()},
                   surface.face_count(), out, options.faces, bits);
}

void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, std::span<const double> magnitude,
                           double threshold, std::vector<LineSegment>& out) {
  ScalarInputs in = scalar_inputs(surface, values, options);
  in.mag = magnitude.data();
  in.mag_t = threshold;
  scalar_crossings(in, StoredNum{options.test_num.data()}, surface.face_count(), out,
                   options.faces);
}

void suggestive_zero_crossings(const Surface& surface, const SuggestiveTest& test,
                               const SignBits& bits, std::vector<LineSegment>& out) {
  scalar_crossings(suggestive_inputs(surface, test), ShiftedNum::of(test), surface.face_count(),
                   out, {}, bits);
}

bool contour_suggestive_zero_crossings(const Surface& surface, std::span<const double> ndotv,
                                       const ScalarCrossingOptions& contour,
                                       const SignBits& contour_bits, const SuggestiveTest& test,
                                       const SignBits& suggestive_bits,
                                       std::vector<LineSegment>& contours,
                                       std::vector<LineSegment>& suggestive, FaceLists* listed,
                                       unsigned listed_bit) {
  if (!contour_bits.signs || contour_bits.signs != suggestive_bits.signs) {
    scalar_zero_crossings(surface, ndotv, contour, contour_bits, contours);
    suggestive_zero_crossings(surface, test, suggestive_bits, suggestive);
    return false;
  }
  fused_crossings(scalar_inputs(surface, ndotv, contour), StoredNum{contour.test_num.data()},
                  contour_bits, suggestive_inputs(surface, test), ShiftedNum::of(test),
                  suggestive_bits, surface.face_count(), surface.vertex_count(), contours,
                  suggestive, listed, listed_bit);
  return listed != nullptr;
}

void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, const std::uint8_t* signs,
                           unsigned above_bit, std::vector<LineSegment>& out,
                           const ApparentVertex* packed, const FaceLists* lists,
                           const ChunkReady* ready) {
  // Only the packed path waits chunk by chunk; every other one reads any
  // vertex from its first face, so it waits for every chunk first.
  if (ready && !(signs && packed)) {
    const std::size_t chunks = (surface.face_count() + detail::kFaceChunk - 1) / detail::kFaceChunk;
    for (std::size_t c = 0; c < chunks; ++c) (*ready)(c);
    ready = nullptr;
  }
  if (!signs) {
    fabrica::vector_zero_crossings(surface, derivative, direction, magnitude, options, out);
    return;
  }
  VectorInputs in{MeshArrays(surface), derivative.data(), direction.data(), magnitude.data(),
                  options};
  const VectorCrossingOptions& o = options;
  // Without culling, vertex mask or edge test (apparent ridges), the
  // survivors of the first test can go straight to their segments.
  const bool direct = o.cull.empty() && o.vertex_mask.empty() && o.test != ExtremumTest::edge;
  if (packed && !direct)
    throw Error(ErrorKind::internal, "vector kernel: packed records need the direct path");
  if (packed) {
    in.delta = &packed->dt1q1;
    in.mag = &packed->q1;
    in.pos = packed->position.data();
    in.ds = in.ps = kApparentStride;
    detail::parallel_chunks<LineSegment>(
        surface.face_count(),
        [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
          const std::size_t c = b / detail::kFaceChunk;
          if (ready) (*ready)(c);
          packed_chunk(in, packed->field.data(), signs, above_bit, b, e,
                       lists ? lists->face.data() + c * detail::kFaceChunk : nullptr,
                       lists ? lists->count[c] : 0, part);
        },
        out);
    return;
  }
  detail::parallel_chunks<LineSegment>(
      surface.face_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
        const Face* faces = in.m.faces;
        CandidateBatch batch;
        // vector_face's first test (at least two edges where E_i·E_j <= 0),
        // evaluated for the whole batch without branches and compacted, so
        // its hard-to-predict outcome does not cost a mispredicted branch
        // per face.
        auto flush = [&] {
          std::size_t keep[CandidateBatch::kSize];
          int nk = 0;
          for (int k = 0; k < batch.n; ++k) {
            const std::size_t f = batch.face[k];
            const Face& fg = faces[f];
            Vec3 E[3];
            for (int c = 0; c < 3; ++c) E[c] = in.d(fg[c]) * in.dir[fg[c]];
            keep[nk] = f;
            nk += int(two_crossings(crossing_bits_of(E[0], E[1], E[2])));
          }
          batch.n = 0;
          for (int k = 0; k < nk; ++k) vector_face(in, keep[k], part);
        };
        for (std::size_t f = b; f < e; ++f) {
          const Face& face = faces[f];
          if (!((signs[face[0]] | signs[face[1]] | signs[face[2]]) & above_bit)) continue;
          for (int k = 0; k < 3; ++k) {
            __builtin_prefetch(&in.delta[face[k]]);
            __builtin_prefetch(&in.dir[face[k]]);
          }
          if (batch.add(f)) flush();
        }
        flush();
      },
      out);
}

}  // namespace detail

void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, std::vector<LineSegment>& out) {
  const VectorInputs in{MeshArrays(surface), derivative.data(), direction.data(), magnitude.data(),
                        options};
  detail::parallel_chunks<LineSegment>(
      surface.face_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
        const Face* faces = in.m.faces;
        const double* mag = in.mag;
        const double th = options.threshold;
        for (std::size_t f = b; f < e; ++f) {
          const Face& face = faces[f];
          if (mag[face[0]] <= th && mag[face[1]] <= th && mag[face[2]] <= th) continue;
          vector_face(in, f, part);
        }
      },
      out);
}

}  // namespace fabrica
