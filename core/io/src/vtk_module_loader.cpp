// Loads libfabrica_io_vtk.so on first use (src/vtk_module.hpp) and forwards
// the VTK-backed functions of fabrica_io to it.
#include <dlfcn.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "mesh_io_internal.hpp"
#include "vtk_module.hpp"

namespace fabrica::io {
namespace {

namespace fs = std::filesystem;

// Set by core/io/CMakeLists.txt.
constexpr const char* kVtkModuleFile = FABRICA_IO_VTK_FILE;
constexpr const char* kBinToVtkModuleDir = FABRICA_IO_VTK_RELATIVE_DIR;  // bin -> lib/fabrica
constexpr const char* kInstalledVtkModuleDir = FABRICA_IO_VTK_INSTALL_DIR;
constexpr const char* kBuildVtkModuleDir = FABRICA_IO_VTK_BUILD_DIR;

// An object in this code's file, to ask the dynamic linker which file that
// is (the executable, or a shared module such as the Python extension).
const char kVtkModuleAnchor = 0;

/// Where the module may be, first found wins: $FABRICA_IO_VTK_MODULE alone
/// when set; else lib/fabrica beside the bin folder of the executable and
/// of the file holding this code, the installed lib/fabrica, the build tree.
std::vector<fs::path> vtk_module_candidates() {
  if (const char* env = std::getenv("FABRICA_IO_VTK_MODULE"); env != nullptr && *env != '\0')
    return {fs::path(env)};
  std::vector<fs::path> dirs;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path() / kBinToVtkModuleDir);
  Dl_info info{};
  if (dladdr(&kVtkModuleAnchor, &info) != 0 && info.dli_fname != nullptr &&
      *info.dli_fname != '\0') {
    const fs::path self = fs::absolute(info.dli_fname, ec).parent_path();
    if (!ec) {
      dirs.push_back(self / kBinToVtkModuleDir);
      dirs.push_back(self / "fabrica");
    }
  }
  dirs.emplace_back(kInstalledVtkModuleDir);
  dirs.emplace_back(kBuildVtkModuleDir);
  std::vector<fs::path> out;
  for (const auto& d : dirs) {
    const fs::path p = (d / kVtkModuleFile).lexically_normal();
    bool seen = false;
    for (const auto& q : out) seen |= q == p;
    if (!seen) out.push_back(p);
  }
  return out;
}

std::string vtk_error_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

struct LoadedVtkModule {
  const detail::VtkModule* table = nullptr;
  std::string failure;  // why table is null
};

LoadedVtkModule load_vtk_module() {
  const std::vector<fs::path> candidates = vtk_module_candidates();
  std::string looked;
  for (const auto& path : candidates) {
    std::error_code ec;
    if (!fs::exists(path, ec)) {
      looked += (looked.empty() ? "" : ", ") + path.string();
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = dlerror();
      return {nullptr,
              "cannot load " + path.string() + ": " + vtk_error_line(why ? why : "dlopen failed")};
    }
    using Entry = const detail::VtkModule* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(handle, FABRICA_IO_VTK_ENTRY_NAME));
    const detail::VtkModule* table = entry != nullptr ? entry() : nullptr;
    if (table == nullptr || table->abi != detail::kVtkModuleAbi ||
        table->layout != detail::kVtkModuleLayout)
      return {nullptr, path.string() + " is from another build of fabrica"};
    return {table, {}};
  }
  return {nullptr, std::string(kVtkModuleFile) + " was not found (looked for " + looked +
                       "; FABRICA_IO_VTK_MODULE may give its path)"};
}

}  // namespace

const detail::VtkModule& detail::vtk_module(const std::string& what) {
  static const LoadedVtkModule loaded = load_vtk_module();
  if (loaded.table == nullptr)
    throw Error(ErrorKind::unavailable, what + " needs fabrica's VTK module: " + loaded.failure);
  return *loaded.table;
}

void detail::read_vtp(const std::filesystem::path& path, const std::string& name,
                      const ReadOptions& options, LoadedMesh& out) {
  vtk_module(name + ": reading .vtp files").read_vtp(path, name, options, out);
}

void detail::check_extract_options(const ExtractOptions& options) {
  if (options.smoothing_iterations &&
      (*options.smoothing_iterations < 0 || *options.smoothing_iterations > 10000))
    throw InputError("smoothing iterations must be between 0 and 10000, got " +
                     std::to_string(*options.smoothing_iterations));
  if (!(options.smoothing_passband >= 1e-3 && options.smoothing_passband < 2.0))
    throw InputError("smoothing pass band (--passband) must be in [0.001, 2), got " +
                     std::to_string(options.smoothing_passband));
  if (!(options.decimate >= 0.0 && options.decimate < 1.0))
    throw InputError("decimation must be a fraction of faces to remove in [0, 1), got " +
                     std::to_string(options.decimate));
  if (options.iso_value && !std::isfinite(*options.iso_value))
    throw InputError("iso value must be a finite number");
}

std::vector<ExtractedSurface> extract_surfaces(const LabelVolume& volume,
                                               const ExtractOptions& options) {
  detail::check_extract_options(options);
  return detail::vtk_module("volume '" + volume.path + "': extracting surfaces")
      .extract_surfaces(volume, options);
}

void smooth_surface(TriangleMesh& mesh, int iterations, double passband) {
  ExtractOptions check;
  check.smoothing_iterations = iterations;
  check.smoothing_passband = passband;
  detail::check_extract_options(check);
  if (iterations == 0) {  // nothing to smooth: no need for the module
    check_mesh_indices_and_values(mesh, "mesh");
    return;
  }
  detail::vtk_module("windowed-sinc smoothing (--smooth)")
      .smooth_surface(mesh, iterations, passband);
}

}  // namespace fabrica::io
