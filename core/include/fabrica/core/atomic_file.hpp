// Writing output files so that nothing half-written is ever left behind:
// everything goes to a temporary file beside the target, which is renamed
// over the target only when complete.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>

namespace fabrica {

/// Calls `write` with a stream to a temporary file in the target's folder,
/// then renames it to `path`. On any failure (exception from `write`, stream
/// error, rename failure) the temporary is removed, the target is untouched,
/// and an OutputError naming `path` is thrown (exceptions of type Error
/// thrown by `write` propagate unchanged after clean-up).
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write, bool binary = false);

/// For writers that need a file name (VTK, stb): calls `write` with a
/// temporary path beside `path` and renames it when `write` returns.
void write_path_atomically(const std::filesystem::path& path,
                           const std::function<void(const std::filesystem::path&)>& write);

}  // namespace fabrica
