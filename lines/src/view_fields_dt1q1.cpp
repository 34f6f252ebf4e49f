// D_t1 q1 (ViewFields::dt1q1), the second pass of the apparent-ridge
// fields: see view_fields_light.hpp.
#include <emmintrin.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>

#include "fabrica/lines/precompute.hpp"
#include "parallel.hpp"
#include "simd_avx2.hpp"
#include "view_fields_light.hpp"

// The pass is compiled for x86-64-v3 (AVX2, three-operand forms) and the
// baseline, picked at load time as core's FABRICA_MULTIVERSION kernels; the
// file has -ffp-contract=off, so both give the same bits.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(FABRICA_NO_MULTIVERSION)
#define FABRICA_DT1Q1_MULTIVERSION __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define FABRICA_DT1Q1_MULTIVERSION
#endif

namespace fabrica::detail {

namespace {

inline void store_apparent_vertex(ApparentVertex& a, double d, const Vec3& t1_world, double q1) {
  a.field = d * t1_world;
  a.dt1q1 = d;
  a.q1 = q1;
}
inline void store_apparent_vertex(ApparentVertex& a, double d, const Vec3& t1_world, double q1,
                                  const Vec3& pos) {
  store_apparent_vertex(a, d, t1_world, q1);
  a.position = pos;
}

// w1 = num / den, the weight of the first corner where the line crosses a
// face's opposite edge, when in [0, 1); false otherwise. Exact early
// rejections before the division: |num| >= |den| (also den == 0 or NaN)
// gives |w1| >= 1, and opposite signs give w1 < 0 unless the quotient
// underflows to -0 (only possible when |num| <= |den| 2^-900).
inline bool crossing_weight(double num, double den, double& w1) {
  if (!(std::abs(num) < std::abs(den))) return false;
  if ((num < 0.0) != (den < 0.0) && std::abs(num) > std::abs(den) * 0x1p-900) return false;
  w1 = num / den;
  return w1 >= 0.0 && w1 < 1.0;
}

constexpr int kMaxFan = 63;

// Two floats (8 bytes, any alignment) into the low half.
inline __m128 load2(const float* f) {
  return _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(f)));
}

// On a fan of m <= 63 faces (face j: neighbours j, j+1; neighbour m is
// neighbour 0) with neighbour offsets (x, y): p[j] = c y_j - sn x_j (the
// neighbour's p·t2, j <= m),
// and a superset of the faces for which crossing_weight(p[j+1],
// p[j+1] - p[j]) holds: those whose two p differ in sign bit, or whose
// p[j+1] is tiny. With the same sign bit (and no NaN, which never crosses),
// |den| <= max |p| or |num| >= |den|, and a crossing with opposite signs of
// num and den needs |num| <= |den| 2^-900; with |c|, |sn| <= 2 and finite
// float offsets |p| <= 2^130, so "tiny" is |p| <= 2^-770 (anything
// otherwise).
//
// Short: a fan of m < kShort faces, without a loop: p for the first kShort
// ring entries (those past the fan's m + 1 belong to the next ring or the
// padding; they are computed and stored, and ignored: their sign bits are
// masked off, and they can only make the rare `small` check below run,
// which then looks at the fan's own entries only).
constexpr int kShort = 8;
template <bool Short>
inline std::uint64_t candidate_faces(const float* x, const float* y, int m, __m128d cs, double* p) {
  const __m128d vc = _mm_unpacklo_pd(cs, cs), vs = _mm_unpackhi_pd(cs, cs);
  const __m128d abs_mask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffff));
  __m128d vmin = _mm_set1_pd(HUGE_VAL);
  std::uint64_t neg = 0;
  const int end = Short ? kShort : m;
#pragma GCC unroll 4
  for (int j = 0; j < end; j += 2) {
    const __m128d vx = _mm_cvtps_pd(load2(x + j)), vy = _mm_cvtps_pd(load2(y + j));
    const __m128d v = _mm_sub_pd(_mm_mul_pd(vc, vy), _mm_mul_pd(vs, vx));
    _mm_store_pd(p + j, v);
    vmin = _mm_min_pd(_mm_and_pd(v, abs_mask), vmin);  // NaN lanes keep the accumulator
    neg |= std::uint64_t(_mm_movemask_pd(v)) << j;
  }
  p[m] = p[0];
  // Bit j of cand: bits j and j + 1 of neg (bit m is bit 0, neighbour m
  // being neighbour 0 again) differ.
  const std::uint64_t all = (std::uint64_t{1} << m) - 1;
  auto pairs = [&](std::uint64_t b) { return (b & all) | (b & 1) << m; };
  neg = pairs(neg);
  std::uint64_t cand = (neg ^ neg >> 1) & all;
  const bool bounded =
      _mm_movemask_pd(_mm_cmple_pd(_mm_and_pd(cs, abs_mask), _mm_set1_pd(2.0))) == 3;
  const double tiny = bounded ? 0x1p-770 : HUGE_VAL;
  if (_mm_cvtsd_f64(_mm_min_sd(vmin, _mm_unpackhi_pd(vmin, vmin))) <= tiny) {
    std::uint64_t small = 0;
    for (int j = 0; j < m; ++j) small |= std::uint64_t(std::abs(p[j]) <= tiny) << j;
    cand |= pairs(small) >> 1 & all;
  }
  return cand;
}

#if defined(FABRICA_LINES_AVX2)
// The sign bits of p[j] = c y_j - sn x_j (candidate_faces) for the fan's m
// entries, from float products eight entries at a time: bit j of `neg` is
// the sign bit of the double p[j] whenever this returns true. Each float
// |p| is compared with a bound on its error against the exact value (the
// products' and the conversions' roundings, < 2^-21 (|c y| + |sn x|) plus
// subnormal steps): a lane above 2^-20 (|c y| + |sn x|) + 2^-120 has the sign
// of the exact value, and so of the double p, whose own error is ~2^-52 of
// the same sum; it also makes that p far from "tiny" (2^-770). A lane at
// or under the bound, NaN or infinite: false (the caller takes the double
// path). |c|, |sn| <= 2 and finite x, y (a fan of valid curvature).
[[gnu::target("arch=x86-64-v3")]] inline bool fan_signs_float(const float* x, const float* y, int m,
                                                              double c, double sn,
                                                              std::uint64_t& neg) {
  const __m256 vc = _mm256_set1_ps(static_cast<float>(c)),
               vs = _mm256_set1_ps(static_cast<float>(sn));
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 rel = _mm256_set1_ps(0x1p-20f), floor = _mm256_set1_ps(0x1p-120f);
  std::uint64_t n = 0, unsure = 0;
  for (int j = 0; j < m; j += 8) {
    const __m256 a = _mm256_mul_ps(vc, _mm256_loadu_ps(y + j));
    const __m256 b = _mm256_mul_ps(vs, _mm256_loadu_ps(x + j));
    const __m256 p = _mm256_sub_ps(a, b);
    const __m256 bound = _mm256_add_ps(
        _mm256_mul_ps(_mm256_add_ps(_mm256_and_ps(a, abs_mask), _mm256_and_ps(b, abs_mask)), rel),
        floor);
    n |= std::uint64_t(static_cast<unsigned>(_mm256_movemask_ps(p))) << j;
    unsure |= std::uint64_t(static_cast<unsigned>(_mm256_movemask_ps(
                  _mm256_cmp_ps(_mm256_and_ps(p, abs_mask), bound, _CMP_NGT_UQ))))
              << j;
  }
  neg = n;
  return (unsure & ((std::uint64_t{1} << m) - 1)) == 0;
}
#endif

#if defined(FABRICA_LINES_AVX2)
// Bit v of words[v / 32] is kQ1Above of sg[v] (v < nv; the words past
// them 0), 32 sign bytes at a time.
[[gnu::target("arch=x86-64-v3")]] void q1_above_bits(const std::uint8_t* sg, std::size_t nv,
                                                     std::vector<std::uint32_t>& words) {
  static_assert(kQ1Above == 32, "bit 5 is moved to bit 7 of each byte");
  words.assign((nv + 31) / 32, 0u);
  std::size_t v = 0;
  for (; v + 32 <= nv; v += 32) {
    const __m256i b = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(sg + v));
    words[v / 32] = static_cast<std::uint32_t>(_mm256_movemask_epi8(_mm256_slli_epi16(b, 2)));
  }
  for (; v < nv; ++v) words[v / 32] |= std::uint32_t((sg[v] & kQ1Above) != 0) << (v % 32);
}

// Whether any of the n ring entries from `vertex` has its bit in `words`:
// eight entries per gather (the entries past a ring are other rings' or the
// padding's, valid vertex indices, and masked off).
[[gnu::target("arch=x86-64-v3")]] inline bool ring_above(const std::uint32_t* words,
                                                         const std::int32_t* vertex, int n) {
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i low5 = _mm256_set1_epi32(31), one = _mm256_set1_epi32(1);
  __m256i any = _mm256_setzero_si256();
  for (int j = 0; j < n; j += 8) {
    const __m256i idx = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(vertex + j));
    const __m256i w =
        _mm256_i32gather_epi32(reinterpret_cast<const int*>(words), _mm256_srli_epi32(idx, 5), 4);
    const __m256i bit = _mm256_and_si256(_mm256_srlv_epi32(w, _mm256_and_si256(idx, low5)), one);
    const __m256i in_ring = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - j), lanes);
    any = _mm256_or_si256(any, _mm256_and_si256(bit, in_ring));
  }
  return !_mm256_testz_si256(any, any);
}
#endif

// The sum of the one-sided differences of fan faces j0 and j1 (j1 only when
// `two`), halved when both count: what the face-order loop gives when they
// are the only candidates (each lane is crossing_weight and the difference
// of that loop, in the same operations; see RingPass::in_order). Fan face j
// has the neighbours j, j + 1 (x, y, nbr); their p (candidate_faces) are
// recomputed here in the same operations (neighbour m is a copy of
// neighbour 0, so p[m] = p[0] too).
inline double two_faces(const float* x, const float* y, const std::int32_t* nbr, const double* q1,
                        int j0, int j1, bool two, double c, double sn, double an, double q0) {
  const __m128d zero = _mm_setzero_pd(), one = _mm_set1_pd(1.0);
  const __m128d abs_mask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffff));
  const __m128d vc = _mm_set1_pd(c), vs = _mm_set1_pd(sn);
  const __m128d x0 = _mm_cvtps_pd(load2(x + j0)), x1 = _mm_cvtps_pd(load2(x + j1));
  const __m128d y0 = _mm_cvtps_pd(load2(y + j0)), y1 = _mm_cvtps_pd(load2(y + j1));
  const __m128d p0 = _mm_sub_pd(_mm_mul_pd(vc, y0), _mm_mul_pd(vs, x0));
  const __m128d p1 = _mm_sub_pd(_mm_mul_pd(vc, y1), _mm_mul_pd(vs, x1));
  const __m128d num = _mm_unpackhi_pd(p0, p1);
  const __m128d den = _mm_sub_pd(num, _mm_unpacklo_pd(p0, p1));
  const __m128d anum = _mm_and_pd(num, abs_mask), aden = _mm_and_pd(den, abs_mask);
  const __m128d sign_differs = _mm_xor_pd(_mm_cmplt_pd(num, zero), _mm_cmplt_pd(den, zero));
  const __m128d w1 = _mm_div_pd(num, den);
  __m128d ok = _mm_and_pd(_mm_cmplt_pd(anum, aden), _mm_cmpge_pd(w1, zero));
  ok = _mm_and_pd(ok, _mm_cmplt_pd(w1, one));
  ok = _mm_andnot_pd(
      _mm_and_pd(sign_differs, _mm_cmpgt_pd(anum, _mm_mul_pd(aden, _mm_set1_pd(0x1p-900)))), ok);
  const __m128d w2 = _mm_sub_pd(one, w1);
  const __m128d along =
      _mm_add_pd(_mm_mul_pd(vc, _mm_add_pd(_mm_mul_pd(w1, _mm_unpacklo_pd(x0, x1)),
                                           _mm_mul_pd(w2, _mm_unpackhi_pd(x0, x1)))),
                 _mm_mul_pd(vs, _mm_add_pd(_mm_mul_pd(w1, _mm_unpacklo_pd(y0, y1)),
                                           _mm_mul_pd(w2, _mm_unpackhi_pd(y0, y1)))));
  const __m128d dist = _mm_mul_pd(along, _mm_set1_pd(an));
  ok = _mm_and_pd(ok, _mm_cmpneq_pd(dist, zero));
  const __m128d qa = _mm_set_pd(q1[nbr[j1]], q1[nbr[j0]]);
  const __m128d qb = _mm_set_pd(q1[nbr[j1 + 1]], q1[nbr[j0 + 1]]);
  const __m128d q = _mm_add_pd(_mm_mul_pd(w1, qa), _mm_mul_pd(w2, qb));
  const __m128d d = _mm_div_pd(_mm_sub_pd(q, _mm_set1_pd(q0)), dist);
  // Lanes that do not count add -0, which leaves any sum unchanged.
  const __m128d neg0 = _mm_set1_pd(-0.0);
  const __m128d term = _mm_or_pd(_mm_and_pd(ok, d), _mm_andnot_pd(ok, neg0));
  const int okm = _mm_movemask_pd(ok) & (two ? 3 : 1);
  const double t0 = _mm_cvtsd_f64(term);
  const double t1 = okm & 2 ? _mm_cvtsd_f64(_mm_unpackhi_pd(term, term)) : -0.0;
  const double sum = (0.0 + t0) + t1;
  return okm == 3 ? sum * 0.5 : sum;
}

// A fan vertex whose D_t1 q1 is two_faces', queued: a batch of them then
// runs back to back, so the long dependency chains (loads, two divisions)
// of several vertices overlap instead of one vertex's filling the
// processor's window. The view's values (t1, n·v, q1) are read again when
// the batch runs.
struct TwoFaces {
  std::uint32_t i;
  std::int32_t jb;
  std::uint8_t j0, j1;
  bool two;
};

// What two_faces reads for a queued vertex: its ring from its start, the
// two faces, t1 = (c, sn), |n·v| and q1 at the vertex.
struct TwoInputs {
  const float *x, *y;
  const std::int32_t* nbr;
  int j0, j1;
  bool two;
  double c, sn, an, q0;
};

#if defined(FABRICA_LINES_AVX2)
// (v[j], v[j + 1]) of A's j0, A's j1 | B's j0, B's j1 as doubles: the
// unpacks give (j0 A, j0 B, j1 A, j1 B) for the faces' first and second
// corners.
[[gnu::target("arch=x86-64-v3"), gnu::always_inline]] inline void face_corners2(
    const float* a, int a0, int a1, const float* b, int b0, int b1, __m256d& first,
    __m256d& second) {
  const __m256d va = _mm256_cvtps_pd(_mm_castsi128_ps(
      _mm_unpacklo_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(a + a0)),
                         _mm_loadl_epi64(reinterpret_cast<const __m128i*>(a + a1)))));
  const __m256d vb = _mm256_cvtps_pd(_mm_castsi128_ps(
      _mm_unpacklo_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(b + b0)),
                         _mm_loadl_epi64(reinterpret_cast<const __m128i*>(b + b1)))));
  first = _mm256_unpacklo_pd(va, vb);
  second = _mm256_unpackhi_pd(va, vb);
}

// two_faces for two vertices at once (their faces in the four lanes of
// 256-bit vectors: A's j0, B's j0, A's j1, B's j1), each lane in the same
// operations as two_faces', so the same bits; A's and B's sums.
[[gnu::target("arch=x86-64-v3"), gnu::always_inline]] inline void two_faces2(
    const TwoInputs& A, const TwoInputs& B, const double* q1, double& ra, double& rb) {
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
  // (A, B, A, B): the lanes of the j0 faces, then the j1 faces.
  const __m256d vc = _mm256_set_pd(B.c, A.c, B.c, A.c), vs = _mm256_set_pd(B.sn, A.sn, B.sn, A.sn);
  __m256d xa, xb, ya, yb;
  face_corners2(A.x, A.j0, A.j1, B.x, B.j0, B.j1, xa, xb);
  face_corners2(A.y, A.j0, A.j1, B.y, B.j0, B.j1, ya, yb);
  const __m256d pa = _mm256_sub_pd(_mm256_mul_pd(vc, ya), _mm256_mul_pd(vs, xa));
  const __m256d num = _mm256_sub_pd(_mm256_mul_pd(vc, yb), _mm256_mul_pd(vs, xb));
  const __m256d den = _mm256_sub_pd(num, pa);
  const __m256d anum = _mm256_and_pd(num, abs_mask), aden = _mm256_and_pd(den, abs_mask);
  const __m256d sign_differs =
      _mm256_xor_pd(_mm256_cmp_pd(num, zero, _CMP_LT_OS), _mm256_cmp_pd(den, zero, _CMP_LT_OS));
  const __m256d w1 = _mm256_div_pd(num, den);
  __m256d ok =
      _mm256_and_pd(_mm256_cmp_pd(anum, aden, _CMP_LT_OS), _mm256_cmp_pd(w1, zero, _CMP_GE_OS));
  ok = _mm256_and_pd(ok, _mm256_cmp_pd(w1, one, _CMP_LT_OS));
  ok = _mm256_andnot_pd(
      _mm256_and_pd(sign_differs,
                    _mm256_cmp_pd(anum, _mm256_mul_pd(aden, _mm256_set1_pd(0x1p-900)), _CMP_GT_OS)),
      ok);
  const __m256d w2 = _mm256_sub_pd(one, w1);
  const __m256d along =
      _mm256_add_pd(_mm256_mul_pd(vc, _mm256_add_pd(_mm256_mul_pd(w1, xa), _mm256_mul_pd(w2, xb))),
                    _mm256_mul_pd(vs, _mm256_add_pd(_mm256_mul_pd(w1, ya), _mm256_mul_pd(w2, yb))));
  const __m256d dist = _mm256_mul_pd(along, _mm256_set_pd(B.an, A.an, B.an, A.an));
  ok = _mm256_and_pd(ok, _mm256_cmp_pd(dist, zero, _CMP_NEQ_UQ));
  const __m256d qa =
      _mm256_set_pd(q1[B.nbr[B.j1]], q1[A.nbr[A.j1]], q1[B.nbr[B.j0]], q1[A.nbr[A.j0]]);
  const __m256d qb = _mm256_set_pd(q1[B.nbr[B.j1 + 1]], q1[A.nbr[A.j1 + 1]], q1[B.nbr[B.j0 + 1]],
                                   q1[A.nbr[A.j0 + 1]]);
  const __m256d q = _mm256_add_pd(_mm256_mul_pd(w1, qa), _mm256_mul_pd(w2, qb));
  const __m256d d = _mm256_div_pd(_mm256_sub_pd(q, _mm256_set_pd(B.q0, A.q0, B.q0, A.q0)), dist);
  const __m256d term =
      _mm256_or_pd(_mm256_and_pd(ok, d), _mm256_andnot_pd(ok, _mm256_set1_pd(-0.0)));
  const int okm = _mm256_movemask_pd(ok);
  alignas(32) double t[4];
  _mm256_store_pd(t, term);
  const int ma = (okm & 1) | (A.two ? (okm >> 2 & 1) << 1 : 0);
  const int mb = (okm >> 1 & 1) | (B.two ? (okm >> 3 & 1) << 1 : 0);
  const double sa = (0.0 + t[0]) + (ma & 2 ? t[2] : -0.0);
  const double sb = (0.0 + t[1]) + (mb & 2 ? t[3] : -0.0);
  ra = ma == 3 ? sa * 0.5 : sa;
  rb = mb == 3 ? sb * 0.5 : sb;
}
#endif

// D_t1 q1 over vertices [b, e) from the tangent ring (see update_dt1q1).
struct RingPass {
  const std::int32_t *off, *nbr;
  const float *xs, *ys;
  const std::uint8_t *fan, *rank, *sg;
  const double* q1;
  const Vec2* t1;
  const Vec3* t1_world;
  const double* ndotv;
  const Vec3* pos;
  double* out;
  ApparentVertex* packed;  // E = out * t1_world, out, q1, pos
  bool cull;
  // With cull on the AVX2 pass: bit v of the words is kQ1Above of vertex v
  // (q1_above_bits), so a ring's test is one gather; nullptr otherwise.
  const std::uint32_t* above = nullptr;
  // false: the records' positions are already there (written once for the
  // surface, update_view_fields' same_surface) and not written again: the
  // position stream and a third of each record's stores (~0.2 ms a view on
  // igea at 1T) saved.
  bool write_pos = true;
  // With a streamed ring (the one-shot extraction): each call builds the
  // entries of its vertices (LinePrecompute::tangent_ring_block) and runs
  // over them; nbr, xs, ys and rank then hold entries from off[b] on
  // (entry_base), not from 0.
  const LinePrecompute* stream = nullptr;
  std::int32_t entry_base = 0;

  // The faces of vertex i with neighbours (a, b) (relative to the ring) in
  // the order given by `next` (returns false at the end), one at a time, as
  // the face-order loop: the average of the first two differences.
  template <class Next>
  static double in_order(const float* x, const float* y, const std::int32_t* nbr, const double* q1,
                         double c, double sn, double an, double q0, Next&& next) {
    double result = 0.0;
    int n = 0;
    int a, b;
    double pa, pb;
    while (next(a, b, pa, pb)) {
      double w1;
      if (!crossing_weight(pb, pb - pa, w1)) continue;
      const double x1 = x[a], y1 = y[a], x2 = x[b], y2 = y[b];
      const double w2 = 1.0 - w1;
      const double dist = (c * (w1 * x1 + w2 * x2) + sn * (w1 * y1 + w2 * y2)) * an;
      if (dist == 0.0) continue;
      const double q = w1 * q1[nbr[a]] + w2 * q1[nbr[b]];
      result += (q - q0) / dist;
      if (++n == 2) return result * 0.5;
    }
    return result;
  }

  // Not a fan, or a fan with more than two candidate faces (p, cand).
  [[gnu::noinline]] double general(std::size_t i, const double* p, std::uint64_t cand, double c,
                                   double sn, double an, double q0) const {
    const std::int32_t jb = off[i] - entry_base, m = off[i + 1] - off[i];
    const float *x = xs + jb, *y = ys + jb;
    if (!fan[i]) {
      int j = 0;
      return in_order(x, y, nbr + jb, q1, c, sn, an, q0,
                      [&](int& a, int& b, double& pa, double& pb) {
                        if (j >= m) return false;
                        a = j, b = j + 1, j += 2;
                        pa = c * y[a] - sn * x[a], pb = c * y[b] - sn * x[b];
                        return true;
                      });
    }
    int key[kMaxFan], nk = 0;  // candidates by rank (face order)
    for (; cand; cand &= cand - 1) {
      const int j = std::countr_zero(cand);
      int v = rank[jb + j] << 8 | j, k = nk++;
      for (; k > 0 && key[k - 1] > v; --k) key[k] = key[k - 1];
      key[k] = v;
    }
    int k = 0;
    return in_order(x, y, nbr + jb, q1, c, sn, an, q0, [&](int& a, int& b, double& pa, double& pb) {
      if (k >= nk) return false;
      a = key[k++] & 0xff, b = a + 1;
      pa = p[a], pb = p[b];
      return true;
    });
  }

  // dt1q1 (0 where not finite) and the record of vertex i.
  // Pos: write_pos (a template argument: no branch, nor register, in the
  // loop).
  template <bool Pos>
  [[gnu::always_inline]] inline void store(std::size_t i, double d) const {
    out[i] = std::isfinite(d) ? d : 0.0;
    if constexpr (Pos)
      store_apparent_vertex(packed[i], out[i], t1_world[i], q1[i], pos[i]);
    else
      store_apparent_vertex(packed[i], out[i], t1_world[i], q1[i]);
  }

  // The run for this pass's entry base and record positions (inlined into
  // each instruction set's caller).
  template <bool Wide>
  [[gnu::always_inline]] inline void run_for(std::size_t b, std::size_t e) const {
    if (entry_base != 0 && write_pos)
      run<Wide, true, true>(b, e);
    else if (entry_base != 0)
      run<Wide, false, true>(b, e);
    else if (write_pos)
      run<Wide, true, false>(b, e);
    else
      run<Wide, false, false>(b, e);
  }
  // Copies of the pass (`r`) in registers, not reloaded after the stores.
  FABRICA_DT1Q1_MULTIVERSION void portable(std::size_t b, std::size_t e) const {
    const RingPass r = *this;
    r.run_for<false>(b, e);
  }
#if defined(FABRICA_LINES_AVX2)
  [[gnu::target("arch=x86-64-v3")]] void wide(std::size_t b, std::size_t e) const {
    const RingPass r = *this;
    r.run_for<true>(b, e);
  }
#endif
  // The same bits either way: the wide pass only finds the candidate faces
  // of a fan from float products where their signs are certain.
  void operator()(std::size_t b, std::size_t e) const {
    if (stream) {
      // This block's ring entries, then the pass over them.
      LinePrecompute::TangentRing ring;
      stream->tangent_ring_block(b, e, ring);
      RingPass r = *this;
      r.stream = nullptr;
      r.nbr = ring.vertex.data();
      r.xs = ring.x.data();
      r.ys = ring.y.data();
      r.rank = ring.rank.data();
      r.entry_base = off[b];
      return r(b, e);
    }
#if defined(FABRICA_LINES_AVX2)
    if (cpu_has_avx2()) return wide(b, e);
#endif
    portable(b, e);
  }

  [[gnu::always_inline]] inline TwoInputs inputs(const TwoFaces& t) const {
    const std::size_t i = t.i;
    return TwoInputs{xs + t.jb, ys + t.jb, nbr + t.jb,         t.j0, t.j1, t.two,
                     t1[i][0],  t1[i][1],  std::abs(ndotv[i]), q1[i]};
  }
  template <bool Pos>
  [[gnu::always_inline]] inline void flush_portable(const TwoFaces* queue, int nq) const {
    for (int k = 0; k < nq; ++k) {
      const TwoInputs t = inputs(queue[k]);
      store<Pos>(queue[k].i,
                 two_faces(t.x, t.y, t.nbr, q1, t.j0, t.j1, t.two, t.c, t.sn, t.an, t.q0));
    }
  }
#if defined(FABRICA_LINES_AVX2)
  // Two vertices at a time (two_faces2), then the odd one. Not inlined: the
  // main loop keeps fewer values live (fewer spills; 0.8 M fewer
  // instructions over 5 igea views).
  template <bool Pos>
  [[gnu::target("arch=x86-64-v3"), gnu::noinline]] void flush_wide(const TwoFaces* queue,
                                                                   int nq) const {
    int k = 0;
    for (; k + 2 <= nq; k += 2) {
      double ra, rb;
      two_faces2(inputs(queue[k]), inputs(queue[k + 1]), q1, ra, rb);
      store<Pos>(queue[k].i, ra);
      store<Pos>(queue[k + 1].i, rb);
    }
    flush_portable<Pos>(queue + k, nq - k);
  }
#endif

  // Based: the entries start at off[b] (entry_base), not at 0.
  template <bool Wide, bool Pos, bool Based>
  [[gnu::always_inline]] inline void run(std::size_t b, std::size_t e) const {
    const std::int32_t base = Based ? entry_base : 0;
    constexpr int kQueue = 16;
    TwoFaces queue[kQueue];
    int nq = 0;
    std::size_t doubles = 0;  // fans handed to the double search (counted once)
    auto flush = [&] {
#if defined(FABRICA_LINES_AVX2)
      if constexpr (Wide) {
        flush_wide<Pos>(queue, nq);
        nq = 0;
        return;
      }
#endif
      flush_portable<Pos>(queue, nq);
      nq = 0;
    };
    for (std::size_t i = b; i < e; ++i) {
      const std::int32_t jb = off[i] - base, je = off[i + 1] - base;
      {
        // q1 of the neighbours of a vertex kAhead further (its ring
        // entries are read in order; q1 is scattered), every other entry,
        // and the start of its offsets (x, y): the hardware prefetcher
        // misses them where culled vertices leave gaps (ring pass alone
        // 2.04 → 1.93 ms on igea at 1T, min of 60).
        constexpr std::size_t kAhead = 6;
        const std::int32_t ahead = off[std::min(i + kAhead, e)] - base;
        const std::int32_t* a = nbr + ahead;
        for (int k = 0; k < 8; k += 2) __builtin_prefetch(q1 + a[k]);
        __builtin_prefetch(xs + ahead);
        __builtin_prefetch(ys + ahead);
        // The record of the vertex twelve further, for writing: a record
        // is written in part (40 of its 64 bytes), so its line is read
        // first (ring pass alone ~2.04 → ~1.91 ms; six or twenty ahead:
        // no better).
        __builtin_prefetch(packed + std::min(i + 12, e - 1), 1);
      }
      if (cull && !(sg[i] & kQ1Above)) {
        // Branch-free over the ring (bytes), by pairs: a ring of odd size
        // is a fan whose last neighbour repeats the first.
        unsigned any = 0;
#if defined(FABRICA_LINES_AVX2)
        if constexpr (Wide) {
          if (above && !ring_above(above, nbr + jb, je - jb)) {
            out[i] = 0.0;
            continue;
          }
        }
        if (Wide && above) {
          any = kQ1Above;
        } else
#endif
            if (je - jb <= kShort) {
          // Without a loop: the eight entries' bytes in one word, those
          // past the ring masked off (the last entry of an odd ring is a
          // fan's first neighbour again); fewer instructions than masking
          // each byte.
          const int n = je - jb;
          std::uint64_t w = 0;
#pragma GCC unroll 8
          for (int j = 0; j < kShort; ++j) w |= std::uint64_t(sg[nbr[jb + j]]) << (8 * j);
          const std::uint64_t in_ring =
              n >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * n)) - 1;
          any = (w & in_ring & (0x0101010101010101ull * kQ1Above)) != 0 ? kQ1Above : 0;
        } else {
          for (std::int32_t j = jb; j + 2 <= je; j += 2) any |= sg[nbr[j]] | sg[nbr[j + 1]];
        }
        if (!(any & kQ1Above)) {
          // No candidate face of the kernel has this corner: its record
          // is never read and is left as it is.
          out[i] = 0.0;
          continue;
        }
      }
      if (t1_world[i].squaredNorm() == 0.0) {
        store<Pos>(i, 0.0);
        continue;
      }
      const __m128d cs = _mm_loadu_pd(t1[i].data());
      const double c = _mm_cvtsd_f64(cs), sn = t1[i][1];
      const double q0 = q1[i], an = std::abs(ndotv[i]);
      double result = 0.0;
      if (fan[i]) {
        const std::int32_t m = je - jb - 1;
#if defined(FABRICA_LINES_AVX2)
        std::uint64_t neg;
        if constexpr (Wide) {
          if (std::abs(c) <= 2.0 && std::abs(sn) <= 2.0 &&
              fan_signs_float(xs + jb, ys + jb, m, c, sn, neg)) {
            // candidate_faces' bits without its "tiny" check (no p is).
            const std::uint64_t all = (std::uint64_t{1} << m) - 1;
            neg = (neg & all) | (neg & 1) << m;
            const std::uint64_t cand = (neg ^ neg >> 1) & all;
            const std::uint64_t rest = cand & (cand - 1);
            if (!(rest & (rest - 1))) {
              if (cand) {
                const int j0 = std::countr_zero(cand), j1 = rest ? std::countr_zero(rest) : j0;
                queue[nq++] =
                    TwoFaces{std::uint32_t(i), jb, std::uint8_t(j0), std::uint8_t(j1), rest != 0};
                if (nq == kQueue) flush();
                continue;
              }
              store<Pos>(i, 0.0);
              continue;
            }
          }
          ++doubles;
        }
#endif
        alignas(16) double p[kMaxFan + 2];
        const std::uint64_t cand = m < kShort ? candidate_faces<true>(xs + jb, ys + jb, m, cs, p)
                                              : candidate_faces<false>(xs + jb, ys + jb, m, cs, p);
        const std::uint64_t rest = cand & (cand - 1);
        if (rest & (rest - 1)) {
          result = general(i, p, cand, c, sn, an, q0);
        } else if (cand) {
          // At most two crossings: their sum does not depend on the order.
          const int j0 = std::countr_zero(cand), j1 = rest ? std::countr_zero(rest) : j0;
          queue[nq++] =
              TwoFaces{std::uint32_t(i), jb, std::uint8_t(j0), std::uint8_t(j1), rest != 0};
          if (nq == kQueue) flush();
          continue;
        }
      } else {
        result = general(i, nullptr, 0, c, sn, an, q0);
      }
      store<Pos>(i, result);
    }
    flush();
    if (doubles) dt1q1_double_path().fetch_add(doubles, std::memory_order_relaxed);
  }
};

// The RingPass of update_dt1q1 over the precomputed tangent ring.
RingPass ring_pass(ViewFields& fields, const Surface& surface, bool cull,
                   const LinePrecompute& precompute, bool write_positions, bool stream_ring) {
  const auto& pos = surface.positions();
  const double* q1 = fields.q1.data();
  const std::uint8_t* sg = fields.signs.data();
  // With the precomputed tangent ring: each neighbour's offset (x, y) in
  // the vertex's principal frame, so with t1 = (c, s) in that frame,
  // t2 = n × t1 = ±(-s, c) (the sign cancels in w1) and every product is
  // two-dimensional. The formulas of the topology walk (update_dt1q1),
  // evaluated from float offsets (relative differences ~1e-7). On a fan
  // each neighbour's p·t2 is computed once for its two faces, and only the
  // faces whose corners can give a crossing (a superset, see
  // candidate_faces) are tested.
  // A streamed ring: its entries are made per block (RingPass::stream).
  const LinePrecompute::TangentRing& tr =
      stream_ring ? precompute.streamed_tangent_ring() : precompute.tangent_ring();
  const bool streamed = tr.vertex.empty();
  return RingPass{tr.offset.data(),
                  tr.vertex.data(),
                  tr.x.data(),
                  tr.y.data(),
                  tr.fan.data(),
                  tr.rank.data(),
                  sg,
                  q1,
                  fields.t1.data(),
                  fields.t1_world.data(),
                  fields.ndotv.data(),
                  pos.data(),
                  fields.dt1q1.data(),
                  fields.apparent_vertex.data(),
                  cull,
                  nullptr,
                  write_positions,
                  streamed ? &precompute : nullptr};
}

}  // namespace

struct Dt1q1Blocks::State {
  RingPass pass;
  std::size_t nv, blocks;
  std::atomic<std::size_t> next{0}, prefix{0};
  std::unique_ptr<std::atomic<bool>[]> done;
  std::vector<std::uint32_t> above;  // RingPass::above's words
};

namespace {
// Gives `pass` the kQ1Above bitmap (in `words`) where the AVX2 pass culls.
void attach_above_bits(RingPass& pass, const ViewFields& fields,
                       std::vector<std::uint32_t>& words) {
#if defined(FABRICA_LINES_AVX2)
  if (!pass.cull || !cpu_has_avx2()) return;
  q1_above_bits(fields.signs.data(), fields.signs.size(), words);
  pass.above = words.data();
#endif
}
}  // namespace

Dt1q1Blocks::Dt1q1Blocks(ViewFields& fields, const Surface& surface, bool cull,
                         const LinePrecompute& precompute, bool write_positions, bool stream_ring) {
  const std::size_t nv = surface.vertex_count(), blocks = (nv + kBlock - 1) / kBlock;
  state_.reset(new State{ring_pass(fields, surface, cull, precompute, write_positions, stream_ring),
                         nv,
                         blocks,
                         {},
                         {},
                         std::make_unique<std::atomic<bool>[]>(blocks),
                         {}});
  attach_above_bits(state_->pass, fields, state_->above);
}

Dt1q1Blocks::~Dt1q1Blocks() = default;

// Moves the prefix of done blocks past every finished one. Sequentially
// consistent: a block marked done while another thread advances is seen by
// one of them (each marks, then advances), so the prefix never stops short.
void Dt1q1Blocks::advance() {
  State& s = *state_;
  std::size_t p = s.prefix.load();
  while (p < s.blocks && s.done[p].load())
    if (s.prefix.compare_exchange_weak(p, p + 1)) ++p;
}

bool Dt1q1Blocks::run_one() {
  State& s = *state_;
  const std::size_t b = s.next.fetch_add(1);
  if (b >= s.blocks) return false;
  s.pass(b * kBlock, std::min(s.nv, (b + 1) * kBlock));
  s.done[b].store(true);
  advance();
  return true;
}

void Dt1q1Blocks::run_all() {
  while (run_one()) {
  }
}

void Dt1q1Blocks::ready_through(std::size_t v) {
  State& s = *state_;
  const std::size_t need = std::min(s.blocks, v / kBlock + 1);
  while (s.prefix.load() < need) {
    if (run_one()) continue;
    advance();
    _mm_pause();  // a block another thread is running
  }
}

void update_dt1q1(ViewFields& fields, const Surface& surface, bool cull,
                  const LinePrecompute* precompute, bool write_positions, bool stream_ring) {
  const std::size_t nv = surface.vertex_count();
  const auto& pos = surface.positions();
  const auto& normals = surface.vertex_normals();
  // Pass 2: D_t1 q1 by Judd's finite differences (docs/algorithms.md §6.2):
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
    RingPass pass = ring_pass(fields, surface, cull, *precompute, write_positions, stream_ring);
    std::vector<std::uint32_t> above;
    attach_above_bits(pass, fields, above);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, Dt1q1Blocks::kBlock),
                      [&](const tbb::blocked_range<std::size_t>& r) { pass(r.begin(), r.end()); });
  } else {
    // D_t1 q1 of vertex i by the walk over its faces (0 where not finite).
    auto walk = [&](std::size_t i) {
      const Vec3& p0 = pos[i];
      const double ndotv = fields.ndotv[i];
      const Vec3& t1w = fields.t1_world[i];
      double result = 0.0;
      if (t1w.squaredNorm() == 0.0) return 0.0;
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
        double w1;
        if (!crossing_weight(p2_t2 - p0_t2, p2_t2 - p1_t2, w1)) return false;
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
      return std::isfinite(result) ? result : 0.0;
    };
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
          fields.dt1q1[i] = 0.0;  // its record is never read: left as it is
          return;
        }
      }
      fields.dt1q1[i] = walk(i);
      store_apparent_vertex(fields.apparent_vertex[i], fields.dt1q1[i], fields.t1_world[i], q1[i],
                            pos[i]);
    });
  }
}

}  // namespace fabrica::detail
