// Sub-commands whose library part this build leaves out
// (cmake/FabricaDependencies.cmake): they stay listed and fail with a
// one-line "unavailable" error (exit code 4) saying how to get them.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "commands.hpp"
#include "fabrica/core/error.hpp"

namespace fabrica::cli {
namespace {

void add_unavailable(CLI::App& app, Action& action, const std::string& name,
                     const std::string& needs, const std::string& option) {
  CLI::App* cmd = app.add_subcommand(name, "(not in this build: needs " + needs + ")");
  cmd->allow_extras();
  const std::string message = "the '" + name + "' command needs " + needs +
                              ", and this fabrica was built without it (rebuild with -D" + option +
                              "=ON)";
  cmd->callback([message, &action] {
    action = [message]() -> int { throw Error(ErrorKind::unavailable, message); };
  });
}

}  // namespace

void add_render_command(CLI::App& app, Action& action) {
  add_unavailable(app, action, "render", "the GL renderer (EGL, OSMesa, stb)",
                  "FABRICA_WITH_RENDER");
}
void add_hatch_command(CLI::App& app, Action& action) {
  add_unavailable(app, action, "hatch", "the GL renderer (EGL, OSMesa, stb)",
                  "FABRICA_WITH_RENDER");
}

}  // namespace fabrica::cli
