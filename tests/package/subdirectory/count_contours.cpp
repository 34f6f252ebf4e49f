// Contours of a mesh from the front: fails unless there are some.
#include <fabrica/core/camera.hpp>
#include <fabrica/core/surface.hpp>
#include <fabrica/io/mesh_io.hpp>
#include <fabrica/lines/extract.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  fabrica::TriangleMesh mesh = fabrica::io::read_mesh(argv[1]).mesh;
  const fabrica::Camera camera = fabrica::anatomical_camera(
      fabrica::AnatomicalView::anterior, fabrica::bounding_box(mesh.positions), mesh.space);
  const fabrica::Surface surface(std::move(mesh));
  fabrica::LineOptions options;
  options.families = {fabrica::LineFamily::contour};
  const auto soups = fabrica::LineExtractor(surface, options).extract(camera);
  std::printf("%zu contour segments\n", soups.at(0).segments.size());
  return soups.at(0).segments.size() > 10 ? 0 : 1;
}
