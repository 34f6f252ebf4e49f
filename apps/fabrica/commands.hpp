// The `fabrica` command line: each sub-command lives in its own cmd_*.cpp and
// registers itself on the top-level CLI11 app. A command sets `action` to the
// work to do after parsing; main() runs it and maps errors to exit codes.
#pragma once

#include <functional>

namespace CLI {
class App;
}

namespace fabrica::cli {

/// The work a parsed sub-command does; returns the process exit code.
using Action = std::function<int()>;

void add_info_command(CLI::App& app, Action& action);
void add_geometry_command(CLI::App& app, Action& action);
void add_extract_command(CLI::App& app, Action& action);
void add_lines_command(CLI::App& app, Action& action);
void add_render_command(CLI::App& app, Action& action);
void add_hatch_command(CLI::App& app, Action& action);
void add_batch_command(CLI::App& app, Action& action);

}  // namespace fabrica::cli
