// Helpers for the render tests: analytic meshes as RenderMesh with exact
// normals and curvature, cameras, pixel measurements.
#pragma once

#include <cmath>
#include <memory>

#include "fabrica/core/camera.hpp"
#include "fabrica/render/image.hpp"
#include "fabrica/render/render_mesh.hpp"
#include "fabrica/render/renderer.hpp"
#include "test_support.hpp"

namespace fabrica::test {

/// One headless renderer for the whole test program (a GL context and its
/// programs are costly; the tests draw one after another).
inline render::Renderer& renderer() {
  static render::Renderer r(render::create_headless_context());
  return r;
}

/// Icosphere of radius r at the origin with exact normals and curvature
/// k1 = k2 = 1/r (e1, e2 any orthonormal tangent pair).
inline std::shared_ptr<render::RenderMesh> sphere_render_mesh(double r, int subdivisions) {
  TriangleMesh mesh = make_icosphere(r, subdivisions);
  std::vector<Vec3> normals, e1, e2;
  std::vector<double> k1, k2;
  for (const Vec3& p : mesh.positions) {
    const Vec3 n = p.normalized();
    normals.push_back(n);
    const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 t = n.cross(a).normalized();
    e1.push_back(t);
    e2.push_back(n.cross(t));
    k1.push_back(1.0 / r);
    k2.push_back(1.0 / r);
  }
  auto m = std::make_shared<render::RenderMesh>(render::make_render_mesh(mesh, normals));
  render::set_curvature(*m, k1, k2, e1, e2);
  m->feature_size = r / 10.0;
  return m;
}

/// Torus (major R around z, minor r) with exact normals and principal
/// curvatures: k = 1/r along the tube's circle, cos(v)/(R + r cos v) along
/// the big circle (convex positive), |k1| >= |k2|.
inline std::shared_ptr<render::RenderMesh> torus_render_mesh(double R, double r, int nu, int nv) {
  TriangleMesh mesh;
  std::vector<Vec3> normals, e1, e2;
  std::vector<double> k1, k2;
  for (int i = 0; i < nu; ++i) {
    const double u = 2.0 * M_PI * i / nu;
    for (int j = 0; j < nv; ++j) {
      const double v = 2.0 * M_PI * j / nv;
      const Vec3 radial(std::cos(u), std::sin(u), 0.0);
      const Vec3 n = std::cos(v) * radial + std::sin(v) * Vec3::UnitZ();
      mesh.positions.push_back(R * radial + r * n);
      normals.push_back(n);
      const Vec3 tube = -std::sin(v) * radial + std::cos(v) * Vec3::UnitZ();  // along v
      const Vec3 ring(-std::sin(u), std::cos(u), 0.0);                        // along u
      const double kt = 1.0 / r, kr = std::cos(v) / (R + r * std::cos(v));
      if (std::abs(kt) >= std::abs(kr)) {
        k1.push_back(kt), k2.push_back(kr), e1.push_back(tube), e2.push_back(n.cross(tube));
      } else {
        k1.push_back(kr), k2.push_back(kt), e1.push_back(ring), e2.push_back(n.cross(ring));
      }
    }
  }
  auto id = [&](int i, int j) { return ((i + nu) % nu) * nv + (j + nv) % nv; };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      mesh.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      mesh.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  auto m = std::make_shared<render::RenderMesh>(render::make_render_mesh(mesh, normals));
  render::set_curvature(*m, k1, k2, e1, e2);
  m->feature_size = r / 5.0;
  return m;
}

inline Camera front_camera(int width, int height, double distance, bool orthographic = false,
                           double fov = 30.0) {
  Camera c;
  c.eye = Vec3(0.0, 0.0, distance);
  c.center = Vec3::Zero();
  c.up = Vec3::UnitY();
  c.fov_deg = fov;
  c.width = width;
  c.height = height;
  c.projection = orthographic ? Projection::orthographic : Projection::perspective;
  return c;
}

/// Dark (ink) pixels: luminance below `level` with some opacity.
inline std::size_t count_dark(const render::Image& img, int level = 128) {
  std::size_t n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const auto* p = img.pixel(x, y);
      if (p[3] > 0 && (p[0] + p[1] + p[2]) / 3 < level) ++n;
    }
  return n;
}

}  // namespace fabrica::test
