// fabrica-viewer [INPUT...] [--script FILE] [--size WxH] [--frame-log FILE.csv]:
// the focus-and-context desktop viewer (docs/viewer.md). Without --script
// it runs until the window is closed; with it, the script drives the real
// window and the program ends after the last line (or `quit`).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "cli_common.hpp"
#include "fabrica/core/error.hpp"
#include "script.hpp"
#include "viewer.hpp"

int main(int argc, char** argv) {
  using namespace fabrica;
  cli::keep_freed_memory_for_reuse();
  CLI::App app("fabrica-viewer: focus-and-context viewer for anatomy surfaces", "fabrica-viewer");
  std::vector<std::string> inputs;
  std::string script, size, frame_log;
  app.add_option("input", inputs, "Meshes, label volumes or scene JSON files to open");
  app.add_option("--script", script, "Run the commands of FILE, one a line (docs/viewer.md)");
  app.add_option("--size", size, "Window size WxH in pixels (default 1280x800)");
  app.add_option("--frame-log", frame_log,
                 "Write frame,ms_frame,ms_gpu_submit,ms_lines,lines_age_frames per frame (CSV)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    viewer::ViewerOptions options;
    if (!size.empty()) std::tie(options.width, options.height) = cli::parse_size(size, 8192);
    options.frame_log = frame_log;
    options.interactive = script.empty();
    viewer::Viewer v(options);
    for (const auto& input : inputs) v.open(input);
    if (!script.empty()) {
      const int code = viewer::run_script(v, script);
      std::fprintf(stderr, "fabrica-viewer: %s done, frames: %llu\n", script.c_str(),
                   static_cast<unsigned long long>(v.last_frame().frame));
      return code;
    }
    while (!v.should_close()) v.frame();
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "fabrica-viewer: %s\n", e.what());
    return e.exit_code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fabrica-viewer: internal error: %s\n", e.what());
    return 1;
  }
}
