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
#include <map>
#include <string>
#include <utility>

#include "fabrica/core/mesh.hpp"
#include "fabrica/io/mesh_io.hpp"

namespace {

fabrica::TriangleMesh subdivide(const fabrica::TriangleMesh& in) {
  fabrica::TriangleMesh out;
  out.space = in.space;
  out.space_source = in.space_source;
  out.positions = in.positions;
  std::map<std::pair<std::int32_t, std::int32_t>, std::int32_t> midpoint;
  auto mid = [&](std::int32_t a, std::int32_t b) {
    const auto key = std::minmax(a, b);
    const auto [it, added] = midpoint.try_emplace({key.first, key.second},
                                                  static_cast<std::int32_t>(out.positions.size()));
    if (added) out.positions.push_back(0.5 * (in.positions[a] + in.positions[b]));
    return it->second;
  };
  for (const fabrica::Face& f : in.faces) {
    const std::int32_t ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
    out.faces.push_back({f[0], ab, ca});
    out.faces.push_back({ab, f[1], bc});
    out.faces.push_back({ca, bc, f[2]});
    out.faces.push_back({ab, bc, ca});
  }
  return out;
}

}  // namespace

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
    for (int i = 0; i < levels; ++i) mesh = subdivide(mesh);
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
