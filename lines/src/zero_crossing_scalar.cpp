// The tuned scalar zero-crossing kernel (docs/algorithms.md §0 "ZC" and
// "ZC-vec"): the per-view scans over the faces' sign bytes, candidates in
// prefetched batches, the fused contour + suggestive-contour scan and the
// packed apparent-ridge path; each hands its batches to the AVX2 kernels
// (zero_crossing_avx2.cpp) when the CPU has AVX2. Same segments, bit for
// bit, as the reference kernel (zero_crossing.cpp).
#include <algorithm>
#include <array>
#include <cmath>

#include "fabrica/core/error.hpp"
#include "parallel.hpp"
#include "simd_avx2.hpp"
#include "zero_crossing_internal.hpp"
#include "zero_crossing_kernel.hpp"

namespace fabrica {

namespace zc {

namespace {

template <class Num>
[[gnu::noinline]] void scalar_face(const ScalarInputs& in, const Num& num, std::size_t f,
                                   std::vector<LineSegment>& out) {
  scalar_face_body(in, num, f, out);
}

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
#if defined(FABRICA_LINES_AVX512)
      if (detail::cpu_has_avx512())
        scalar_faces_avx512(in, num, batch.face, batch.n, part);
      else
#endif
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
#if defined(FABRICA_LINES_AVX512)
  if (detail::cpu_has_avx512()) {
    kept_segments_avx512(in, field, kept, out);
    return;
  }
#endif
#if defined(FABRICA_LINES_AVX2)
  if (detail::cpu_has_avx2()) {
    kept_segments_avx2(in, field, kept, out);
    return;
  }
#endif
  kept_segments_scalar(in, field, kept, out);
}

}  // namespace

}  // namespace zc

namespace detail {

using namespace zc;

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

}  // namespace fabrica
