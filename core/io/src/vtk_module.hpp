// The VTK-backed readers and filters live in a separate shared module,
// libfabrica_io_vtk.so, that fabrica_io loads with dlopen the first time a
// VTK facility is used (.vtp reading, label-volume extraction, windowed-sinc
// smoothing): a program that reads PLY or OBJ never maps VTK's libraries.
// The module exports one C function returning a table of the entry points
// below; the host checks that the table was built from the same headers.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"

namespace fabrica::io::detail {

/// Bumped when the table changes.
inline constexpr int kVtkModuleAbi = 1;
/// The sizes of the types passed across: a module from another build of the
/// headers is refused rather than called.
inline constexpr std::array<std::size_t, 6> kVtkModuleLayout{
    sizeof(ReadOptions),    sizeof(LoadedMesh),       sizeof(LabelVolume),
    sizeof(ExtractOptions), sizeof(ExtractedSurface), sizeof(TriangleMesh)};

struct VtkModule {
  int abi = kVtkModuleAbi;
  std::array<std::size_t, 6> layout = kVtkModuleLayout;
  void (*read_vtp)(const std::filesystem::path& path, const std::string& name,
                   const ReadOptions& options, LoadedMesh& out) = nullptr;
  std::vector<ExtractedSurface> (*extract_surfaces)(const LabelVolume& volume,
                                                    const ExtractOptions& options) = nullptr;
  void (*smooth_surface)(TriangleMesh& mesh, int iterations, double passband) = nullptr;
};

/// Throws InputError for out-of-range extraction or smoothing options: checked
/// by the host before the module is loaded (bad options are exit code 2 with
/// or without the module) and again by the module.
void check_extract_options(const ExtractOptions& options);

/// The module's implementations (src/mesh_io_vtk.cpp, src/label_volume_extract.cpp).
void read_vtp_with_vtk(const std::filesystem::path& path, const std::string& name,
                       const ReadOptions& options, LoadedMesh& out);
std::vector<ExtractedSurface> extract_surfaces_with_vtk(const LabelVolume& volume,
                                                        const ExtractOptions& options);
void smooth_surface_with_vtk(TriangleMesh& mesh, int iterations, double passband);

/// The loaded module's table; throws Error(ErrorKind::unavailable) (exit
/// code 4) with one line naming `what` and where the module was looked for
/// when it cannot be loaded.
const VtkModule& vtk_module(const std::string& what);

}  // namespace fabrica::io::detail

/// The module's one exported symbol.
#define FABRICA_IO_VTK_ENTRY fabrica_io_vtk_module
#define FABRICA_IO_VTK_ENTRY_NAME "fabrica_io_vtk_module"
