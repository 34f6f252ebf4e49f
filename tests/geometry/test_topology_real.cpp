// Topology on a real open mesh (with extra non-manifold, duplicate and
// degenerate faces and an isolated vertex) against a plain reference built
// with ordered maps: every list, in order.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

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
  for (std::size_t v = 0; v < m.positions.size(); ++v) {
    const auto nb = t.vertex_neighbors(v);
    ASSERT_EQ(std::vector<std::int32_t>(nb.begin(), nb.end()),
              std::vector<std::int32_t>(ref.neighbors[v].begin(), ref.neighbors[v].end()))
        << v;
    const auto vi = static_cast<std::int32_t>(v);
    for (std::size_t i = 0; i < nb.size(); ++i) {
      const std::array<std::int32_t, 2> pair{std::min(vi, nb[i]), std::max(vi, nb[i])};
      ASSERT_EQ(t.edge(static_cast<std::size_t>(t.vertex_edge(v, i))), pair);
    }
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

}  // namespace

TEST(TopologyReal, OpenNonManifoldMeshMatchesAReferenceBuild) {
  expect_reference_topology(irregular_aneurysm(false));
}

TEST(TopologyReal, DegenerateFacesToo) {
  expect_reference_topology(irregular_aneurysm(true));
}
