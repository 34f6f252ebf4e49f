#include "inflate.hpp"

#include <zlib.h>

#include <algorithm>

#include "fabrica/core/error.hpp"

namespace fabrica::io::detail {

namespace {

[[noreturn]] void report(const std::function<void(const std::string&)>& fail,
                         const std::string& problem) {
  fail(problem);
  throw Error(ErrorKind::internal, "inflate: error callback returned: " + problem);
}

}  // namespace

bool is_gzip(std::string_view data) {
  return data.size() >= 2 && static_cast<unsigned char>(data[0]) == 0x1f &&
         static_cast<unsigned char>(data[1]) == 0x8b;
}

std::string inflate_zlib_or_gzip(std::string_view compressed, std::size_t expected,
                                 InflateSize mode,
                                 const std::function<void(const std::string&)>& fail) {
  const bool known_size = expected != kInflateToEnd;
  const bool exact = known_size && mode == InflateSize::exact;
  if (compressed.size() > std::numeric_limits<uInt>::max())
    report(fail, "compressed data larger than 4 GiB is not supported");
  if (known_size && expected / 1100 > compressed.size() + 64)  // deflate expands at most ~1032:1
    report(fail, std::to_string(compressed.size()) +
                     " bytes of compressed data cannot hold the expected " +
                     std::to_string(expected) + " bytes (file truncated or header wrong)");
  std::string out;
  out.resize(known_size ? expected : std::max<std::size_t>(compressed.size() * 4, 1 << 16));
  std::size_t produced = 0;
  std::string_view rest = compressed;
  while (!rest.empty()) {
    z_stream zs{};
    if (inflateInit2(&zs, 15 + 32) != Z_OK)  // 15 + 32: zlib or gzip header, auto-detected
      throw Error(ErrorKind::internal, "zlib: inflateInit2 failed");
    struct End {
      z_stream* stream;
      ~End() { inflateEnd(stream); }
    } end_on_exit{&zs};
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(rest.data()));
    zs.avail_in = static_cast<uInt>(rest.size());
    int rc = Z_OK;
    bool full = false;  // at_least: the expected bytes are out
    for (;;) {
      if (produced == out.size()) {
        if (known_size && !exact) {
          full = true;
          break;
        }
        if (known_size) {
          // One more byte tells "exactly the expected size" from "too much".
          char probe = 0;
          zs.next_out = reinterpret_cast<Bytef*>(&probe);
          zs.avail_out = 1;
          rc = inflate(&zs, Z_NO_FLUSH);
          if (zs.avail_out == 0)
            report(fail,
                   "decompresses to more than the expected " + std::to_string(expected) + " bytes");
          if (rc != Z_OK) break;
          continue;
        }
        if (out.size() >= (std::size_t{1} << 32))
          report(fail, "decompresses to more than 4 GiB, more than fabrica reads");
        out.resize(2 * out.size());
      }
      const std::size_t room =
          std::min<std::size_t>(out.size() - produced, std::numeric_limits<uInt>::max());
      zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
      zs.avail_out = static_cast<uInt>(room);
      rc = inflate(&zs, Z_NO_FLUSH);
      produced += room - zs.avail_out;
      if (rc != Z_OK) break;  // end, error, or Z_BUF_ERROR: input exhausted
    }
    if (full) break;
    const std::string message = zs.msg != nullptr ? std::string(zs.msg) : std::to_string(rc);
    if (rc != Z_STREAM_END && rc != Z_OK && rc != Z_BUF_ERROR)
      report(fail, "corrupt compressed data (zlib: " + message + ")");
    if (rc != Z_STREAM_END)
      report(fail, "compressed data ends early (file truncated?) after " +
                       std::to_string(produced) + " bytes" +
                       (known_size ? " of " + std::to_string(expected) : std::string()));
    rest = rest.substr(rest.size() - zs.avail_in);
    while (!rest.empty() && rest.front() == '\0') rest.remove_prefix(1);  // gzip padding
    if (rest.empty() || (known_size && !exact && produced >= expected)) break;
    if (!is_gzip(rest)) report(fail, "unexpected bytes after the end of the compressed data");
    // Another gzip member follows (concatenated .gz files are one stream).
  }
  if (known_size && produced != expected)
    report(fail, "compressed data holds " + std::to_string(produced) +
                     " bytes but the header describes " + std::to_string(expected) +
                     " (file truncated or header wrong)");
  out.resize(produced);
  return out;
}

}  // namespace fabrica::io::detail
