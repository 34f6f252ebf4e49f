#include "fabrica/core/atomic_file.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <mutex>
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

// Temporaries being written, removed if the process is interrupted (SIGINT,
// SIGTERM, SIGHUP) so that no partial file is left behind; the handler then
// re-raises the signal with its default action. Only async-signal-safe calls
// in the handler: fixed slots, atomics, unlink, sigaction, raise.
struct TemporarySlot {
  std::atomic<int> state{0};  // 0 free, 1 being filled, 2 holds a path to remove
  char path[4096];
};
TemporarySlot g_temporaries[32];

extern "C" void remove_temporaries_and_reraise(int sig) {
  for (auto& slot : g_temporaries)
    if (slot.state.load() == 2) ::unlink(slot.path);
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  ::sigaction(sig, &dfl, nullptr);
  ::raise(sig);
}

void install_interrupt_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL) continue;
      struct sigaction sa {};
      sa.sa_handler = remove_temporaries_and_reraise;
      ::sigemptyset(&sa.sa_mask);
      ::sigaction(sig, &sa, nullptr);
    }
  });
}

/// Registers a temporary for removal on interruption while it lives.
class TemporaryGuard {
 public:
  explicit TemporaryGuard(const std::filesystem::path& tmp) {
    install_interrupt_handlers();
    const std::string& s = tmp.native();
    if (s.size() >= sizeof(TemporarySlot::path)) return;
    for (auto& slot : g_temporaries) {
      int expected = 0;
      if (!slot.state.compare_exchange_strong(expected, 1)) continue;
      std::memcpy(slot.path, s.c_str(), s.size() + 1);
      slot.state.store(2);
      slot_ = &slot;
      return;
    }
  }
  ~TemporaryGuard() {
    if (slot_) slot_->state.store(0);
  }
  TemporaryGuard(const TemporaryGuard&) = delete;
  TemporaryGuard& operator=(const TemporaryGuard&) = delete;

 private:
  TemporarySlot* slot_ = nullptr;
};

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
  const TemporaryGuard guard(tmp);
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
