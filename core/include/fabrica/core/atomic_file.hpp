// Writing output files so that nothing half-written is ever left behind:
// everything goes to a temporary file beside the target, which is renamed
// over the target only when complete. Temporaries are named
// NAME.tmp-PID-N; those left by a process that no longer runs (killed with
// SIGKILL, power loss) are removed by the next write of NAME.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <ostream>
#include <utility>
#include <vector>

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

/// All the outputs of one command, or none: while a StagedOutputs lives on
/// this thread, write_file_atomically and write_path_atomically write their
/// temporaries but do not rename them; commit() renames them all at the end.
/// Destroyed without commit() (an exception, a failed output), it removes
/// the temporaries and every target is left as it was. Not nestable.
class StagedOutputs {
 public:
  StagedOutputs();
  ~StagedOutputs();
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;

  /// Renames every staged temporary over its target, in the order written.
  /// OutputError naming the target when a rename fails.
  void commit();

  /// Called by the writers: keeps `tmp` for `target` (internal).
  void stage(const std::filesystem::path& tmp, const std::filesystem::path& target);
  /// The staging of this thread, or nullptr.
  static StagedOutputs* current();

 private:
  struct Entry;
  std::vector<std::unique_ptr<Entry>> entries_;
  StagedOutputs* previous_ = nullptr;
};

/// Removes NAME.tmp-PID-N files beside `path` whose process PID no longer
/// runs (called before every atomic write of `path`).
void remove_stale_temporaries(const std::filesystem::path& path);

}  // namespace fabrica
