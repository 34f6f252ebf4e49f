#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <set>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/topology.hpp"
#include "test_support.hpp"

using namespace fabrica;

TEST(Topology, ClosedSphereHasEulerCharacteristicTwoAndNoBoundary) {
  const auto m = test::make_icosphere(1.0, 2);
  const Topology t(m);
  const auto chi = static_cast<long>(t.vertex_count()) - static_cast<long>(t.edge_count()) +
                   static_cast<long>(t.face_count());
  EXPECT_EQ(chi, 2);
  for (std::size_t e = 0; e < t.edge_count(); ++e) EXPECT_EQ(t.edge_faces(e).size(), 2u);
  for (std::size_t v = 0; v < t.vertex_count(); ++v) EXPECT_FALSE(t.is_boundary_vertex(v));
}

TEST(Topology, EdgesAreSortedPairsAndFaceEdgesAreOppositeCorners) {
  const auto m = test::make_torus(3.0, 1.0, 12, 8);
  const Topology t(m);
  for (std::size_t e = 1; e < t.edge_count(); ++e) EXPECT_LT(t.edge(e - 1), t.edge(e));
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto& e = t.edge(t.face_edge(f, k));
      const auto a = m.faces[f][(k + 1) % 3], b = m.faces[f][(k + 2) % 3];
      EXPECT_EQ(e[0], std::min(a, b));
      EXPECT_EQ(e[1], std::max(a, b));
      const auto g = t.face_neighbor(f, k);
      ASSERT_GE(g, 0);
      bool back = false;
      for (int j = 0; j < 3; ++j) back |= t.face_neighbor(g, j) == static_cast<int>(f);
      EXPECT_TRUE(back);
    }
}

TEST(Topology, OpenGridHasBoundaryLoopAndNonManifoldEdgeIsDetected) {
  auto m = test::make_plane(1.0, 4);  // 9 quads, 18 triangles
  const Topology t(m);
  std::size_t boundary_edges = 0;
  for (std::size_t e = 0; e < t.edge_count(); ++e) boundary_edges += t.is_boundary_edge(e);
  EXPECT_EQ(boundary_edges, 12u);
  EXPECT_TRUE(t.is_boundary_vertex(0));
  EXPECT_FALSE(t.is_boundary_vertex(5));

  // A third triangle on the interior diagonal (0,5) makes it non-manifold.
  m.positions.emplace_back(0.5, 0.0, 1.0);
  m.faces.push_back({0, 5, static_cast<int>(m.positions.size()) - 1});
  const Topology t2(m);
  std::size_t nonmanifold = 0;
  for (std::size_t e = 0; e < t2.edge_count(); ++e) nonmanifold += t2.is_nonmanifold_edge(e);
  EXPECT_EQ(nonmanifold, 1u);
}

TEST(Topology, IsolatedVerticesAndDegenerateFacesDoNotBreakIt) {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 5}};
  m.faces = {{0, 1, 2}, {0, 0, 1}};
  const Topology t(m);
  EXPECT_TRUE(t.is_isolated_vertex(3));
  EXPECT_EQ(t.edge_count(), 3u);
  EXPECT_EQ(t.face_edge(1, 2), -1);  // the edge (0,0) of the degenerate face
}

// Every adjacency list agrees with the edge list on an irregular soup:
// random triangles over few vertices (repeated, degenerate, non-manifold
// faces, isolated vertices), so the edge numbering is checked against its
// definition (lexicographic order of (lower, higher)) everywhere.
TEST(Topology, AdjacencyListsAgreeWithEdgesOnAnIrregularSoup) {
  TriangleMesh m;
  for (int i = 0; i < 40; ++i) m.positions.emplace_back(i, (i * 7) % 5, (i * 3) % 11);
  std::uint32_t state = 12345;
  auto next = [&] { return static_cast<int>((state = state * 1664525u + 1013904223u) >> 8) % 37; };
  for (int f = 0; f < 300; ++f) m.faces.push_back({next(), next(), next()});
  const Topology t(m);
  std::set<std::array<std::int32_t, 2>> pairs;
  for (const Face& f : m.faces)
    for (int k = 0; k < 3; ++k) {
      const auto a = f[(k + 1) % 3], b = f[(k + 2) % 3];
      if (a != b) pairs.insert({std::min(a, b), std::max(a, b)});
    }
  ASSERT_EQ(t.edge_count(), pairs.size());
  std::size_t e = 0;
  for (const auto& p : pairs) EXPECT_EQ(t.edge(e++), p);
  for (std::size_t v = 0; v < t.vertex_count(); ++v) {
    const auto nb = t.vertex_neighbors(v);
    for (std::size_t i = 0; i < nb.size(); ++i) {
      if (i > 0) EXPECT_LT(nb[i - 1], nb[i]);
      const auto vi = static_cast<std::int32_t>(v);
      const std::array<std::int32_t, 2> expect{std::min(vi, nb[i]), std::max(vi, nb[i])};
      EXPECT_EQ(t.edge(static_cast<std::size_t>(t.vertex_edge(v, i))), expect);
      EXPECT_EQ(t.find_edge(vi, nb[i]), t.vertex_edge(v, i));
      EXPECT_EQ(t.find_edge(nb[i], vi), t.vertex_edge(v, i));
    }
  }
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = m.faces[f][(k + 1) % 3], b = m.faces[f][(k + 2) % 3];
      if (a == b) {
        EXPECT_EQ(t.face_edge(f, k), -1);
        continue;
      }
      const std::array<std::int32_t, 2> expect{std::min(a, b), std::max(a, b)};
      EXPECT_EQ(t.edge(static_cast<std::size_t>(t.face_edge(f, k))), expect);
      const auto ef = t.edge_faces(static_cast<std::size_t>(t.face_edge(f, k)));
      EXPECT_TRUE(std::find(ef.begin(), ef.end(), static_cast<std::int32_t>(f)) != ef.end());
    }
  for (std::size_t v = 0; v < t.vertex_count(); ++v) {
    const auto fs = t.vertex_faces(v);
    const auto cs = t.vertex_face_corners(v);
    const auto os = t.vertex_face_opposite(v);
    ASSERT_EQ(os.size(), fs.size());
    for (std::size_t j = 0; j < fs.size(); ++j) {
      const Face& f = m.faces[static_cast<std::size_t>(fs[j])];
      EXPECT_EQ(f[cs[j]], static_cast<std::int32_t>(v));
      EXPECT_EQ(os[j][0], f[(cs[j] + 1) % 3]);
      EXPECT_EQ(os[j][1], f[(cs[j] + 2) % 3]);
    }
  }
  for (std::size_t v = 37; v < 40; ++v) EXPECT_TRUE(t.is_isolated_vertex(v));
}
