// Orientation of open surfaces (issue 17, item 1): io::prepare_for_lines
// turns every open piece outward by its signed volume with the boundary loops
// capped, reports it, and --keep-orientation keeps the file's orientation.
// Real data: the bundled vmtk aorta with both ends cut open by the test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/io/validate.hpp"
#include "fabrica/lines/extract.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

void flip_all(TriangleMesh& m) {
  for (Face& f : m.faces) std::swap(f[1], f[2]);
}

// The aorta, prepared (closed, outward), and the same mesh with the faces
// beyond two planes across its long axis dropped: an open tube, vertex i
// still vertex i (unreferenced vertices stay).
struct Aorta {
  TriangleMesh closed;
  TriangleMesh open;
  int axis = 2;
  double lo = 0.0, hi = 0.0;  // the kept slab along `axis`
};

Aorta cut_aorta() {
  Aorta a;
  a.closed =
      io::read_mesh(test::bundled_data() / "meshes/anatomy/vessels/vmtk_aorta-surface.stl").mesh;
  io::prepare_for_lines(a.closed);
  const BoundingBox box = bounding_box(a.closed.positions);
  const Vec3 size = box.max - box.min;
  size.maxCoeff(&a.axis);
  a.lo = box.min[a.axis] + 0.12 * size[a.axis];
  a.hi = box.max[a.axis] - 0.12 * size[a.axis];
  a.open.positions = a.closed.positions;
  for (const Face& f : a.closed.faces) {
    bool inside = true;
    for (auto v : f) {
      const double t = a.closed.positions[v][a.axis];
      inside = inside && t >= a.lo && t <= a.hi;
    }
    if (inside) a.open.faces.push_back(f);
  }
  return a;
}

// Segment midpoints of one family more than `margin` inside the slab.
std::vector<Vec3> midpoints(const TriangleMesh& mesh, LineFamily family, const Aorta& a,
                            double margin) {
  Surface surface{TriangleMesh(mesh)};
  LineOptions o;
  o.families = {family};
  o.ridge.cull_backfaces = o.valley.cull_backfaces = false;  // all round the vessel
  LineExtractor extractor(surface, o);
  Camera camera;  // ridges and valleys do not depend on the view (without culling)
  std::vector<Vec3> out;
  for (const auto& soup : extractor.extract(camera))
    for (const auto& s : soup.resolved()) {
      const Vec3 m = 0.5 * (s.end[0].position + s.end[1].position);
      if (m[a.axis] > a.lo + margin && m[a.axis] < a.hi - margin) out.push_back(m);
    }
  return out;
}

// Fraction of `points` within `tolerance` of some point of `near`.
double matched(const std::vector<Vec3>& points, const std::vector<Vec3>& near, double tolerance) {
  if (points.empty()) return 0.0;
  std::size_t hits = 0;
  for (const Vec3& p : points)
    for (const Vec3& q : near)
      if ((p - q).squaredNorm() <= tolerance * tolerance) {
        ++hits;
        break;
      }
  return static_cast<double>(hits) / static_cast<double>(points.size());
}

TEST(OpenOrientation, CutInwardAortaIsTurnedOutwardAndReported) {
  const Aorta a = cut_aorta();
  TriangleMesh inward = a.open;
  flip_all(inward);
  const auto before = io::validate_mesh(inward);
  EXPECT_FALSE(before.closed);
  EXPECT_GE(before.boundary_loops, 2u);
  EXPECT_EQ(before.inward_open_pieces, 1u);
  EXPECT_FALSE(before.clean());

  TriangleMesh prepared = inward;
  const auto report = io::prepare_for_lines(prepared);
  EXPECT_EQ(report.open_pieces_reversed, 1u);
  EXPECT_EQ(report.flipped_faces, a.open.faces.size());
  ASSERT_FALSE(report.changes.empty());
  EXPECT_NE(report.changes.front().find("open piece turned outward"), std::string::npos)
      << report.changes.front();
  EXPECT_EQ(prepared.faces, a.open.faces);  // exactly the closed version's orientation
  EXPECT_EQ(io::validate_mesh(prepared).inward_open_pieces, 0u);

  // Per-vertex normals agree with the closed aorta's away from the cuts.
  const Surface open_surface{TriangleMesh(prepared)};
  const Surface closed_surface{TriangleMesh(a.closed)};
  const double margin = 5.0 * io::validate_mesh(a.closed).mean_edge_length;
  std::size_t compared = 0, agree = 0;
  for (std::size_t v = 0; v < prepared.positions.size(); ++v) {
    const double t = prepared.positions[v][a.axis];
    if (t < a.lo + margin || t > a.hi - margin) continue;
    ++compared;
    agree += open_surface.vertex_normals()[v].dot(closed_surface.vertex_normals()[v]) > 0.99;
  }
  EXPECT_GT(compared, 1000u);
  EXPECT_EQ(agree, compared);

  // --keep-orientation keeps the file's (inward) orientation.
  TriangleMesh kept = inward;
  PrepareOptions keep;
  keep.orient = false;
  const auto kept_report = io::prepare_for_lines(kept, keep);
  EXPECT_EQ(kept_report.flipped_faces, 0u);
  EXPECT_EQ(kept.faces, inward.faces);

  // repair_mesh (info --repair) does the same.
  TriangleMesh repaired = inward;
  EXPECT_EQ(io::repair_mesh(repaired).open_pieces_reversed, 1u);
  EXPECT_EQ(repaired.faces, a.open.faces);
}

TEST(OpenOrientation, CutAortaRidgesAndValleysMatchTheClosedOnes) {
  const Aorta a = cut_aorta();
  TriangleMesh prepared = a.open;
  flip_all(prepared);
  io::prepare_for_lines(prepared);
  const double edge = io::validate_mesh(a.closed).mean_edge_length;
  const double margin = 8.0 * edge;
  for (LineFamily family : {LineFamily::ridge, LineFamily::valley}) {
    const auto open_lines = midpoints(prepared, family, a, margin);
    const auto closed_lines = midpoints(a.closed, family, a, margin);
    ASSERT_GT(open_lines.size(), 20u) << family_name(family);
    ASSERT_GT(closed_lines.size(), 20u) << family_name(family);
    const double forward = matched(open_lines, closed_lines, edge);
    const double backward = matched(closed_lines, open_lines, edge);
    std::printf("%s: %zu open / %zu closed segments, matched %.3f / %.3f\n", family_name(family),
                open_lines.size(), closed_lines.size(), forward, backward);
    EXPECT_GT(forward, 0.9) << family_name(family);
    EXPECT_GT(backward, 0.9) << family_name(family);
  }
  // The control: left inward, the open aorta has few ridges (the closed
  // one's valleys are fewer than its ridges): the comparison above can fail.
  TriangleMesh inward = a.open;
  flip_all(inward);
  const auto inward_ridges = midpoints(inward, LineFamily::ridge, a, margin);
  const auto closed_ridges = midpoints(a.closed, LineFamily::ridge, a, margin);
  EXPECT_LT(inward_ridges.size(), closed_ridges.size() / 4);
  EXPECT_LT(matched(closed_ridges, inward_ridges, edge), 0.5);
}

TEST(OpenOrientation, ContoursOfTheCutAortaArePresent) {
  const Aorta a = cut_aorta();
  TriangleMesh prepared = a.open;
  flip_all(prepared);
  io::prepare_for_lines(prepared);
  Surface surface{TriangleMesh(prepared)};
  LineOptions o;
  o.families = {LineFamily::contour, LineFamily::boundary};
  LineExtractor extractor(surface, o);
  const Camera camera =
      anatomical_camera(AnatomicalView::anterior, bounding_box(prepared.positions), Space::lps);
  const auto soups = extractor.extract(camera);
  const double height = a.hi - a.lo;
  EXPECT_GT(soups[0].total_length(), 1.5 * height);  // both sides of the tube
  EXPECT_GT(soups[1].total_length(), 0.0);           // the cut rims
}

TEST(OpenOrientation, InwardOpenCylinderIsFlippedAndAFlatSheetIsLeftAlone) {
  TriangleMesh cylinder = test::make_cylinder(10.0, 60.0, 20, 32);
  const TriangleMesh outward = cylinder;
  flip_all(cylinder);
  EXPECT_EQ(io::validate_mesh(cylinder).inward_open_pieces, 1u);
  EXPECT_EQ(io::validate_mesh(outward).inward_open_pieces, 0u);
  const auto report = io::prepare_for_lines(cylinder);
  EXPECT_EQ(report.open_pieces_reversed, 1u);
  EXPECT_EQ(report.open_piece_loops, 2u);
  EXPECT_EQ(cylinder.faces, outward.faces);
  TriangleMesh again = outward;
  EXPECT_FALSE(io::prepare_for_lines(again).changed());

  // A flat sheet has no inside: both orientations are kept.
  for (bool flipped : {false, true}) {
    TriangleMesh plane = test::make_plane(10.0, 8);
    if (flipped) flip_all(plane);
    const TriangleMesh original = plane;
    EXPECT_EQ(io::validate_mesh(plane).inward_open_pieces, 0u);
    EXPECT_FALSE(io::prepare_for_lines(plane).changed());
    EXPECT_EQ(plane.faces, original.faces);
  }
}

}  // namespace
}  // namespace fabrica
