// The reference view c3d_igea_v1 (tests/data: reference/rtsc/index.tsv):
// rtsc's camera and feature size, shared by the line benchmarks.
#pragma once

#include <memory>
#include <string>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"

namespace fabrica::bench {

inline Camera igea_v1_camera() {
  Camera c;
  c.eye = Vec3(0.000535484229, -0.00086883083, 0.16167897);
  c.center = Vec3(0.000535484229, -0.00086883083, 0.00324995629);
  c.up = Vec3(0, 1, 0);
  c.fov_deg = 40.7329788;
  c.width = c.height = 1024;
  return c;
}

inline constexpr double kIgeaV1FeatureSize = 0.000873700483;

/// c3d_igea.ply from the bundled data, prepared for lines.
inline std::unique_ptr<Surface> load_igea() {
  auto loaded = io::read_mesh(std::string(FABRICA_BENCH_DATA) + "/meshes/classic/c3d_igea.ply");
  TriangleMesh mesh = std::move(loaded.mesh);
  io::prepare_for_lines(mesh);
  return std::make_unique<Surface>(std::move(mesh));
}

}  // namespace fabrica::bench
