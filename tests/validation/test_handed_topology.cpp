// The preparation's topology handed to the Surface (PreparedMesh::topology,
// fabrica::to_surface, Surface(mesh, topology), the topology_out overloads
// of io::prepare_for_lines and io::repair_mesh): the topology handed over is
// Topology(mesh) of the mesh as prepared, also after repair changed it, and a
// Surface given it computes the same bits as one that builds its own
// (geometry, curvature, every topology accessor, the lines of two views).
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/prepare.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/draw.hpp"
#include "lines_test_meshes.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

template <class T>
std::vector<T> list(std::span<const T> s) {
  return std::vector<T>(s.begin(), s.end());
}

// Every accessor of two topologies, entry by entry.
void expect_same_topology(const Topology& a, const Topology& b) {
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  ASSERT_EQ(a.face_count(), b.face_count());
  ASSERT_EQ(a.edge_count(), b.edge_count());
  for (std::size_t v = 0; v < a.vertex_count(); ++v) {
    ASSERT_EQ(list(a.vertex_faces(v)), list(b.vertex_faces(v))) << v;
    ASSERT_EQ(list(a.vertex_face_corners(v)), list(b.vertex_face_corners(v))) << v;
    ASSERT_EQ(list(a.vertex_face_opposite(v)), list(b.vertex_face_opposite(v))) << v;
    ASSERT_EQ(list(a.vertex_neighbors(v)), list(b.vertex_neighbors(v))) << v;
    ASSERT_EQ(list(a.upper_neighbors(v)), list(b.upper_neighbors(v))) << v;
    ASSERT_EQ(a.vertex_edge_begin(v), b.vertex_edge_begin(v)) << v;
    for (std::size_t i = 0; i < a.vertex_neighbors(v).size(); ++i)
      ASSERT_EQ(a.vertex_edge(v, i), b.vertex_edge(v, i)) << v;
    ASSERT_EQ(a.is_boundary_vertex(v), b.is_boundary_vertex(v)) << v;
    ASSERT_EQ(a.is_isolated_vertex(v), b.is_isolated_vertex(v)) << v;
  }
  for (std::size_t e = 0; e < a.edge_count(); ++e) {
    ASSERT_EQ(a.edge(e), b.edge(e)) << e;
    ASSERT_EQ(list(a.edge_faces(e)), list(b.edge_faces(e))) << e;
  }
  for (std::size_t f = 0; f < a.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(a.face_edge(f, k), b.face_edge(f, k)) << f;
      ASSERT_EQ(a.face_neighbor(f, k), b.face_neighbor(f, k)) << f;
    }
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// The lines of one view, every field, bit for bit.
void expect_same_lines(const LineDrawing& a, const LineDrawing& b) {
  EXPECT_TRUE(same_bits(a.feature_size, b.feature_size));
  EXPECT_EQ(a.segments, b.segments);
  ASSERT_EQ(a.lines.polylines.size(), b.lines.polylines.size());
  for (std::size_t i = 0; i < a.lines.polylines.size(); ++i) {
    const Polyline& p = a.lines.polylines[i];
    const Polyline& q = b.lines.polylines[i];
    ASSERT_EQ(p.family, q.family) << i;
    ASSERT_EQ(p.closed, q.closed) << i;
    ASSERT_EQ(p.edge_faces, q.edge_faces) << i;
    ASSERT_EQ(p.vertices.size(), q.vertices.size()) << i;
    for (std::size_t j = 0; j < p.vertices.size(); ++j) {
      const LineVertex& u = p.vertices[j];
      const LineVertex& w = q.vertices[j];
      ASSERT_EQ(u.anchor.face, w.anchor.face) << i << " " << j;
      ASSERT_EQ(std::memcmp(u.anchor.bary.data(), w.anchor.bary.data(), 3 * sizeof(double)), 0);
      ASSERT_EQ(std::memcmp(u.position.data(), w.position.data(), 3 * sizeof(double)), 0);
      ASSERT_EQ(std::memcmp(&u.strength, &w.strength, sizeof u.strength), 0);
      ASSERT_EQ(u.visible, w.visible) << i << " " << j;
    }
  }
}

// A Surface given a topology against one that builds its own: the same
// mesh, topology, geometry, curvature and lines.
void expect_same_surface(const Surface& given, const Surface& built, bool with_lines) {
  ASSERT_EQ(given.faces(), built.faces());
  ASSERT_TRUE(same_bits(given.positions(), built.positions()));
  expect_same_topology(given.topology(), built.topology());
  EXPECT_TRUE(same_bits(given.face_normals(), built.face_normals()));
  EXPECT_TRUE(same_bits(given.face_areas(), built.face_areas()));
  EXPECT_TRUE(same_bits(given.corner_areas(), built.corner_areas()));
  EXPECT_TRUE(same_bits(given.vertex_normals(), built.vertex_normals()));
  EXPECT_TRUE(same_bits(given.vertex_areas(), built.vertex_areas()));
  const PrincipalCurvatures& c = given.curvature();
  const PrincipalCurvatures& d = built.curvature();
  EXPECT_TRUE(same_bits(c.k1, d.k1) && same_bits(c.k2, d.k2));
  EXPECT_TRUE(same_bits(c.e1, d.e1) && same_bits(c.e2, d.e2));
  EXPECT_EQ(c.valid, d.valid);
  const CurvatureDerivatives& g = given.curvature_derivatives();
  const CurvatureDerivatives& h = built.curvature_derivatives();
  EXPECT_TRUE(same_bits(g.a, h.a) && same_bits(g.b, h.b) && same_bits(g.c, h.c) &&
              same_bits(g.d, h.d));
  EXPECT_EQ(g.valid, h.valid);
  EXPECT_TRUE(same_bits(given.feature_size(), built.feature_size()));
  EXPECT_TRUE(same_bits(given.median_edge_length(), built.median_edge_length()));
  EXPECT_TRUE(same_bits(given.mean_edge_length(), built.mean_edge_length()));
  if (!with_lines) return;
  DrawLinesOptions options;
  options.lines.families = reference_families();
  options.lines.families.push_back(LineFamily::boundary);
  for (const Vec3& direction : {Vec3(0.3, 0.2, 1.0), Vec3(-1.0, 0.4, -0.2)}) {
    const LineDrawing a = draw_lines(given, test::camera_towards(given, direction), options);
    const LineDrawing b = draw_lines(built, test::camera_towards(built, direction), options);
    EXPECT_GT(a.segment_count(), 100u);
    expect_same_lines(a, b);
  }
}

// The prepared mesh as a Surface through to_surface (with the kept topology)
// against Surface(mesh) building its own.
void expect_to_surface_same(PreparedMesh prepared, bool with_lines) {
  const Surface built(prepared.mesh);
  const Surface given = to_surface(std::move(prepared));
  EXPECT_FALSE(prepared.topology.has_value());  // taken out
  expect_same_surface(given, built, with_lines);
}

TriangleMesh bundled(const char* relative) {
  return io::read_mesh(test::bundled_data() / "meshes" / relative).mesh;
}

// The copies of every corner of faces [0, n) as new vertices at the same
// positions: a crack along the border of those faces that welding closes.
TriangleMesh cracked(TriangleMesh m, std::size_t n) {
  std::vector<std::int32_t> copy(m.positions.size(), -1);
  for (std::size_t f = 0; f < n; ++f)
    for (auto& v : m.faces[f]) {
      auto& c = copy[static_cast<std::size_t>(v)];
      if (c < 0) {
        c = static_cast<std::int32_t>(m.positions.size());
        m.positions.push_back(m.positions[static_cast<std::size_t>(v)]);
      }
      v = c;
    }
  return m;
}

}  // namespace

TEST(HandedTopology, PreparedRealMeshKeepsTheTopologyOfTheFinalMesh) {
  PreparedMesh prepared =
      prepare_mesh(test::bundled_data() / "meshes/classic/c3d_stanford-bunny.obj");
  ASSERT_TRUE(prepared.topology.has_value());
  EXPECT_FALSE(prepared.repair.changed());
  expect_same_topology(*prepared.topology, Topology(prepared.mesh));
  expect_to_surface_same(std::move(prepared), true);
}

TEST(HandedTopology, SurfaceFromAHandedTopologyEqualsOneBuildingItsOwn) {
  TriangleMesh mesh = bundled("classic/c3d_fandisk.obj");
  io::prepare_for_lines(mesh);
  Topology topology(mesh);
  const Surface built(mesh);
  const Surface given(mesh, std::move(topology));
  expect_same_surface(given, built, true);
  // With options other than the default.
  SurfaceOptions options;
  options.normal_weighting = NormalWeighting::area;
  options.mixed_areas = MixedAreaScheme::meyer;
  options.curvature_smoothing_passes = options.derivative_smoothing_passes = 1;
  expect_same_surface(Surface(mesh, Topology(mesh), options), Surface(mesh, options), false);
}

TEST(HandedTopology, MismatchThrowsInputError) {
  const TriangleMesh mesh = test::make_icosphere(1.0, 1);  // 80 faces
  TriangleMesh more = mesh;
  more.positions.push_back(Vec3::Zero());
  EXPECT_THROW(Surface(mesh, Topology(more)), InputError);
  EXPECT_THROW(Surface(more, Topology(mesh)), InputError);
  TriangleMesh fewer = mesh;
  fewer.faces.pop_back();
  EXPECT_THROW(Surface(mesh, Topology(fewer)), InputError);
  EXPECT_THROW(Surface(mesh, Topology()), InputError);
  try {
    Surface s(mesh, Topology(more));
    FAIL() << "no exception";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("topology"), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(more.positions.size()) + " vertices"), std::string::npos)
        << what;
  }
  // Same counts, one face's corners in the other order: the face check
  // (every face of a mesh of up to 64 faces is sampled) catches it.
  const TriangleMesh small = test::make_icosphere(1.0, 0);  // 20 faces
  for (std::size_t f = 0; f < small.faces.size(); ++f) {
    TriangleMesh flipped = small;
    std::swap(flipped.faces[f][1], flipped.faces[f][2]);
    EXPECT_THROW(Surface(flipped, Topology(small)), InputError) << f;
  }
  // Same counts, another mesh.
  TriangleMesh shifted = mesh;
  for (Face& f : shifted.faces)
    for (auto& v : f) v = (v + 1) % static_cast<std::int32_t>(mesh.positions.size());
  EXPECT_THROW(Surface(shifted, Topology(mesh)), InputError);
  // Bad indices are still reported as by Surface(mesh).
  TriangleMesh bad = mesh;
  bad.faces[0][0] = 1000;
  EXPECT_THROW(Surface(bad, Topology(mesh)), InputError);
  EXPECT_NO_THROW(Surface(mesh, Topology(mesh)));
}

TEST(HandedTopology, WeldedMeshGetsTheTopologyOfTheWeldedMesh) {
  const TriangleMesh bunny = bundled("classic/c3d_stanford-bunny.obj");
  PreparedMesh prepared = prepare_mesh(cracked(bunny, bunny.faces.size() / 3));
  EXPECT_GT(prepared.repair.welded_vertices, 100u);
  EXPECT_EQ(prepared.repair.flipped_faces, 0u);
  // The weld changed the faces; the orientation step built the topology
  // again, of the welded mesh, and changed nothing after it.
  ASSERT_TRUE(prepared.topology.has_value());
  const Topology rebuilt(prepared.mesh);
  expect_same_topology(*prepared.topology, rebuilt);
  // The crack is closed: as many edges and boundary edges as the bunny's.
  const Topology uncracked(bunny);
  auto boundary_edges = [](const Topology& t) {
    std::size_t n = 0;
    for (std::size_t e = 0; e < t.edge_count(); ++e) n += t.is_boundary_edge(e);
    return n;
  };
  EXPECT_EQ(rebuilt.edge_count(), uncracked.edge_count());
  EXPECT_EQ(boundary_edges(rebuilt), boundary_edges(uncracked));
  expect_to_surface_same(std::move(prepared), true);
}

TEST(HandedTopology, TurnedFacesAreTurnedInTheTopology) {
  TriangleMesh mesh = bundled("classic/c3d_stanford-bunny.obj");
  const TriangleMesh original = mesh;
  for (std::size_t f : {std::size_t{5}, mesh.faces.size() / 2})
    std::swap(mesh.faces[f][1], mesh.faces[f][2]);
  PreparedMesh prepared = prepare_mesh(cracked(mesh, 1000));
  EXPECT_EQ(prepared.repair.flipped_faces, 2u);
  EXPECT_GT(prepared.repair.welded_vertices, 0u);
  // The orientation step turned the two faces in its topology too.
  ASSERT_TRUE(prepared.topology.has_value());
  expect_same_topology(*prepared.topology, Topology(prepared.mesh));
  expect_to_surface_same(std::move(prepared), true);

  // A whole inward mesh: every face flipped.
  TriangleMesh inward = original;
  for (Face& f : inward.faces) std::swap(f[1], f[2]);
  std::optional<Topology> topology = Topology(original);  // replaced
  const auto report = io::prepare_for_lines(inward, {}, topology);
  EXPECT_EQ(report.flipped_faces, original.faces.size());
  EXPECT_EQ(inward.faces, original.faces);
  ASSERT_TRUE(topology.has_value());
  expect_same_topology(*topology, Topology(inward));
}

TEST(HandedTopology, ReverseFaceEqualsARebuild) {
  // Open, with a non-manifold edge, a duplicate face and an isolated vertex.
  TriangleMesh mesh = bundled("anatomy/vessels/sofa_aneurysm3D_1.off");
  const auto n = static_cast<std::int32_t>(mesh.positions.size());
  const Face first = mesh.faces[0];
  mesh.positions.push_back(mesh.positions[0] + Vec3(0.0, 0.0, 1.0));
  mesh.positions.push_back(Vec3::Zero());
  mesh.faces.push_back({first[0], first[1], n});
  mesh.faces.push_back(first);
  Topology turned(mesh);
  for (std::size_t f = 0; f < mesh.faces.size(); f += 3) {
    turned.reverse_face(f, mesh.faces[f]);
    std::swap(mesh.faces[f][1], mesh.faces[f][2]);
  }
  expect_same_topology(turned, Topology(mesh));
  // Turned back: the topology it started from.
  for (std::size_t f = 0; f < mesh.faces.size(); f += 3) {
    turned.reverse_face(f, mesh.faces[f]);
    std::swap(mesh.faces[f][1], mesh.faces[f][2]);
  }
  expect_same_topology(turned, Topology(mesh));
  // A face that is not the topology's: InputError, nothing changed.
  const Face f1 = mesh.faces[1];
  const Face bad[] = {{f1[0], f1[2], f1[1]},
                      {f1[0], f1[0], f1[1]},
                      {f1[0], f1[1], n + 1},
                      {f1[0], f1[1], -1},
                      {f1[0], f1[1], n + 2}};
  for (const Face& corners : bad) EXPECT_THROW(turned.reverse_face(1, corners), InputError);
  EXPECT_THROW(turned.reverse_face(mesh.faces.size(), f1), InputError);
  expect_same_topology(turned, Topology(mesh));
}

// reverse_face on a topology whose opposite corners were released (rebuilt
// afterwards from the new face edges), on one that holds them while a copy
// shares them (the copy keeps the old corners), and on such a copy.
TEST(HandedTopology, ReverseFaceWithReleasedOrSharedParts) {
  TriangleMesh mesh = bundled("anatomy/vessels/sofa_aneurysm3D_1.off");
  const TriangleMesh before = mesh;
  const Topology original(mesh);
  Topology released = original;
  released.release_derived_parts();
  Topology shared = released;  // shares the released (not yet rebuilt) parts
  Topology held = original;    // shares the constructor's parts with `original`
  for (std::size_t f = 0; f < mesh.faces.size(); f += 5) {
    released.reverse_face(f, mesh.faces[f]);
    held.reverse_face(f, mesh.faces[f]);
    std::swap(mesh.faces[f][1], mesh.faces[f][2]);
  }
  EXPECT_FALSE(released.has_vertex_face_opposite());
  EXPECT_TRUE(held.has_vertex_face_opposite());
  const Topology rebuilt(mesh);
  expect_same_topology(released, rebuilt);
  expect_same_topology(held, rebuilt);
  // The copies that shared the parts keep the topology of the mesh before.
  expect_same_topology(shared, Topology(before));
  expect_same_topology(original, Topology(before));
}

// Given a topology without the derived parts (as `fabrica lines` hands it
// over), the one-shot drawing of the reference families never builds them
// (they would be 8 + 4 bytes per corner for the rest of the run: its ring
// reads the faces); the lines are those of a Surface whose topology holds
// them (the drawer path's ring reads them).
TEST(HandedTopology, SurfaceTopologyWithoutDerivedParts) {
  TriangleMesh mesh = bundled("classic/c3d_stanford-bunny.obj");
  Topology released(mesh);
  released.release_derived_parts();  // as `fabrica lines` hands it over
  const Surface surface(mesh, std::move(released));
  EXPECT_FALSE(surface.topology().has_vertex_face_opposite());
  EXPECT_FALSE(surface.topology().has_edge_faces());
  const Camera camera = test::camera_towards(surface, Vec3(0.3, 0.2, 1.0));
  DrawLinesOptions options;
  options.lines.families = reference_families();
  const LineDrawing one_shot = draw_lines(surface, camera, options);
  EXPECT_GT(one_shot.segment_count(), 100u);
  EXPECT_FALSE(surface.topology().has_vertex_face_opposite());
  EXPECT_FALSE(surface.topology().has_edge_faces());
  // Without the edges' vertex pairs either (as `fabrica lines` keeps the
  // Surface): chaining finds an edge's ends from its face, hidden-line
  // removal reads the edge-length statistics computed before the release;
  // the same lines, at one and two threads, and the pairs never rebuilt.
  const Surface bare(mesh, [&] {
    Topology t(mesh);
    t.release_derived_parts();
    return t;
  }());
  bare.release_topology_edges();
  EXPECT_FALSE(bare.topology().has_edges());
  for (const int threads : {1, 2}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    static_cast<std::size_t>(threads));
    expect_same_lines(one_shot, draw_lines(bare, camera, options));
  }
  EXPECT_FALSE(bare.topology().has_edges());
  EXPECT_FALSE(bare.topology().has_vertex_face_opposite());
  // With the parts built first, a drawer's lines: the same.
  const Surface other(mesh);
  EXPECT_TRUE(other.topology().has_vertex_face_opposite());
  EXPECT_TRUE(other.topology().has_edge_faces());
  LineDrawer drawer(other, options);
  const LineDrawing drawn = drawer.draw(camera);
  expect_same_lines(one_shot, drawn);
}

TEST(HandedTopology, RealMeshesThatPreparationTurns) {
  // A closed piece turned outward, open pieces turned outward (capped
  // volume), a few faces of open pieces.
  for (const char* relative : {"anatomy/heart/sofa_coeur1.off", "classic/vtkdata_fran_cut.vtk",
                               "anatomy/teeth/sofa_teeth.obj"}) {
    SCOPED_TRACE(relative);
    PreparedMesh prepared = prepare_mesh(test::bundled_data() / "meshes" / relative);
    EXPECT_GT(prepared.repair.flipped_faces, 0u);
    ASSERT_TRUE(prepared.topology.has_value());
    expect_same_topology(*prepared.topology, Topology(prepared.mesh));
    expect_to_surface_same(std::move(prepared), relative[0] == 'c');
  }
}

TEST(HandedTopology, RepeatedIndexFacesAndKeptOrientation) {
  // A face with a repeated corner: the preparation's topology leaves it
  // out, so it is not the mesh's (none is handed over).
  TriangleMesh mesh = test::make_torus(2.0, 0.5, 24, 16);
  mesh.faces.push_back({3, 3, 40});
  PreparedMesh degenerate = prepare_mesh(mesh);
  EXPECT_FALSE(degenerate.topology.has_value());
  expect_to_surface_same(std::move(degenerate), false);

  // orient off: only the weld runs.
  PrepareOptions keep;
  keep.orient = false;
  PreparedMesh plain = prepare_mesh(test::make_torus(2.0, 0.5, 24, 16), keep);
  ASSERT_TRUE(plain.topology.has_value());  // nothing changed after the weld's build
  expect_same_topology(*plain.topology, Topology(plain.mesh));
  expect_to_surface_same(std::move(plain), false);
  PreparedMesh welded = prepare_mesh(cracked(test::make_torus(2.0, 0.5, 24, 16), 100), keep);
  EXPECT_GT(welded.repair.welded_vertices, 0u);
  EXPECT_FALSE(welded.topology.has_value());  // no step followed the weld
  expect_to_surface_same(std::move(welded), false);
}

TEST(HandedTopology, FullRepairHandsOverOnlyTheFinalMeshsTopology) {
  // Non-manifold edge, duplicate face, degenerate face: every step runs.
  TriangleMesh mesh = test::make_icosphere(1.0, 2);
  const auto n = static_cast<std::int32_t>(mesh.positions.size());
  const Face first = mesh.faces[0];
  mesh.positions.push_back(Vec3(2.0, 0.0, 0.0));
  mesh.faces.push_back({first[0], first[1], n});
  mesh.faces.push_back(first);
  mesh.faces.push_back({first[2], first[2], first[0]});
  std::optional<Topology> topology;
  const io::RepairReport report = io::repair_mesh(mesh, {}, topology);
  EXPECT_TRUE(report.changed());
  EXPECT_GT(report.cut_nonmanifold_edges, 0u);
  EXPECT_EQ(report.removed_duplicate_faces, 1u);
  EXPECT_EQ(report.removed_degenerate_faces, 1u);
  // Built again after the removal and the split, for the orientation.
  ASSERT_TRUE(topology.has_value());
  expect_same_topology(*topology, Topology(mesh));

  // A clean mesh: the repair's one build is handed over.
  TriangleMesh clean = test::make_icosphere(1.0, 2);
  ASSERT_FALSE(io::repair_mesh(clean, {}, topology).changed());
  ASSERT_TRUE(topology.has_value());
  expect_same_topology(*topology, Topology(clean));
}

TEST(HandedTopology, TopologyOutIsResetWhenPreparationThrows) {
  TriangleMesh mesh = test::make_icosphere(1.0, 1);
  std::optional<Topology> topology = Topology(mesh);
  mesh.faces[3][1] = -2;
  EXPECT_THROW(io::prepare_for_lines(mesh, {}, topology), InputError);
  EXPECT_FALSE(topology.has_value());
}
