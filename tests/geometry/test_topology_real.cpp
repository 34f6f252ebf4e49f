// Topology on a real open mesh (with extra non-manifold, duplicate and
// degenerate faces and an isolated vertex) against a plain reference built
// with ordered maps: every list, in order.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <thread>
#include <vector>

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "fabrica/core/topology.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

struct ReferenceTopology {
  std::map<std::array<std::int32_t, 2>, std::vector<std::int32_t>> edge_faces;
  std::vector<std::set<std::int32_t>> neighbors;
  std::vector<std::vector<std::int32_t>> vertex_faces;

  explicit ReferenceTopology(const TriangleMesh& m)
      : neighbors(m.positions.size()), vertex_faces(m.positions.size()) {
    for (std::size_t f = 0; f < m.faces.size(); ++f) {
      const auto fi = static_cast<std::int32_t>(f);
      for (int k = 0; k < 3; ++k) {
        vertex_faces[static_cast<std::size_t>(m.faces[f][k])].push_back(fi);
        const auto a = m.faces[f][(k + 1) % 3], b = m.faces[f][(k + 2) % 3];
        if (a == b) continue;
        neighbors[static_cast<std::size_t>(a)].insert(b);
        neighbors[static_cast<std::size_t>(b)].insert(a);
        auto& faces = edge_faces[{std::min(a, b), std::max(a, b)}];
        if (faces.empty() || faces.back() != fi) faces.push_back(fi);
      }
    }
  }
};

/// The aneurysm (open: boundary loops) with two more faces on an edge
/// (non-manifold), a duplicate face, an isolated vertex and, when
/// `degenerate`, faces with repeated corners of each kind (the topology
/// then takes its slower path).
TriangleMesh irregular_aneurysm(bool degenerate) {
  TriangleMesh m =
      io::read_mesh(test::bundled_data() / "meshes/anatomy/vessels/sofa_aneurysm3D_1.off").mesh;
  const auto n = static_cast<std::int32_t>(m.positions.size());
  const Face first = m.faces[0];
  for (int i = 0; i < 3; ++i) m.positions.push_back(m.positions[static_cast<std::size_t>(i)]);
  m.faces.push_back({first[0], first[1], n});
  m.faces.push_back({first[1], first[0], n + 1});
  m.faces.push_back(first);
  if (degenerate) {
    m.faces.push_back({first[2], first[2], first[0]});
    m.faces.push_back({first[1], first[2], first[1]});
    m.faces.push_back({first[0], first[0], first[0]});
  }
  return m;
}

/// Every vertex's neighbour list of `t` against the reference's, with each
/// entry's edge.
void expect_reference_neighbors(const Topology& t, const ReferenceTopology& ref) {
  for (std::size_t v = 0; v < ref.neighbors.size(); ++v) {
    const auto nb = t.vertex_neighbors(v);
    ASSERT_EQ(std::vector<std::int32_t>(nb.begin(), nb.end()),
              std::vector<std::int32_t>(ref.neighbors[v].begin(), ref.neighbors[v].end()))
        << v;
    const auto vi = static_cast<std::int32_t>(v);
    for (std::size_t i = 0; i < nb.size(); ++i) {
      const std::array<std::int32_t, 2> pair{std::min(vi, nb[i]), std::max(vi, nb[i])};
      ASSERT_EQ(t.edge(static_cast<std::size_t>(t.vertex_edge(v, i))), pair);
      ASSERT_EQ(t.find_edge(vi, nb[i]), t.vertex_edge(v, i));
    }
    const auto up = t.upper_neighbors(v);
    ASSERT_TRUE(
        std::equal(up.begin(), up.end(), nb.end() - static_cast<std::ptrdiff_t>(up.size())));
    for (std::size_t i = 0; i < up.size(); ++i)
      ASSERT_EQ(t.edge(static_cast<std::size_t>(t.vertex_edge_begin(v)) + i)[1], up[i]);
  }
}

void expect_reference_topology(const TriangleMesh& m) {
  const auto n = static_cast<std::int32_t>(m.positions.size()) - 3;
  const Topology t(m);
  const ReferenceTopology ref(m);

  ASSERT_EQ(t.vertex_count(), m.positions.size());
  ASSERT_EQ(t.edge_count(), ref.edge_faces.size());
  std::size_t boundary = 0, nonmanifold = 0;
  std::vector<std::uint8_t> boundary_vertex(m.positions.size(), 0);
  std::size_t e = 0;
  for (const auto& [pair, faces] : ref.edge_faces) {
    ASSERT_EQ(t.edge(e), pair) << e;
    const auto ef = t.edge_faces(e);
    ASSERT_EQ(std::vector<std::int32_t>(ef.begin(), ef.end()), faces) << e;
    EXPECT_EQ(t.find_edge(pair[0], pair[1]), static_cast<std::int32_t>(e));
    EXPECT_EQ(t.find_edge(pair[1], pair[0]), static_cast<std::int32_t>(e));
    boundary += t.is_boundary_edge(e);
    nonmanifold += t.is_nonmanifold_edge(e);
    if (faces.size() == 1) boundary_vertex[pair[0]] = boundary_vertex[pair[1]] = 1;
    ++e;
  }
  EXPECT_GT(boundary, 0u);
  EXPECT_GT(nonmanifold, 0u);
  expect_reference_neighbors(t, ref);
  for (std::size_t v = 0; v < m.positions.size(); ++v) {
    const auto vf = t.vertex_faces(v);
    ASSERT_EQ(std::vector<std::int32_t>(vf.begin(), vf.end()), ref.vertex_faces[v]) << v;
    EXPECT_EQ(t.is_boundary_vertex(v), boundary_vertex[v] != 0) << v;
    EXPECT_EQ(t.is_isolated_vertex(v), vf.empty());
  }
  EXPECT_TRUE(t.is_isolated_vertex(static_cast<std::size_t>(n + 2)));
  EXPECT_EQ(t.find_edge(n + 2, 0), -1);
  EXPECT_EQ(t.find_edge(3, 3), -1);
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = m.faces[f][(k + 1) % 3], b = m.faces[f][(k + 2) % 3];
      const auto fe = t.face_edge(f, k);
      if (a == b) {
        EXPECT_EQ(fe, -1);
        continue;
      }
      ASSERT_EQ(fe, t.find_edge(a, b));
      const auto& faces = ref.edge_faces.at({std::min(a, b), std::max(a, b)});
      const auto fi = static_cast<std::int32_t>(f);
      const std::int32_t across = faces.size() == 2 ? (faces[0] == fi ? faces[1] : faces[0]) : -1;
      EXPECT_EQ(t.face_neighbor(f, k), across);
    }
}

/// Eight threads reading `t` and `copy` (alternately) at once, each summing
/// what `sum` gives for its topology: every sum the same.
template <class Sum>
void expect_same_concurrent_sums(const Topology& t, const Topology& copy, const Sum& sum) {
  std::vector<std::size_t> sums(8, 0);
  std::vector<std::thread> threads;
  for (std::size_t k = 0; k < sums.size(); ++k)
    threads.emplace_back([&, k] { sums[k] = sum(k % 2 ? copy : t); });
  for (auto& th : threads) th.join();
  for (std::size_t k = 1; k < sums.size(); ++k) EXPECT_EQ(sums[k], sums[0]);
}

}  // namespace

TEST(TopologyReal, OpenNonManifoldMeshMatchesAReferenceBuild) {
  expect_reference_topology(irregular_aneurysm(false));
}

TEST(TopologyReal, DegenerateFacesToo) {
  expect_reference_topology(irregular_aneurysm(true));
}

// The neighbour lists are built on first use (from the edges): on a real
// closed mesh, at one and two threads, they equal the lists of the faces'
// edges, and nothing before the first call builds them.
TEST(TopologyReal, LazyNeighborsMatchTheFacesOnIgea) {
  const TriangleMesh m = io::read_mesh(test::bundled_data() / "meshes/classic/c3d_igea.ply").mesh;
  const ReferenceTopology ref(m);
  for (const int threads : {1, 2}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(threads));
    const Topology t(m);
    EXPECT_FALSE(t.has_vertex_neighbors());
    // find_edge does not need them.
    EXPECT_EQ(t.find_edge(m.faces[0][0], m.faces[0][1]), t.face_edge(0, 2));
    EXPECT_FALSE(t.has_vertex_neighbors());
    expect_reference_neighbors(t, ref);
    EXPECT_TRUE(t.has_vertex_neighbors());
  }
}

// Many threads asking at once for the lists of a fresh topology (and of a
// copy, which shares them) all get the same, complete lists.
TEST(TopologyReal, LazyNeighborsConcurrentFirstUse) {
  const TriangleMesh m = irregular_aneurysm(true);
  const ReferenceTopology ref(m);
  for (int round = 0; round < 4; ++round) {
    const Topology t(m);
    const Topology copy = t;
    expect_same_concurrent_sums(t, copy, [&](const Topology& mine) {
      std::size_t sum = 0;
      for (std::size_t v = 0; v < m.positions.size(); ++v)
        for (const auto w : mine.vertex_neighbors(v)) sum += static_cast<std::size_t>(w) + v;
      return sum;
    });
    EXPECT_TRUE(t.has_vertex_neighbors());
    EXPECT_TRUE(copy.has_vertex_neighbors());
    expect_reference_neighbors(copy, ref);
  }
  // From TBB tasks too.
  const Topology t(m);
  std::vector<std::size_t> degree(m.positions.size());
  tbb::parallel_for(std::size_t{0}, m.positions.size(),
                    [&](std::size_t v) { degree[v] = t.vertex_neighbors(v).size(); });
  for (std::size_t v = 0; v < degree.size(); ++v) EXPECT_EQ(degree[v], ref.neighbors[v].size());
}

namespace {

/// The opposite corners of every corner entry, from the faces, and each
/// edge's faces, of an eager topology `eager`, against `lazy` (whose parts
/// were released), entry by entry.
void expect_rebuilt_parts(const TriangleMesh& m, const Topology& eager, const Topology& lazy) {
  for (std::size_t v = 0; v < m.positions.size(); ++v) {
    const auto fs = eager.vertex_faces(v);
    const auto cs = eager.vertex_face_corners(v);
    const auto oe = eager.vertex_face_opposite(v);
    const auto ol = lazy.vertex_face_opposite(v);
    ASSERT_EQ(oe.size(), fs.size());
    ASSERT_EQ(ol.size(), fs.size());
    for (std::size_t j = 0; j < fs.size(); ++j) {
      const Face& f = m.faces[static_cast<std::size_t>(fs[j])];
      const std::array<std::int32_t, 2> want{f[(cs[j] + 1) % 3], f[(cs[j] + 2) % 3]};
      ASSERT_EQ(oe[j], want) << v << " " << j;
      ASSERT_EQ(ol[j], want) << v << " " << j;
    }
  }
  for (std::size_t e = 0; e < eager.edge_count(); ++e) {
    const auto a = eager.edge_faces(e), b = lazy.edge_faces(e);
    ASSERT_EQ(std::vector<std::int32_t>(a.begin(), a.end()),
              std::vector<std::int32_t>(b.begin(), b.end()))
        << e;
  }
}

}  // namespace

// release_derived_parts frees the opposite corners and the edges' faces;
// the accessors then rebuild them from the face edges, the same lists as
// the constructor's (closed igea; the open, non-manifold aneurysm with
// degenerate faces of each kind), at one and two threads. A copy made
// before the release keeps its own.
TEST(TopologyReal, ReleasedPartsRebuiltBitForBit) {
  const TriangleMesh igea =
      io::read_mesh(test::bundled_data() / "meshes/classic/c3d_igea.ply").mesh;
  for (const TriangleMesh& m : {igea, irregular_aneurysm(true), irregular_aneurysm(false)})
    for (const int threads : {1, 2}) {
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(threads));
      const Topology eager(m);
      EXPECT_TRUE(eager.has_vertex_face_opposite());
      EXPECT_TRUE(eager.has_edge_faces());
      Topology lazy = eager;
      lazy.release_derived_parts();
      EXPECT_FALSE(lazy.has_vertex_face_opposite());
      EXPECT_FALSE(lazy.has_edge_faces());
      EXPECT_TRUE(eager.has_vertex_face_opposite());
      // Other accessors do not build them.
      (void)lazy.vertex_faces(0);
      (void)lazy.face_edge(0, 0);
      (void)lazy.find_edge(m.faces[0][0], m.faces[0][1]);
      EXPECT_FALSE(lazy.has_vertex_face_opposite());
      EXPECT_FALSE(lazy.has_edge_faces());
      expect_rebuilt_parts(m, eager, lazy);
      EXPECT_TRUE(lazy.has_vertex_face_opposite());
      EXPECT_TRUE(lazy.has_edge_faces());
    }
}

// release_edges frees the edges' vertex pairs; edge(), find_edge and the
// parts read from them rebuild them from the vertex faces and face edges:
// the constructor's pairs (closed igea; the open, non-manifold aneurysm with
// degenerate faces of each kind, whose collapsed face edges are -1), at one
// and two threads, alone or with the derived parts released too; the edge
// count and face edges do not build them; a copy made before keeps its own.
TEST(TopologyReal, ReleasedEdgesRebuiltBitForBit) {
  const TriangleMesh igea =
      io::read_mesh(test::bundled_data() / "meshes/classic/c3d_igea.ply").mesh;
  for (const TriangleMesh& m : {igea, irregular_aneurysm(true), irregular_aneurysm(false)})
    for (const int threads : {1, 2})
      for (const bool derived_too : {false, true}) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                        static_cast<std::size_t>(threads));
        const Topology eager(m);
        EXPECT_TRUE(eager.has_edges());
        Topology lazy = eager;
        lazy.release_edges();
        if (derived_too) lazy.release_derived_parts();
        EXPECT_FALSE(lazy.has_edges());
        EXPECT_TRUE(eager.has_edges());
        EXPECT_EQ(lazy.edge_count(), eager.edge_count());
        (void)lazy.vertex_faces(0);
        (void)lazy.face_edge(0, 0);
        (void)lazy.vertex_edge_begin(0);
        EXPECT_FALSE(lazy.has_edges());
        if (derived_too) {
          // The derived parts read the edges: they rebuild them first.
          expect_rebuilt_parts(m, eager, lazy);
          EXPECT_TRUE(lazy.has_edges());
        }
        for (std::size_t e = 0; e < eager.edge_count(); ++e)
          ASSERT_EQ(lazy.edge(e), eager.edge(e)) << e;
        EXPECT_TRUE(lazy.has_edges());
        for (const Face& f : m.faces)
          for (int k = 0; k < 3; ++k)
            ASSERT_EQ(lazy.find_edge(f[k], f[(k + 1) % 3]), eager.find_edge(f[k], f[(k + 1) % 3]));
      }
  // Many threads asking at once, on a released topology and a copy sharing
  // its (released) pairs.
  const TriangleMesh m = irregular_aneurysm(true);
  const Topology eager(m);
  Topology t = eager;
  t.release_edges();
  const Topology copy = t;
  expect_same_concurrent_sums(t, copy, [&](const Topology& mine) {
    std::size_t sum = 0;
    for (std::size_t e = 0; e < mine.edge_count(); ++e)
      sum +=
          static_cast<std::size_t>(mine.edge(e)[0]) * 7 + static_cast<std::size_t>(mine.edge(e)[1]);
    return sum;
  });
  for (std::size_t e = 0; e < eager.edge_count(); ++e) ASSERT_EQ(copy.edge(e), eager.edge(e));
}

// Many threads (and TBB tasks) asking at once for the released parts of a
// topology and of a copy of it (which shares them) get the same lists.
TEST(TopologyReal, ReleasedPartsConcurrentFirstUse) {
  const TriangleMesh m = irregular_aneurysm(true);
  const Topology eager(m);
  for (int round = 0; round < 4; ++round) {
    Topology t = eager;
    t.release_derived_parts();
    const Topology copy = t;
    expect_same_concurrent_sums(t, copy, [&](const Topology& mine) {
      std::size_t sum = 0;
      for (std::size_t v = 0; v < m.positions.size(); ++v)
        for (const auto& o : mine.vertex_face_opposite(v))
          sum += static_cast<std::size_t>(o[0]) * 3 + static_cast<std::size_t>(o[1]) + v;
      for (std::size_t e = 0; e < mine.edge_count(); ++e)
        for (const auto f : mine.edge_faces(e)) sum += static_cast<std::size_t>(f) ^ e;
      return sum;
    });
    EXPECT_TRUE(copy.has_vertex_face_opposite());
    EXPECT_TRUE(t.has_edge_faces());
    expect_rebuilt_parts(m, eager, copy);
  }
  Topology t = eager;
  t.release_derived_parts();
  std::vector<std::size_t> count(m.positions.size());
  tbb::parallel_for(std::size_t{0}, m.positions.size(), [&](std::size_t v) {
    count[v] = t.vertex_face_opposite(v).size() + (v < t.edge_count() ? t.edge_faces(v).size() : 0);
  });
  for (std::size_t v = 0; v < count.size(); ++v)
    EXPECT_EQ(count[v], eager.vertex_faces(v).size() +
                            (v < eager.edge_count() ? eager.edge_faces(v).size() : 0));
}
