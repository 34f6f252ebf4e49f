// Self-intersections (CGAL, exact predicates) through validate_mesh.
#include <gtest/gtest.h>

#include "fabrica/io/repair.hpp"
#include "fabrica/io/validate.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

io::ValidationReport check(const TriangleMesh& m) {
  io::ValidateOptions o;
  o.self_intersections = true;
  return io::validate_mesh(m, o);
}

TEST(SelfIntersections, OnlyOnRequest) {
  EXPECT_FALSE(io::validate_mesh(test::make_icosphere(1.0, 2)).self_intersecting_face_pairs);
}

TEST(SelfIntersections, OneSphereHasNone) {
  const auto r = check(test::make_icosphere(1.0, 2));
  ASSERT_TRUE(r.self_intersecting_face_pairs.has_value()) << r.self_intersections_skipped;
  EXPECT_EQ(*r.self_intersecting_face_pairs, 0u);
  EXPECT_TRUE(r.clean());
}

TEST(SelfIntersections, TwoOverlappingSpheres) {
  TriangleMesh m = test::make_icosphere(1.0, 2);
  const TriangleMesh b = m;
  const auto base = static_cast<std::int32_t>(m.positions.size());
  for (const Vec3& p : b.positions) m.positions.push_back(p + Vec3(1.0, 0.1, 0.05));
  for (const Face& f : b.faces) m.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  const auto r = check(m);
  ASSERT_TRUE(r.self_intersecting_face_pairs.has_value()) << r.self_intersections_skipped;
  // The intersection curve is a circle of radius ~0.87 crossing faces about
  // 0.15 wide on both spheres: dozens of pairs.
  EXPECT_GT(*r.self_intersecting_face_pairs, 20u);
  EXPECT_FALSE(r.clean());

  // Apart, they do not intersect.
  for (std::size_t i = base; i < m.positions.size(); ++i) m.positions[i].x() += 2.0;
  EXPECT_EQ(check(m).self_intersecting_face_pairs.value_or(99), 0u);
}

TEST(SelfIntersections, TouchingAtAPinchVertexIsNotAnIntersection) {
  // Two tetrahedra meeting at vertex 0 (point reflection through it).
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  m.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3},
             {0, 4, 5}, {0, 6, 4}, {0, 5, 6}, {4, 6, 5}};
  const auto r = check(m);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  ASSERT_TRUE(r.self_intersecting_face_pairs.has_value()) << r.self_intersections_skipped;
  EXPECT_EQ(*r.self_intersecting_face_pairs, 0u);

  // Shear the second tetrahedron into the first: now they cross.
  for (int i = 4; i < 7; ++i) m.positions[i] += Vec3(0.6, 0.6, 0.6);
  EXPECT_GT(check(m).self_intersecting_face_pairs.value_or(0), 0u);
}

TEST(SelfIntersections, SheetsCutApartAtANonManifoldEdgeDoNotIntersect) {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  m.faces = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  io::repair_mesh(m);  // cuts the edge: three triangles sharing only positions
  auto r = check(m);
  ASSERT_TRUE(r.self_intersecting_face_pairs.has_value()) << r.self_intersections_skipped;
  EXPECT_EQ(*r.self_intersecting_face_pairs, 0u);

  // Fold the third sheet flat onto the first: now they overlap.
  m.positions.push_back({0.5, 0.5, 0});
  m.faces[2] = {m.faces[2][0], m.faces[2][1], static_cast<std::int32_t>(m.positions.size() - 1)};
  r = check(m);
  ASSERT_TRUE(r.self_intersecting_face_pairs.has_value()) << r.self_intersections_skipped;
  EXPECT_EQ(*r.self_intersecting_face_pairs, 1u);
}

TEST(SelfIntersections, InconsistentOrientationIsHandledOnACopy) {
  TriangleMesh m = test::make_icosphere(1.0, 1);
  std::swap(m.faces[4][1], m.faces[4][2]);
  const auto r = check(m);
  ASSERT_TRUE(r.self_intersecting_face_pairs.has_value()) << r.self_intersections_skipped;
  EXPECT_EQ(*r.self_intersecting_face_pairs, 0u);
}

TEST(SelfIntersections, SkippedWithAReasonOnNonManifoldEdges) {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  m.faces = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const auto r = check(m);
  EXPECT_FALSE(r.self_intersecting_face_pairs.has_value());
  EXPECT_NE(r.self_intersections_skipped.find("non-manifold edge"), std::string::npos);
  EXPECT_FALSE(r.notes.empty());
}

}  // namespace
}  // namespace fabrica
