// Private to the curvature estimator: the per-face least-squares fits of
// the second fundamental form II and of the derivative tensor C
// (docs/algorithms.md §2.1, §2.3), in single precision, eight faces at a
// time. The kernels are templates over a lane type L: `FloatLanes`
// (below; plain loops, the portable build) and an AVX2 type
// (curvature_fit_avx2.cpp, compiled with -mavx2, picked at run time when
// the CPU has AVX2). Every lane type performs the same IEEE single-precision
// operations (+, -, *, /, sqrt, compare, select) in the same order on each
// lane, and the sources are compiled with -ffp-contract=off, so both paths
// give the same bits. rtsc computes these fits in float too.
//
// Inputs are loaded per lane from the Surface's double arrays (three
// consecutive doubles: a position, a face normal, a face's corner areas;
// edges are differences of double positions, rounded once), per-vertex
// records are float (FitVertex, loaded whole and transposed), and each
// corner's weighted, re-expressed result goes into its slot of the
// vertex -> faces CSR order, which the vertex passes then sum in a fixed
// order (same bits at any thread count).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "fabrica/core/mesh.hpp"

namespace fabrica::detail {

/// What a face pass reads about one vertex, in one 48-byte record: the unit
/// normal n, a tangent frame (x, y): the reference frame (u, v) for the II
/// fit, the principal frame (e1, e2) for the C fit, and k1, k2 (C fit).
struct FitVertex {
  float n[3];
  float x[3];
  float y[3];
  float k1, k2, pad;
};
static_assert(sizeof(FitVertex) == 48);

/// One corner's weighted result: II (3 values) or C (4 values), then the
/// weight (0 = the corner contributes nothing).
using FitSlot = std::array<float, 5>;

/// The flat arrays a face pass reads and writes.
struct FitArrays {
  const double* positions;     ///< 3 per vertex
  const Face* faces;           ///< mesh faces
  const double* face_normals;  ///< 3 per face; zero for degenerate faces
  const double* corner_areas;  ///< 3 per face (the fit weights)
  const std::uint8_t* valid;   ///< per vertex: normal (II fit) or curvature (C fit) valid
  const FitVertex* vertices;
  const std::array<std::int32_t, 3>* corner_slot;  ///< per face: each corner's slot
  FitSlot* slots;
  /// When set, read instead of face_normals and corner_areas: per face the
  /// normal and the corner areas as float (kFaceRecord floats; the values
  /// the fits would round them to: the same bits), with two readable floats
  /// after the last face's.
  const float* face_records = nullptr;
};

/// Floats per face in FitArrays::face_records (normal, corner areas).
constexpr std::size_t kFaceRecord = 6;

// Internal linkage: this header is compiled both for the baseline and with
// -mavx2, and the two copies of its inline code must never be merged.
namespace {
namespace fitk {

constexpr int kLanes = 8;

/// The portable lane type: eight floats, every operation a plain loop.
struct FloatLanes {
  float v[kLanes];

  struct Mask {
    bool b[kLanes];
    friend Mask operator&(const Mask& p, const Mask& q) {
      Mask r;
      for (int l = 0; l < kLanes; ++l) r.b[l] = p.b[l] && q.b[l];
      return r;
    }
  };

  static FloatLanes splat(float x) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = x;
    return r;
  }
  /// Three consecutive doubles per lane, kept in double: c[k][l] = base[i[l] + k].
  struct Double3 {
    double c[3][kLanes];
  };
  static void load3(const double* base, const std::int32_t* i, Double3& out) {
    for (int l = 0; l < kLanes; ++l)
      for (int k = 0; k < 3; ++k) out.c[k][l] = base[i[l] + k];
  }
  /// float(a.c[k])
  static FloatLanes to_float(const Double3& a, int k) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = static_cast<float>(a.c[k][l]);
    return r;
  }
  /// float(a.c[k] - b.c[k]): the difference in double, rounded once.
  static FloatLanes diff(const Double3& a, const Double3& b, int k) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = static_cast<float>(a.c[k][l] - b.c[k][l]);
    return r;
  }
  /// The first six floats at base + i[l] per lane: out[f][l] = base[i[l] + f].
  static void load_six(const float* base, const std::int32_t* i, FloatLanes (&out)[6]) {
    for (int l = 0; l < kLanes; ++l)
      for (int f = 0; f < 6; ++f) out[f].v[l] = base[i[l] + f];
  }
  /// The twelve floats of each lane's record: out[f][l] = base[rec[l] + f].
  static void load_records(const float* base, const std::int32_t* rec, FloatLanes (&out)[12]) {
    for (int l = 0; l < kLanes; ++l)
      for (int f = 0; f < 12; ++f) out[f].v[l] = base[rec[l] + f];
  }
  /// Each real lane's corner result into its slot: slots[slot[l]] =
  /// (v[0][l], v[1][l], v[2][l], v[3][l], w[l]) for l < count.
  static void store_slots(FitSlot* slots, const std::int32_t* slot, int count,
                          const FloatLanes (&v)[4], const FloatLanes& w) {
    for (int l = 0; l < count; ++l) {
      FitSlot& s = slots[slot[l]];
      for (int i = 0; i < 4; ++i) s[i] = v[i].v[l];
      s[4] = w.v[l];
    }
  }
  static FloatLanes load(const float* p) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = p[l];
    return r;
  }
#define FABRICA_FIT_LANE_OP(OP)                                             \
  friend FloatLanes operator OP(const FloatLanes& a, const FloatLanes& b) { \
    FloatLanes r;                                                           \
    for (int l = 0; l < kLanes; ++l) r.v[l] = a.v[l] OP b.v[l];             \
    return r;                                                               \
  }
  FABRICA_FIT_LANE_OP(+)
  FABRICA_FIT_LANE_OP(-)
  FABRICA_FIT_LANE_OP(*)
  FABRICA_FIT_LANE_OP(/)
#undef FABRICA_FIT_LANE_OP
  friend FloatLanes sqrt(const FloatLanes& a) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = std::sqrt(a.v[l]);
    return r;
  }
  /// a > b ? a : b (b where either is NaN, like maxps).
  friend FloatLanes max(const FloatLanes& a, const FloatLanes& b) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = a.v[l] > b.v[l] ? a.v[l] : b.v[l];
    return r;
  }
  /// a > b (false where either is NaN).
  friend Mask greater(const FloatLanes& a, const FloatLanes& b) {
    Mask r;
    for (int l = 0; l < kLanes; ++l) r.b[l] = a.v[l] > b.v[l];
    return r;
  }
  friend FloatLanes select(const Mask& m, const FloatLanes& a, const FloatLanes& b) {
    FloatLanes r;
    for (int l = 0; l < kLanes; ++l) r.v[l] = m.b[l] ? a.v[l] : b.v[l];
    return r;
  }
};

template <class L>
struct V3 {
  L x, y, z;
};

template <class L>
inline L dot(const V3<L>& a, const V3<L>& b) {
  return (a.x * b.x + a.y * b.y) + a.z * b.z;
}

template <class L>
inline V3<L> cross(const V3<L>& a, const V3<L>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

template <class L>
inline V3<L> sub(const V3<L>& a, const V3<L>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}

/// A vertex record's normal n and tangent frame (x, y) and its k1, k2, for
/// each lane's record index (in floats) `rec`.
template <class L>
struct VertexFrame {
  V3<L> n, x, y;
  L k1, k2;
};

template <class L>
inline VertexFrame<L> load_frame(const float* base, const std::int32_t* rec) {
  L f[12];
  L::load_records(base, rec, f);
  return {{f[0], f[1], f[2]}, {f[3], f[4], f[5]}, {f[6], f[7], f[8]}, f[9], f[10]};
}

/// Coordinates, in the face frame (t, b), of the vertex tangent vectors x
/// and y after the minimal rotation from the vertex plane (normal n) into
/// the face plane (normal nT): R x . t = x . t - (nT . x)(n . t)/(1 + c),
/// c = n . nT. Where n and nT are (nearly) opposite the rotation is
/// replaced by the projection x - (nT . x) nT, whose dots with t and b are
/// x . t and x . b (the same formula with 1/(1 + c) taken as 0).
template <class L>
struct FrameInFace {
  L x1, x2, y1, y2;
};

template <class L>
inline FrameInFace<L> frame_in_face(const V3<L>& x, const V3<L>& y, const V3<L>& n, const V3<L>& nT,
                                    const V3<L>& t, const V3<L>& b) {
  const L c = dot(n, nT);
  const L one = L::splat(1.0f);
  const L s = select(greater(c, L::splat(-1.0f + 1e-6f)), one / (one + c), L::splat(0.0f));
  const L nt = dot(n, t) * s, nb = dot(n, b) * s;
  const L xn = dot(nT, x), yn = dot(nT, y);
  return {dot(x, t) - xn * nt, dot(x, b) - xn * nb, dot(y, t) - yn * nt, dot(y, b) - yn * nb};
}

/// LDLᵀ solve of the symmetric tridiagonal system (diag, off[i] = A[i][i+1])
/// without pivoting; `ok` is cleared in lanes where a pivot is not clearly
/// positive (rank-deficient fit; as the double version, 1e-12 of the
/// largest diagonal entry).
template <class L, int N>
inline void solve_tridiagonal(const L (&diag)[N], const L (&off)[N - 1], const L (&rhs)[N],
                              L (&x)[N], typename L::Mask& ok) {
  L max_diag = diag[0];
  for (int i = 1; i < N; ++i) max_diag = max(diag[i], max_diag);
  ok = ok & greater(max_diag, L::splat(0.0f));
  const L tiny = L::splat(1e-12f) * max_diag;
  const L one = L::splat(1.0f);
  L inv_d[N], l[N], y[N];
  ok = ok & greater(diag[0], tiny);
  inv_d[0] = one / diag[0];
  y[0] = rhs[0];
  for (int i = 1; i < N; ++i) {
    l[i] = off[i - 1] * inv_d[i - 1];
    const L d = diag[i] - l[i] * off[i - 1];
    ok = ok & greater(d, tiny);
    inv_d[i] = one / d;
    y[i] = rhs[i] - l[i] * y[i - 1];
  }
  x[N - 1] = y[N - 1] * inv_d[N - 1];
  for (int i = N - 2; i >= 0; --i) x[i] = y[i] * inv_d[i] - l[i + 1] * x[i + 1];
}

/// Per block of up to eight faces: which faces, where their data is.
struct Block {
  int count;                                 ///< real lanes (the rest repeat the last)
  alignas(32) std::int32_t pos[3][kLanes];   ///< 3 * vertex of corner k
  alignas(32) std::int32_t rec[3][kLanes];   ///< 12 * vertex of corner k (FitVertex floats)
  alignas(32) std::int32_t face3[kLanes];    ///< 3 * face
  alignas(32) std::int32_t face6[kLanes];    ///< kFaceRecord * face
  alignas(32) std::int32_t slot[3][kLanes];  ///< corner k's slot
  alignas(32) float usable[kLanes];          ///< 1: normal not zero, three vertices valid
};

inline void load_block(const FitArrays& a, std::size_t first, std::size_t end, Block& blk) {
  blk.count = static_cast<int>(end - first < kLanes ? end - first : kLanes);
  for (int l = 0; l < kLanes; ++l) {
    const std::size_t f = first + static_cast<std::size_t>(l < blk.count ? l : blk.count - 1);
    const Face& face = a.faces[f];
    // (A unit normal is not zero in float either.)
    bool ok;
    if (a.face_records) {
      const float* nT = a.face_records + kFaceRecord * f;
      ok = !(nT[0] == 0.0f && nT[1] == 0.0f && nT[2] == 0.0f);
    } else {
      const double* nT = a.face_normals + 3 * f;
      ok = !(nT[0] == 0.0 && nT[1] == 0.0 && nT[2] == 0.0);
    }
    for (int k = 0; k < 3; ++k) {
      blk.pos[k][l] = 3 * face[k];
      blk.rec[k][l] = 12 * face[k];
      blk.slot[k][l] = a.corner_slot[f][k];
      ok = ok && a.valid[face[k]] != 0;
    }
    blk.face3[l] = static_cast<std::int32_t>(3 * f);
    blk.face6[l] = static_cast<std::int32_t>(kFaceRecord * f);
    blk.usable[l] = ok ? 1.0f : 0.0f;
  }
}

/// The face's edges e[k] = p[k+2] - p[k+1], its normal nT, the frame
/// (t = e[0] / |e[0]|, b = nT x t) both fits use, and the corner areas w
/// (the fit weights).
template <class L>
struct FaceFrame {
  V3<L> e[3];
  V3<L> nT, t, b;
  L w[3];
};

template <class L>
inline FaceFrame<L> face_frame(const FitArrays& a, const Block& blk) {
  FaceFrame<L> F;
  typename L::Double3 p[3];
  for (int k = 0; k < 3; ++k) L::load3(a.positions, blk.pos[k], p[k]);
  for (int k = 0; k < 3; ++k) {
    const auto& head = p[(k + 2) % 3];
    const auto& tail = p[(k + 1) % 3];
    F.e[k] = {L::diff(head, tail, 0), L::diff(head, tail, 1), L::diff(head, tail, 2)};
  }
  if (a.face_records) {
    L r[6];
    L::load_six(a.face_records, blk.face6, r);
    F.nT = {r[0], r[1], r[2]};
    for (int k = 0; k < 3; ++k) F.w[k] = r[3 + k];
  } else {
    typename L::Double3 d;
    L::load3(a.face_normals, blk.face3, d);
    F.nT = {L::to_float(d, 0), L::to_float(d, 1), L::to_float(d, 2)};
    L::load3(a.corner_areas, blk.face3, d);
    for (int k = 0; k < 3; ++k) F.w[k] = L::to_float(d, k);
  }
  const L inv = L::splat(1.0f) / sqrt(dot(F.e[0], F.e[0]));
  F.t = {F.e[0].x * inv, F.e[0].y * inv, F.e[0].z * inv};
  F.b = cross(F.nT, F.t);
  return F;
}

/// Calls body(block, face frame) for the faces [begin, end), eight at a
/// time (the last block may be partial).
template <class L, class Body>
inline void for_each_block(const FitArrays& a, std::size_t begin, std::size_t end,
                           const Body& body) {
  for (std::size_t first = begin; first < end; first += kLanes) {
    Block blk;
    load_block(a, first, end, blk);
    body(blk, face_frame<L>(a, blk));
  }
}

/// The II fit over faces [begin, end) (docs/algorithms.md §2.1): per edge
/// j (head corner j+2, tail j+1), e u + f v = dn . t, f u + g v = dn . b in
/// the face frame; then II re-expressed in each vertex's reference frame
/// (u, v), weighted by the corner area.
template <class L>
void fit_second_fundamental_forms(const FitArrays& a, std::size_t begin, std::size_t end) {
  const float* rec = &a.vertices[0].n[0];
  for_each_block<L>(a, begin, end, [&](const Block& blk, const FaceFrame<L>& F) {
    const VertexFrame<L> V[3] = {load_frame<L>(rec, blk.rec[0]), load_frame<L>(rec, blk.rec[1]),
                                 load_frame<L>(rec, blk.rec[2])};
    L suu = L::splat(0.0f), suv = suu, svv = suu, r0 = suu, r1 = suu, r2 = suu;
    for (int j = 0; j < 3; ++j) {
      const L u = dot(F.e[j], F.t), v = dot(F.e[j], F.b);
      const V3<L> dn = sub(V[(j + 2) % 3].n, V[(j + 1) % 3].n);
      const L dnt = dot(dn, F.t), dnb = dot(dn, F.b);
      suu = suu + u * u;
      suv = suv + u * v;
      svv = svv + v * v;
      r0 = r0 + u * dnt;
      r1 = r1 + (v * dnt + u * dnb);
      r2 = r2 + v * dnb;
    }
    const L diag[3] = {suu, suu + svv, svv};
    const L off[2] = {suv, suv};
    const L rhs[3] = {r0, r1, r2};
    L s[3];
    typename L::Mask ok = greater(L::load(blk.usable), L::splat(0.0f));
    solve_tridiagonal<L, 3>(diag, off, rhs, s, ok);
    const L zero = L::splat(0.0f), two = L::splat(2.0f);
    for (int k = 0; k < 3; ++k) {
      const L w = F.w[k];
      const typename L::Mask use = ok & greater(w, zero);
      const FrameInFace<L> r = frame_in_face(V[k].x, V[k].y, V[k].n, F.nT, F.t, F.b);
      const L a1 = r.x1, b1 = r.x2, a2 = r.y1, b2 = r.y2;
      const L v0 = w * ((a1 * a1 * s[0] + two * a1 * b1 * s[1]) + b1 * b1 * s[2]);
      const L v1 = w * ((a1 * a2 * s[0] + (a1 * b2 + a2 * b1) * s[1]) + b1 * b2 * s[2]);
      const L v2 = w * ((a2 * a2 * s[0] + two * a2 * b2 * s[1]) + b2 * b2 * s[2]);
      const L v[4] = {select(use, v0, zero), select(use, v1, zero), select(use, v2, zero), zero};
      L::store_slots(a.slots, blk.slot[k], blk.count, v, select(use, w, zero));
    }
  });
}

/// The C fit over faces [begin, end) (§2.3): each vertex's II from its
/// principal values and frame, carried into the face frame; per edge
/// de = a u + b v, df = b u + c v (counted twice), dg = c u + d v; then C
/// re-expressed in each vertex's principal frame, weighted by corner area.
template <class L>
void fit_curvature_derivatives(const FitArrays& a, std::size_t begin, std::size_t end) {
  const float* rec = &a.vertices[0].n[0];
  for_each_block<L>(a, begin, end, [&](const Block& blk, const FaceFrame<L>& F) {
    FrameInFace<L> r[3];
    L hxx[3], hxy[3], hyy[3];
    for (int k = 0; k < 3; ++k) {
      const VertexFrame<L> V = load_frame<L>(rec, blk.rec[k]);
      const L k1 = V.k1, k2 = V.k2;
      r[k] = frame_in_face(V.x, V.y, V.n, F.nT, F.t, F.b);
      // II = k1 (c,s)(c,s)ᵀ + k2 (-s,c)(-s,c)ᵀ with (c, s) = e1 in the face frame.
      const L c = r[k].x1, s = r[k].x2;
      hxx[k] = k1 * c * c + k2 * s * s;
      hxy[k] = (k1 - k2) * c * s;
      hyy[k] = k1 * s * s + k2 * c * c;
    }
    const L zero = L::splat(0.0f), two = L::splat(2.0f);
    L suu = zero, suv = zero, svv = zero;
    L rhs[4] = {zero, zero, zero, zero};
    for (int j = 0; j < 3; ++j) {
      const L u = dot(F.e[j], F.t), v = dot(F.e[j], F.b);
      const int h = (j + 2) % 3, t = (j + 1) % 3;
      const L de = hxx[h] - hxx[t], df = hxy[h] - hxy[t], dg = hyy[h] - hyy[t];
      suu = suu + u * u;
      suv = suv + u * v;
      svv = svv + v * v;
      rhs[0] = rhs[0] + u * de;
      rhs[1] = rhs[1] + (v * de + two * u * df);
      rhs[2] = rhs[2] + (two * v * df + u * dg);
      rhs[3] = rhs[3] + v * dg;
    }
    const L diag[4] = {suu, svv + two * suu, two * svv + suu, svv};
    const L off[3] = {suv, two * suv, suv};
    L C[4];
    typename L::Mask ok = greater(L::load(blk.usable), zero);
    solve_tridiagonal<L, 4>(diag, off, rhs, C, ok);
    for (int k = 0; k < 3; ++k) {
      const L w = F.w[k];
      const typename L::Mask use = ok & greater(w, zero);
      // C(p, q, .) as a linear form; p, q the vertex axes in the face frame.
      const L x1 = r[k].x1, x2 = r[k].x2, y1 = r[k].y1, y2 = r[k].y2;
      const L xx1 = (C[0] * x1 * x1 + two * C[1] * x1 * x2) + C[2] * x2 * x2;
      const L xx2 = (C[1] * x1 * x1 + two * C[2] * x1 * x2) + C[3] * x2 * x2;
      const L yy1 = (C[0] * y1 * y1 + two * C[1] * y1 * y2) + C[2] * y2 * y2;
      const L yy2 = (C[1] * y1 * y1 + two * C[2] * y1 * y2) + C[3] * y2 * y2;
      const L v[4] = {select(use, w * (xx1 * x1 + xx2 * x2), zero),
                      select(use, w * (xx1 * y1 + xx2 * y2), zero),
                      select(use, w * (yy1 * x1 + yy2 * x2), zero),
                      select(use, w * (yy1 * y1 + yy2 * y2), zero)};
      L::store_slots(a.slots, blk.slot[k], blk.count, v, select(use, w, zero));
    }
  });
}

}  // namespace fitk
}  // namespace

/// The AVX2 versions (curvature_fit_avx2.cpp), where built.
void fit_second_fundamental_forms_avx2(const FitArrays& a, std::size_t begin, std::size_t end);
void fit_curvature_derivatives_avx2(const FitArrays& a, std::size_t begin, std::size_t end);

}  // namespace fabrica::detail
