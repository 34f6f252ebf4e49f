#include "script.hpp"

#include "ui.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli_common.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica::viewer {

namespace {

// CPU seconds of the whole process so far (every thread: the lines worker's
// and the GL driver's too).
double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double parse_number(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v))
    throw InputError(what + " must be a number (got \"" + text + "\")");
  return v;
}

/// KEY=VALUE: VALUE as JSON when it parses (numbers, true, [1,0,0]), else as
/// a string; `lines` also takes a comma-separated list of families.
nlohmann::json parse_keys(const std::vector<std::string>& words, std::size_t first,
                          const std::string& command = "set") {
  nlohmann::json keys = nlohmann::json::object();
  for (std::size_t i = first; i < words.size(); ++i) {
    const auto eq = words[i].find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError(command + ": \"" + words[i] + "\" must be KEY=VALUE");
    const std::string key = words[i].substr(0, eq), text = words[i].substr(eq + 1);
    nlohmann::json value = nlohmann::json::parse(text, nullptr, false);
    if (value.is_discarded()) value = text;
    if (key == "lines" && value.is_string()) {
      nlohmann::json list = nlohmann::json::array();
      std::stringstream in(text);
      std::string item;
      while (std::getline(in, item, ','))
        if (!item.empty() && item != "none") list.push_back(item);
      value = list;
    }
    keys[key] = value;
  }
  if (keys.empty()) throw InputError("set NAME KEY=VALUE...: no key given");
  return keys;
}

void expect_args(const std::vector<std::string>& w, std::size_t min, std::size_t max,
                 const char* usage) {
  if (w.size() - 1 < min || w.size() - 1 > max) throw InputError(std::string("usage: ") + usage);
}

}  // namespace

std::vector<std::string> split_script_line(const std::string& line) {
  std::vector<std::string> words;
  std::string word;
  bool quoted = false, any = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
      any = true;
    } else if (!quoted && c == '#') {
      break;
    } else if (!quoted && std::isspace(static_cast<unsigned char>(c))) {
      if (any) words.push_back(word);
      word.clear();
      any = false;
    } else {
      word += c;
      any = true;
    }
  }
  if (quoted) throw InputError("unclosed quote");
  if (any) words.push_back(word);
  return words;
}

int run_script(Viewer& v, const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open the script; check the path");
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (v.should_close()) return 0;
    try {
      const std::vector<std::string> w = split_script_line(line);
      if (w.empty()) continue;
      const std::string& cmd = w[0];
      // Commands that name structures act on what is loaded: wait for it.
      auto loaded = [&] {
        while (v.loader().busy()) v.frame();
      };
      if (cmd == "open") {
        expect_args(w, 1, 1, "open PATH");
        v.open(w[1]);
        v.frame();
      } else if (cmd == "focus" || cmd == "context" || cmd == "hide" || cmd == "show") {
        expect_args(w, 1, 1, "focus|context|hide|show NAME");
        loaded();
        const std::size_t i = v.find(w[1]);
        if (cmd == "focus") v.focus(i);
        if (cmd == "context") v.set_role(i, render::Role::context);
        if (cmd == "hide" || cmd == "show") v.structures()[i].visible = cmd == "show";
        v.style_changed();
        v.frame();
      } else if (cmd == "set") {
        if (w.size() < 3) throw InputError("usage: set NAME KEY=VALUE...");
        loaded();
        v.set_keys(v.find(w[1]), parse_keys(w, 2));
        v.frame();
      } else if (cmd == "view") {
        expect_args(w, 1, 2, "view anterior|posterior|left|right|superior|inferior [animate]");
        if (w.size() == 3 && w[2] != "animate")
          throw InputError("view: the second word can only be \"animate\"");
        const auto view = parse_anatomical_view(w[1]);
        if (!view)
          throw InputError("view: unknown view \"" + w[1] +
                           "\" (anterior, posterior, left, right, superior, inferior)");
        loaded();
        v.view(*view, w.size() == 3);
        do {
          v.frame();
        } while (v.transitioning() && !v.should_close());
      } else if (cmd == "clip") {
        const char* usage =
            "clip off | clip view [OFFSET_MM] | clip anterior|posterior|left|right|superior|"
            "inferior [OFFSET_MM]";
        expect_args(w, 1, 2, usage);
        const double offset = w.size() == 3 ? parse_number(w[2], "clip OFFSET_MM") : 0.0;
        loaded();
        if (w[1] == "off") {
          if (w.size() == 3) throw InputError(std::string("usage: ") + usage);
          v.set_clip(ClipSettings::Mode::off);
        } else if (w[1] == "view") {
          v.set_clip(ClipSettings::Mode::view, AnatomicalView::anterior, offset);
        } else if (const auto side = parse_anatomical_view(w[1])) {
          v.set_clip(ClipSettings::Mode::side, *side, offset);
        } else {
          throw InputError("clip: unknown orientation \"" + w[1] + "\" (" + usage + ")");
        }
        v.frame();
      } else if (cmd == "cutaway") {
        // cutaway off | cutaway on [MARGIN_PX [FADE_PX]] | cutaway KEY=VALUE...
        const char* usage =
            "cutaway off | cutaway on [MARGIN_PX [FADE_PX]] | cutaway KEY=VALUE... (keys "
            "enabled, margin_px, fade_px, rim, rim_color)";
        if (w.size() < 2) throw InputError(std::string("usage: ") + usage);
        render::Cutaway c = v.cutaway();
        if (w[1] == "off" || w[1] == "on") {
          expect_args(w, 1, w[1] == "on" ? 3 : 1, usage);
          c.enabled = w[1] == "on";
          if (w.size() > 2) c.margin_px = parse_number(w[2], "cutaway MARGIN_PX");
          if (w.size() > 3) c.fade_px = parse_number(w[3], "cutaway FADE_PX");
        } else if (w[1].find('=') != std::string::npos) {
          c = render::cutaway_from_json(parse_keys(w, 1, "cutaway"), "cutaway", c);
        } else {
          throw InputError("cutaway: unknown argument \"" + w[1] + "\" (" + usage + ")");
        }
        loaded();
        v.set_cutaway(c);
        v.frame();
      } else if (cmd == "camera") {
        expect_args(w, 1, 1, "camera FILE");
        Camera c = read_camera(w[1]);
        validate_camera(c, w[1]);
        v.set_camera(c);
        v.frame();
      } else if (cmd == "fit") {
        expect_args(w, 0, 0, "fit");
        loaded();
        v.fit_to_selection();
        v.frame();
      } else if (cmd == "orbit") {
        expect_args(w, 2, 2, "orbit DEGREES FRAMES");
        const double degrees = parse_number(w[1], "orbit DEGREES");
        const double frames = parse_number(w[2], "orbit FRAMES");
        if (frames < 1 || frames != std::floor(frames) || frames > 1e6)
          throw InputError("orbit FRAMES must be a whole number >= 1");
        loaded();
        const double cpu0 = process_cpu_seconds();
        const auto wall0 = std::chrono::steady_clock::now();
        int drawn = 0;
        for (; drawn < static_cast<int>(frames) && !v.should_close(); ++drawn) {
          v.orbit(degrees / frames);
          v.frame();
        }
        // What the orbit cost (bench/viewer_orbit.sh reads this line).
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        std::printf("orbit: %d frames, %.1f ms per frame, cpu %.1f ms per frame (all threads)\n",
                    drawn, 1e3 * wall / std::max(drawn, 1),
                    1e3 * (process_cpu_seconds() - cpu0) / std::max(drawn, 1));
        std::fflush(stdout);
      } else if (cmd == "wait") {
        expect_args(w, 0, 0, "wait");
        v.wait();
      } else if (cmd == "screenshot") {
        expect_args(w, 1, 3, "screenshot PATH [WxH] [transparent]");
        int width = v.camera().width, height = v.camera().height;
        bool transparent = false;
        for (std::size_t k = 2; k < w.size(); ++k) {
          if (w[k] == "transparent")
            transparent = true;
          else
            std::tie(width, height) = cli::parse_size(w[k], 16384, "screenshot");
        }
        loaded();
        render::write_png(v.screenshot(width, height, transparent), w[1]);
      } else if (cmd == "screenshot-window") {
        expect_args(w, 1, 1, "screenshot-window PATH");
        loaded();
        v.capture_window(w[1]);
      } else if (cmd == "panel") {
        expect_args(w, 2, 2, "panel NAME open|closed");
        if (w[2] != "open" && w[2] != "closed") throw InputError("usage: panel NAME open|closed");
        loaded();
        v.find(w[1]);
        set_panel_open(w[1], w[2] == "open");
        v.frame();
      } else if (cmd == "moving-lines") {
        expect_args(w, 1, 1, "moving-lines full|coarse");
        if (w[1] != "full" && w[1] != "coarse") throw InputError("usage: moving-lines full|coarse");
        v.coarse_lines_while_moving() = w[1] == "coarse";
        v.style_changed();
      } else if (cmd == "export-svg") {
        expect_args(w, 1, 1, "export-svg PATH.svg|PATH.pdf");
        loaded();
        v.export_svg(w[1]);
      } else if (cmd == "save-scene") {
        expect_args(w, 1, 1, "save-scene PATH");
        loaded();
        v.save_scene(w[1]);
      } else if (cmd == "save-camera") {
        expect_args(w, 1, 1, "save-camera PATH");
        write_camera(v.camera(), w[1]);
      } else if (cmd == "click") {
        expect_args(w, 2, 2, "click X Y");
        const double x = parse_number(w[1], "click X"), y = parse_number(w[2], "click Y");
        loaded();
        v.click_at(static_cast<int>(x), static_cast<int>(y));
        v.frame();
      } else if (cmd == "measure") {
        expect_args(w, 1, 1, "measure on|off");
        if (w[1] != "on" && w[1] != "off") throw InputError("usage: measure on|off");
        v.measure_mode() = w[1] == "on";
        v.measure_points().clear();
      } else if (cmd == "quit") {
        expect_args(w, 0, 0, "quit");
        return 0;
      } else {
        throw InputError(
            "unknown command \"" + cmd +
            "\" (open, focus, context, hide, show, set, view, clip, cutaway, camera, fit, orbit, "
            "wait, screenshot, screenshot-window, panel, export-svg, save-scene, "
            "save-camera, click, measure, "
            "quit)");
      }
    } catch (const Error& e) {
      throw Error(e.kind(), path.string() + ":" + std::to_string(number) + ": " + e.what());
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string() + ":" + std::to_string(number) + ": " + e.what());
    }
  }
  return 0;
}

}  // namespace fabrica::viewer
