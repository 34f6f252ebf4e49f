#include "fabrica/core/atomic_file.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
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

thread_local StagedOutputs* t_staging = nullptr;

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
  // Checked now rather than at the rename, which may wait for the other
  // outputs of the command (StagedOutputs).
  if (std::filesystem::is_directory(path))
    throw OutputError(path.string() + ": cannot write: it is a folder; choose a file name");
  remove_stale_temporaries(path);
  const auto tmp = temporary_beside(path);
  auto guard = std::make_unique<TemporaryGuard>(tmp);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw;
  }
  if (!std::filesystem::exists(tmp)) throw OutputError(path.string() + ": writer produced no file");
  if (StagedOutputs* staging = StagedOutputs::current()) {
    guard.reset();  // the staging registers it again for the time it waits
    staging->stage(tmp, path);
    return;
  }
  rename_into_place(tmp, path);
}

struct StagedOutputs::Entry {
  std::filesystem::path tmp, target;
  TemporaryGuard guard;
  Entry(std::filesystem::path t, std::filesystem::path p)
      : tmp(std::move(t)), target(std::move(p)), guard(tmp) {}
};

StagedOutputs::StagedOutputs() : previous_(t_staging) {
  t_staging = this;
}

StagedOutputs::~StagedOutputs() {
  t_staging = previous_;
  for (const auto& e : entries_) {
    std::error_code ec;
    std::filesystem::remove(e->tmp, ec);
  }
}

StagedOutputs* StagedOutputs::current() {
  return t_staging;
}

void StagedOutputs::stage(const std::filesystem::path& tmp, const std::filesystem::path& target) {
  try {
    entries_.push_back(std::make_unique<Entry>(tmp, target));
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw;
  }
}

void StagedOutputs::commit() {
  t_staging = previous_;
  std::vector<std::unique_ptr<Entry>> entries;
  entries.swap(entries_);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    try {
      rename_into_place(entries[k]->tmp, entries[k]->target);
    } catch (...) {
      for (std::size_t j = k + 1; j < entries.size(); ++j) {
        std::error_code ec;
        std::filesystem::remove(entries[j]->tmp, ec);
      }
      throw;
    }
  }
}

void remove_stale_temporaries(const std::filesystem::path& path) {
  const auto parent = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const std::string prefix = path.filename().string() + ".tmp-";
  std::error_code ec;
  std::filesystem::directory_iterator it(parent, ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    // NAME.tmp-PID-N: a PID of digits, a dash, a counter of digits.
    const std::size_t dash = name.find('-', prefix.size());
    if (dash == std::string::npos || dash == prefix.size() || dash + 1 >= name.size()) continue;
    const std::string pid_text = name.substr(prefix.size(), dash - prefix.size());
    const std::string counter = name.substr(dash + 1);
    auto digits = [](const std::string& t) {
      return !t.empty() && t.size() <= 10 && t.find_first_not_of("0123456789") == std::string::npos;
    };
    if (!digits(pid_text) || !digits(counter)) continue;
    const long pid = std::stol(pid_text);
    if (pid <= 0 || pid == static_cast<long>(::getpid())) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // still running
    std::error_code ignored;
    std::filesystem::remove(it->path(), ignored);
  }
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
