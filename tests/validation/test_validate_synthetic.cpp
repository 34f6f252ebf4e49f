// Validation and repair on small synthetic meshes with one known defect each:
// exact counts before, the exact change made by repair, a clean report after,
// and the vertex-order promise (vertex i stays vertex i).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <tbb/global_control.h>

#include "fabrica/core/error.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/io/validate.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

using io::repair_mesh;
using io::validate_mesh;

TriangleMesh sphere() {
  return test::make_icosphere(1.0, 1);
}  // 42 V, 80 F, 120 E

TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

Face reversed(Face f) {
  return {f[0], f[2], f[1]};
}

// Appends b's vertices and faces to a.
void append(TriangleMesh& a, const TriangleMesh& b, const Vec3& offset) {
  const auto base = static_cast<std::int32_t>(a.positions.size());
  for (const Vec3& p : b.positions) a.positions.push_back(p + offset);
  for (const Face& f : b.faces) a.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
}

// Repairs a copy and checks the promises every repair keeps: existing
// vertices unchanged, appended vertices copy an existing position, every face
// has the same corner positions as the face it came from (up to a flip).
io::RepairReport repair_and_check_order(const TriangleMesh& before, TriangleMesh& after,
                                        const io::RepairOptions& options = {}) {
  after = before;
  const io::RepairReport report = repair_mesh(after, options);
  EXPECT_GE(after.positions.size(), before.positions.size());
  for (std::size_t i = 0; i < before.positions.size(); ++i)
    EXPECT_EQ(after.positions[i], before.positions[i]) << "vertex " << i << " moved";
  EXPECT_EQ(report.face_origin.size(), after.faces.size());
  for (std::size_t f = 0; f < after.faces.size(); ++f) {
    const Face& o = before.faces[report.face_origin[f]];
    const Face& n = after.faces[f];
    EXPECT_EQ(after.positions[n[0]], before.positions[o[0]]) << "face " << f;
    const bool same = after.positions[n[1]] == before.positions[o[1]] &&
                      after.positions[n[2]] == before.positions[o[2]];
    const bool flipped = after.positions[n[1]] == before.positions[o[2]] &&
                         after.positions[n[2]] == before.positions[o[1]];
    EXPECT_TRUE(same || flipped) << "face " << f;
  }
  return report;
}

TEST(Validate, CleanTetrahedronExactMeasures) {
  const auto r = validate_mesh(tetrahedron());
  EXPECT_EQ(r.vertices, 4u);
  EXPECT_EQ(r.faces, 4u);
  EXPECT_EQ(r.edges, 6u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.consistently_oriented);
  ASSERT_TRUE(r.outward.has_value());
  EXPECT_TRUE(*r.outward);
  EXPECT_NEAR(r.signed_volume, 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(r.area, 1.5 + std::sqrt(3.0) / 2.0, 1e-15);
  EXPECT_NEAR(r.mean_edge_length, (3.0 + 3.0 * std::sqrt(2.0)) / 6.0, 1e-15);
  EXPECT_EQ(r.bbox.max, Vec3(1, 1, 1));
  EXPECT_TRUE(r.clean());
  EXPECT_TRUE(r.notes.empty());
}

TEST(Validate, CleanSphereHasNoDefects) {
  const auto r = validate_mesh(sphere());
  EXPECT_EQ(r.edges, 120u);
  EXPECT_EQ(r.boundary_edges + r.boundary_loops + r.nonmanifold_edges + r.nonmanifold_vertices +
                r.degenerate_faces + r.duplicate_faces + r.unreferenced_vertices +
                r.inconsistent_edges,
            0u);
  EXPECT_EQ(r.euler_characteristic, 2);
  EXPECT_TRUE(r.outward.value_or(false));
  // Inscribed polyhedron: volume and area a little below the sphere's.
  EXPECT_LT(r.signed_volume, 4.0 / 3.0 * std::numbers::pi);
  EXPECT_GT(r.signed_volume, 0.85 * 4.0 / 3.0 * std::numbers::pi);
  EXPECT_TRUE(r.clean());
  TriangleMesh after;
  const auto rep = repair_and_check_order(sphere(), after);
  EXPECT_FALSE(rep.changed());
  EXPECT_EQ(after.faces, sphere().faces);
}

TEST(Validate, DuplicateFace) {
  for (bool flip : {false, true}) {
    TriangleMesh m = sphere();
    m.faces.push_back(flip ? reversed(m.faces[10]) : m.faces[10]);
    const auto r = validate_mesh(m);
    EXPECT_EQ(r.duplicate_faces, 1u);
    EXPECT_EQ(r.degenerate_faces, 0u);
    EXPECT_EQ(r.nonmanifold_edges, 3u);  // each edge of face 10 now has three faces
    EXPECT_EQ(r.nonmanifold_vertices, 0u);
    EXPECT_FALSE(r.outward.has_value());
    EXPECT_FALSE(r.clean());
    ASSERT_FALSE(r.problems.empty());
    EXPECT_NE(r.problems.front().find("face 80 repeats face 10"), std::string::npos)
        << r.problems.front();

    TriangleMesh after;
    const auto rep = repair_and_check_order(m, after);
    EXPECT_EQ(rep.removed_duplicate_faces, 1u);
    EXPECT_EQ(rep.removed_degenerate_faces, 0u);
    EXPECT_EQ(rep.cut_nonmanifold_edges, 0u);  // removing the duplicate came first
    EXPECT_EQ(rep.flipped_faces, 0u);
    EXPECT_EQ(after.faces, sphere().faces);
    EXPECT_TRUE(validate_mesh(after).clean());
  }
}

TEST(Validate, DegenerateFaces) {
  TriangleMesh m = sphere();
  const Face f0 = m.faces[0];
  // A repeated index, and a zero-area face on a new midpoint of an edge.
  m.faces.push_back({f0[0], f0[0], f0[1]});
  m.positions.push_back(0.5 * (m.positions[f0[0]] + m.positions[f0[1]]));
  m.faces.push_back({f0[0], 42, f0[1]});
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.degenerate_faces, 2u);
  EXPECT_EQ(r.duplicate_faces, 0u);
  EXPECT_EQ(r.boundary_edges, 2u);     // the two halves of the split edge
  EXPECT_EQ(r.nonmanifold_edges, 1u);  // the edge under the sliver
  EXPECT_EQ(r.unreferenced_vertices, 0u);
  EXPECT_NE(r.problems.front().find("e.g. face 80"), std::string::npos) << r.problems.front();

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.removed_degenerate_faces, 2u);
  EXPECT_EQ(after.faces, sphere().faces);
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_EQ(again.unreferenced_vertices, 1u);  // the midpoint stays, vertex 42
}

TEST(Validate, FlippedFace) {
  TriangleMesh m = sphere();
  m.faces[7] = reversed(m.faces[7]);
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.inconsistent_edges, 3u);
  EXPECT_FALSE(r.consistently_oriented);
  EXPECT_TRUE(r.closed);
  EXPECT_FALSE(r.outward.has_value());
  EXPECT_FALSE(r.clean());

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.flipped_faces, 1u);
  EXPECT_EQ(rep.components_reversed, 0u);
  EXPECT_EQ(after.faces, sphere().faces);
  EXPECT_TRUE(validate_mesh(after).clean());
}

TEST(Validate, InwardSphere) {
  TriangleMesh m = sphere();
  for (Face& f : m.faces) f = reversed(f);
  const auto r = validate_mesh(m);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_TRUE(r.closed);
  ASSERT_TRUE(r.outward.has_value());
  EXPECT_FALSE(*r.outward);
  EXPECT_EQ(r.inward_pieces, 1u);
  EXPECT_LT(r.signed_volume, 0.0);
  EXPECT_FALSE(r.clean());

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.flipped_faces, 80u);
  EXPECT_EQ(rep.components_reversed, 1u);
  EXPECT_EQ(after.faces, sphere().faces);
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_NEAR(again.signed_volume, -r.signed_volume, 1e-12);

  // Orientation only: the majority rule would keep an open piece as is.
  io::RepairOptions no_outward;
  no_outward.outward = false;
  EXPECT_EQ(repair_and_check_order(m, after, no_outward).flipped_faces, 0u);
}

TEST(Validate, TwoComponentsOneInward) {
  TriangleMesh m = sphere();
  append(m, sphere(), Vec3(5, 0, 0));
  auto r = validate_mesh(m);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.euler_characteristic, 4);
  EXPECT_TRUE(r.clean());
  EXPECT_EQ(r.notes.size(), 1u);  // "2 separate components"

  for (std::size_t f = 80; f < 160; ++f) m.faces[f] = reversed(m.faces[f]);
  r = validate_mesh(m);
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_FALSE(r.outward.value_or(true));
  EXPECT_EQ(r.inward_pieces, 1u);
  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.flipped_faces, 80u);
  EXPECT_EQ(rep.components_reversed, 1u);
  EXPECT_TRUE(validate_mesh(after).clean());
}

TEST(Validate, NestedShellsFaceOutOfTheSolid) {
  // A hollow ball: outer sphere outward, inner sphere (the cavity wall)
  // facing into the cavity, i.e. negative volume.
  TriangleMesh m = test::make_icosphere(2.0, 2);
  const auto outer_faces = m.faces.size();
  append(m, sphere(), Vec3(0.1, -0.2, 0.05));
  for (std::size_t f = outer_faces; f < m.faces.size(); ++f) m.faces[f] = reversed(m.faces[f]);
  auto r = validate_mesh(m);
  EXPECT_EQ(r.components, 2u);
  EXPECT_TRUE(r.outward.value_or(false));
  EXPECT_TRUE(r.clean());
  TriangleMesh after;
  EXPECT_FALSE(repair_and_check_order(m, after).changed());

  // Both shells outward: the cavity wall faces into the solid.
  for (std::size_t f = outer_faces; f < m.faces.size(); ++f) m.faces[f] = reversed(m.faces[f]);
  r = validate_mesh(m);
  EXPECT_FALSE(r.outward.value_or(true));
  EXPECT_EQ(r.inward_pieces, 1u);
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.components_reversed, 1u);
  EXPECT_EQ(rep.flipped_faces, 80u);
  EXPECT_TRUE(validate_mesh(after).clean());

  // A ball inside the cavity (three shells) is solid again: outward.
  append(m, test::make_icosphere(0.3, 1), Vec3(0.1, -0.2, 0.05));
  r = validate_mesh(m);
  EXPECT_EQ(r.inward_pieces, 1u);  // still only the cavity wall
  EXPECT_EQ(repair_and_check_order(m, after).flipped_faces, 80u);

  // Overlapping, not nested, spheres are each outward.
  TriangleMesh two = sphere();
  append(two, sphere(), Vec3(0.5, 0.3, 0.1));
  EXPECT_TRUE(validate_mesh(two).outward.value_or(false));
}

TEST(Validate, BowTieVertex) {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, -0.5, 0}, {1, 0.5, 0}, {-1, 0.5, 0}, {-1, -0.5, 0}};
  m.faces = {{0, 1, 2}, {0, 3, 4}};
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_EQ(r.components, 1u);  // vertex-connected
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_FALSE(r.closed);
  EXPECT_NE(r.problems.front().find("vertex 0"), std::string::npos);

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.split_nonmanifold_vertices, 1u);
  ASSERT_EQ(after.positions.size(), 6u);
  EXPECT_EQ(after.faces[0], (Face{0, 1, 2}));  // the fan with the lowest face keeps vertex 0
  EXPECT_EQ(after.faces[1], (Face{5, 3, 4}));
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_EQ(again.components, 2u);
  EXPECT_EQ(again.boundary_loops, 2u);
}

TEST(Validate, ClosedPinchOfTwoTetrahedra) {
  TriangleMesh m = tetrahedron();
  // Point reflection of the tetrahedron through vertex 0 (reflection flips
  // orientation, so the faces are reversed to stay outward).
  for (int i = 1; i < 4; ++i) m.positions.push_back(-m.positions[i]);
  for (const Face& f : tetrahedron().faces) {
    Face g = reversed(f);
    for (auto& v : g)
      if (v != 0) v += 3;
    m.faces.push_back(g);
  }
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.outward.value_or(false));
  EXPECT_EQ(r.euler_characteristic, 7 - 12 + 8);
  EXPECT_NEAR(r.signed_volume, 2.0 / 6.0, 1e-15);

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.split_nonmanifold_vertices, 1u);
  EXPECT_EQ(rep.flipped_faces, 0u);
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_EQ(again.components, 2u);
  EXPECT_EQ(again.euler_characteristic, 4);
}

TEST(Validate, NonManifoldEdge) {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  m.faces = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  EXPECT_EQ(r.nonmanifold_vertices, 0u);  // the three faces are joined through the edge
  EXPECT_EQ(r.boundary_edges, 6u);
  EXPECT_EQ(r.boundary_loops, 3u);  // one chain per sheet
  EXPECT_EQ(r.components, 1u);
  EXPECT_NE(r.problems.front().find("between vertices 0 and 1"), std::string::npos);

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.cut_nonmanifold_edges, 1u);
  EXPECT_EQ(rep.split_nonmanifold_vertices, 4u);  // two more copies of each end
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_EQ(again.components, 3u);
  EXPECT_EQ(again.boundary_edges, 9u);
  EXPECT_EQ(again.boundary_loops, 3u);

  io::RepairOptions keep_edges;
  keep_edges.split_nonmanifold_edges = false;
  repair_and_check_order(m, after, keep_edges);
  EXPECT_EQ(validate_mesh(after).nonmanifold_edges, 1u);
}

TEST(Validate, UnreferencedVertexIsANoteNotAProblem) {
  TriangleMesh m = sphere();
  m.positions.push_back(Vec3(3, 3, 3));
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.unreferenced_vertices, 1u);
  EXPECT_TRUE(r.clean());
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_NE(r.notes[0].find("vertex 42"), std::string::npos);
  EXPECT_EQ(r.bbox.max, Vec3(3, 3, 3));  // unreferenced vertices count in the box
  TriangleMesh after;
  EXPECT_FALSE(repair_and_check_order(m, after).changed());
  EXPECT_EQ(after.positions.size(), 43u);
}

TEST(Validate, OpenCylinderHasTwoBoundaryLoops) {
  const TriangleMesh m = test::make_cylinder(1.0, 2.0, 4, 16);
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.boundary_edges, 32u);
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.euler_characteristic, 0);
  EXPECT_FALSE(r.closed);
  EXPECT_FALSE(r.outward.has_value());
  EXPECT_TRUE(r.consistently_oriented);
  EXPECT_TRUE(r.clean());

  // An open piece keeps the orientation of the majority of its faces.
  TriangleMesh m2 = m;
  for (std::size_t f = 0; f < 40; ++f) m2.faces[f] = reversed(m2.faces[f]);
  TriangleMesh after;
  const auto rep = repair_and_check_order(m2, after);
  EXPECT_EQ(rep.flipped_faces, 40u);
  EXPECT_EQ(after.faces, m.faces);
}

// Two holes touching at a vertex with faces between them on both sides: the
// surface's boundary runs from one hole through the vertex into the other,
// so it is one loop (plus the rim), before and after splitting the vertex.
TEST(Validate, HolesTouchingAtAVertexFollowTheSurface) {
  TriangleMesh m = test::make_plane(4.0, 5);  // 5 x 5 vertices, one boundary loop
  ASSERT_EQ(validate_mesh(m).boundary_loops, 1u);
  const std::int32_t center = 12;
  // Remove two faces at the centre that share only the centre vertex.
  std::vector<std::size_t> at_center;
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    if (std::count(m.faces[f].begin(), m.faces[f].end(), center)) at_center.push_back(f);
  std::size_t a = 0, b = 0;
  for (std::size_t i = 0; i < at_center.size() && b == 0; ++i)
    for (std::size_t j = i + 1; j < at_center.size(); ++j) {
      int common = 0;
      for (auto u : m.faces[at_center[i]])
        common += std::count(m.faces[at_center[j]].begin(), m.faces[at_center[j]].end(), u);
      if (common == 1) {
        a = at_center[i];
        b = at_center[j];
        break;
      }
    }
  ASSERT_NE(b, 0u);
  m.faces.erase(m.faces.begin() + static_cast<std::ptrdiff_t>(b));
  m.faces.erase(m.faces.begin() + static_cast<std::ptrdiff_t>(a));
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.boundary_loops, 2u);  // the rim and the figure-eight hole
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_NE(r.problems.front().find("vertex 12"), std::string::npos);
  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.split_nonmanifold_vertices, 1u);
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_EQ(again.boundary_loops, 2u);
}

TEST(Validate, MoebiusStripIsNotOrientable) {
  TriangleMesh m;
  const int n = 24;
  for (int i = 0; i < n; ++i) {
    const double t = 2 * std::numbers::pi * i / n;
    const Vec3 c(3 * std::cos(t), 3 * std::sin(t), 0);
    const Vec3 w =
        std::cos(t / 2) * Vec3(std::cos(t), std::sin(t), 0) + std::sin(t / 2) * Vec3(0, 0, 1);
    m.positions.push_back(c + 0.5 * w);
    m.positions.push_back(c - 0.5 * w);
  }
  for (int i = 0; i < n; ++i) {
    const int a = 2 * i, b = 2 * i + 1;
    const int j = (i + 1) % n;
    // After the last quad the half twist swaps the strip's sides.
    const int c = i + 1 < n ? 2 * j : 2 * j + 1, d = i + 1 < n ? 2 * j + 1 : 2 * j;
    m.faces.push_back({a, c, d});
    m.faces.push_back({a, d, b});
  }
  const auto r = validate_mesh(m);
  EXPECT_EQ(r.boundary_loops, 1u);  // a Moebius strip has one boundary curve
  EXPECT_EQ(r.boundary_edges, static_cast<std::size_t>(2 * n));
  EXPECT_GE(r.inconsistent_edges, 1u);
  EXPECT_EQ(r.euler_characteristic, 0);

  TriangleMesh after;
  const auto rep = repair_and_check_order(m, after);
  EXPECT_EQ(rep.nonorientable_pieces, 1u);
  EXPECT_EQ(validate_mesh(after).inconsistent_edges, 1u);  // one seam remains
}

TEST(Validate, TriangleSoupIsWeldedToFirstOccurrences) {
  const TriangleMesh welded = sphere();
  TriangleMesh soup;
  for (const Face& f : welded.faces) {
    const auto base = static_cast<std::int32_t>(soup.positions.size());
    for (int k = 0; k < 3; ++k) soup.positions.push_back(welded.positions[f[k]]);
    soup.faces.push_back({base, base + 1, base + 2});
  }
  const auto r = validate_mesh(soup);
  EXPECT_EQ(r.components, 80u);
  EXPECT_EQ(r.boundary_edges, 240u);
  EXPECT_EQ(r.boundary_loops, 80u);

  TriangleMesh after;
  auto rep = repair_and_check_order(soup, after);
  EXPECT_EQ(rep.welded_vertices, 240u - 42u);
  const auto again = validate_mesh(after);
  EXPECT_TRUE(again.clean());
  EXPECT_TRUE(again.closed);
  EXPECT_EQ(again.unreferenced_vertices, 240u - 42u);
  // Each face refers to the first occurrence of its positions.
  for (const Face& f : after.faces)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::find(soup.positions.begin(), soup.positions.end(), after.positions[f[k]]) -
                    soup.positions.begin(),
                f[k]);

  // With a tolerance, points moved by less than it weld too.
  TriangleMesh noisy = soup;
  for (std::size_t i = 0; i < noisy.positions.size(); ++i)
    noisy.positions[i] += Vec3(1e-9 * static_cast<double>(i % 3), -1e-9, 0);
  io::RepairOptions exact, tolerant;
  tolerant.weld_tolerance = 1e-6;
  rep = repair_and_check_order(noisy, after, exact);
  EXPECT_LT(rep.welded_vertices, 240u - 42u);
  after = noisy;
  rep = repair_mesh(after, tolerant);
  EXPECT_EQ(rep.welded_vertices, 240u - 42u);
  EXPECT_EQ(after.positions, noisy.positions);
  EXPECT_TRUE(validate_mesh(after).closed);
}

TEST(Validate, PrepareForLinesKeepsFacesAndVertices) {
  TriangleMesh m = sphere();
  for (Face& f : m.faces) f = reversed(f);
  m.faces.push_back({3, 3, 4});           // degenerate: kept, not touched
  m.positions.push_back(m.positions[5]);  // an exact duplicate of vertex 5 ...
  const auto uses5 = std::find_if(m.faces.begin(), m.faces.end(), [](const Face& f) {
    return f[0] == 5 || f[1] == 5 || f[2] == 5;
  });
  ASSERT_NE(uses5, m.faces.end());
  std::replace(uses5->begin(), uses5->end(), 5, 42);  // ... used by one face
  const TriangleMesh before = m;
  const auto rep = io::prepare_for_lines(m);
  EXPECT_EQ(m.faces.size(), before.faces.size());
  EXPECT_EQ(m.positions, before.positions);
  EXPECT_EQ(rep.welded_vertices, 1u);
  EXPECT_EQ(rep.flipped_faces, 80u);
  EXPECT_EQ(rep.components_reversed, 1u);
  EXPECT_EQ(m.faces[80], (Face{3, 3, 4}));
  for (std::size_t f = 0; f < 80; ++f) EXPECT_EQ(m.faces[f], sphere().faces[f]) << f;
}

TEST(Validate, EmptyAndCollapsedMeshesGiveNoNaN) {
  TriangleMesh empty;
  auto r = validate_mesh(empty);
  EXPECT_EQ(r.faces, 0u);
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.mean_edge_length, 0.0);

  TriangleMesh point;  // every vertex at the same place
  point.positions.assign(4, Vec3(1, 2, 3));
  point.faces = tetrahedron().faces;
  r = validate_mesh(point);
  EXPECT_EQ(r.degenerate_faces, 4u);
  EXPECT_TRUE(std::isfinite(r.signed_volume) && std::isfinite(r.area) &&
              std::isfinite(r.mean_edge_length));
  TriangleMesh after = point;
  const auto rep = repair_mesh(after);
  EXPECT_EQ(rep.welded_vertices, 0u);  // a closed fan has no crack to close
  EXPECT_TRUE(after.faces.empty());
  EXPECT_NO_THROW(validate_mesh(after));
}

TEST(Validate, RejectsBadIndicesAndNonFiniteCoordinates) {
  TriangleMesh m = tetrahedron();
  m.faces.push_back({0, 1, 9});
  EXPECT_THROW(validate_mesh(m), InputError);
  EXPECT_THROW(repair_mesh(m), InputError);
  m = tetrahedron();
  m.positions[2].y() = std::nan("");
  EXPECT_THROW(validate_mesh(m), InputError);
}

TEST(Validate, JsonReportIsCompleteAndDeterministic) {
  TriangleMesh m = sphere();
  m.faces[3] = reversed(m.faces[3]);
  const auto j = io::to_json(validate_mesh(m));
  EXPECT_EQ(j, io::to_json(validate_mesh(m)));
  EXPECT_EQ(j.at("inconsistent_edges"), 3);
  EXPECT_TRUE(j.at("outward").is_null());
  EXPECT_TRUE(j.at("self_intersecting_face_pairs").is_null());
  EXPECT_EQ(j.at("clean"), false);
  EXPECT_EQ(j.at("problems").size(), 1u);
  EXPECT_EQ(j.at("bbox").at("max").size(), 3u);
  TriangleMesh after = m;
  const auto rj = io::to_json(repair_mesh(after));
  EXPECT_EQ(rj.at("flipped_faces"), 1);
}

TEST(Validate, SameReportAtAnyThreadCount) {
  const TriangleMesh m = test::make_torus(3.0, 1.0, 120, 60, 0.2);
  nlohmann::json one, many;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = io::to_json(validate_mesh(m));
  }
  many = io::to_json(validate_mesh(m));
  EXPECT_EQ(one.dump(), many.dump());  // bit-identical sums
}

// Random small soups on a coarse integer grid (coincident points, collinear
// and repeated faces, bow-ties, fins): never a crash or a NaN, and repair
// leaves none of the defects it promises to remove.
TEST(Validate, RandomSoupsAreRepaired) {
  std::mt19937 rng(20240607);
  std::uniform_int_distribution<int> coord(0, 2);
  for (int trial = 0; trial < 300; ++trial) {
    TriangleMesh m;
    const int nv = 4 + trial % 9;
    for (int i = 0; i < nv; ++i) m.positions.emplace_back(coord(rng), coord(rng), coord(rng));
    std::uniform_int_distribution<int> vertex(0, nv - 1);
    const int nf = 1 + trial % 17;
    for (int f = 0; f < nf; ++f) m.faces.push_back({vertex(rng), vertex(rng), vertex(rng)});
    const auto r = validate_mesh(m);
    ASSERT_TRUE(std::isfinite(r.area) && std::isfinite(r.signed_volume) &&
                std::isfinite(r.mean_edge_length))
        << trial;
    TriangleMesh after;
    const auto rep = repair_and_check_order(m, after);
    const auto again = validate_mesh(after);
    EXPECT_EQ(again.degenerate_faces, 0u) << trial;
    EXPECT_EQ(again.duplicate_faces, 0u) << trial;
    EXPECT_EQ(again.nonmanifold_vertices, 0u) << trial;
    EXPECT_EQ(again.nonmanifold_edges, 0u) << trial;
    if (rep.nonorientable_pieces == 0) {
      EXPECT_TRUE(again.consistently_oriented) << trial;
      EXPECT_TRUE(again.outward.value_or(true)) << trial;
    }
    // Repair is idempotent.
    TriangleMesh twice = after;
    EXPECT_FALSE(repair_mesh(twice).changed()) << trial;
    EXPECT_EQ(twice.faces, after.faces) << trial;
  }
}

}  // namespace
}  // namespace fabrica
