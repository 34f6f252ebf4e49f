// Makes larger meshes from a small one for the scaling benchmark
// (bench/scale_lines.sh, docs/PERFORMANCE.md "Time and memory from 100k to
// 2M faces"): each step splits every triangle, keeping the surface's shape
// (new vertices lie on the old triangles):
//   4  midpoint subdivision: a vertex at each edge's midpoint (shared by the
//      edge's two faces), four triangles per triangle;
//   3  centroid split: a vertex at each triangle's centroid, three triangles.
//   scale_mesh IN OUT STEPS     e.g. scale_mesh data/aneurysm.off big.ply 3344
// OUT's format is chosen by extension (binary PLY is quickest to read). Prints
// the vertex and face counts, the bounding box's centre and half diagonal.
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>
#include <unordered_map>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "mesh_refine.hpp"

namespace {

using fabrica::Face;
using fabrica::TriangleMesh;
using fabrica::Vec3;
using fabrica::bench::split_centroids;
using fabrica::bench::split_midpoints;

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr,
                 "usage: scale_mesh IN OUT STEPS (STEPS: digits 4 = midpoint, 3 = centroid)\n");
    return 2;
  }
  const std::string steps = argv[3];
  for (const char c : steps)
    if (c != '3' && c != '4') {
      std::fprintf(stderr,
                   "scale_mesh: STEPS '%s' holds '%c'; use only 4 (midpoint) and 3 (centroid)\n",
                   argv[3], c);
      return 2;
    }
  try {
    TriangleMesh m = fabrica::io::read_mesh(argv[1]).mesh;
    for (const char c : steps) {
      if (m.faces.size() * 4 > std::size_t{1} << 30) {
        std::fprintf(stderr, "scale_mesh: STEPS '%s' would make more than 2^30 faces\n", argv[3]);
        return 2;
      }
      c == '4' ? split_midpoints(m) : split_centroids(m);
    }
    fabrica::io::write_mesh(m, argv[2]);
    // The bounding box's centre and half diagonal (for a camera looking at
    // the mesh, e.g. rtsc_bench's eye in bench/scale_lines.sh).
    Vec3 lo = m.positions[0], hi = lo;
    for (const Vec3& p : m.positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const Vec3 c = 0.5 * (lo + hi);
    std::printf("vertices %zu faces %zu centre %.9g %.9g %.9g radius %.9g\n", m.positions.size(),
                m.faces.size(), c[0], c[1], c[2], 0.5 * (hi - lo).norm());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "scale_mesh: %s\n", e.what());
    return 2;
  }
  return 0;
}
