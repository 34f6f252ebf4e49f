// Hidden-line removal's depth buffer from GL (render/gl_depth.hpp) against
// the CPU rasteriser (core/depth_raster.hpp): the same pixels covered but
// for single pixels along outlines (GL's edge rule), the same linear eye
// depth to float precision where both cover, rows in the same (y-down)
// order, perspective and orthographic, a non-square image; and the same
// visible / hidden marks on the lines of a real mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/render/context.hpp"
#include "fabrica/render/gl_depth.hpp"
#include "test_support.hpp"

namespace fr = fabrica::render;
using namespace fabrica;

namespace {

fr::GlContext& context() {
  static std::unique_ptr<fr::GlContext> c = fr::create_headless_context();
  c->make_current();
  return *c;
}

Camera camera_towards(const TriangleMesh& mesh, const Vec3& direction, int w, int h) {
  const BoundingBox box = bounding_box(mesh.positions);
  Camera c;
  c.center = box.center();
  c.eye = c.center + direction.normalized() * 2.0 * box.diagonal();
  c.up = Vec3::UnitY();
  c.fov_deg = 30.0;
  c.width = w;
  c.height = h;
  return c;
}

struct Agreement {
  std::size_t covered = 0, one_side = 0, both = 0, close = 0;
};

Agreement compare(const DepthBuffer& cpu, const DepthBuffer& gl) {
  Agreement a;
  EXPECT_EQ(cpu.width, gl.width);
  EXPECT_EQ(cpu.height, gl.height);
  EXPECT_TRUE(gl.face.empty());
  for (std::size_t i = 0; i < cpu.depth.size(); ++i) {
    const bool c = std::isfinite(cpu.depth[i]), g = std::isfinite(gl.depth[i]);
    a.covered += c || g;
    a.one_side += c != g;
    if (!(c && g)) continue;
    ++a.both;
    a.close += std::abs(cpu.depth[i] - gl.depth[i]) <= 1e-4f * cpu.depth[i];
  }
  return a;
}

}  // namespace

TEST(GlDepth, MatchesTheCpuRaster) {
  const TriangleMesh torus = test::make_torus(30.0, 10.0, 96, 48, 0.2);
  const TriangleMesh ellipsoid = test::make_ellipsoid(40.0, 25.0, 15.0, 48, 96);
  for (const TriangleMesh* mesh : {&torus, &ellipsoid}) {
    fr::GlDepthRenderer gl(context(), *mesh);
    DepthBuffer from_gl;
    for (Projection projection : {Projection::perspective, Projection::orthographic}) {
      // Tilted, so the torus hides part of itself.
      Camera c = camera_towards(*mesh, Vec3(0.3, 0.8, 0.5), 320, 200);
      c.projection = projection;
      const DepthBuffer cpu = render_depth(*mesh, c);
      gl.render(c, from_gl);
      const Agreement a = compare(cpu, from_gl);
      std::printf("covered %zu, one side only %zu, both %zu, within 1e-4: %zu\n", a.covered,
                  a.one_side, a.both, a.close);
      EXPECT_GT(a.covered, 5000u);
      // At most single outline pixels (none seen on llvmpipe).
      EXPECT_LE(a.one_side, a.covered / 200);
      // Depth to float precision but at the pixels where a fold's two
      // layers meet.
      EXPECT_GE(static_cast<double>(a.close), 0.995 * static_cast<double>(a.both));
    }
  }
}

TEST(GlDepth, HiddenLinesAgreeWithTheCpuRaster) {
  auto file = io::read_mesh(test::bundled_data() / "meshes/classic/c3d_cow.obj");
  io::prepare_for_lines(file.mesh);
  const Surface surface(TriangleMesh(file.mesh));
  const Camera c = camera_towards(surface.mesh(), Vec3(-0.4, 0.3, 1.0), 640, 480);
  DrawLinesOptions o;
  o.visibility = false;
  const LineDrawing drawing = draw_lines(surface, c, o);
  fr::GlDepthRenderer gl(context(), surface.mesh());
  DepthBuffer from_gl;
  gl.render(c, from_gl);
  const DepthBuffer cpu = render_depth(surface.mesh(), c);
  LineSet with_cpu = drawing.lines, with_gl = drawing.lines;
  compute_visibility(with_cpu, surface, c, {}, &cpu);
  compute_visibility(with_gl, surface, c, {}, &from_gl);
  std::size_t vertices = 0, hidden = 0, differ = 0;
  for (std::size_t p = 0; p < with_cpu.polylines.size(); ++p) {
    const auto& a = with_cpu.polylines[p].vertices;
    const auto& b = with_gl.polylines[p].vertices;
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      ++vertices;
      hidden += !a[i].visible;
      differ += a[i].visible != b[i].visible;
    }
  }
  std::printf("%zu line vertices, %zu hidden (CPU), %zu marked differently\n", vertices, hidden,
              differ);
  EXPECT_GT(hidden, vertices / 10);  // the view hides a good part
  EXPECT_LE(differ, vertices / 200);
}

TEST(GlDepth, RejectsBadInput) {
  EXPECT_THROW(fr::GlDepthRenderer(context(), TriangleMesh{}), InputError);
  const TriangleMesh sphere = test::make_sphere(10.0, 8, 16);
  fr::GlDepthRenderer gl(context(), sphere);
  DepthBuffer out;
  Camera c = camera_towards(sphere, Vec3(0, 0, 1), context().max_framebuffer_size() + 1, 16);
  EXPECT_THROW(gl.render(c, out), InputError);
  c.width = 0;
  EXPECT_THROW(gl.render(c, out), InputError);
}
