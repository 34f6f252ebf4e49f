// The per-view passes of ViewFields have two implementations: four vertices
// at a time with 256-bit vectors (AVX2, from LinePrecompute::vertex_blocks(),
// used when the CPU has it) and the portable scalar passes. Both must give
// the same bits, on every vertex, including vertices whose curvature is
// invalid and the partial last block: the vertex pass (n·v, K_r, the
// suggestive numerator, q1, t1, the sign bytes) and the illumination pass
// (f, Δf, ∇f, |∇f|, the PEL derivatives, the listed faces).
#include <gtest/gtest.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/extract.hpp"
#include "lines_test_meshes.hpp"
#include "simd_avx2.hpp"
#include "test_support.hpp"
#include "view_fields_light.hpp"
#include "zero_crossing_internal.hpp"
#include "zero_crossing_kernel.hpp"

using namespace fabrica;

namespace {

template <class T>
std::size_t differing_bits(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size()) + 1;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(T)) != 0;
  return n;
}

// Segments whose fields differ in any bit (field by field: LineSegment
// has padding bytes, which need not agree; an end's t, or its float
// barycentrics inside the face, as their 8 bytes). With `nan_equal`, a NaN
// equals any NaN (for NaN inputs: which operand's NaN an operation passes
// on, and so its sign, depends on how the compiler ordered the operands of
// a commutative operation, in any of the kernels).
std::size_t differing_segments(const std::vector<LineSegment>& a, const std::vector<LineSegment>& b,
                               bool nan_equal = false) {
  if (a.size() != b.size()) return std::max(a.size(), b.size()) + 1;
  auto same = [nan_equal](const auto& x, const auto& y) {
    return std::memcmp(&x, &y, sizeof(x)) == 0 || (nan_equal && std::isnan(x) && std::isnan(y));
  };
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    bool eq = a[i].face == b[i].face;
    for (int k = 0; k < 2; ++k) {
      const SegmentEnd &x = a[i].end[k], &y = b[i].end[k];
      const bool inside = a[i].kind[k] == EndKind::interior;
      eq = eq && a[i].kind[k] == b[i].kind[k] &&
           (inside ? same(x.bary[0], y.bary[0]) && same(x.bary[1], y.bary[1]) : same(x.t, y.t)) &&
           x.element == y.element && same(x.strength, y.strength);
    }
    n += !eq;
  }
  return n;
}

// The apparent-ridge records that the kernel reads (the corners of faces
// with kQ1Above at some corner in `whole`) and differ in any bit between
// `f` and `whole`; `records` counts those read.
std::size_t differing_records(const Surface& surface, const ViewFields& f, const ViewFields& whole,
                              std::size_t& records) {
  std::size_t differ = 0;
  records = 0;
  for (const Face& face : surface.faces()) {
    if (!((whole.signs[face[0]] | whole.signs[face[1]] | whole.signs[face[2]]) & kQ1Above))
      continue;
    for (int k = 0; k < 3; ++k) {
      ++records;
      differ += std::memcmp(&f.apparent_vertex[face[k]], &whole.apparent_vertex[face[k]],
                            sizeof(ApparentVertex)) != 0;
    }
  }
  return differ;
}

#define EXPECT_SAME_FIELD(a, b, name)                           \
  do {                                                          \
    EXPECT_FALSE((a).name.empty()) << #name;                    \
    EXPECT_EQ(differing_bits((a).name, (b).name), 0u) << #name; \
  } while (0)

// The fields with the AVX2 passes (where the CPU has them) and with the
// portable passes, from the same precompute.
std::pair<ViewFields, ViewFields> both_ways(const Surface& surface, const LinePrecompute& pre,
                                            const Camera& camera, const ViewFieldsRequest& req) {
  ViewFields simd = compute_view_fields(surface, camera, req, &pre);
#if defined(FABRICA_LINES_AVX2)
  const bool had = detail::avx2_enabled().exchange(false);
#endif
  ViewFields portable = compute_view_fields(surface, camera, req, &pre);
#if defined(FABRICA_LINES_AVX2)
  detail::avx2_enabled() = had;
#endif
  return {std::move(simd), std::move(portable)};
}

void expect_same_vertex_pass(const Surface& surface, const LinePrecompute& pre,
                             const Camera& camera, bool cull,
                             std::optional<double> min_ndotv = std::nullopt) {
  ViewFieldsRequest req;
  req.apparent_cull_threshold = cull ? std::optional<double>(1.0e3) : std::nullopt;
  req.apparent_min_ndotv = min_ndotv;
  // The suggestive-test bits in the sign bytes (compared with `signs`).
  req.suggestive_test_shift = cull ? std::optional<double>(0.05) : std::nullopt;
  const auto [simd, portable] = both_ways(surface, pre, camera, req);
  EXPECT_SAME_FIELD(simd, portable, ndotv);
  EXPECT_SAME_FIELD(simd, portable, kr);
  EXPECT_SAME_FIELD(simd, portable, sc_num);
  EXPECT_SAME_FIELD(simd, portable, q1);
  EXPECT_SAME_FIELD(simd, portable, t1);
  EXPECT_SAME_FIELD(simd, portable, t1_world);
  EXPECT_SAME_FIELD(simd, portable, signs);
  EXPECT_SAME_FIELD(simd, portable, dt1q1);
  EXPECT_SAME_FIELD(simd, portable, apparent_vertex);
  // The apparent-ridge kernel's record: E is D_t1 q1 times t1, and the
  // copies of D_t1 q1, q1 and the position, bit for bit, at every corner of
  // a face the kernel can read (with a cull threshold: a corner with
  // q1 above it).
  ASSERT_EQ(simd.apparent_vertex.size(), surface.vertex_count());
  std::vector<char> read(surface.vertex_count(), !cull);
  for (const Face& f : surface.faces())
    if ((simd.signs[f[0]] | simd.signs[f[1]] | simd.signs[f[2]]) & kQ1Above)
      read[f[0]] = read[f[1]] = read[f[2]] = 1;
  std::size_t wrong = 0, checked = 0;
  for (std::size_t i = 0; i < simd.apparent_vertex.size(); ++i) {
    if (!read[i]) continue;
    ++checked;
    const ApparentVertex& a = simd.apparent_vertex[i];
    const Vec3 e = simd.dt1q1[i] * simd.t1_world[i];
    wrong += std::memcmp(e.data(), a.field.data(), sizeof(Vec3)) != 0 ||
             std::memcmp(&simd.dt1q1[i], &a.dt1q1, sizeof(double)) != 0 ||
             std::memcmp(&simd.q1[i], &a.q1, sizeof(double)) != 0 ||
             std::memcmp(surface.positions()[i].data(), a.position.data(), sizeof(Vec3)) != 0;
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(checked, 0u);
}

void expect_same_light_pass(const Surface& surface, const LinePrecompute& pre, const Camera& camera,
                            std::optional<Vec3> light, double threshold) {
  ViewFieldsRequest req;
  req.radial = req.sc_test = req.apparent = false;
  req.light = req.pel = true;
  req.light_direction = light;
  req.light_threshold = threshold;
  req.light_cull_backfaces = true;
  const auto [simd, portable] = both_ways(surface, pre, camera, req);
  EXPECT_SAME_FIELD(simd, portable, ndotv);
  EXPECT_SAME_FIELD(simd, portable, light);
  EXPECT_SAME_FIELD(simd, portable, light_laplacian);
  EXPECT_SAME_FIELD(simd, portable, light_gradient);
  EXPECT_SAME_FIELD(simd, portable, light_gradient_norm);
  EXPECT_SAME_FIELD(simd, portable, pel_h);
  EXPECT_SAME_FIELD(simd, portable, pel_maximum);
  EXPECT_SAME_FIELD(simd, portable, light_faces);
}

Surface load(const char* rel, bool degenerate) {
  return test::load_for_lines(rel, degenerate);
}

// Every family, for the kernels' comparisons: with the defaults (variant
// 0); without the maximum test, and the scalar kernel without test
// function, fade or culling (1); without the apparent-ridge threshold (2).
LineOptions kernel_variant(int variant) {
  LineOptions o;
  o.families = all_families();
  if (variant == 1) {
    o.apparent.maximum_test = false;
    o.contour.trim_concave = false;
    o.suggestive.fade = o.highlight.fade = 0.0;
    o.suggestive.cull_backfaces = o.highlight.cull_backfaces = false;
  }
  if (variant == 2) o.apparent.threshold = 0.0;
  return o;
}
using test::camera_towards;

}  // namespace

TEST(LinesViewFields, SimdAndPortablePassesGiveTheSameBits) {
#if !defined(FABRICA_LINES_AVX2)
  GTEST_SKIP() << "no AVX2 passes in this build";
#else
  if (!detail::cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2";
#endif
  for (const char* rel : {"meshes/anatomy/bones/gfxmorph_femur.stl", "meshes/classic/c3d_cow.obj",
                          "meshes/classic/libigl_camelhead.off"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, std::string(rel).find("classic") != std::string::npos);
    const LinePrecompute pre(surface);
    const auto& valid = surface.curvature().valid;
    std::size_t invalid = 0;
    for (auto v : valid) invalid += v == 0;
    std::printf("%s: %zu vertices, %zu with invalid curvature\n", rel, valid.size(), invalid);
    Camera c = camera_towards(surface, Vec3(0.3, 0.2, 1.0));
    const double t = 0.2 / surface.feature_size();
    expect_same_vertex_pass(surface, pre, c, true);
    expect_same_vertex_pass(surface, pre, c, false);
    expect_same_vertex_pass(surface, pre, c, true, -0.2);
    expect_same_light_pass(surface, pre, c, std::nullopt, t);
    expect_same_light_pass(surface, pre, c, Vec3(1.0, 2.0, 0.5), t);
    c.projection = Projection::orthographic;
    expect_same_vertex_pass(surface, pre, c, true);
    expect_same_light_pass(surface, pre, c, std::nullopt, t);
  }
}

// The one-shot vertex pass packs its vertex blocks a few at a time instead
// of reading LinePrecompute::vertex_blocks(): the same bits (on a mesh
// whose vertex count is not a multiple of four, so the partial last block
// is packed too).
TEST(LinesViewFields, StreamedVertexBlocksGiveTheSameBits) {
#if !defined(FABRICA_LINES_AVX2)
  GTEST_SKIP() << "no AVX2 passes in this build";
#else
  if (!detail::cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2";
#endif
  const Surface surface = load("meshes/classic/libigl_camelhead.off", true);
  ASSERT_NE(surface.vertex_count() % 4, 0u);
  ASSERT_GT(surface.vertex_count(), 4u * 64u * 3u);  // several packs of 64 blocks
  const Camera c = camera_towards(surface, Vec3(0.3, 0.2, 1.0));
  for (const bool cull : {true, false}) {
    ViewFieldsRequest req;
    req.apparent_cull_threshold = cull ? std::optional<double>(1.0e3) : std::nullopt;
    req.suggestive_test_shift = cull ? std::optional<double>(0.05) : std::nullopt;
    const LinePrecompute streamed_pre(surface), held_pre(surface);
    ViewFields streamed, held;
    detail::update_view_fields(streamed, surface, c, req, &streamed_pre, false, false, true);
    detail::update_view_fields(held, surface, c, req, &held_pre, false, false, false);
    EXPECT_SAME_FIELD(streamed, held, ndotv);
    EXPECT_SAME_FIELD(streamed, held, kr);
    EXPECT_SAME_FIELD(streamed, held, sc_num);
    EXPECT_SAME_FIELD(streamed, held, q1);
    EXPECT_SAME_FIELD(streamed, held, t1);
    EXPECT_SAME_FIELD(streamed, held, t1_world);
    EXPECT_SAME_FIELD(streamed, held, signs);
    EXPECT_SAME_FIELD(streamed, held, dt1q1);
    EXPECT_SAME_FIELD(streamed, held, apparent_vertex);
    // pack_vertex_blocks writes what vertex_blocks() holds.
    const auto& vb = held_pre.vertex_blocks();
    const std::size_t nb = vb.block.size();
    std::vector<LinePrecompute::VertexBlock> packed(nb);
    std::vector<std::uint8_t> valid(nb);
    streamed_pre.pack_vertex_blocks(0, nb, packed.data(), valid.data());
    EXPECT_EQ(std::memcmp(packed.data(), vb.block.data(), nb * sizeof(packed[0])), 0);
    EXPECT_EQ(std::memcmp(valid.data(), vb.valid.data(), nb), 0);
  }
}

// The AVX2 D_t1 q1 pass finds a fan's candidate faces from float signs and
// hands the fan to the double search when a sign is within the float
// error: on a cylinder seen across its axis, t1 runs around it, so the
// neighbours on a vertex's own ring lie on the line through it (p = 0 up to
// rounding). Same bits as the portable pass, and that hand-over happens.
TEST(LinesViewFields, Dt1q1FloatSignsHandNearZeroToDouble) {
#if !defined(FABRICA_LINES_AVX2)
  GTEST_SKIP() << "no AVX2 passes in this build";
#else
  if (!detail::cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2";
  const Surface surface(test::make_cylinder(10.0, 40.0, 24, 64));
  const LinePrecompute pre(surface);
  Camera c = camera_towards(surface, Vec3(1.0, 0.0, 0.0));
  c.projection = Projection::orthographic;
  const std::size_t before = detail::dt1q1_double_path().load();
  expect_same_vertex_pass(surface, pre, c, false);
  EXPECT_GT(detail::dt1q1_double_path().load(), before);
  c = camera_towards(surface, Vec3(1.0, 0.3, 0.1));
  expect_same_vertex_pass(surface, pre, c, false);
#endif
}

// The face kernels also have AVX2 paths (the apparent-ridge crossing test
// and segments, and the contour and suggestive-contour segments, four faces
// at a time); every family's segments, all fields
// of every segment, must be the same bits with and without them, also with
// the maximum test off (and the scalar kernel without test function, fade
// or culling) and with no threshold (every fade branch). And the
// apparent ridges are the same whether their candidate faces come from the
// extractor's shared scan or from their own.
TEST(LinesViewFields, SimdAndPortableKernelsGiveTheSameSegments) {
#if !defined(FABRICA_LINES_AVX2)
  GTEST_SKIP() << "no AVX2 passes in this build";
#else
  if (!detail::cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2";
  std::size_t centroid_ends = 0;
  for (const char* rel : {"meshes/classic/c3d_cow.obj", "meshes/classic/libigl_camelhead.off"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, true);
    Camera c = camera_towards(surface, Vec3(-0.4, 0.3, 1.0));
    for (int variant = 0; variant < 3; ++variant) {
      const LineOptions o = kernel_variant(variant);
      LineExtractor simd_x(surface, o), portable_x(surface, o);
      const auto simd = simd_x.extract(c);
      const bool had = detail::avx2_enabled().exchange(false);
      const auto portable = portable_x.extract(c);
      detail::avx2_enabled() = had;
      ASSERT_EQ(simd.size(), portable.size());
      std::size_t centroid = 0;
      for (std::size_t k = 0; k < simd.size(); ++k) {
        SCOPED_TRACE(family_name(simd[k].family));
        EXPECT_EQ(simd[k].family, portable[k].family);
        EXPECT_EQ(differing_segments(simd[k].segments, portable[k].segments), 0u);
        if (simd[k].family == LineFamily::apparent) {
          EXPECT_GT(simd[k].segments.size(), 100u);
          // The extractor takes the kernel's candidate faces from the
          // contour scan; the family on its own scans for them.
          const SegmentSoup alone =
              extract_apparent_ridges(surface, simd_x.fields(), simd_x.feature_size(), o.apparent);
          EXPECT_EQ(differing_segments(simd[k].segments, alone.segments), 0u);
          for (const auto& seg : simd[k].segments) centroid += seg.kind[1] == EndKind::centroid;
        }
      }
      std::printf("%s variant %d: %zu apparent-ridge ends at a centroid\n", rel, variant, centroid);
      centroid_ends += centroid;
    }
  }
  // The kernels' three-crossing (centroid) branch was compared too.
  EXPECT_GT(centroid_ends, 0u);
#endif
}

// The suggestive-contour test in the sign bytes: kScOffFront and
// kScOffBack mean what they say at every vertex, they reject faces the
// scan would otherwise pass to the kernel, and the suggestive contours are
// the same bits as from fields without them.
TEST(LinesViewFields, SuggestiveTestBitsRejectExactlyWhatTheTestRejects) {
  for (const char* rel : {"meshes/classic/c3d_cow.obj", "meshes/classic/libigl_camelhead.off"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, true);
    const Camera c = camera_towards(surface, Vec3(-0.4, 0.3, 1.0));
    LineOptions o;
    o.families = {LineFamily::contour, LineFamily::suggestive};
    LineExtractor ex(surface, o);
    const auto soups = ex.extract(c);
    const ViewFields& f = ex.fields();
    const double fs = ex.feature_size();
    ASSERT_TRUE(f.suggestive_test_shift.has_value());
    const double s = *f.suggestive_test_shift;
    EXPECT_EQ(s, o.suggestive.threshold / (fs * fs));
    std::size_t front = 0, back = 0, wrong = 0;
    for (std::size_t i = 0; i < surface.vertex_count(); ++i) {
      const double n = f.sc_num[i] - s * f.ndotv[i];
      const bool a = n <= 0.0 && f.ndotv[i] >= 0.0, b = n >= 0.0 && f.ndotv[i] <= 0.0;
      wrong += a != ((f.signs[i] & kScOffFront) != 0) || b != ((f.signs[i] & kScOffBack) != 0);
      front += a;
      back += b;
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(front, 0u);
    EXPECT_GT(back, 0u);
    // Faces with a K_r sign change, not all back-facing, that the bits reject.
    std::size_t rejected = 0;
    for (const Face& face : surface.faces()) {
      const unsigned a0 = f.signs[face[0]], a1 = f.signs[face[1]], a2 = f.signs[face[2]];
      const unsigned any = a0 | a1 | a2, all = a0 & a1 & a2;
      rejected += (any & ~all & (kKrPositive | kKrNegative)) && (any & kNdotvNotBack) &&
                  (all & (kScOffFront | kScOffBack));
    }
    std::printf("%s: %zu + %zu vertices with a bit, %zu candidate faces rejected\n", rel, front,
                back, rejected);
    EXPECT_GT(rejected, 0u);
    ViewFieldsRequest req;
    req.apparent = false;
    const ViewFields plain = compute_view_fields(surface, c, req);
    ASSERT_FALSE(plain.suggestive_test_shift.has_value());
    const SegmentSoup without = extract_suggestive_contours(surface, plain, fs, o.suggestive);
    ASSERT_EQ(soups[1].family, LineFamily::suggestive);
    EXPECT_GT(without.segments.size(), 50u);
    EXPECT_EQ(differing_segments(soups[1].segments, without.segments), 0u);
  }
}

// D_t1 q1 in claimable blocks (the one-thread extraction computes it as
// the apparent-ridge kernel's chunks need it): the same bits as the whole
// pass, whoever computes which block, and ready_through(v) returns only
// when every vertex up to v is done.
TEST(LinesViewFields, Dt1q1InBlocksIsTheWholePass) {
  const Surface surface = load("meshes/classic/libigl_camelhead.off", true);
  const LinePrecompute pre(surface);
  const Camera c = camera_towards(surface, Vec3(0.2, -0.3, 1.0));
  ViewFieldsRequest req;
  req.apparent_cull_threshold = 0.1 / (surface.feature_size() * surface.feature_size());
  const ViewFields whole = compute_view_fields(surface, c, req, &pre);
  const std::size_t nv = surface.vertex_count();
  ASSERT_GT(nv, 3 * detail::Dt1q1Blocks::kBlock);  // several blocks
  std::size_t nonzero = 0;
  for (double d : whole.dt1q1) nonzero += d != 0.0;
  EXPECT_GT(nonzero, nv / 10);
  tbb::task_arena arena(2);
  for (int round = 0; round < 4; ++round) {
    ViewFields f;
    detail::update_view_fields(f, surface, c, req, &pre, true);
    detail::Dt1q1Blocks blocks(f, surface, true, pre);
    std::size_t early_wrong = 0;
    // Alone first (only the blocks up to v are computed), then with
    // another thread running blocks at the same time.
    const std::size_t first =
        detail::Dt1q1Blocks::kBlock + 5 + 13 * static_cast<std::size_t>(round);
    blocks.ready_through(first);
    for (std::size_t i = 0; i <= first; ++i)
      early_wrong += std::memcmp(&f.dt1q1[i], &whole.dt1q1[i], sizeof(double)) != 0;
    const std::size_t mid = nv / 2 + 77 * static_cast<std::size_t>(round);
    arena.execute([&] {
      tbb::parallel_invoke(
          [&] {
            blocks.ready_through(mid);
            for (std::size_t i = 0; i <= mid; ++i)
              early_wrong += std::memcmp(&f.dt1q1[i], &whole.dt1q1[i], sizeof(double)) != 0;
            blocks.ready_through(nv - 1);
          },
          [&] { blocks.run_all(); });
    });
    blocks.ready_through(nv - 1);
    EXPECT_EQ(early_wrong, 0u) << "round " << round;
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < nv; ++i)
      wrong += std::memcmp(&f.dt1q1[i], &whole.dt1q1[i], sizeof(double)) != 0;
    EXPECT_EQ(wrong, 0u) << "round " << round;
    // The records the kernel reads (corners of faces with q1 above the
    // threshold somewhere) are the whole pass's too.
    std::size_t records = 0;
    const std::size_t differ = differing_records(surface, f, whole, records);
    EXPECT_GT(records, 0u);
    EXPECT_EQ(differ, 0u) << "round " << round;
  }
  // The kernel honours the gate on every path: with fields computed
  // without the cull threshold (no q1 bits) it takes the plain path, which
  // must wait for every chunk before reading any record.
  ViewFieldsRequest plain;
  const ViewFields all = compute_view_fields(surface, c, plain, &pre);
  ViewFields g;
  detail::update_view_fields(g, surface, c, plain, &pre, true);
  detail::Dt1q1Blocks gate(g, surface, false, pre);
  const detail::ChunkReady ready = [&](std::size_t) { gate.ready_through(nv - 1); };
  const ApparentOptions ao;
  const double fs = surface.feature_size();
  const SegmentSoup want = extract_apparent_ridges(surface, all, fs, ao);
  const SegmentSoup got = detail::extract_apparent_ridges(surface, g, fs, ao, nullptr, &ready);
  EXPECT_GT(want.segments.size(), 50u);
  EXPECT_EQ(differing_segments(got.segments, want.segments), 0u);
}

// A LineExtractor's records keep their positions from when the array was
// sized (same_surface) and the D_t1 q1 pass does not write them again: the
// records the kernel reads are still the public pass's, bit for bit, over
// several views and after apparent ridges were switched off and on (the
// array cleared and sized again); positions written nowhere else fail it.
TEST(LinesViewFields, ExtractorRecordsKeepTheirPositions) {
  const Surface surface = load("meshes/classic/libigl_camelhead.off", true);
  LineOptions o;
  o.families = reference_families();
  LineExtractor ex(surface, o);
  const double fs = surface.feature_size();
  ViewFieldsRequest req;
  req.apparent_cull_threshold = o.apparent.threshold / (fs * fs);
  req.suggestive_test_shift = o.suggestive.threshold / (fs * fs);
  const Vec3 dirs[] = {Vec3(0.2, -0.3, 1.0), Vec3(-1.0, 0.4, 0.1), Vec3(0.3, 1.0, -0.5)};
  for (int round = 0; round < 4; ++round) {
    SCOPED_TRACE(round);
    if (round == 2) {
      LineOptions off = o;
      off.families = {LineFamily::contour};
      ex.set_options(off);
      (void)ex.extract(camera_towards(surface, dirs[0]));
      EXPECT_TRUE(ex.fields().apparent_vertex.empty());
      ex.set_options(o);
    }
    const Camera c = camera_towards(surface, dirs[round % 3]);
    (void)ex.extract(c);
    const ViewFields whole = compute_view_fields(surface, c, req, &ex.precompute());
    const ViewFields& f = ex.fields();
    ASSERT_EQ(f.apparent_vertex.size(), surface.vertex_count());
    std::size_t records = 0;
    const std::size_t differ = differing_records(surface, f, whole, records);
    EXPECT_GT(records, 100u);
    EXPECT_EQ(differ, 0u);
    // Every record's position is the vertex's, read or not.
    std::size_t off_position = 0;
    for (std::size_t i = 0; i < surface.vertex_count(); ++i)
      off_position += f.apparent_vertex[i].position != surface.positions()[i];
    EXPECT_EQ(off_position, 0u);
  }
}

// ApparentOptions::min_ndotv (the viewer's moving frames): the kQ1Above
// bits are those without it less the vertices with n·v < m, every other
// field and bit is the same, the other families' segments are the same bit
// for bit, and the apparent ridges are exactly those without it on the
// faces that keep a corner with the bit, bit for bit (D_t1 q1 is current
// wherever such a face reads it). On an open and a closed mesh, two views.
TEST(LinesViewFields, ApparentMinNdotvKeepsTheRidgesOfTheFacesItLists) {
  for (const char* rel : {"meshes/classic/libigl_camelhead.off", "meshes/classic/c3d_cow.obj"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, true);
    LineOptions all;
    all.families = reference_families();
    LineOptions limited = all;
    limited.apparent.min_ndotv = -0.2;
    LineExtractor a(surface, all), b(surface, limited);
    for (const Vec3& dir : {Vec3(0.2, -0.3, 1.0), Vec3(-1.0, 0.4, 0.1)}) {
      const Camera c = camera_towards(surface, dir);
      const std::vector<SegmentSoup> sa = a.extract(c), sb = b.extract(c);
      const ViewFields &fa = a.fields(), &fb = b.fields();
      ASSERT_EQ(fb.apparent_min_ndotv, std::optional<double>(-0.2));
      EXPECT_EQ(differing_bits(fa.ndotv, fb.ndotv), 0u);
      EXPECT_EQ(differing_bits(fa.q1, fb.q1), 0u);
      std::size_t wrong = 0, dropped = 0;
      for (std::size_t v = 0; v < surface.vertex_count(); ++v) {
        const bool keep = !(fa.ndotv[v] < -0.2);
        const unsigned want = keep ? fa.signs[v] : fa.signs[v] & ~unsigned(kQ1Above);
        wrong += fb.signs[v] != want;
        dropped += !keep && (fa.signs[v] & kQ1Above);
      }
      EXPECT_EQ(wrong, 0u);
      EXPECT_GT(dropped, 0u) << "no vertex above the threshold turned away: the test tests nothing";
      ASSERT_EQ(sa.size(), sb.size());
      for (std::size_t k = 0; k < sa.size(); ++k) {
        SCOPED_TRACE(family_name(sa[k].family));
        if (sa[k].family != LineFamily::apparent) {
          EXPECT_EQ(differing_segments(sa[k].segments, sb[k].segments), 0u);
          continue;
        }
        std::vector<LineSegment> kept;
        for (const LineSegment& seg : sa[k].segments) {
          const Face& f = surface.faces()[static_cast<std::size_t>(seg.face)];
          if ((fb.signs[f[0]] | fb.signs[f[1]] | fb.signs[f[2]]) & kQ1Above) kept.push_back(seg);
        }
        EXPECT_LT(kept.size(), sa[k].segments.size());
        EXPECT_GT(kept.size(), 0u);
        EXPECT_EQ(differing_segments(kept, sb[k].segments), 0u);
      }
    }
  }
}

// What the limit is for: on a closed surface seen from outside, the
// apparent ridges it drops are hidden. The visible apparent ridges of the
// igea (CPU hidden-line removal at 1024², lines as a LineDrawer chains
// them) keep their length with the limit, in three views; the hidden ones
// lose a good part of theirs.
TEST(LinesViewFields, ApparentMinNdotvDropsHiddenRidgesOnAClosedSurface) {
  const Surface surface = load("meshes/classic/c3d_igea.ply", true);
  DrawLinesOptions all;
  all.lines.families = {LineFamily::apparent};
  DrawLinesOptions limited = all;
  limited.lines.apparent.min_ndotv = -0.2;
  LineDrawer a(surface, all), b(surface, limited);
  auto lengths = [](const LineSet& lines) {
    double visible = 0.0, hidden = 0.0;
    for (const Polyline& pl : lines.polylines) {
      const std::size_t n = pl.vertices.size(), edges = pl.closed ? n : n - 1;
      for (std::size_t i = 0; i < edges; ++i) {
        const LineVertex &p = pl.vertices[i], &q = pl.vertices[(i + 1) % n];
        ((p.visible && q.visible) ? visible : hidden) += (q.position - p.position).norm();
      }
    }
    return std::pair{visible, hidden};
  };
  for (const Vec3& dir : {Vec3(0.0, 0.0, 1.0), Vec3(1.0, 0.2, 0.3), Vec3(-0.5, 0.8, 0.4)}) {
    Camera c = camera_towards(surface, dir);
    c.width = c.height = 1024;
    const auto [va, ha] = lengths(a.draw(c).lines);
    const auto [vb, hb] = lengths(b.draw(c).lines);
    std::printf("visible %.5f -> %.5f mm, hidden %.5f -> %.5f mm\n", va, vb, ha, hb);
    EXPECT_NEAR(vb, va, 0.005 * va);
    EXPECT_LT(hb, 0.8 * ha);
  }
}

// The limit lives in the view fields: extract_apparent_ridges refuses
// options whose limit the fields were not computed with (they would read
// D_t1 q1 where it is stale), and a NaN limit is an input error.
TEST(LinesViewFields, ApparentMinNdotvNeedsFieldsComputedWithIt) {
  const Surface surface = load("meshes/classic/libigl_camelhead.off", true);
  const Camera c = camera_towards(surface, Vec3(0.2, -0.3, 1.0));
  const double fs = surface.feature_size();
  ApparentOptions o;
  o.min_ndotv = -0.2;
  ViewFieldsRequest req;
  req.apparent_cull_threshold = o.threshold / (fs * fs);
  const ViewFields without = compute_view_fields(surface, c, req);
  EXPECT_THROW((void)extract_apparent_ridges(surface, without, fs, o), InputError);
  req.apparent_min_ndotv = o.min_ndotv;
  const ViewFields with = compute_view_fields(surface, c, req);
  EXPECT_NO_THROW((void)extract_apparent_ridges(surface, with, fs, o));
  ApparentOptions plain;
  EXPECT_THROW((void)extract_apparent_ridges(surface, with, fs, plain), InputError);
  req.apparent_min_ndotv = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)compute_view_fields(surface, c, req), InputError);
}

// D_t1 q1 from the precomputed tangent ring (neighbour fans, and two
// neighbours per face where the ring is not a closed fan: boundaries,
// degenerate and non-manifold vertices) against the independent
// face-by-face walk over the topology in double positions. The ring holds
// float offsets, so values agree to float precision, except where a crossing
// lands within rounding of a ring corner and the two walks pick different
// faces.
TEST(LinesViewFields, Dt1q1FromTheTangentRingMatchesTheTopologyWalk) {
  for (const char* rel : {"meshes/classic/c3d_cow.obj", "meshes/classic/libigl_camelhead.off"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, true);
    const LinePrecompute pre(surface);
    const auto& ring = pre.tangent_ring();
    std::size_t fans = 0;
    for (auto f : ring.fan) fans += f != 0;
    // Both kinds of ring are exercised.
    EXPECT_GT(fans, surface.vertex_count() / 2);
    EXPECT_LT(fans, surface.vertex_count());
    Camera c = camera_towards(surface, Vec3(-0.4, 0.3, 1.0));
    ViewFieldsRequest req;
    const ViewFields fast = compute_view_fields(surface, c, req, &pre);
    const ViewFields walk = compute_view_fields(surface, c, req, nullptr);
    ASSERT_EQ(fast.dt1q1.size(), walk.dt1q1.size());
    // Values near 0 (relative to the typical magnitude, the median: the
    // largest are outliers where a crossing lands next to the vertex) are
    // compared absolutely.
    std::vector<double> mags;
    for (double d : walk.dt1q1)
      if (d != 0.0) mags.push_back(std::abs(d));
    ASSERT_FALSE(mags.empty());
    std::nth_element(mags.begin(), mags.begin() + mags.size() / 2, mags.end());
    const double floor = 1e-6 * mags[mags.size() / 2];
    // Counted separately on fans and on the other rings (few, but a path
    // of their own).
    std::size_t nonzero[2] = {0, 0}, close[2] = {0, 0};
    for (std::size_t i = 0; i < walk.dt1q1.size(); ++i) {
      const double a = fast.dt1q1[i], b = walk.dt1q1[i];
      EXPECT_TRUE(std::isfinite(a)) << i;
      if (b == 0.0 && a == 0.0) continue;
      const int kind = ring.fan[i] ? 0 : 1;
      ++nonzero[kind];
      close[kind] += std::abs(a - b) <= 1e-4 * std::max(std::abs(b), floor);
    }
    std::printf("%s: fans %zu/%zu close, other rings %zu/%zu close\n", rel, close[0], nonzero[0],
                close[1], nonzero[1]);
    EXPECT_GT(nonzero[0], surface.vertex_count() / 2);
    EXPECT_GT(nonzero[1], 0u);
    for (int kind = 0; kind < 2; ++kind)
      EXPECT_GE(static_cast<double>(close[kind]), 0.97 * static_cast<double>(nonzero[kind]));
  }
}

// The AVX-512 kernels (eight faces at a time, where the CPU has AVX-512:
// the apparent ridges' segments, and the scalar kernel of contours,
// suggestive contours and highlights) against the AVX2 and the portable
// ones: every family's segments, every field, the same bits, on three
// meshes (igea: the reference mesh, 268k faces), with and without the
// maximum test and the threshold, the scalar kernel without test function,
// fade or culling, in perspective and orthographic views (igea with the
// default options only).
TEST(LinesViewFields, Avx512Avx2AndPortableKernelsGiveTheSameSegments) {
#if !defined(FABRICA_LINES_AVX512)
  GTEST_SKIP() << "no AVX-512 kernels in this build";
#else
  if (!detail::cpu_has_avx512()) GTEST_SKIP() << "this CPU has no AVX-512 (F, VL, DQ, BW)";
  std::size_t centroid_ends = 0, apparent = 0;
  for (const char* rel : {"meshes/classic/c3d_cow.obj", "meshes/classic/libigl_camelhead.off",
                          "meshes/classic/c3d_igea.ply"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, false);
    // (igea, 20× the others' faces: the default options only)
    const bool big = surface.face_count() > 100000;
    for (int variant = 0; variant < (big ? 1 : 4); ++variant) {
      SCOPED_TRACE(variant);
      Camera c = camera_towards(surface, Vec3(0.5, -0.2, 1.0));
      const LineOptions o = kernel_variant(variant);
      if (variant == 3) c.projection = Projection::orthographic;
      LineExtractor x512(surface, o), x2(surface, o), xp(surface, o);
      const auto wide = x512.extract(c);
      const bool had512 = detail::avx512_enabled().exchange(false);
      const auto avx2 = x2.extract(c);
      const bool had2 = detail::avx2_enabled().exchange(false);
      const auto portable = xp.extract(c);
      detail::avx2_enabled() = had2;
      detail::avx512_enabled() = had512;
      // The fields the kernels read (D_t1 q1 at every vertex, and the
      // records) are the same on every path.
      EXPECT_SAME_FIELD(x512.fields(), x2.fields(), dt1q1);
      EXPECT_SAME_FIELD(x512.fields(), xp.fields(), dt1q1);
      std::size_t records = 0;
      EXPECT_EQ(differing_records(surface, x512.fields(), x2.fields(), records), 0u);
      EXPECT_GT(records, 0u);
      ASSERT_EQ(wide.size(), avx2.size());
      ASSERT_EQ(wide.size(), portable.size());
      for (std::size_t k = 0; k < wide.size(); ++k) {
        SCOPED_TRACE(family_name(wide[k].family));
        EXPECT_EQ(differing_segments(wide[k].segments, avx2[k].segments), 0u);
        EXPECT_EQ(differing_segments(wide[k].segments, portable[k].segments), 0u);
        if (wide[k].family != LineFamily::apparent) continue;
        apparent += wide[k].segments.size();
        for (const auto& seg : wide[k].segments) centroid_ends += seg.kind[1] == EndKind::centroid;
      }
    }
  }
  // Enough segments for every lane pattern, and the centroid branch.
  EXPECT_GT(apparent, 10000u);
  EXPECT_GT(centroid_ends, 0u);
#endif
}

#if defined(FABRICA_LINES_AVX512)
namespace {

// Random apparent-ridge records for every vertex of `surface` (its real
// positions): E, D_t1 q1 and q1 of either sign, with exact zeros (both
// ends of a cut at D_t1 q1 = 0: t = 1/2), signed zeros, subnormals and
// values near the overflow of a product; with `special`, also infinities
// and NaNs.
std::vector<ApparentVertex> random_records(const Surface& surface, std::uint64_t seed,
                                           bool special) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 99);
  auto value = [&] {
    const int p = pick(rng);
    if (p < 8) return 0.0;
    if (p < 12) return -0.0;
    if (p < 14) return normal(rng) * 1e-310;
    if (p < 16) return normal(rng) * 1e150;
    if (special && p < 18)
      return p == 16 ? std::numeric_limits<double>::infinity()
                     : -std::numeric_limits<double>::infinity();
    if (special && p < 20) return std::numeric_limits<double>::quiet_NaN();
    return normal(rng);
  };
  std::vector<ApparentVertex> r(surface.vertex_count());
  for (std::size_t i = 0; i < r.size(); ++i) {
    for (int k = 0; k < 3; ++k) r[i].field[k] = value();
    r[i].dt1q1 = value();
    r[i].q1 = value();
    r[i].position = surface.positions()[i];
  }
  return r;
}

struct KernelRun {
  std::unique_ptr<zc::KeptFaces> kept = std::make_unique<zc::KeptFaces>();
  std::vector<LineSegment> segments;
};

enum class KernelPath { portable, avx2, avx512 };

// packed_chunk's kernel calls for the listed faces, on one path: the kept
// faces in batches of `batch`, then their segments.
KernelRun run_kernels(const Surface& surface, const std::vector<ApparentVertex>& records,
                      const std::vector<std::uint32_t>& list, int batch,
                      const VectorCrossingOptions& o, KernelPath path) {
  zc::VectorInputs in{zc::MeshArrays(surface), &records[0].dt1q1, nullptr, &records[0].q1, o};
  in.pos = records[0].position.data();
  in.ds = in.ps = zc::kApparentStride;
  const double* field = records[0].field.data();
  const Face* faces = surface.faces().data();
  const Topology& topo = surface.topology();
  KernelRun r;
  zc::KeptFaces& kept = *r.kept;
  for (std::size_t j = 0; j < list.size(); j += std::size_t(batch)) {
    const int n = static_cast<int>(std::min(list.size() - j, std::size_t(batch)));
    if (path != KernelPath::portable)
      zc::keep_crossed_avx2(faces, list.data() + j, n, field, topo, kept);
    else
      for (int k = 0; k < n; ++k)
        zc::keep_if_crossed(list[j + k], zc::crossing_bits_of(faces[list[j + k]], field), topo,
                            kept);
  }
  if (path == KernelPath::avx512) {
    zc::kept_segments_avx512(in, field, kept, r.segments);
  } else if (path == KernelPath::avx2) {
    zc::kept_segments_avx2(in, field, kept, r.segments);
  } else {
    for (std::size_t j = 0; j < kept.n; ++j) {
      const Face& fg = faces[kept.f[j]];
      const int v[3] = {fg[0], fg[1], fg[2]};
      const Vec3 E[3] = {zc::field_at(field, fg[0]), zc::field_at(field, fg[1]),
                         zc::field_at(field, fg[2])};
      zc::vector_face_segments(in, kept.f[j], v, E, kept.z[j], r.segments);
    }
  }
  return r;
}

// Kept faces (and their crossing bits) that differ between two runs.
std::size_t differing_kept(const zc::KeptFaces& a, const zc::KeptFaces& b) {
  if (a.n != b.n) return std::max(a.n, b.n) + 1;
  std::size_t n = 0;
  for (std::size_t j = 0; j < a.n; ++j) n += a.f[j] != b.f[j] || a.z[j] != b.z[j];
  return n;
}

}  // namespace
#endif

// The segment kernel alone on random records with the awkward values
// (exact and signed zeros, subnormals, huge products; infinities and NaNs
// against the AVX2 kernel, any NaN equal to any other), lists of every
// length mod 8 and batches of 16 (as the packed path calls keep_crossed)
// and of 13: the AVX-512 kernel gives the AVX2 and portable kernels'
// segments, bit for bit (from the same kept faces, whose AVX2 and portable
// lists and crossing bits are compared too), with and without the maximum
// test, the threshold and the raw magnitude; every count of kept faces mod
// 8 occurs.
TEST(LinesViewFields, Avx512KernelMatchesOnAwkwardRecords) {
#if !defined(FABRICA_LINES_AVX512)
  GTEST_SKIP() << "no AVX-512 kernels in this build";
#else
  if (!detail::cpu_has_avx512()) GTEST_SKIP() << "this CPU has no AVX-512 (F, VL, DQ, BW)";
  const Surface surface = load("meshes/classic/c3d_cow.obj", false);
  const std::size_t nf = std::min<std::size_t>(surface.face_count(), detail::kFaceChunk);
  std::size_t segments = 0, centroid = 0, compared = 0;
  unsigned tails = 0;  // bit r: a run kept r faces mod 8
  for (int special = 0; special < 2; ++special) {
    const auto records = random_records(surface, 0x5eed + std::uint64_t(special), special != 0);
    for (std::size_t len : {nf, nf - 1, nf - 3, std::size_t{1}, std::size_t{7}, std::size_t{9},
                            std::size_t{30}, std::size_t{61}, std::size_t{200}}) {
      // A chunk's candidates: ascending, every face or every other one.
      for (int stride = 1; stride <= 2; ++stride) {
        std::vector<std::uint32_t> list;
        for (std::size_t f = 0; f < nf && list.size() < len; f += std::size_t(stride))
          list.push_back(static_cast<std::uint32_t>(f));
        for (int batch : {16, 13}) {
          for (int variant = 0; variant < 4; ++variant) {
            SCOPED_TRACE(testing::Message() << "special " << special << " length " << list.size()
                                            << " batch " << batch << " variant " << variant);
            VectorCrossingOptions o;
            o.test = variant == 1 ? ExtremumTest::none : ExtremumTest::perpendicular;
            o.threshold = variant == 2 ? 0.0 : 0.3;
            o.keep_raw_magnitude = variant == 3;
            const KernelRun w = run_kernels(surface, records, list, batch, o, KernelPath::avx512);
            const KernelRun a = run_kernels(surface, records, list, batch, o, KernelPath::avx2);
            EXPECT_EQ(differing_kept(*w.kept, *a.kept), 0u);
            EXPECT_EQ(differing_segments(w.segments, a.segments, special != 0), 0u);
            if (!special) {
              const KernelRun p =
                  run_kernels(surface, records, list, batch, o, KernelPath::portable);
              EXPECT_EQ(differing_kept(*w.kept, *p.kept), 0u);
              EXPECT_EQ(differing_segments(w.segments, p.segments), 0u);
            }
            ++compared;
            tails |= 1u << (w.kept->n % 8);
            segments += w.segments.size();
            for (const auto& seg : w.segments) centroid += seg.kind[1] == EndKind::centroid;
          }
        }
      }
    }
  }
  std::printf("%zu runs, %zu segments, %zu ends at a centroid\n", compared, segments, centroid);
  EXPECT_GT(segments, 10000u);
  EXPECT_GT(centroid, 100u);
  EXPECT_EQ(tails, 0xFFu);
#endif
}

// The scalar kernel alone (contours, suggestive contours: scalar_face_body)
// on random per-vertex values with the awkward ones (exact and signed
// zeros, subnormals, huge values; infinities and NaNs against the AVX2
// kernel, any NaN equal to any other), with a stored test numerator or the
// shifted one (negated too), with and without denominator, culling and
// fade, lists of every length mod 8: the AVX-512 kernel gives the AVX2
// kernel's and scalar_face_body's segments, bit for bit.
TEST(LinesViewFields, Avx512ScalarKernelMatchesOnAwkwardValues) {
#if !defined(FABRICA_LINES_AVX512)
  GTEST_SKIP() << "no AVX-512 kernels in this build";
#else
  if (!detail::cpu_has_avx512()) GTEST_SKIP() << "this CPU has no AVX-512 (F, VL, DQ, BW)";
  const Surface surface = load("meshes/classic/c3d_cow.obj", false);
  const std::size_t nv = surface.vertex_count();
  std::size_t segments = 0, interior = 0, runs = 0;
  for (int special = 0; special < 2; ++special) {
    std::mt19937_64 rng(0xfab + std::uint64_t(special));
    std::normal_distribution<double> normal(0.0, 1.0);
    std::uniform_int_distribution<int> pick(0, 99);
    auto value = [&] {
      const int p = pick(rng);
      if (p < 10) return 0.0;
      if (p < 14) return -0.0;
      if (p < 16) return normal(rng) * 1e-310;
      if (p < 18) return normal(rng) * 1e300;
      if (special && p < 20)
        return p == 18 ? std::numeric_limits<double>::infinity()
                       : std::numeric_limits<double>::quiet_NaN();
      return normal(rng);
    };
    std::vector<double> val(nv), num(nv), den(nv), cull(nv), sc(nv);
    for (std::size_t i = 0; i < nv; ++i) {
      val[i] = value(), num[i] = value(), den[i] = value(), cull[i] = value(), sc[i] = value();
    }
    std::vector<std::size_t> list;
    for (std::size_t f = 0; f < surface.face_count(); ++f) list.push_back(f);
    for (int variant = 0; variant < 8; ++variant) {
      SCOPED_TRACE(testing::Message() << "special " << special << " variant " << variant);
      zc::ScalarInputs in{zc::MeshArrays(surface),
                          val.data(),
                          variant & 1 ? cull.data() : nullptr,
                          variant & 2 ? den.data() : nullptr,
                          variant != 4,
                          variant & 4 ? 0.0 : 0.25};
      auto run = [&](const auto& nm, int path, std::size_t len) {
        std::vector<LineSegment> out;
        for (std::size_t j = 0; j < len; j += zc::CandidateBatch::kSize) {
          const int n = static_cast<int>(std::min<std::size_t>(zc::CandidateBatch::kSize, len - j));
          if (path == 2)
            zc::scalar_faces_avx512(in, nm, list.data() + j, n, out);
          else if (path == 1)
            zc::scalar_faces_avx2(in, nm, list.data() + j, n, out);
          else
            for (int k = 0; k < n; ++k) zc::scalar_face_body(in, nm, list[j + k], out);
        }
        return out;
      };
      const zc::StoredNum stored{num.data()};
      const zc::ShiftedNum shifted{sc.data(), den.data(), variant == 3, 0.375};
      for (std::size_t len : {list.size(), list.size() - 1, list.size() - 5, std::size_t{3},
                              std::size_t{8}, std::size_t{17}, std::size_t{21}, std::size_t{26},
                              std::size_t{46}, std::size_t{71}, std::size_t{100}}) {
        for (int which = 0; which < 2; ++which) {
          const auto w = which ? run(shifted, 2, len) : run(stored, 2, len);
          const auto a = which ? run(shifted, 1, len) : run(stored, 1, len);
          EXPECT_EQ(differing_segments(w, a, special != 0), 0u)
              << "len " << len << " shifted " << which;
          if (!special) {
            const auto p = which ? run(shifted, 0, len) : run(stored, 0, len);
            EXPECT_EQ(differing_segments(w, p), 0u) << "len " << len << " shifted " << which;
          }
          ++runs;
          segments += w.size();
          for (const auto& seg : w) interior += seg.kind[0] == EndKind::interior;
        }
      }
    }
  }
  std::printf("%zu runs, %zu segments, %zu starting inside a face\n", runs, segments, interior);
  EXPECT_GT(segments, 100000u);
  EXPECT_GT(interior, 1000u);
#endif
}
