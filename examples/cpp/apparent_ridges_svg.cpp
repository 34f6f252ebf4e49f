// Apparent ridges and contours of a mesh, seen from the front, as SVG:
//   apparent_ridges_svg MESH OUT.svg [VIEW]   (VIEW: anterior, left, superior, ...)
#include <fabrica/core/camera.hpp>
#include <fabrica/core/error.hpp>
#include <fabrica/core/surface.hpp>
#include <fabrica/io/mesh_io.hpp>
#include <fabrica/io/repair.hpp>
#include <fabrica/lines/chain.hpp>
#include <fabrica/lines/extract.hpp>
#include <fabrica/lines/visibility.hpp>
#include <fabrica/lines/writers.hpp>

#include <cstdio>

int main(int argc, char** argv) try {
  if (argc < 3) return std::fprintf(stderr, "usage: %s MESH OUT.svg [VIEW]\n", argv[0]), 2;
  fabrica::TriangleMesh mesh = fabrica::io::read_mesh(argv[1]).mesh;
  fabrica::io::prepare_for_lines(mesh);  // weld, orient faces outward
  const auto view = fabrica::parse_anatomical_view(argc > 3 ? argv[3] : "anterior");
  if (!view) return std::fprintf(stderr, "unknown view %s\n", argv[3]), 2;
  const fabrica::Camera camera = fabrica::anatomical_camera(
      *view, fabrica::bounding_box(mesh.positions), mesh.space, 800, 800);

  const fabrica::Surface surface(std::move(mesh));
  fabrica::LineOptions options;
  options.families = {fabrica::LineFamily::contour, fabrica::LineFamily::apparent};
  fabrica::LineExtractor extractor(surface, options);
  fabrica::ChainOptions chain;
  chain.camera = camera;
  fabrica::LineSet lines = fabrica::chain_segments(extractor.extract(camera), chain);
  fabrica::compute_visibility(lines, surface, camera);  // hidden parts are left out of the SVG
  fabrica::write_svg(argv[2], lines, camera);
  std::printf("%zu polylines -> %s\n", lines.polylines.size(), argv[2]);
  return 0;
} catch (const fabrica::Error& e) {  // one line naming the file; exit code by kind
  std::fprintf(stderr, "%s\n", e.what());
  return e.exit_code();
}
