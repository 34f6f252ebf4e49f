// Private to fabrica::lines: the pieces of the zero-crossing kernel
// (zero_crossing.hpp, docs/algorithms.md §0 "ZC" and "ZC-vec") shared by its
// three parts: the portable reference kernel (zero_crossing.cpp: one face
// at a time, the public entry points), the tuned scalar kernel
// (zero_crossing_scalar.cpp: sign-byte scans, batches, the fused contour +
// suggestive scan, the packed apparent-ridge path) and the AVX2 kernels
// (zero_crossing_avx2.cpp: four faces per register, same operations in the
// same order, so the same bits; called only when the CPU has AVX2), and two
// of them for AVX-512 (zero_crossing_avx512.cpp: eight faces per register,
// the same bits again; called only when the CPU has AVX-512).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/lines/segments.hpp"
#include "fabrica/lines/view_fields.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "parallel.hpp"
#include "simd_avx2.hpp"
#include "zero_crossing_internal.hpp"

namespace fabrica::zc {

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
  double t;  // edge ends: the fraction along the edge from its lower vertex
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
  p.t = e.t;
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

// Writes a kernel endpoint into end i of a lean record: an edge end keeps
// its edge and t (its barycentrics and position are recomputed from them
// with the same operations, segments.hpp), an interior one its barycentrics.
[[gnu::always_inline]] inline void write_end(LineSegment& seg, int i, const ScalarEnd& p,
                                             float strength) {
  SegmentEnd& e = seg.end[i];
  seg.kind[i] = p.kind;
  if (p.kind == EndKind::edge) {
    e.t = p.t;
    e.element = p.element;
  } else {
    e.bary[0] = static_cast<float>(p.bary[0]);
    e.bary[1] = static_cast<float>(p.bary[1]);
    e.element = -1;
  }
  e.strength = strength;
}

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
  LineSegment& seg = out.emplace_back();
  seg.face = static_cast<std::int32_t>(f);
  write_end(seg, 0, a, sa);
  write_end(seg, 1, b, sb);
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

// The four points of the SIMD scalar kernels' N lanes (p1, the clips at z1
// and z2, p2; kept_segments uses points 0 and 3): the edge ends' fractions
// t (points 0 and 3) and elements (of the lane being written), the clip
// points' first two barycentrics per lane (points 1 and 2; the third is
// never stored), strengths. Plain code: the AVX2 and AVX-512 kernels fill
// it with stores of N lanes.
template <int N>
struct LanePoints {
  alignas(64) double t[4][N], bary[4][2][N];
  alignas(32) float st[4][N];
  std::int32_t el[4] = {-1, -1, -1, -1};
  bool fade;
};

// Segment (points a, b) of lane l of face `face`, converted into the lean
// LineSegment in place by emplace_back (each field written once), as
// emit_segment writes it.
template <int N>
struct LaneSegment {
  const LanePoints<N>& lp;
  std::int32_t face;
  int l, a, b;
  static bool on_edge(int i) { return i == 0 || i == 3; }
  SegmentEnd end(int i) const {
    SegmentEnd e;
    if (on_edge(i)) {
      e.t = lp.t[i][l];
      e.element = lp.el[i];
    } else {
      e.bary[0] = static_cast<float>(lp.bary[i][0][l]);
      e.bary[1] = static_cast<float>(lp.bary[i][1][l]);
      e.element = -1;
    }
    e.strength = lp.fade ? lp.st[i][l] : 1.0f;
    return e;
  }
  static EndKind kind(int i) { return on_edge(i) ? EndKind::edge : EndKind::interior; }
  operator LineSegment() const { return LineSegment{face, {kind(a), kind(b)}, {end(a), end(b)}}; }
};

// The segments of a SIMD scalar kernel group's emitted lanes (bits of
// `emit`, in lane, so face, order) of the faces list[0..N): each lane's
// edge elements from its edges' slots in the face, then emit_points'
// order: p1 when valid (bit of `valid`), the clip points at the nonzero
// ones of z1, z2, p2 when the count is odd; consumed in pairs.
template <int N>
[[gnu::always_inline]] inline void emit_lanes(LanePoints<N>& lp, unsigned emit, unsigned valid,
                                              const double (&zv)[2][N],
                                              const std::int32_t (&slot)[2][N],
                                              const std::size_t* list, const Topology& topo,
                                              std::vector<LineSegment>& out) {
  for (; emit; emit &= emit - 1) {
    const int l = std::countr_zero(emit);
    const std::size_t f = list[l];
    lp.el[0] = topo.face_edge(f, slot[0][l]);
    lp.el[3] = topo.face_edge(f, slot[1][l]);
    int pts[4], npts = 0;
    if (valid >> l & 1) pts[npts++] = 0;
    if (zv[0][l] != 0.0) pts[npts++] = 1;
    if (zv[1][l] != 0.0) pts[npts++] = 2;
    if (npts != 2) pts[npts++] = 3;
    const auto fi = static_cast<std::int32_t>(f);
    for (int i = 0; i + 1 < npts; i += 2)
      out.emplace_back(LaneSegment<N>{lp, fi, l, pts[i], pts[i + 1]});
  }
}

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

// A kept segment's fields, converted into the lean LineSegment in place by
// emplace_back (aggregate initialisation: each field is written once,
// nothing is value-initialised first). Edge ends keep the cut's t (the
// fraction from the lower vertex: the barycentrics 1 - t at lo and t at hi
// and the position cut_point computes are recomputed from it); the
// centroid end keeps its face.
template <bool ToCenter>
struct SegmentRecord {
  std::int32_t face;
  const EdgeCut &a, &b;
  std::int32_t ea, eb;
  float sa, sb;
  operator LineSegment() const {
    SegmentEnd e0, e1;
    e0.t = a.t;
    e0.element = ea;
    e0.strength = sa;
    e1.t = ToCenter ? 0.0 : b.t;
    e1.element = eb;
    e1.strength = sb;
    return LineSegment{
        face, {EndKind::edge, ToCenter ? EndKind::centroid : EndKind::edge}, {e0, e1}};
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
  out.emplace_back(SegmentRecord<ToCenter>{fi, a, b, ea, eb, ridge_strength(sp, m01, k01),
                                           ridge_strength(sp, m12, k12)});
}

// The three segments of a face crossed on all three edges, each joined to
// the centroid (rare: kept out of the common path; zero_crossing.cpp).
void vector_centroid_segments(const VectorInputs& in, const SegmentParams& sp, std::size_t f,
                              const int v[3], const Vec3 E[3], std::vector<LineSegment>& out);

// The segments of face f (vertices v, E_i = delta_i dir_i) given its
// crossing bits z (at least two edges cross; zero_crossing.cpp).
void vector_face_segments(const VectorInputs& in, std::size_t f, const int v[3], const Vec3 E[3],
                          unsigned z, std::vector<LineSegment>& out);

// The reference vector kernel for one face with a corner above the
// threshold: culling, vertex mask, crossing bits, the edge test, then its
// segments (zero_crossing.cpp).
void vector_face(const VectorInputs& in, std::size_t f, std::vector<LineSegment>& out);

// The AVX2 kernels (zero_crossing_avx2.cpp), each giving the bits of the
// scalar code it replaces; call only when detail::cpu_has_avx2().
#if defined(FABRICA_LINES_AVX2)
/// scalar_face_body for the listed faces (no magnitude threshold), four at
/// a time (Num: StoredNum or ShiftedNum).
template <class Num>
[[gnu::target("avx2")]] void scalar_faces_avx2(const ScalarInputs& in, const Num& num,
                                               const std::size_t* list, int n,
                                               std::vector<LineSegment>& out);

/// keep_if_crossed for n listed faces (records E of ApparentVertex), four
/// at a time.
[[gnu::target("avx2")]] void keep_crossed_avx2(const Face* faces, const std::uint32_t* face, int n,
                                               const double* E, const Topology& topo,
                                               KeptFaces& kept);

/// scan_face for faces [b, e), eight at a time; returns the first face not
/// scanned (fewer than eight are left).
[[gnu::target("avx2")]] std::size_t scan_faces_avx2(const Face* faces, std::size_t b, std::size_t e,
                                                    std::size_t vertex_count,
                                                    const std::uint8_t* sg, const SignTest& ct,
                                                    const SignTest& stt, unsigned listed_bit,
                                                    std::uint32_t* cc, std::uint32_t* sc,
                                                    std::uint32_t* lf, std::size_t& nc,
                                                    std::size_t& ns, std::size_t& nl);

/// vector_face_segments for the kept faces of a packed chunk, four at a
/// time.
[[gnu::target("avx2")]] void kept_segments_avx2(const VectorInputs& in, const double* field,
                                                const KeptFaces& kept,
                                                std::vector<LineSegment>& out);
#endif

// The AVX-512 kernels (zero_crossing_avx512.cpp), eight faces at a time,
// each giving the bits of the AVX2 one it replaces; call only when
// detail::cpu_has_avx512().
#if defined(FABRICA_LINES_AVX512)
/// scalar_faces_avx2 (Num: StoredNum or ShiftedNum).
template <class Num>
[[gnu::target(FABRICA_AVX512_ISA)]] void scalar_faces_avx512(const ScalarInputs& in, const Num& num,
                                                             const std::size_t* list, int n,
                                                             std::vector<LineSegment>& out);

/// kept_segments_avx2.
[[gnu::target(FABRICA_AVX512_ISA)]] void kept_segments_avx512(const VectorInputs& in,
                                                              const double* field,
                                                              const KeptFaces& kept,
                                                              std::vector<LineSegment>& out);
#endif

}  // namespace fabrica::zc
