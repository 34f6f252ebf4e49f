// Context meshes for the viewer's orbit benchmark (bench/viewer_orbit.sh,
// issue 18): a bundled mesh subdivided (each triangle into four at its edge
// midpoints, `levels` times) and placed around a reference mesh (centred on
// its bounding box, scaled so its largest side is `scale` times the
// reference's), written as binary PLY. The face count grows by 4^levels; the
// shape stays the same, so the ghosted context costs what a finer
// segmentation would.
//   make_context IN REFERENCE OUT.ply LEVELS SCALE
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "fabrica/core/mesh.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "mesh_refine.hpp"

int main(int argc, char** argv) {
  using namespace fabrica;
  if (argc != 6) {
    std::fprintf(stderr, "usage: make_context IN REFERENCE OUT.ply LEVELS SCALE\n");
    return 2;
  }
  const int levels = std::atoi(argv[4]);
  const double scale = std::atof(argv[5]);
  if (levels < 0 || levels > 4 || !(scale > 0.0)) {
    std::fprintf(stderr, "make_context: LEVELS must be 0..4 and SCALE positive\n");
    return 2;
  }
  try {
    TriangleMesh mesh = io::read_mesh(argv[1]).mesh;
    const TriangleMesh reference = io::read_mesh(argv[2]).mesh;
    for (int i = 0; i < levels; ++i) bench::split_midpoints(mesh);
    const BoundingBox box = bounding_box(mesh.positions), ref = bounding_box(reference.positions);
    const double factor = scale * (ref.max - ref.min).maxCoeff() / (box.max - box.min).maxCoeff();
    const Vec3 c = 0.5 * (box.min + box.max), rc = 0.5 * (ref.min + ref.max);
    for (Vec3& p : mesh.positions) p = rc + factor * (p - c);
    mesh.space = reference.space;
    io::write_mesh(mesh, argv[3]);
    std::printf("%s: %zu vertices, %zu faces\n", argv[3], mesh.vertex_count(), mesh.face_count());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_context: %s\n", e.what());
    return 2;
  }
  return 0;
}
