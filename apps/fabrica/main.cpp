// fabrica: line drawings of anatomy meshes. Exit codes (docs/cli.md):
//   0 success, 1 internal error, 2 bad input or arguments,
//   3 output could not be written, 4 needed facility unavailable,
//   5 a batch finished but some items failed.
#include <tbb/global_control.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>

#include "cli_common.hpp"
#include "cli_main.hpp"
#include "commands.hpp"
#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"

namespace {

/// Options every command gets and checks every command shares: --threads N
/// (unless the command has its own), finite numbers for every
/// floating-point option, positive stroke widths.
void add_common_options(CLI::App& app, int& threads) {
  const CLI::Validator finite(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || !std::isfinite(v))
          return "expected a finite number, got \"" + text + "\"";
        return {};
      },
      "FINITE", "finite");
  const CLI::Validator positive(
      [](std::string& text) -> std::string {
        if (!(std::strtod(text.c_str(), nullptr) > 0.0))
          return "expected a positive number, got \"" + text + "\"";
        return {};
      },
      "POSITIVE", "positive");
  for (CLI::App* sub : app.get_subcommands({})) {
    for (CLI::Option* option : sub->get_options()) {
      if (option->get_type_name() != "FLOAT") continue;
      option->check(finite);
      for (const char* width : {"--width", "--stroke-width", "--line-width"})
        if (option->check_lname(std::string(width).substr(2))) option->check(positive);
    }
    if (sub->get_option_no_throw("--threads") == nullptr)
      sub->add_option("--threads", threads,
                      "Worker threads (0 = all cores); the output does not depend on it")
          ->check(CLI::Range(0, 4096));
  }
}

}  // namespace

int main(int argc, char** argv) {
  fabrica::cli::keep_freed_memory_for_reuse();
#if defined(__GLIBC__) && defined(M_ARENA_MAX)
  // One arena for every thread: the worker threads' large arrays reuse the
  // memory the others freed instead of growing arenas of their own (10 MB
  // less at the peak of `fabrica lines` on a 270k-face mesh at two threads;
  // small blocks still come from each thread's cache, without the lock).
  mallopt(M_ARENA_MAX, 1);
#endif
  CLI::App app{
      "fabrica: feature lines, hatching and focus-and-context illustrations of anatomy meshes"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "fabrica 0.1.0");
  fabrica::cli::Action action;
#ifdef FABRICA_HAVE_CMD_INFO
  fabrica::cli::add_info_command(app, action);
#endif
#ifdef FABRICA_HAVE_CMD_GEOMETRY
  fabrica::cli::add_geometry_command(app, action);
#endif
#ifdef FABRICA_HAVE_CMD_EXTRACT
  fabrica::cli::add_extract_command(app, action);
#endif
#ifdef FABRICA_HAVE_CMD_LINES
  fabrica::cli::add_lines_command(app, action);
#endif
#ifdef FABRICA_HAVE_CMD_RENDER
  fabrica::cli::add_render_command(app, action);
#endif
#ifdef FABRICA_HAVE_CMD_HATCH
  fabrica::cli::add_hatch_command(app, action);
#endif
#ifdef FABRICA_HAVE_CMD_BATCH
  fabrica::cli::add_batch_command(app, action);
#endif
  int threads = 0;
  add_common_options(app, threads);
  return fabrica::cli::parse_and_run(
      app, argc, argv, "fabrica",
      [&] {
        std::unique_ptr<tbb::global_control> parallelism;
        if (threads > 0)
          parallelism = std::make_unique<tbb::global_control>(
              tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
        // A command writes all its outputs or none (a batch commits per item).
        fabrica::StagedOutputs staged;
        for (const CLI::App* command : app.get_subcommands())
          if (command->get_name() == "batch") staged.commit();
        const int code = action ? action() : 0;
        staged.commit();
        return code;
      },
      // One line: the "did you mean" for a misspelt command or option, else
      // the parser's own message.
      [&] { return fabrica::cli::parse_error_hint(app, argc, argv); });
}
