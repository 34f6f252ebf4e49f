#include "fabrica/core/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <string>
#include <system_error>

#include "fabrica/core/error.hpp"

namespace fabrica {

namespace {

std::filesystem::path temporary_beside(const std::filesystem::path& path) {
  static std::atomic<unsigned> counter{0};
  auto tmp = path;
  tmp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  return tmp;
}

void rename_into_place(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;  // keep ec: its message is the reason
    std::filesystem::remove(tmp, ignored);
    throw OutputError(path.string() + ": cannot write: " + ec.message());
  }
}

}  // namespace

void write_path_atomically(const std::filesystem::path& path,
                           const std::function<void(const std::filesystem::path&)>& write) {
  const auto parent = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(parent))
    throw OutputError(path.string() + ": cannot write: folder " + parent.string() + " does not exist");
  const auto tmp = temporary_beside(path);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw;
  }
  if (!std::filesystem::exists(tmp)) throw OutputError(path.string() + ": writer produced no file");
  rename_into_place(tmp, path);
}

void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write, bool binary) {
  write_path_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, binary ? std::ios::binary | std::ios::out : std::ios::out);
    if (!out) throw OutputError(path.string() + ": cannot open for writing");
    try {
      write(out);
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw OutputError(path.string() + ": " + e.what());
    }
    out.flush();
    if (!out) throw OutputError(path.string() + ": write failed (disk full?)");
  });
}

}  // namespace fabrica
