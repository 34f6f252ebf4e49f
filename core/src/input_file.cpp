#include "fabrica/core/input_file.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "fabrica/core/error.hpp"

namespace fabrica {

std::uintmax_t require_regular_file(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status))
    throw InputError(what + ": file not found (does not exist); check the path");
  if (std::filesystem::is_directory(status)) throw InputError(what + ": is a folder, not a file");
  if (!std::filesystem::is_regular_file(status))
    throw InputError(what +
                     ": is not a regular file (a pipe, socket or device); save the data to a "
                     "file first");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(what + ": cannot read the file size: " + ec.message());
  return size;
}

std::string read_input_file(const std::filesystem::path& path, const std::string& what,
                            std::uintmax_t max_bytes) {
  const std::uintmax_t size = require_regular_file(path, what);
  if (size > max_bytes)
    throw InputError(what + ": file is " + std::to_string(size) + " bytes, more than the " +
                     std::to_string(max_bytes) + " fabrica reads");
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                             &std::fclose);
  if (!file) throw InputError(what + ": cannot open: " + std::strerror(errno));
  std::string data;
  data.reserve(static_cast<std::size_t>(size));
  char chunk[1 << 16];
  for (;;) {
    const std::size_t got = std::fread(chunk, 1, sizeof chunk, file.get());
    data.append(chunk, got);
    if (data.size() > max_bytes)
      throw InputError(what + ": file grew beyond " + std::to_string(max_bytes) +
                       " bytes while being read");
    if (got < sizeof chunk) break;
  }
  if (std::ferror(file.get())) throw InputError(what + ": read error");
  return data;
}

}  // namespace fabrica
