#include <gtest/gtest.h>

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
