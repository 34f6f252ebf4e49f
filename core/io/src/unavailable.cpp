// What fabrica_io does in a build without an optional dependency
// (cmake/FabricaDependencies.cmake): the functions that need it exist and
// throw a one-line "facility unavailable" error (exit code 4) saying how to
// get them, so nothing is silently missing.
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "mesh_io_internal.hpp"
#include "validate_detail.hpp"

namespace fabrica::io {
namespace {

[[noreturn]] void unavailable(const std::string& what, const char* dependency, const char* option,
                              const char* package) {
  throw Error(ErrorKind::unavailable,
              what + " needs " + dependency +
                  ", and this fabrica was built without it (rebuild with -D" + option + "=ON and " +
                  package + " installed)");
}

}  // namespace

#ifndef FABRICA_HAVE_VTK
void detail::read_vtp(const std::filesystem::path&, const std::string& name, const ReadOptions&,
                      LoadedMesh&) {
  unavailable(name + ": reading .vtp files", "VTK", "FABRICA_WITH_VTK", "libvtk9-dev");
}

std::vector<ExtractedSurface> extract_surfaces(const LabelVolume& volume, const ExtractOptions&) {
  unavailable("volume '" + volume.path + "': extracting surfaces", "VTK", "FABRICA_WITH_VTK",
              "libvtk9-dev");
}

void smooth_surface(TriangleMesh&, int, double) {
  unavailable("windowed-sinc smoothing (--smooth)", "VTK", "FABRICA_WITH_VTK", "libvtk9-dev");
}
#endif

#ifndef FABRICA_HAVE_CGAL
std::optional<std::size_t> detail::count_self_intersecting_face_pairs(const TriangleMesh&,
                                                                      std::string&) {
  unavailable("the self-intersection check", "CGAL", "FABRICA_WITH_CGAL", "libcgal-dev");
}
#endif

}  // namespace fabrica::io
