// Private to fabrica_io: zlib / gzip decompression shared by the readers of
// compressed mesh data (GIfTI) and label volumes (.nii.gz, NRRD gzip,
// MetaImage zlib). Concatenated gzip members (and zero padding between
// them) are one stream.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <string_view>

namespace fabrica::io::detail {

inline constexpr std::size_t kInflateToEnd = std::numeric_limits<std::size_t>::max();

enum class InflateSize {
  exact,     ///< the data must decompress to exactly `expected` bytes
  at_least,  ///< stop once `expected` bytes are out; anything after is ignored
};

/// True when the data starts with the gzip magic bytes.
bool is_gzip(std::string_view data);

/// Decompresses `compressed` (zlib or gzip, detected). `expected` is the
/// size the caller's header promises, or kInflateToEnd for "all of it".
/// Problems (corrupt, truncated, too large, wrong size) are reported by
/// calling `fail` with one sentence; `fail` must throw.
std::string inflate_zlib_or_gzip(std::string_view compressed, std::size_t expected,
                                 InflateSize mode,
                                 const std::function<void(const std::string&)>& fail);

}  // namespace fabrica::io::detail
