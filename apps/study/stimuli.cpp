#include "stimuli.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/render/image.hpp"
#include "log.hpp"
#include "plan.hpp"

#ifndef FABRICA_STUDY_FABRICA_BIN
#define FABRICA_STUDY_FABRICA_BIN ""
#endif

namespace fabrica::study {

std::set<std::string> all_stimuli(const Study& study) {
  std::set<std::string> ids;
  for (const auto& t : study.techniques)
    for (const auto& m : study.models)
      for (const auto& v : study.views) ids.insert(stimulus_id(t.name, m.name, v.name));
  return ids;
}

std::string fabrica_program() {
  if (const char* env = std::getenv("FABRICA_BIN"); env && *env) return env;
  const std::string built = FABRICA_STUDY_FABRICA_BIN;
  if (!built.empty() && std::filesystem::exists(built)) return built;
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec && std::filesystem::exists(self.parent_path() / "fabrica"))
    return (self.parent_path() / "fabrica").string();
  return "fabrica";
}

void run_program(const std::vector<std::string>& argv, const std::string& what) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw Error(ErrorKind::internal, what + ": cannot fork: " + std::strerror(errno));
  if (pid == 0) {
    execvp(args[0], args.data());
    std::fprintf(stderr, "fabrica-study: cannot run %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw Error(ErrorKind::internal, what + ": waitpid failed");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  if (code == 127)
    throw Error(ErrorKind::unavailable,
                what + ": cannot run " + argv[0] + " (install it, or set FABRICA_BIN for fabrica)");
  // The drawing program's own exit code says what kind of failure it was.
  const ErrorKind kind =
      code >= 2 && code <= 4 ? static_cast<ErrorKind>(code) : ErrorKind::internal;
  throw Error(kind, what + ": " + argv[0] + " failed with exit code " + std::to_string(code) +
                        " (its message is above)");
}

std::vector<std::string> stimulus_command(const Technique& t, const Model& m,
                                          const std::filesystem::path& camera,
                                          const std::filesystem::path& output) {
  std::vector<std::string> argv = {fabrica_program(), t.command, m.path.string(), "--camera",
                                   camera.string(),   "-o",      output.string(), "-q"};
  for (const auto& [key, value] : t.options.items()) {
    if (value.is_boolean()) {
      if (value.get<bool>()) argv.push_back("--" + key);
    } else if (value.is_array()) {
      for (const auto& v : value) argv.insert(argv.end(), {"--" + key, v.get<std::string>()});
    } else {
      argv.insert(argv.end(),
                  {"--" + key, value.is_string() ? value.get<std::string>() : value.dump()});
    }
  }
  return argv;
}

namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void check_size(const std::filesystem::path& png, const Study& study) {
  const render::Image img = render::read_png(png);
  if (img.width != study.width || img.height != study.height)
    throw InputError(png.string() + ": stimulus is " + std::to_string(img.width) + "x" +
                     std::to_string(img.height) + ", the study's size is " +
                     std::to_string(study.width) + "x" + std::to_string(study.height));
}

/// Draws one stimulus into `png` (atomically: a temporary beside it).
void draw(const Technique& t, const Model& m, const std::filesystem::path& camera,
          const std::filesystem::path& png, const Study& study, const std::string& id) {
  write_path_atomically(png, [&](const std::filesystem::path& tmp) {
    std::filesystem::path target = tmp;
    target.replace_extension(t.command == "lines" ? ".svg" : ".png");
    run_program(stimulus_command(t, m, camera, target), "stimulus " + id);
    if (t.command == "lines") {
      // `fabrica lines` writes vectors; rasterised at the study size on white.
      run_program(
          {"rsvg-convert", "-w", std::to_string(study.width), "-h", std::to_string(study.height),
           "-b", "white", "-f", "png", "-o", tmp.string(), target.string()},
          "stimulus " + id + " (rasterising the SVG)");
      std::filesystem::remove(target);
    } else if (target != tmp) {
      std::filesystem::rename(target, tmp);
    }
  });
}

}  // namespace

std::map<std::string, std::filesystem::path> prepare_stimuli(const Study& study,
                                                             const std::set<std::string>& ids,
                                                             const std::filesystem::path& out_dir,
                                                             const std::filesystem::path& from_dir,
                                                             bool quiet) {
  std::map<std::string, std::filesystem::path> out;
  if (!from_dir.empty()) {
    if (!std::filesystem::is_directory(from_dir))
      throw InputError("--stimuli " + from_dir.string() + ": not a folder");
    // The output folder of `fabrica-study stimuli -o DIR` (or of a run) holds them in stimuli/.
    std::filesystem::path dir = from_dir;
    if (!ids.empty() && !std::filesystem::exists(dir / (*ids.begin() + ".png")) &&
        std::filesystem::is_directory(dir / "stimuli"))
      dir /= "stimuli";
    for (const auto& id : ids) {
      const auto png = dir / (id + ".png");
      if (!std::filesystem::is_regular_file(png))
        throw InputError(
            "--stimuli " + from_dir.string() + ": " + id +
            ".png is missing (draw them with `fabrica-study stimuli STUDY.json -o DIR`)");
      check_size(png, study);
      out[id] = png;
    }
    return out;
  }
  const auto stim_dir = out_dir / "stimuli", cam_dir = out_dir / "cameras";
  std::error_code ec;
  std::filesystem::create_directories(stim_dir, ec);
  std::filesystem::create_directories(cam_dir, ec);
  if (ec) throw OutputError(out_dir.string() + ": cannot create folders: " + ec.message());
  std::map<std::string, ModelGeometry> geometry;
  for (const auto& t : study.techniques)
    for (const auto& m : study.models)
      for (const auto& v : study.views) {
        const std::string id = stimulus_id(t.name, m.name, v.name);
        if (!ids.count(id)) continue;
        const auto png = stim_dir / (id + ".png"), record = stim_dir / (id + ".cmd");
        const auto camera_file = cam_dir / (m.name + "." + v.name + ".json");
        if (!geometry.count(m.name)) geometry[m.name] = load_model(m);
        const Camera camera = stimulus_camera(study, m, v, geometry[m.name]);
        const std::string camera_text = camera_to_json(camera).dump(2) + "\n";
        if (read_text(camera_file) != camera_text)
          write_file_atomically(camera_file, [&](std::ostream& o) { o << camera_text; });
        // The record: the command and the camera; a change redraws.
        const std::string key =
            join(stimulus_command(t, m, camera_file, png), " ") + "\n" + camera_text;
        out[id] = png;
        if (std::filesystem::is_regular_file(png) && read_text(record) == key) continue;
        if (!quiet) std::fprintf(stderr, "fabrica-study: drawing stimulus %s\n", id.c_str());
        draw(t, m, camera_file, png, study, id);
        check_size(png, study);
        write_file_atomically(record, [&](std::ostream& o) { o << key; });
      }
  return out;
}

}  // namespace fabrica::study
