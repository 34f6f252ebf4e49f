// Test helpers shared by the lines tests that compare passes on real
// meshes: a bundled mesh prepared for lines (optionally with degenerate
// vertices first) and a camera looking at it.
#pragma once

#include <utility>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "test_support.hpp"

namespace fabrica::test {

// The bundled mesh `rel`, prepared for lines. With `degenerate`, five
// vertices at one point joined by two zero-area faces are put first, so the
// first two blocks of four mix vertices with invalid curvature and valid
// ones (and vertex 2 has two faces that are no closed fan).
inline Surface load_for_lines(const char* rel, bool degenerate) {
  auto loaded = io::read_mesh(bundled_data() / rel);
  io::prepare_for_lines(loaded.mesh);
  TriangleMesh mesh = std::move(loaded.mesh);
  if (degenerate) {
    TriangleMesh m;
    m.positions.assign(5, mesh.positions[0]);
    m.positions.insert(m.positions.end(), mesh.positions.begin(), mesh.positions.end());
    m.faces = {{0, 1, 2}, {2, 3, 4}};
    for (Face f : mesh.faces) m.faces.push_back({f[0] + 5, f[1] + 5, f[2] + 5});
    mesh = std::move(m);
  }
  return Surface(std::move(mesh));
}

// A 30° perspective camera looking at the mesh from `direction`, 2.5
// bounding-box diagonals away, 512² pixels.
inline Camera camera_towards(const Surface& surface, const Vec3& direction) {
  const BoundingBox box = bounding_box(surface.positions());
  Camera c;
  c.center = box.center();
  c.eye = c.center + direction.normalized() * 2.5 * box.diagonal();
  c.up = Vec3::UnitY();
  c.fov_deg = 30.0;
  c.width = c.height = 512;
  return c;
}

}  // namespace fabrica::test
