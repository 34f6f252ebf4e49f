// Chaining and hidden-line removal against independent, plain
// implementations: the depth raster against a brute-force rasteriser (every
// triangle, every pixel of its box, the same per-pixel formula: the buffers
// must agree bit for bit, so the binning, the back-face skipping and the
// reused working memory change nothing); chaining by the flat end table
// against the sort-based pairing (ids too large for the table); branch
// points; visibility with and without a given depth buffer; threads.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "chain_internal.hpp"
#include "depth_raster_internal.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/visibility.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

Camera look_at(const Vec3& eye, const Vec3& center, int w, int h,
               Projection proj = Projection::perspective, double fov = 40.0) {
  Camera c;
  c.eye = eye;
  c.center = center;
  c.up = Vec3(0.0, 1.0, 0.0);
  c.fov_deg = fov;
  c.projection = proj;
  c.width = w;
  c.height = h;
  return c;
}

TriangleMesh translated(TriangleMesh m, const Vec3& t) {
  for (auto& p : m.positions) p += t;
  return m;
}

TriangleMesh merged(const TriangleMesh& a, const TriangleMesh& b) {
  TriangleMesh m = a;
  const auto off = static_cast<std::int32_t>(a.positions.size());
  m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
  for (Face f : b.faces) {
    for (int k = 0; k < 3; ++k) f[k] += off;
    m.faces.push_back(f);
  }
  return m;
}

// Every triangle, every pixel of its (unclipped) box, the weights and the
// depth by the documented formula; min kept. With `faces`, the face of the
// minimum per pixel (the lower index on equal depth), -1 where empty.
std::vector<float> brute_force_depth(const TriangleMesh& mesh, const Camera& camera,
                                     std::vector<std::int32_t>* faces = nullptr) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> out(static_cast<std::size_t>(camera.width) * camera.height, inf);
  if (faces) faces->assign(out.size(), -1);
  const bool perspective = camera.projection == Projection::perspective;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& t = mesh.faces[f];
    ProjectedPoint q[3];
    for (int k = 0; k < 3; ++k) q[k] = project(camera, mesh.positions[t[k]]);
    if (perspective && (q[0].depth <= 1e-9 || q[1].depth <= 1e-9 || q[2].depth <= 1e-9)) continue;
    const Vec2 p[3] = {q[0].pixel, q[1].pixel, q[2].pixel};
    const double area =
        (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (area == 0.0) continue;
    const double inv_area = 1.0 / area;
    const double xmin = std::min({p[0].x(), p[1].x(), p[2].x()});
    const double xmax = std::max({p[0].x(), p[1].x(), p[2].x()});
    const double ymin = std::min({p[0].y(), p[1].y(), p[2].y()});
    const double ymax = std::max({p[0].y(), p[1].y(), p[2].y()});
    const int x0 = std::max(0, static_cast<int>(std::floor(xmin)));
    const int x1 = std::min(camera.width - 1, static_cast<int>(std::floor(xmax)));
    const int y0 = std::max(0, static_cast<int>(std::floor(ymin)));
    const int y1 = std::min(camera.height - 1, static_cast<int>(std::floor(ymax)));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        double w[3];
        for (int k = 0; k < 3; ++k) {
          const Vec2& a = p[(k + 1) % 3];
          const Vec2& b = p[(k + 2) % 3];
          w[k] = ((b.x() - a.x()) * (py - a.y()) - (b.y() - a.y()) * (px - a.x())) * inv_area;
        }
        if (w[0] < 0.0 || w[1] < 0.0 || w[2] < 0.0) continue;
        const double d = perspective
                             ? 1.0 / (w[0] / q[0].depth + w[1] / q[1].depth + w[2] / q[2].depth)
                             : w[0] * q[0].depth + w[1] * q[1].depth + w[2] * q[2].depth;
        const std::size_t at = static_cast<std::size_t>(y) * camera.width + x;
        const float z = static_cast<float>(d);
        if (faces && z < out[at]) (*faces)[at] = static_cast<std::int32_t>(f);
        out[at] = std::min(out[at], z);
      }
  }
  return out;
}

std::size_t count_differences(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  std::size_t n = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    n += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
  return n;
}

std::size_t finite_pixels(const std::vector<float>& d) {
  return static_cast<std::size_t>(
      std::count_if(d.begin(), d.end(), [](float z) { return std::isfinite(z); }));
}

// Runs the depth raster with its portable row kernel while alive (the AVX2
// kernel is the default where the CPU has it).
class PortableRaster {
 public:
  PortableRaster() : had_(detail::depth_raster_avx2_enabled().exchange(false)) {}
  ~PortableRaster() { detail::depth_raster_avx2_enabled() = had_; }
  PortableRaster(const PortableRaster&) = delete;
  PortableRaster& operator=(const PortableRaster&) = delete;

 private:
  bool had_;
};

}  // namespace

TEST(DepthRaster, BitIdenticalToBruteForceOnClosedOpenAndClippedScenes) {
  // Twice: with the default row kernel (AVX2 where the CPU has it), then the
  // portable one.
  for (const bool portable : {false, true}) {
    SCOPED_TRACE(portable ? "portable kernel" : "default kernel");
    std::unique_ptr<PortableRaster> forced;
    if (portable) forced = std::make_unique<PortableRaster>();
    // Two spheres (closed, back faces hidden), an open cylinder seen from an
    // angle (back faces visible through the ends), a jittered torus, an
    // orthographic view, and an eye between the spheres (near-plane skipping).
    const TriangleMesh spheres =
        merged(translated(test::make_icosphere(1.0, 4), Vec3(0, 0, 1)),
               translated(test::make_icosphere(1.5, 4), Vec3(0.8, 0.3, -2)));
    const TriangleMesh cylinder = test::make_cylinder(1.0, 3.0, 20, 48);
    const TriangleMesh torus = test::make_torus(2.0, 0.6, 64, 32, 0.05);
    // More faces than one binning chunk (16384): the bands draw the chunks'
    // triangles one chunk after another.
    const TriangleMesh fine = test::make_torus(2.0, 0.6, 240, 100, 0.05);
    struct Case {
      const TriangleMesh* mesh;
      Camera camera;
    };
    const std::vector<Case> cases = {
        {&spheres, look_at(Vec3(0, 0, 9), Vec3(0, 0, 0), 320, 240)},
        {&cylinder, look_at(Vec3(3, 4, 5), Vec3(0, 0, 0), 257, 300)},
        {&torus, look_at(Vec3(1, 6, 4), Vec3(0, 0, 0), 400, 400)},
        {&torus, look_at(Vec3(0, 2, 8), Vec3(0, 0, 0), 200, 150, Projection::orthographic, 30)},
        {&spheres,
         look_at(Vec3(0.2, 0.1, -0.5), Vec3(0, 0, 1), 160, 120, Projection::perspective, 100)},
        {&fine, look_at(Vec3(2, 5, 3), Vec3(0, 0, 0), 300, 260)},
    };
    DepthBuffer reused;  // rendered into again and again: working memory reused
    for (std::size_t i = 0; i < cases.size(); ++i) {
      const auto& c = cases[i];
      const std::vector<float> expected = brute_force_depth(*c.mesh, c.camera);
      ASSERT_GT(finite_pixels(expected), 500u) << "case " << i << " sees too little";
      const DepthBuffer fresh = render_depth(*c.mesh, c.camera);
      EXPECT_EQ(fresh.width, c.camera.width);
      EXPECT_EQ(fresh.height, c.camera.height);
      EXPECT_EQ(count_differences(fresh.depth, expected), 0u) << "case " << i;
      render_depth(*c.mesh, c.camera, reused);
      EXPECT_EQ(count_differences(reused.depth, expected), 0u) << "case " << i << " (reused)";
      EXPECT_TRUE(reused.face.empty());
      // With faces (hatching's seeds and occlusion): the same depths, and the
      // face of the nearest triangle at every pixel. Faces are visited in
      // index order by the brute force, so `z < depth` keeps the lower index
      // on ties, as the rasteriser promises.
      std::vector<std::int32_t> expected_faces;
      brute_force_depth(*c.mesh, c.camera, &expected_faces);
      render_depth(*c.mesh, c.camera, reused, /*faces=*/true);
      EXPECT_EQ(count_differences(reused.depth, expected), 0u) << "case " << i << " (faces)";
      EXPECT_EQ(reused.face, expected_faces) << "case " << i;
      std::size_t seen = 0;
      for (int y = 0; y < c.camera.height; ++y)
        for (int x = 0; x < c.camera.width; ++x) {
          const Vec2 centre(x + 0.5, y + 0.5);
          const std::int32_t f = reused.face_at(centre);
          EXPECT_EQ(f >= 0, std::isfinite(reused.depth_at(centre)));
          seen += f >= 0;
        }
      EXPECT_EQ(seen, finite_pixels(expected)) << "case " << i;
      EXPECT_EQ(reused.face_at(Vec2(-0.5, 1.0)), -1);
      EXPECT_EQ(reused.depth_at(Vec2(c.camera.width + 1.0, 1.0)),
                std::numeric_limits<float>::infinity());
      {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        const DepthBuffer serial = render_depth(*c.mesh, c.camera);
        EXPECT_EQ(count_differences(serial.depth, expected), 0u) << "case " << i << " (1 thread)";
        const DepthBuffer serial_faces = render_depth(*c.mesh, c.camera, /*faces=*/true);
        EXPECT_EQ(serial_faces.face, expected_faces) << "case " << i << " (1 thread, faces)";
      }
    }
  }
}

// The AVX2 row kernel (four pixels per step, masked loads and stores at the
// right edge of the image) against the portable one, bit for bit, depth and
// faces: real meshes at odd image sizes (one pixel, one row, one column,
// widths that are not a multiple of four, a band boundary), perspective and
// orthographic, the eye inside the mesh (skipped triangles), and triangles
// far larger than the image.
TEST(DepthRaster, Avx2AndPortableKernelsGiveTheSameBits) {
  if (!detail::depth_raster_avx2_enabled()) GTEST_SKIP() << "no AVX2 raster kernel here";
  struct Scene {
    std::string name;
    TriangleMesh mesh;
  };
  std::vector<Scene> scenes;
  for (const char* rel : {"meshes/classic/c3d_cow.obj", "meshes/classic/libigl_camelhead.off"})
    scenes.push_back({rel, io::read_mesh(test::bundled_data() / rel).mesh});
  // Two large triangles (a square of side 4 at z = 0) and a few slivers.
  TriangleMesh quad;
  quad.positions = {Vec3(-2, -2, 0), Vec3(2, -2, 0),       Vec3(2, 2, 0),         Vec3(-2, 2, 0),
                    Vec3(0, 0, 0.5), Vec3(1e-3, 1.5, 0.5), Vec3(-1e-3, -1.5, 0.5)};
  quad.faces = {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {6, 5, 4}};
  scenes.push_back({"quad", quad});
  const std::pair<int, int> sizes[] = {{1024, 1024}, {333, 257}, {1, 1}, {2, 3},    {5, 7},
                                       {37, 1},      {1, 41},    {6, 6}, {1021, 33}};
  std::size_t compared = 0, covered = 0;
  for (const Scene& scene : scenes) {
    SCOPED_TRACE(scene.name);
    const BoundingBox box = bounding_box(scene.mesh.positions);
    const Vec3 centre = box.center();
    const double r = box.diagonal();
    for (const auto& [w, h] : sizes)
      for (int view = 0; view < 4; ++view) {
        SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h) + " view " + std::to_string(view));
        Camera c;
        if (view == 0) {
          c = look_at(centre + Vec3(0.3, 0.4, 1.0).normalized() * 1.5 * r, centre, w, h);
        } else if (view == 1) {
          c = look_at(centre + Vec3(-1.0, 0.2, 0.3) * r, centre, w, h, Projection::orthographic,
                      40.0);
        } else if (view == 2) {  // the eye at the centre: many triangles skipped
          c = look_at(centre, centre + Vec3(0.0, 0.0, 1.0), w, h, Projection::perspective, 100.0);
        } else {  // so near that the triangles are much larger than the image
          c = look_at(centre + Vec3(0.1, 0.2, 1.0).normalized() * 0.02 * r, centre, w, h,
                      Projection::perspective, 20.0);
        }
        for (const bool faces : {false, true}) {
          const DepthBuffer wide = render_depth(scene.mesh, c, faces);
          DepthBuffer portable;
          {
            PortableRaster forced;
            render_depth(scene.mesh, c, portable, faces);
          }
          EXPECT_EQ(count_differences(wide.depth, portable.depth), 0u) << "faces " << faces;
          EXPECT_EQ(wide.face, portable.face);
          ++compared;
          covered += finite_pixels(portable.depth);
        }
      }
  }
  EXPECT_EQ(compared, scenes.size() * std::size(sizes) * 4 * 2);
  EXPECT_GT(covered, 1000000u) << "the scenes cover too little to compare";
}

// The AVX2 projection of the corners against the portable one, bit for bit
// (pixel position, depth, validity and, where valid, the pixel centres
// around the corner): points spread around the view, behind and at the eye,
// at the near limit, far outside the image, infinite and NaN; perspective
// and orthographic, square and not.
TEST(DepthRaster, Avx2AndPortableProjectionGiveTheSameBits) {
  if (!detail::depth_raster_avx2_enabled()) GTEST_SKIP() << "no AVX2 raster kernel here";
  std::vector<Vec3> points;
  std::uint64_t state = 12345;
  auto uniform = [&] {  // in [-1, 1)
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 4503599627370496.0 - 1.0;
  };
  for (int i = 0; i < 4000; ++i) {
    const double s = i % 3 == 0 ? 1.0 : i % 3 == 1 ? 10.0 : 1e6;
    points.emplace_back(s * uniform(), s * uniform(), s * uniform());
  }
  const double inf = std::numeric_limits<double>::infinity(), nan = std::nan("");
  const Vec3 eye(0.5, 1.0, 6.0);
  for (const Vec3& p : {eye, Vec3(eye + Vec3(0.0, 0.0, -1e-9)), Vec3(eye + Vec3(1e-3, 0.0, -2e-9)),
                        Vec3(inf, 0.0, 0.0), Vec3(0.0, -inf, 1.0), Vec3(nan, 0.0, 0.0),
                        Vec3(0.0, 0.0, nan), Vec3(0.0, 0.0, 0.0), Vec3(1e300, 1e300, -1e300)})
    points.push_back(p);
  points.resize(points.size() + 3, Vec3(0.1, 0.2, 0.3));  // not a multiple of four
  std::size_t valid = 0;
  for (int view = 0; view < 4; ++view) {
    SCOPED_TRACE("view " + std::to_string(view));
    const Camera c = look_at(eye, Vec3(0.0, 0.0, 0.0), view % 2 ? 333 : 1024, view % 2 ? 257 : 1024,
                             view < 2 ? Projection::perspective : Projection::orthographic, 40.0);
    const Projector project(c);
    std::vector<detail::RasterCorner> wide(points.size()), portable(points.size());
    const std::size_t done =
        detail::project_corners_avx2(project, points.data(), wide.data(), 0, points.size());
    EXPECT_EQ(done, points.size() / 4 * 4);
    for (std::size_t i = 0; i < points.size(); ++i) {
      detail::project_corner(project, points[i], portable[i]);
      if (i >= done) continue;
      const detail::RasterCorner &a = wide[i], &b = portable[i];
      ASSERT_EQ(a.valid, b.valid) << "point " << i;
      EXPECT_EQ(std::memcmp(&a.z, &b.z, sizeof a.z), 0) << "point " << i;
      if (!b.valid) continue;
      ++valid;
      EXPECT_EQ(std::memcmp(&a.x, &b.x, sizeof a.x), 0) << "point " << i;
      EXPECT_EQ(std::memcmp(&a.y, &b.y, sizeof a.y), 0) << "point " << i;
      EXPECT_EQ(a.x_lo, b.x_lo) << "point " << i;
      EXPECT_EQ(a.x_hi, b.x_hi) << "point " << i;
      EXPECT_EQ(a.y_lo, b.y_lo) << "point " << i;
      EXPECT_EQ(a.y_hi, b.y_hi) << "point " << i;
    }
  }
  EXPECT_GT(valid, 8000u);
}

TEST(DepthRaster, RejectsImagesTooLargeToIndex) {
  const TriangleMesh m = test::make_icosphere(1.0, 1);
  Camera c = look_at(Vec3(0, 0, 5), Vec3(0, 0, 0), 40000, 10);
  EXPECT_THROW(render_depth(m, c), InputError);
}

namespace {

// A segment between vertices a and b (vertex ends), in face min(a, b) (of
// parabola_strip: it holds both when they are consecutive).
LineSegment seg(std::int32_t a, std::int32_t b) {
  LineSegment s;
  s.face = std::min(a, b);
  s.kind[0] = s.kind[1] = EndKind::vertex;
  s.end[0].element = a;
  s.end[1].element = b;
  return s;
}

// Vertex i at (i, 0.1 i^2, 0), faces (i, i+1, i+2): the ends' positions
// encode their ids.
TriangleMesh parabola_strip(int n) {
  TriangleMesh m;
  for (int i = 0; i < n; ++i) m.positions.emplace_back(i, 0.1 * i * i, 0.0);
  for (int i = 0; i + 2 < n; ++i) m.faces.push_back({i, i + 1, i + 2});
  return m;
}

void expect_same_lines(const std::vector<Polyline>& a, const std::vector<Polyline>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].closed, b[i].closed);
    ASSERT_EQ(a[i].vertices.size(), b[i].vertices.size());
    for (std::size_t k = 0; k < a[i].vertices.size(); ++k)
      EXPECT_EQ(a[i].vertices[k].position, b[i].vertices[k].position);
    EXPECT_EQ(a[i].edge_faces, b[i].edge_faces);
  }
}

}  // namespace

TEST(Chaining, FlatTableAndSortedPairingAgree) {
  // A shuffled open chain of 6 segments, a loop of 4, and a branch point
  // where three segments meet (nothing joins there); ids 0..99 use the flat
  // table, the same ids times 2^24 force the sort-based pairing.
  const Surface strip(parabola_strip(40));
  auto soup_with_scale = [&](std::int32_t scale) {
    SegmentSoup s;
    s.family = LineFamily::ridge;
    s.surface = &strip;
    auto id = [&](std::int32_t i) { return i * scale; };
    // open chain 1-2-3-4-5-6-7, segments out of order and flipped
    s.segments.push_back(seg(id(4), id(3)));
    s.segments.push_back(seg(id(1), id(2)));
    s.segments.push_back(seg(id(6), id(7)));
    s.segments.push_back(seg(id(3), id(2)));
    s.segments.push_back(seg(id(5), id(6)));
    s.segments.push_back(seg(id(4), id(5)));
    // loop 20-21-22-23-20
    s.segments.push_back(seg(id(21), id(22)));
    s.segments.push_back(seg(id(20), id(21)));
    s.segments.push_back(seg(id(23), id(20)));
    s.segments.push_back(seg(id(22), id(23)));
    // branch at 30: three segments end there
    s.segments.push_back(seg(id(30), id(31)));
    s.segments.push_back(seg(id(32), id(30)));
    s.segments.push_back(seg(id(30), id(33)));
    return s;
  };
  const SegmentSoup small = soup_with_scale(1);
  const auto flat = chain_segments(small);
  // The same pairs from the table, from the sort, and from the sort of
  // ids too large for a table (the same ids times 2^24).
  const auto pairs = detail::pair_ends(small.segments);
  EXPECT_EQ(pairs, detail::pair_ends(small.segments, true));
  EXPECT_EQ(pairs, detail::pair_ends(soup_with_scale(1 << 24).segments));
  // 1 open chain of 6 segments, 3 single segments at the branch, 1 loop.
  ASSERT_EQ(flat.size(), 5u);
  EXPECT_FALSE(flat[0].closed);
  EXPECT_EQ(flat[0].vertices.size(), 7u);
  for (int i = 1; i <= 3; ++i) EXPECT_EQ(flat[static_cast<std::size_t>(i)].vertices.size(), 2u);
  EXPECT_TRUE(flat[4].closed);
  EXPECT_EQ(flat[4].vertices.size(), 4u);
  EXPECT_EQ(flat[4].edge_faces.size(), 4u);
  // The chain runs through consecutive x (positions encode the ids), and
  // each vertex is anchored at its vertex of the segment's face.
  EXPECT_EQ(flat[0].edge_faces, (std::vector<std::int32_t>{1, 2, 3, 4, 5, 6}));
  for (std::size_t k = 1; k < flat[0].vertices.size(); ++k)
    EXPECT_DOUBLE_EQ(
        std::abs(flat[0].vertices[k].position.x() - flat[0].vertices[k - 1].position.x()), 1.0);
  for (const auto& v : flat[0].vertices)
    EXPECT_EQ((v.anchor.position(strip.mesh()) - v.position).norm(), 0.0);
}

TEST(Chaining, SameAtOneAndTwoThreadsOnATorus) {
  const Surface s(test::make_torus(2.0, 0.7, 96, 48, 0.02));
  const Camera cam = look_at(Vec3(0.5, 5.0, 6.0), Vec3(0, 0, 0), 600, 400);
  LineOptions o;
  o.families = {LineFamily::contour, LineFamily::suggestive, LineFamily::ridge, LineFamily::valley,
                LineFamily::apparent};
  LineExtractor ex(s, o);
  const auto soups = ex.extract(cam);
  ChainOptions co;
  co.camera = cam;
  co.min_length_px = 3.0;
  LineSet one, two;
  {
    tbb::global_control g(tbb::global_control::max_allowed_parallelism, 1);
    one = chain_segments(soups, co);
  }
  {
    tbb::global_control g(tbb::global_control::max_allowed_parallelism, 2);
    two = chain_segments(soups, co);
  }
  ASSERT_GT(one.polylines.size(), 4u);
  expect_same_lines(one.polylines, two.polylines);
  // Every kept chain is at least 3 px long on screen.
  for (const auto& p : one.polylines) EXPECT_GE(projected_length(p, cam), 3.0);
}

TEST(LinesVisibility, GivenAndOwnDepthBufferAgree) {
  const Surface s(merged(translated(test::make_icosphere(1.0, 4), Vec3(0.3, 0, 1.5)),
                         test::make_torus(2.0, 0.6, 64, 32)));
  const Camera cam = look_at(Vec3(0.5, 3.0, 7.0), Vec3(0, 0, 0), 500, 400);
  LineOptions o;
  o.families = {LineFamily::contour, LineFamily::suggestive};
  LineExtractor ex(s, o);
  const LineSet chained = chain_segments(ex.extract(cam));
  LineSet a = chained, b = chained;
  compute_visibility(a, s, cam);
  DepthBuffer depth;
  render_depth(s.mesh(), cam, depth);
  compute_visibility(b, s, cam, {}, &depth);
  ASSERT_EQ(a.polylines.size(), b.polylines.size());
  std::size_t hidden = 0, visible = 0;
  for (std::size_t i = 0; i < a.polylines.size(); ++i) {
    ASSERT_EQ(a.polylines[i].vertices.size(), b.polylines[i].vertices.size());
    EXPECT_EQ(a.polylines[i].edge_faces.size(), b.polylines[i].edge_faces.size());
    for (std::size_t k = 0; k < a.polylines[i].vertices.size(); ++k) {
      EXPECT_EQ(a.polylines[i].vertices[k].visible, b.polylines[i].vertices[k].visible);
      EXPECT_EQ(a.polylines[i].vertices[k].position, b.polylines[i].vertices[k].position);
      (a.polylines[i].vertices[k].visible ? visible : hidden)++;
    }
  }
  // The sphere hides part of the torus' lines: both states occur.
  EXPECT_GT(hidden, 10u);
  EXPECT_GT(visible, 100u);
}

namespace {

// The lean record's formulas written out plainly (docs/algorithms.md §11):
// what SegmentGeometry::locate (chaining's inline resolve) must give, bit
// for bit, for every kind of end.
SurfacePoint reference_anchor(const Surface& surface, const LineSegment& s, int i) {
  const SegmentEnd& e = s.end[i];
  const Face& f = surface.mesh().faces[static_cast<std::size_t>(s.face)];
  SurfacePoint p{s.face, Vec3::Zero()};
  if (s.kind[i] == EndKind::edge) {
    const auto& ev = surface.topology().edge(static_cast<std::size_t>(e.element));
    for (int k = 0; k < 3; ++k) {
      if (f[k] == ev[0]) p.bary[k] = 1.0 - e.t;
      if (f[k] == ev[1]) p.bary[k] = e.t;
    }
  } else if (s.kind[i] == EndKind::vertex) {
    for (int k = 0; k < 3; ++k)
      if (f[k] == e.element) p.bary[k] = 1.0;
  } else if (s.kind[i] == EndKind::centroid) {
    p.bary = Vec3::Constant(1.0 / 3.0);
  } else {
    const double b0 = e.bary[0], b1 = e.bary[1];
    p.bary = Vec3(b0, b1, 1.0 - b0 - b1);
  }
  return p;
}

Vec3 reference_position(const Surface& surface, const LineSegment& s, int i) {
  const SegmentEnd& e = s.end[i];
  const auto& pos = surface.mesh().positions;
  const Face& f = surface.mesh().faces[static_cast<std::size_t>(s.face)];
  if (s.kind[i] == EndKind::edge) {
    const auto& ev = surface.topology().edge(static_cast<std::size_t>(e.element));
    const Vec3 &a = pos[ev[0]], &b = pos[ev[1]];
    Vec3 p;
    for (int c = 0; c < 3; ++c) p[c] = (1.0 - e.t) * a[c] + e.t * b[c];
    return p;
  }
  if (s.kind[i] == EndKind::vertex) return pos[static_cast<std::size_t>(e.element)];
  const Vec3 &a = pos[f[0]], &b = pos[f[1]], &c = pos[f[2]];
  if (s.kind[i] == EndKind::centroid) {
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = (a[k] + b[k] + c[k]) / 3.0;
    return p;
  }
  const Vec3 w = reference_anchor(surface, s, i).bary;
  Vec3 p;
  for (int k = 0; k < 3; ++k) p[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
  return p;
}

bool same_bits(const Vec3& a, const Vec3& b) {
  return std::memcmp(a.data(), b.data(), 24) == 0;
}

// The torus' soups of a view: edge, centroid and interior ends.
std::vector<SegmentSoup> torus_soups(const Surface& s, const Camera& cam) {
  LineOptions o;
  o.families = {LineFamily::contour, LineFamily::suggestive, LineFamily::ridge, LineFamily::valley,
                LineFamily::apparent};
  LineExtractor ex(s, o);
  return ex.extract(cam);
}

}  // namespace

TEST(Chaining, InlineResolveGivesTheRecordsFormulasBitForBit) {
  const Surface s(test::make_torus(2.0, 0.7, 96, 48, 0.02));
  const Camera cam = look_at(Vec3(0.5, 5.0, 6.0), Vec3(0, 0, 0), 600, 400);
  std::vector<SegmentSoup> soups = torus_soups(s, cam);
  // Hand-made ends of every kind in the first faces: vertex ends at each
  // corner, a centroid, an interior point, and edge ends along each side
  // (both orders of the edge's vertices among the corners).
  SegmentSoup made;
  made.surface = &s;
  for (std::int32_t face = 0; face < 8; ++face) {
    const Face& f = s.mesh().faces[static_cast<std::size_t>(face)];
    for (int k = 0; k < 3; ++k) {
      LineSegment g;
      g.face = face;
      g.kind[0] = EndKind::vertex;
      g.end[0].element = f[k];
      g.kind[1] = EndKind::edge;
      g.end[1].element = s.topology().face_edge(static_cast<std::size_t>(face), k);
      g.end[1].t = 0.1 + 0.25 * k + 0.01 * face;
      made.segments.push_back(g);
    }
    LineSegment g;
    g.face = face;
    g.kind[0] = EndKind::centroid;
    g.end[0].element = face;
    const double bary[3] = {0.2 + 0.01 * face, 0.3, 0.5 - 0.01 * face};
    SegmentGeometry::set_interior(g, 1, bary);
    made.segments.push_back(g);
  }
  soups.push_back(made);
  std::size_t kinds[4] = {0, 0, 0, 0};
  for (const SegmentSoup& soup : soups) {
    const SegmentGeometry geo = soup.geometry();
    for (const LineSegment& seg : soup.segments)
      for (int i = 0; i < 2; ++i) {
        ++kinds[static_cast<int>(seg.kind[i])];
        SurfacePoint a;
        Vec3 p;
        geo.locate(seg, i, a, p);
        const SurfacePoint ra = reference_anchor(s, seg, i);
        const Vec3 rp = reference_position(s, seg, i);
        ASSERT_EQ(a.face, ra.face);
        ASSERT_TRUE(same_bits(a.bary, ra.bary)) << "kind " << int(seg.kind[i]);
        ASSERT_TRUE(same_bits(p, rp)) << "kind " << int(seg.kind[i]);
        ASSERT_TRUE(same_bits(geo.anchor(seg, i).bary, ra.bary));
        ASSERT_TRUE(same_bits(geo.position(seg, i), rp));
        const ResolvedEnd r = geo.resolve(seg, i);
        ASSERT_TRUE(same_bits(r.position, rp));
        ASSERT_EQ(r.element, seg.end[i].element);
        ASSERT_EQ(r.strength, seg.end[i].strength);
      }
  }
  for (int k = 0; k < 4; ++k) EXPECT_GT(kinds[k], 0u) << "no end of kind " << k;
  EXPECT_GT(kinds[static_cast<int>(EndKind::edge)], 1000u);
}

TEST(Chaining, LengthFiltersKeepExactlyTheChainsReachingTheirBound) {
  // The filters stop summing once the bound is reached: they must keep the
  // chains whose whole length (projected_length, Polyline::length) is at
  // least the bound, also for bounds equal to a chain's length and the
  // next double above it.
  const Surface s(test::make_torus(2.0, 0.7, 96, 48, 0.02));
  const Camera cam = look_at(Vec3(0.5, 5.0, 6.0), Vec3(0, 0, 0), 600, 400);
  const std::vector<SegmentSoup> soups = torus_soups(s, cam);
  const LineSet all = chain_segments(soups);
  ASSERT_GT(all.polylines.size(), 20u);
  std::vector<double> px, mm;
  for (const Polyline& pl : all.polylines) {
    px.push_back(projected_length(pl, cam));
    mm.push_back(pl.length());
  }
  auto bounds_of = [](std::vector<double> lengths) {
    std::sort(lengths.begin(), lengths.end());
    std::vector<double> b;
    for (double q : {0.1, 0.3, 0.5, 0.7, 0.9}) {
      const double l = lengths[static_cast<std::size_t>(q * double(lengths.size() - 1))];
      b.push_back(l);
      b.push_back(std::nextafter(l, std::numeric_limits<double>::infinity()));
    }
    return b;
  };
  bool any_closed = false;
  for (const Polyline& pl : all.polylines) any_closed |= pl.closed;
  EXPECT_TRUE(any_closed);
  for (int in_pixels = 0; in_pixels < 2; ++in_pixels)
    for (double bound : bounds_of(in_pixels ? px : mm)) {
      ChainOptions co;
      if (in_pixels) {
        co.camera = cam;
        co.min_length_px = bound;
      } else {
        co.min_length = bound;
      }
      std::vector<Polyline> expected;
      for (std::size_t i = 0; i < all.polylines.size(); ++i)
        if ((in_pixels ? px[i] : mm[i]) >= bound) expected.push_back(all.polylines[i]);
      const LineSet kept = chain_segments(soups, co);
      ASSERT_GT(expected.size(), 0u);
      ASSERT_LT(expected.size(), all.polylines.size());
      expect_same_lines(kept.polylines, expected);
    }
}

TEST(Chaining, PairingTableSizedByTheMeshAgrees) {
  const Surface s(test::make_torus(2.0, 0.7, 96, 48, 0.02));
  const Camera cam = look_at(Vec3(0.5, 5.0, 6.0), Vec3(0, 0, 0), 600, 400);
  std::vector<SegmentSoup> soups = torus_soups(s, cam);
  const std::int64_t bound[3] = {static_cast<std::int64_t>(s.topology().edge_count()),
                                 static_cast<std::int64_t>(s.vertex_count()),
                                 static_cast<std::int64_t>(s.face_count())};
  std::size_t joined = 0;
  for (const SegmentSoup& soup : soups) {
    const auto pairs = detail::pair_ends(soup.segments, bound);
    EXPECT_EQ(pairs, detail::pair_ends(soup.segments));
    EXPECT_EQ(pairs, detail::pair_ends(soup.segments, true));
    for (std::int32_t p : pairs) joined += p >= 0;
  }
  EXPECT_GT(joined, 1000u);
  // An element past its bound (a soup not of this mesh): the same pairs
  // as without bounds, from the sort or a table of its own ids.
  SegmentSoup& soup = soups.front();
  ASSERT_GT(soup.segments.size(), 10u);
  const std::int64_t small[3] = {bound[0] / 2, bound[1], bound[2]};
  EXPECT_EQ(detail::pair_ends(soup.segments, small), detail::pair_ends(soup.segments, true));
  // And the table is left empty: the next call pairs as before.
  EXPECT_EQ(detail::pair_ends(soup.segments, bound), detail::pair_ends(soup.segments, true));
}
