// Opening input files safely: only regular files are read (a FIFO would block
// forever, /dev/zero never ends, a folder is not a file), and a file is read
// whole only up to a size limit, so no reader allocates without bound.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace fabrica {

/// Largest input file fabrica reads whole (16 GiB; docs/reliability.md).
inline constexpr std::uintmax_t kMaxInputFileBytes = std::uintmax_t{16} << 30;

/// Largest camera or scene JSON file fabrica reads (64 MiB).
inline constexpr std::uintmax_t kMaxJsonBytes = std::uintmax_t{64} << 20;

/// Throws InputError("<what>: ...") unless `path` names an existing regular
/// file (symbolic links are followed): missing files, folders, FIFOs, sockets
/// and devices are refused. Returns the file's size in bytes.
std::uintmax_t require_regular_file(const std::filesystem::path& path, const std::string& what);

/// The whole file as bytes, after require_regular_file; InputError when it
/// is larger than `max_bytes` or cannot be read.
std::string read_input_file(const std::filesystem::path& path, const std::string& what,
                            std::uintmax_t max_bytes = kMaxInputFileBytes);

}  // namespace fabrica
