// PELs and Laplacian lines (docs/algorithms.md §7): the analytic case of a sphere
// under a directional light, and the sparse illumination fields (computed
// only where a line can be kept, ViewFieldsRequest::light_threshold) giving
// the same segments, bit for bit, as fields computed everywhere.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/extract.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

Camera camera_at(const Vec3& eye, const Vec3& center, double fov_deg = 40.0) {
  Camera c;
  c.eye = eye;
  c.center = center;
  c.up = std::abs(eye.normalized().dot(Vec3::UnitY())) > 0.9 ? Vec3::UnitZ() : Vec3::UnitY();
  c.fov_deg = fov_deg;
  c.width = c.height = 512;
  return c;
}

bool same_end(const ResolvedEnd& a, const ResolvedEnd& b) {
  return a.anchor.face == b.anchor.face && a.anchor.bary == b.anchor.bary &&
         a.position == b.position && a.element == b.element && a.kind == b.kind &&
         a.strength == b.strength;
}

// Number of segments that differ between two soups (all if the sizes differ).
std::size_t differing(const SegmentSoup& a, const SegmentSoup& b) {
  if (a.segments.size() != b.segments.size()) return std::max(a.segments.size(), b.segments.size());
  std::size_t n = 0;
  const auto ra = a.resolved(), rb = b.resolved();
  for (std::size_t i = 0; i < ra.size(); ++i) {
    const ResolvedSegment& s = ra[i];
    const ResolvedSegment& t = rb[i];
    if (s.face != t.face || !same_end(s.end[0], t.end[0]) || !same_end(s.end[1], t.end[1])) ++n;
  }
  return n;
}

}  // namespace

// f = n·l on a sphere of radius r is cos θ (θ from l): |∇f| = sin θ / r is
// largest on the terminator θ = 90°, and Δf = -2 cos θ / r² vanishes there.
// Both families must therefore trace the terminator (the great circle
// n·l = 0), on the half that faces the camera.
TEST(PhoticSphere, PelsAndLaplacianLinesTraceTheTerminator) {
  const double r = 1.0;
  Surface surface(test::make_sphere(r, 96, 192));
  LineOptions o;
  o.families = {LineFamily::pel, LineFamily::laplacian};
  o.feature_size = 1.0;  // threshold 0.2 on |∇f| (1/r = 1 on the terminator)
  o.pel.light_direction = o.laplacian.light_direction = Vec3(1.0, 0.0, 0.0);
  LineExtractor ex(surface, o);
  const auto soups = ex.extract(camera_at(Vec3(0.0, 0.0, 6.0), Vec3::Zero()));
  ASSERT_EQ(soups.size(), 2u);
  for (const SegmentSoup& soup : soups) {
    SCOPED_TRACE(family_name(soup.family));
    ASSERT_FALSE(soup.segments.empty());
    double length = 0.0;
    for (const ResolvedSegment& s : soup.resolved()) {
      for (const ResolvedEnd& e : s.end) {
        EXPECT_NEAR(e.position.x(), 0.0, 0.02 * r);  // on n·l = 0
        EXPECT_NEAR(e.position.norm(), r, 0.01 * r);
        EXPECT_GT(e.position.z(), -0.05 * r);  // the front half (back faces culled)
      }
      length += (s.end[1].position - s.end[0].position).norm();
    }
    // The arc of the terminator in front of the eye (perspective, eye at
    // distance 6r: n·v > 0 where cos φ > r/6), plus the culling's margin of
    // faces with one front corner.
    const double arc = 2.0 * std::acos(1.0 / 6.0) * r;
    EXPECT_GT(length, 0.98 * arc);
    EXPECT_LT(length, 1.05 * arc);
  }
}

// The extractor computes the PEL derivatives only around the faces that can
// carry a kept line and visits only those faces; the segments must equal,
// bit for bit, those extracted from fields computed everywhere, for
// headlight and fixed light, several thresholds and views, with and
// without back-face culling.
TEST(PhoticSparseFields, SameSegmentsAsFieldsComputedEverywhere) {
  auto loaded = io::read_mesh(test::bundled_data() / "meshes/anatomy/bones/gfxmorph_femur.stl");
  TriangleMesh mesh = std::move(loaded.mesh);
  io::prepare_for_lines(mesh);
  Surface surface(std::move(mesh));
  const BoundingBox box = bounding_box(surface.positions());
  const double fs = surface.feature_size();
  const Vec3 c = box.center();
  const double d = 2.5 * box.diagonal();
  const Camera views[] = {camera_at(c + Vec3(0.0, -d, 0.0), c),
                          camera_at(c + Vec3(d, 0.2 * d, 0.3 * d), c)};
  std::size_t compared = 0;
  for (const Camera& cam : views)
    for (int light = 0; light < 2; ++light)
      for (const double t : {0.2, 0.05, 1.0})
        for (const bool cull : {true, false}) {
          SCOPED_TRACE(testing::Message()
                       << "light " << light << " threshold " << t << " cull " << cull);
          LineOptions o;
          o.families = {LineFamily::pel, LineFamily::laplacian};
          o.feature_size = fs;
          o.pel.threshold = o.laplacian.threshold = t;
          o.pel.cull_backfaces = o.laplacian.cull_backfaces = cull;
          if (light) o.pel.light_direction = o.laplacian.light_direction = Vec3(0.3, -0.5, 0.8);
          LineExtractor ex(surface, o);
          const auto sparse = ex.extract(cam);
          EXPECT_LT(ex.fields().light_faces.size(), surface.face_count());

          ViewFieldsRequest full;  // default light_threshold: everywhere
          full.radial = full.sc_test = full.apparent = false;
          full.light = full.pel = true;
          full.light_direction = o.pel.light_direction;
          const ViewFields fields = compute_view_fields(surface, cam, full, &ex.precompute());
          const SegmentSoup pel = extract_pels(surface, fields, fs, o.pel);
          const SegmentSoup lap = extract_laplacian_lines(surface, fields, fs, o.laplacian);
          ASSERT_EQ(sparse.size(), 2u);
          EXPECT_EQ(differing(sparse[0], pel), 0u);
          EXPECT_EQ(differing(sparse[1], lap), 0u);
          compared += pel.segments.size() + lap.segments.size();
        }
  EXPECT_GT(compared, 1000u);
}

// Fields computed for a higher threshold (or with culling) cannot serve an
// extraction that would keep more: reported, not silently incomplete.
TEST(PhoticSparseFields, RejectsFieldsComputedForAHigherThreshold) {
  Surface surface(test::make_torus(2.0, 0.7, 48, 24));
  LinePrecompute pre(surface);
  const Camera cam = camera_at(Vec3(0.0, -6.0, 3.0), Vec3::Zero());
  ViewFieldsRequest req;
  req.radial = req.sc_test = req.apparent = false;
  req.light = req.pel = true;
  req.light_threshold = 0.5;
  req.light_cull_backfaces = true;
  const ViewFields fields = compute_view_fields(surface, cam, req, &pre);
  PhoticOptions p;
  p.threshold = 0.5;  // with feature size 1: the same threshold, fine
  EXPECT_NO_THROW(extract_pels(surface, fields, 1.0, p));
  p.threshold = 0.4;
  EXPECT_THROW(extract_pels(surface, fields, 1.0, p), Error);
  LaplacianOptions l;
  l.threshold = 0.5;
  l.cull_backfaces = false;
  EXPECT_THROW(extract_laplacian_lines(surface, fields, 1.0, l), Error);
}
