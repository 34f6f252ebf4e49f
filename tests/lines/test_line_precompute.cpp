// LinePrecompute's view-independent arrays against straightforward
// reference computations on real meshes: the tangent ring of the D_t1 q1
// pass (fan detection, fan order, layout, offsets in the principal frame,
// padding), the per-vertex blocks of the SIMD vertex pass, the raw
// ridge / valley keys and raw_above. And the same bits at any thread count,
// for the precompute and for a first view, whose view-independent
// precompute runs beside its view fields (LineExtractor::extract).
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/precompute.hpp"
#include "fabrica/lines/zero_crossing.hpp"
#include "lines_test_meshes.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

using test::camera_towards;
Surface load_mesh(const char* rel, bool degenerate) {
  return test::load_for_lines(rel, degenerate);
}

template <class A, class B>
bool same_bytes(const A& a, const B& b) {
  if (a.size() != b.size()) return false;
  return a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
}

// Field by field (LineSegment has padding bytes).
bool same_segments(const std::vector<LineSegment>& a, const std::vector<LineSegment>& b) {
  if (a.size() != b.size()) return false;
  auto same = [](const auto& x, const auto& y) { return std::memcmp(&x, &y, sizeof(x)) == 0; };
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].face != b[i].face) return false;
    for (int k = 0; k < 2; ++k) {
      const SegmentEnd &x = a[i].end[k], &y = b[i].end[k];
      if (a[i].kind[k] != b[i].kind[k] || !same(x.t, y.t) || x.element != y.element ||
          !same(x.strength, y.strength))
        return false;
    }
  }
  return true;
}

// The tangent ring as its documentation (precompute.hpp) describes it,
// computed the plain way: a fan by following each face's second opposite
// corner to the face whose first opposite corner it is (a map from first
// corners to faces), offsets as (p_v - p_i)·e1, (p_v - p_i)·e2 in float.
struct ReferenceRing {
  std::vector<std::int32_t> offset{0};
  std::vector<std::uint8_t> fan;
  std::vector<std::int32_t> vertex;
  std::vector<float> x, y;
  std::vector<std::uint8_t> rank;
};

ReferenceRing reference_ring(const Surface& s) {
  const Topology& topo = s.topology();
  const auto& pos = s.positions();
  const auto& curv = s.curvature();
  ReferenceRing r;
  for (std::size_t i = 0; i < s.vertex_count(); ++i) {
    const auto o = topo.vertex_face_opposite(i);
    const std::size_t k = o.size();
    auto offset = [&](std::int32_t v, const Vec3& axis) {
      return static_cast<float>((pos[static_cast<std::size_t>(v)] - pos[i]).dot(axis));
    };
    // Fan order.
    std::vector<std::size_t> order;
    bool fan = k >= 1 && k <= 63;
    if (fan) {
      std::multimap<std::int32_t, std::size_t> by_first;
      for (std::size_t g = 0; g < k; ++g) by_first.emplace(o[g][0], g);
      std::vector<bool> used(k, false);
      std::size_t f = 0;
      for (std::size_t j = 0; j < k && fan; ++j) {
        if (used[f]) {
          fan = false;
          break;
        }
        used[f] = true;
        order.push_back(f);
        if (by_first.count(o[f][1]) != 1) {
          fan = false;
          break;
        }
        f = by_first.find(o[f][1])->second;
      }
      fan = fan && f == 0;
    }
    if (fan && curv.valid[i])
      for (std::size_t j = 0; j < k; ++j) {
        const std::int32_t v = o[order[j]][0];
        if (!std::isfinite(offset(v, curv.e1[i])) || !std::isfinite(offset(v, curv.e2[i])))
          fan = false;
      }
    r.fan.push_back(fan);
    std::vector<std::int32_t> ring;
    if (fan) {
      for (std::size_t j = 0; j < k; ++j) {
        ring.push_back(o[order[j]][0]);
        r.rank.push_back(static_cast<std::uint8_t>(order[j]));
      }
      ring.push_back(o[order[k - 1]][1]);
      r.rank.push_back(0);
    } else {
      for (std::size_t g = 0; g < k; ++g) {
        ring.push_back(o[g][0]);
        ring.push_back(o[g][1]);
        r.rank.push_back(0);
        r.rank.push_back(0);
      }
    }
    for (std::int32_t v : ring) {
      r.vertex.push_back(v);
      r.x.push_back(curv.valid[i] ? offset(v, curv.e1[i]) : 0.0f);
      r.y.push_back(curv.valid[i] ? offset(v, curv.e2[i]) : 0.0f);
    }
    r.offset.push_back(static_cast<std::int32_t>(r.vertex.size()));
  }
  const std::size_t pad = LinePrecompute::TangentRing::kPad;
  r.vertex.resize(r.vertex.size() + pad, 0);
  r.rank.resize(r.rank.size() + pad, 0);
  r.x.resize(r.x.size() + pad, 0.0f);
  r.y.resize(r.y.size() + pad, 0.0f);
  return r;
}

// Every array of two tangent rings (LinePrecompute's or the reference) byte
// for byte.
template <class A, class B>
void expect_same_ring(const A& a, const B& b) {
  EXPECT_TRUE(same_bytes(a.offset, b.offset));
  EXPECT_TRUE(same_bytes(a.fan, b.fan));
  EXPECT_TRUE(same_bytes(a.vertex, b.vertex));
  EXPECT_TRUE(same_bytes(a.rank, b.rank));
  EXPECT_TRUE(same_bytes(a.x, b.x));
  EXPECT_TRUE(same_bytes(a.y, b.y));
}

void expect_tangent_ring_matches(const Surface& s, const LinePrecompute::TangentRing& t) {
  const ReferenceRing r = reference_ring(s);
  expect_same_ring(t, r);
  // Where they differ, the first vertex says more than a byte count.
  for (std::size_t i = 0; i + 1 < r.offset.size() && i + 1 < t.offset.size(); ++i) {
    if (t.fan[i] != r.fan[i] || t.offset[i + 1] != r.offset[i + 1]) {
      ADD_FAILURE() << "vertex " << i << ": fan " << int(t.fan[i]) << " (expected " << int(r.fan[i])
                    << "), ring end " << t.offset[i + 1] << " (expected " << r.offset[i + 1] << ")";
      break;
    }
  }
}

void expect_vertex_blocks_match(const Surface& s, const LinePrecompute::VertexBlocks& vb) {
  const std::size_t nv = s.vertex_count();
  ASSERT_EQ(vb.block.size(), (nv + 3) / 4);
  ASSERT_EQ(vb.valid.size(), vb.block.size());
  const auto& pos = s.positions();
  const auto& nrm = s.vertex_normals();
  const auto& curv = s.curvature();
  const auto& dcurv = s.curvature_derivatives();
  std::size_t wrong = 0;
  for (std::size_t b = 0; b < vb.block.size(); ++b) {
    const LinePrecompute::VertexBlock& k = vb.block[b];
    unsigned valid = 0;
    for (std::size_t l = 0; l < 4; ++l) {
      const std::size_t i = 4 * b + l;
      const bool in = i < nv;
      for (int c = 0; c < 3; ++c) {
        wrong += k.p[c][l] != (in ? pos[i][c] : 0.0);
        wrong += k.n[c][l] != (in ? nrm[i][c] : 0.0);
        wrong += k.e1[c][l] != (in ? curv.e1[i][c] : 0.0);
        wrong += k.e2[c][l] != (in ? curv.e2[i][c] : 0.0);
      }
      wrong += k.k1[l] != (in ? curv.k1[i] : 0.0);
      wrong += k.k2[l] != (in ? curv.k2[i] : 0.0);
      wrong += k.a[l] != (in ? dcurv.a[i] : 0.0);
      wrong += k.b[l] != (in ? dcurv.b[i] : 0.0);
      wrong += k.c[l] != (in ? dcurv.c[i] : 0.0);
      wrong += k.d[l] != (in ? dcurv.d[i] : 0.0);
      if (in) valid |= unsigned(curv.valid[i] != 0) << l | unsigned(dcurv.valid[i] != 0) << (4 + l);
    }
    wrong += vb.valid[b] != valid;
  }
  EXPECT_EQ(wrong, 0u);
}

}  // namespace

TEST(LinePrecompute, TangentRingAndVertexBlocksMatchAPlainComputation) {
  for (const char* rel : {"meshes/classic/libigl_camelhead.off", "meshes/classic/c3d_cow.obj"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load_mesh(rel, true);
    const LinePrecompute pre(surface);
    const auto& t = pre.tangent_ring();
    // The cases the comparison must cover: fans and other rings, vertices
    // with and without valid curvature, a partial last block.
    std::size_t fans = 0, invalid = 0;
    for (auto f : t.fan) fans += f != 0;
    for (auto v : surface.curvature().valid) invalid += v == 0;
    EXPECT_GT(fans, surface.vertex_count() / 2);
    EXPECT_LT(fans, surface.vertex_count());
    EXPECT_GT(invalid, 0u);
    expect_tangent_ring_matches(surface, t);
    expect_vertex_blocks_match(surface, pre.vertex_blocks());
    // Released and built again: the same.
    pre.release_tangent_ring();
    pre.release_vertex_blocks();
    expect_tangent_ring_matches(surface, pre.tangent_ring());
    expect_vertex_blocks_match(surface, pre.vertex_blocks());
  }
}

// The streamed ring (the one-shot extraction's): its layout is the whole
// ring's, and each block's entries are those of the whole ring at
// [offset[v0], offset[v1]), then kPad entries of vertex 0 and zeros; from
// the layout alone and once the whole ring exists.
TEST(LinePrecompute, StreamedTangentRingBlocksMatchTheWholeRing) {
  const Surface surface = load_mesh("meshes/classic/libigl_camelhead.off", true);
  const LinePrecompute whole(surface);
  const auto& t = whole.tangent_ring();
  const std::size_t nv = surface.vertex_count();
  const LinePrecompute streamed(surface);
  for (const bool built : {false, true}) {
    SCOPED_TRACE(built ? "whole ring built" : "layout only");
    if (built) (void)streamed.tangent_ring();
    const auto& layout = streamed.streamed_tangent_ring();
    EXPECT_TRUE(same_bytes(layout.offset, t.offset));
    EXPECT_TRUE(same_bytes(layout.fan, t.fan));
    EXPECT_EQ(layout.vertex.empty(), !built);
    for (const std::size_t block : {std::size_t{1}, std::size_t{7}, std::size_t{2048}, nv}) {
      std::size_t wrong = 0;
      LinePrecompute::TangentRing out;  // reused: stale entries must not show
      for (std::size_t v0 = 0; v0 < nv; v0 += block) {
        const std::size_t v1 = std::min(nv, v0 + block);
        streamed.tangent_ring_block(v0, v1, out);
        const auto a = static_cast<std::size_t>(t.offset[v0]);
        const std::size_t n = static_cast<std::size_t>(t.offset[v1]) - a;
        const std::size_t pad = LinePrecompute::TangentRing::kPad;
        ASSERT_EQ(out.vertex.size(), n + pad);
        ASSERT_EQ(out.x.size(), n + pad);
        wrong += std::memcmp(out.vertex.data(), t.vertex.data() + a, n * 4) != 0;
        wrong += std::memcmp(out.rank.data(), t.rank.data() + a, n) != 0;
        wrong += std::memcmp(out.x.data(), t.x.data() + a, n * 4) != 0;
        wrong += std::memcmp(out.y.data(), t.y.data() + a, n * 4) != 0;
        for (std::size_t j = n; j < n + pad; ++j)
          wrong += out.vertex[j] != 0 || out.rank[j] != 0 || out.x[j] != 0.0f || out.y[j] != 0.0f;
      }
      EXPECT_EQ(wrong, 0u) << block << " vertices a block";
    }
    streamed.release_tangent_ring();
  }
}

TEST(LinePrecompute, PartialLastBlockIsZeroPadded) {
  // The cow's vertex count is not a multiple of 4 (checked), so the last
  // block has padding lanes.
  const Surface surface = load_mesh("meshes/classic/c3d_cow.obj", false);
  ASSERT_NE(surface.vertex_count() % 4, 0u);
  const LinePrecompute pre(surface);
  expect_vertex_blocks_match(surface, pre.vertex_blocks());
}

TEST(LinePrecompute, RawKeysAndRawAboveFollowTheRawSegments) {
  const Surface surface = load_mesh("meshes/classic/c3d_cow.obj", false);
  const LinePrecompute pre(surface);
  const double t = 0.1 / surface.feature_size();
  for (LineFamily family : {LineFamily::ridge, LineFamily::valley, LineFamily::demarcating}) {
    SCOPED_TRACE(family_name(family));
    const auto& raw = family == LineFamily::ridge    ? pre.raw_ridges()
                      : family == LineFamily::valley ? pre.raw_valleys()
                                                     : pre.raw_demarcating();
    const auto& keys = family == LineFamily::ridge    ? pre.raw_ridge_keys()
                       : family == LineFamily::valley ? pre.raw_valley_keys()
                                                      : pre.raw_demarcating_keys();
    ASSERT_FALSE(raw.empty());
    ASSERT_EQ(keys.size(), raw.size());
    // Demarcating strengths are in 1/mm² (their threshold per feature size²).
    const double tt = family == LineFamily::demarcating ? t / surface.feature_size() : t;
    std::vector<std::uint32_t> index;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      const Face& f = surface.faces()[static_cast<std::size_t>(raw[i].face)];
      ASSERT_EQ(keys[i].corners, (std::array<std::int32_t, 3>{f[0], f[1], f[2]}));
      ASSERT_EQ(keys[i].m0, raw[i].end[0].strength);
      ASSERT_EQ(keys[i].m1, raw[i].end[1].strength);
      if (raw[i].end[0].strength > tt || raw[i].end[1].strength > tt)
        index.push_back(static_cast<std::uint32_t>(i));
    }
    const auto above = pre.raw_above(family, tt);
    EXPECT_GT(index.size(), 0u);
    EXPECT_LT(index.size(), raw.size());
    EXPECT_EQ(above->index, index);
    ASSERT_EQ(above->segments.size(), index.size());
    for (std::size_t j = 0; j < index.size(); ++j) {
      const LineSegment& r = raw[index[j]];
      const LineSegment& a = above->segments[j];
      EXPECT_EQ(a.face, r.face);
      for (int e = 0; e < 2; ++e) {
        const double k = std::max(double(r.end[e].strength) - tt, 0.0);
        EXPECT_EQ(a.end[e].strength, static_cast<float>(k / (k + tt)));
      }
    }
  }
}

// The raw ridges and valleys come from one pass over the faces; they must
// be what vector_zero_crossings gives for each family alone (δ = ±a,
// direction e1, magnitude |k1|, threshold 0, the edge test, the vertex
// mask "curvature and derivatives valid, k1 > 0" or "< 0"), on a mesh with
// many face chunks and degenerate faces, and raw_above over many key
// chunks must keep exactly the segments above the threshold, in order.
TEST(LinePrecompute, RawRidgesAndValleysMatchOnePassPerFamily) {
  const Surface surface = load_mesh("meshes/classic/c3d_igea.ply", true);
  const LinePrecompute pre(surface);
  const auto& curv = surface.curvature();
  const auto& dcurv = surface.curvature_derivatives();
  const std::size_t nv = surface.vertex_count();
  std::vector<double> abs_k1(nv);
  for (std::size_t i = 0; i < nv; ++i) abs_k1[i] = std::abs(curv.k1[i]);
  for (bool ridge : {true, false}) {
    SCOPED_TRACE(ridge ? "ridges" : "valleys");
    std::vector<double> delta(nv);
    std::vector<std::uint8_t> mask(nv);
    for (std::size_t i = 0; i < nv; ++i) {
      const bool ok = curv.valid[i] && dcurv.valid[i];
      delta[i] = ok ? (ridge ? dcurv.a[i] : -dcurv.a[i]) : 0.0;
      mask[i] = ok && (ridge ? curv.k1[i] > 0.0 : curv.k1[i] < 0.0);
    }
    VectorCrossingOptions o;
    o.vertex_mask = mask;
    o.test = ExtremumTest::edge;
    o.threshold = 0.0;
    o.keep_raw_magnitude = true;
    std::vector<LineSegment> expected;
    vector_zero_crossings(surface, delta, curv.e1, abs_k1, o, expected);
    const auto& raw = ridge ? pre.raw_ridges() : pre.raw_valleys();
    EXPECT_GT(raw.size(), 20000u);  // several chunks of raw_above (8192 keys)
    EXPECT_TRUE(same_segments(raw, expected));
    const LineFamily family = ridge ? LineFamily::ridge : LineFamily::valley;
    const double t = 0.1 / surface.feature_size();
    const auto above = pre.raw_above(family, t);
    std::vector<std::uint32_t> index;
    for (std::size_t i = 0; i < raw.size(); ++i)
      if (raw[i].end[0].strength > t || raw[i].end[1].strength > t)
        index.push_back(static_cast<std::uint32_t>(i));
    EXPECT_GT(index.size(), 8192u);
    EXPECT_EQ(above->index, index);
    ASSERT_EQ(above->corners.size(), index.size());
    for (std::size_t j = 0; j < index.size(); ++j) {
      const Face& f = surface.faces()[static_cast<std::size_t>(raw[index[j]].face)];
      ASSERT_EQ(above->corners[j], (std::array<std::int32_t, 3>{f[0], f[1], f[2]}));
    }
  }
}

// The light set's operators (per-face quantities computed once per face
// and read by each corner) against the plain per-corner formulas, bit for
// bit, on a mesh with degenerate faces: the normal Laplacian
// (ΔN)_i = 1/A_i Σ (cot/2)(n_j - n_i) and the gradient operator
// (corner-area weighted hat-function gradients, rotated into n_i's plane).
TEST(LinePrecompute, LightOperatorsMatchThePlainFormulas) {
  const Surface surface = load_mesh("meshes/classic/c3d_cow.obj", true);
  const LinePrecompute pre(surface);
  const Topology& topo = surface.topology();
  const auto& pos = surface.positions();
  const auto& faces = surface.faces();
  const auto& vn = surface.vertex_normals();
  const auto& fn = surface.face_normals();
  const auto& corner = surface.corner_areas();
  const auto& area = surface.vertex_areas();
  const std::size_t nv = surface.vertex_count();
  auto cot_at = [&](int apex, int p, int q) {
    const Vec3 u = pos[p] - pos[apex], v = pos[q] - pos[apex];
    const double cr = u.cross(v).norm();
    return cr > 0.0 ? u.dot(v) / cr : 0.0;
  };
  auto rotate = [](const Vec3& x, const Vec3& from, const Vec3& to) -> Vec3 {
    const double c = from.dot(to);
    if (c <= -1.0 + 1e-12) return x - to * to.dot(x);
    const Vec3 axis = from.cross(to);
    return c * x + axis.cross(x) + axis * (axis.dot(x) / (1.0 + c));
  };
  const auto& lap = pre.normal_laplacian();
  const GradientOperator& G = pre.gradient_operator();
  ASSERT_EQ(lap.size(), nv);
  ASSERT_EQ(G.offset.size(), nv + 1);
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < nv; ++i) {
    Vec3 acc = Vec3::Zero();
    const auto fs = topo.vertex_faces(i);
    const auto cs = topo.vertex_face_corners(i);
    for (std::size_t j = 0; j < fs.size(); ++j) {
      const Face& f = faces[static_cast<std::size_t>(fs[j])];
      const int c = cs[j];
      const int a = f[(c + 1) % 3], b = f[(c + 2) % 3];
      acc += 0.5 * cot_at(b, static_cast<int>(i), a) * (vn[a] - vn[i]) +
             0.5 * cot_at(a, static_cast<int>(i), b) * (vn[b] - vn[i]);
    }
    const Vec3 want = area[i] > 0.0 ? Vec3(acc / area[i]) : Vec3::Zero();
    mismatches += std::memcmp(want.data(), lap[i].data(), sizeof(Vec3)) != 0;
    // The gradient operator's row i: column i first, then the neighbours.
    const auto nb = topo.vertex_neighbors(i);
    std::vector<Vec3> row(nb.size() + 1, Vec3::Zero());
    auto slot = [&](std::int32_t v) -> std::size_t {
      if (v == static_cast<std::int32_t>(i)) return 0;
      return 1 + static_cast<std::size_t>(std::lower_bound(nb.begin(), nb.end(), v) - nb.begin());
    };
    double wsum = 0.0;
    for (std::size_t j = 0; j < fs.size(); ++j) {
      const auto t = static_cast<std::size_t>(fs[j]);
      const Face& f = faces[t];
      const Vec3& nt = fn[t];
      const double twice_area = (pos[f[1]] - pos[f[0]]).cross(pos[f[2]] - pos[f[0]]).norm();
      if (nt.squaredNorm() == 0.0 || !(twice_area > 0.0)) continue;
      const double w = corner[t][cs[j]];
      if (!(w > 0.0)) continue;
      wsum += w;
      for (int k = 0; k < 3; ++k) {
        const Vec3 e = pos[f[(k + 2) % 3]] - pos[f[(k + 1) % 3]];
        Vec3 basis = nt.cross(e) / twice_area;
        if (vn[i].squaredNorm() > 0.0) basis = rotate(basis, nt, vn[i]);
        row[slot(f[k])] += w * basis;
      }
    }
    const double inv = wsum > 0.0 ? 1.0 / wsum : 0.0;
    const auto base = static_cast<std::size_t>(G.offset[i]);
    ASSERT_EQ(static_cast<std::size_t>(G.offset[i + 1]) - base, row.size());
    for (std::size_t j = 0; j < row.size(); ++j)
      for (int c = 0; c < 3; ++c) {
        const float want_c = static_cast<float>(row[j][c] * inv);
        mismatches += std::memcmp(&want_c, &G.coeff[3 * (base + j) + c], sizeof(float)) != 0;
      }
  }
  EXPECT_EQ(mismatches, 0u);
}

TEST(LinePrecompute, SameBitsAtAnyThreadCount) {
  const Surface surface = load_mesh("meshes/classic/libigl_camelhead.off", true);
  const LinePrecompute many(surface);
  const LinePrecompute one(surface);
  tbb::task_arena single(1);
  single.execute([&] {
    (void)one.tangent_ring();
    (void)one.vertex_blocks();
    (void)one.raw_ridges();
    (void)one.raw_demarcating();
  });
  expect_same_ring(many.tangent_ring(), one.tangent_ring());
  EXPECT_TRUE(same_bytes(many.vertex_blocks().valid, one.vertex_blocks().valid));
  EXPECT_EQ(std::memcmp(many.vertex_blocks().block.data(), one.vertex_blocks().block.data(),
                        one.vertex_blocks().block.size() * sizeof(LinePrecompute::VertexBlock)),
            0);
  EXPECT_TRUE(same_segments(many.raw_ridges(), one.raw_ridges()));
  EXPECT_TRUE(same_segments(many.raw_valleys(), one.raw_valleys()));
  EXPECT_TRUE(same_segments(many.raw_demarcating(), one.raw_demarcating()));
}

// A new extractor's first view computes its view-independent precompute
// beside the view fields: the same segments as a later view of the same
// camera, at one thread (the pipelined apparent ridges) and at several.
TEST(LinePrecompute, FirstViewEqualsALaterViewAtAnyThreadCount) {
  const Surface surface = load_mesh("meshes/classic/c3d_cow.obj", false);
  LineOptions o;
  o.families = reference_families();
  o.families.push_back(LineFamily::demarcating);
  const Camera c = camera_towards(surface, Vec3(0.3, 0.2, 1.0));
  LineExtractor warm(surface, o);
  (void)warm.extract(c);
  const std::vector<SegmentSoup> later = warm.extract(c);
  std::size_t segments = 0;
  for (const auto& soup : later) segments += soup.segments.size();
  EXPECT_GT(segments, 100u);
  for (int threads : {1, 2}) {
    SCOPED_TRACE(threads);
    tbb::task_arena arena(threads);
    std::vector<SegmentSoup> first;
    arena.execute([&] {
      LineExtractor fresh(surface, o);
      first = fresh.extract(c);
    });
    ASSERT_EQ(first.size(), later.size());
    for (std::size_t k = 0; k < first.size(); ++k) {
      SCOPED_TRACE(family_name(first[k].family));
      EXPECT_EQ(first[k].family, later[k].family);
      EXPECT_TRUE(same_segments(first[k].segments, later[k].segments));
    }
  }
}
