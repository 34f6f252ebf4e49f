// fabrica: line drawings of anatomy meshes. Exit codes (docs/cli.md):
//   0 success, 1 internal error, 2 bad input or arguments,
//   3 output could not be written, 4 needed facility unavailable,
//   5 a batch finished but some items failed.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/error.hpp"

int main(int argc, char** argv) {
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
  if (argc < 2) {  // no command: the usage, on stderr, as a bad-arguments error
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    const std::string hint = fabrica::cli::parse_error_hint(app, argc, argv);
    if (!hint.empty()) std::fprintf(stderr, "fabrica: %s\n", hint.c_str());
    return 2;
  }
  try {
    return action ? action() : 0;
  } catch (const fabrica::Error& e) {
    std::fprintf(stderr, "fabrica: %s\n", e.what());
    return e.exit_code();
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "fabrica: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fabrica: internal error: %s\n", e.what());
    return 1;
  }
}
