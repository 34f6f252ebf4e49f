// Reference views of the bundled rtsc reference lines (tests/data:
// reference/rtsc/index.tsv): rtsc's camera and feature size, shared by the
// line benchmarks. c3d_igea_v1 is the default view of the line benchmarks;
// c3d_stanford-bunny_v1 is the bunny's (bench/rtsc_side_by_side.sh).
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"

namespace fabrica::bench {

/// One row of reference/rtsc/index.tsv: the mesh (relative to the bundled
/// meshes folder), rtsc's camera (eye looking at the bounding-sphere centre,
/// 40.73° field of view, 1024²) and the feature size rtsc used.
struct ReferenceView {
  const char* name;
  const char* mesh;
  Vec3 eye, center, up;
  double feature_size;
};

inline constexpr double kReferenceFovDeg = 40.7329788;

inline const ReferenceView* find_reference_view(std::string_view name) {
  static const ReferenceView views[] = {
      {"igea_v1", "classic/c3d_igea.ply", Vec3(0.000535484229, -0.00086883083, 0.16167897),
       Vec3(0.000535484229, -0.00086883083, 0.00324995629), Vec3(0, 1, 0), 0.000873700483},
      {"bunny_v1", "classic/c3d_stanford-bunny.obj", Vec3(-0.0197627805, 0.10807047, 0.289503247),
       Vec3(-0.0197627805, 0.10807047, -0.0109680882), Vec3(0, 1, 0), 0.0021362158},
  };
  for (const auto& v : views)
    if (name == v.name) return &v;
  return nullptr;
}

inline Camera reference_camera(const ReferenceView& v) {
  Camera c;
  c.eye = v.eye;
  c.center = v.center;
  c.up = v.up;
  c.fov_deg = kReferenceFovDeg;
  c.width = c.height = 1024;
  return c;
}

inline Camera igea_v1_camera() {
  return reference_camera(*find_reference_view("igea_v1"));
}

inline constexpr double kIgeaV1FeatureSize = 0.000873700483;

/// A bundled mesh (path relative to the meshes folder), prepared for lines.
inline TriangleMesh load_prepared_mesh(const std::string& relative) {
  auto loaded = io::read_mesh(std::string(FABRICA_BENCH_DATA) + "/meshes/" + relative);
  TriangleMesh mesh = std::move(loaded.mesh);
  io::prepare_for_lines(mesh);
  return mesh;
}

/// c3d_igea.ply from the bundled data, prepared for lines.
inline std::unique_ptr<Surface> load_igea() {
  return std::make_unique<Surface>(load_prepared_mesh("classic/c3d_igea.ply"));
}

}  // namespace fabrica::bench
