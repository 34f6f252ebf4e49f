// The manifest of `fabrica batch` (docs/batch.md): reading, checking (every
// error with its JSON path, before any work), expanding into numbered items,
// and turning an item into the command lines of `lines`, `render` or `hatch`.
#include <glob.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "../cli_common.hpp"
#include "../commands.hpp"
#include "batch.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"
#include "fabrica/io/label_volume.hpp"

namespace fabrica::cli::batch {
namespace fs = std::filesystem;
using nlohmann::json;

bool is_path_option(const std::string& key) {
  // Of the options of lines, render and hatch that name files, only these may
  // be style options; the others (-o, --svg, --pdf, --camera, --save-scene,
  // --save-camera) are reserved_keys().
  return key == "context";
}

namespace {

/// The commands a style may name (those compiled in), each registering
/// itself on a CLI11 app.
const std::map<std::string, void (*)(CLI::App&, Action&)>& drawing_commands() {
  static const std::map<std::string, void (*)(CLI::App&, Action&)> commands = {
#ifdef FABRICA_HAVE_CMD_LINES
      {"lines", &add_lines_command},
#endif
#ifdef FABRICA_HAVE_CMD_RENDER
      {"render", &add_render_command},
#endif
#ifdef FABRICA_HAVE_CMD_HATCH
      {"hatch", &add_hatch_command},
#endif
  };
  return commands;
}

/// Output formats per command; render's "svg" is its --svg secondary output.
const std::map<std::string, std::vector<std::string>>& command_formats() {
  static const std::map<std::string, std::vector<std::string>> formats = {
      {"lines", {"svg", "pdf", "seg", "json"}},
      {"render", {"png", "svg"}},
      {"hatch", {"svg", "png"}}};
  return formats;
}

/// Style keys the batch sets itself (from views, formats and the output pattern).
const std::map<std::string, std::string>& reserved_keys() {
  static const std::map<std::string, std::string> keys = {
      {"o", "outputs come from \"output\" and \"formats\""},
      {"output", "outputs come from \"output\" and \"formats\""},
      {"svg", "add \"svg\" to \"formats\""},
      {"save-scene", "not available in a batch"},
      {"save-camera", "not available in a batch (the camera is in each output's .meta.json)"},
      {"camera", "cameras are views: {\"camera\": FILE}"},
      {"view", "views are listed in \"views\""},
      {"q", "a batch runs its commands quietly"},
      {"quiet", "a batch runs its commands quietly"},
      {"mesh", "inputs are listed in \"inputs\""},
      {"input", "inputs are listed in \"inputs\""}};
  return keys;
}

struct Errors {
  std::vector<std::string> list;
  void add(const std::string& path, const std::string& what) { list.push_back(path + ": " + what); }
};

std::string stem_of(const fs::path& p) {
  fs::path s = p.filename();
  if (lower(s.extension().string()) == ".gz") s = s.stem();
  if (s.string().size() > 4 && lower(s.string()).ends_with(".seg.nrrd"))
    return s.string().substr(0, s.string().size() - 9);
  return s.stem().string();
}

/// Letters, digits, '-', '_', '.'; anything else becomes '_'.
std::string safe_name(const std::string& name) {
  std::string out;
  for (char c : name) {
    const auto u = static_cast<unsigned char>(c);
    out.push_back(std::isalnum(u) || c == '-' || c == '_' || c == '.' ? c : '_');
  }
  while (!out.empty() && out.front() == '.') out.erase(out.begin());
  return out.empty() ? "_" : out;
}

/// "a", "a-2", "a-3", ... in order of appearance.
std::string unique_name(const std::string& name, std::set<std::string>& used) {
  std::string n = name;
  for (int k = 2; used.count(n); ++k) n = name + "-" + std::to_string(k);
  used.insert(n);
  return n;
}

std::string json_number_text(const json& v) {
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  return v.dump();  // shortest text that reads back to the same double
}

/// A scalar style value as command-line text; nullopt when it has none.
std::optional<std::string> scalar_text(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number()) return json_number_text(v);
  return std::nullopt;
}

std::string size_text(const std::pair<int, int>& s) {
  return std::to_string(s.first) + "x" + std::to_string(s.second);
}

/// Parses "WxH" or [W, H].
std::optional<std::pair<int, int>> parse_size_value(const json& v, std::string& error) {
  try {
    if (v.is_string()) return parse_size(v.get<std::string>(), 16384, "size");
    if (v.is_array() && v.size() == 2 && v[0].is_number_integer() && v[1].is_number_integer())
      return parse_size(
          std::to_string(v[0].get<long long>()) + "x" + std::to_string(v[1].get<long long>()),
          16384, "size");
    error = "expected [WIDTH, HEIGHT] or \"WIDTHxHEIGHT\" in pixels";
  } catch (const Error& e) {
    error = e.what();
  }
  return std::nullopt;
}

struct ParsedCommand {
  CLI::App app;
  Action action;
  CLI::App* sub = nullptr;
};

/// A fresh parser holding just `command` (so every run starts from defaults).
std::unique_ptr<ParsedCommand> make_parser(const std::string& command) {
  auto p = std::make_unique<ParsedCommand>();
  const auto it = drawing_commands().find(command);
  if (it == drawing_commands().end())
    throw InputError("no command \"" + command + "\" in this build");
  it->second(p->app, p->action);
  p->sub = p->app.get_subcommand(command);
  return p;
}

/// The style's options as arguments (after the input and the view).
void append_style_options(const Style& style, const Plan& plan, const CLI::App& sub,
                          std::vector<std::string>& args, std::vector<std::string>& recorded) {
  for (const auto& [key, value] : style.options) {
    const CLI::Option* opt = sub.get_option_no_throw("--" + key);
    const bool flag = opt && opt->get_type_size_max() == 0;
    const bool repeatable =
        opt && opt->get_items_expected_max() >= CLI::detail::expected_max_vector_size;
    auto add = [&](const std::string& text) {
      args.push_back("--" + key);
      recorded.push_back("--" + key);
      if (is_path_option(key)) {
        args.push_back((plan.base / text).lexically_normal().string());
      } else {
        args.push_back(text);
      }
      recorded.push_back(text);
    };
    if (flag) {
      if (value.is_boolean() && value.get<bool>()) {
        args.push_back("--" + key);
        recorded.push_back("--" + key);
      }
      continue;
    }
    if (key == "size" && value.is_array()) {
      std::string ignored;
      if (const auto s = parse_size_value(value, ignored)) add(size_text(*s));
      continue;
    }
    if (value.is_array()) {
      if (repeatable) {
        for (const auto& v : value)
          if (const auto t = scalar_text(v)) add(*t);
      } else {
        std::string joined;
        for (const auto& v : value)
          if (const auto t = scalar_text(v)) joined += (joined.empty() ? "" : ",") + *t;
        add(joined);
      }
      continue;
    }
    if (const auto t = scalar_text(value)) add(*t);
  }
}

std::string substitute(std::string pattern, const std::map<std::string, std::string>& values) {
  for (const auto& [key, value] : values) {
    const std::string token = "{" + key + "}";
    for (std::size_t at = pattern.find(token); at != std::string::npos;
         at = pattern.find(token, at + value.size()))
      pattern.replace(at, token.size(), value);
  }
  return pattern;
}

std::vector<fs::path> expand_glob(const fs::path& pattern) {
  glob_t g{};
  std::vector<fs::path> out;
  if (::glob(pattern.c_str(), 0, nullptr, &g) == 0)
    for (std::size_t k = 0; k < g.gl_pathc; ++k)
      if (fs::is_regular_file(g.gl_pathv[k])) out.emplace_back(g.gl_pathv[k]);
  ::globfree(&g);
  std::sort(out.begin(), out.end(), [](const fs::path& a, const fs::path& b) {
    return a.string() < b.string();  // byte order, whatever the locale
  });
  return out;
}

void check_keys(const json& object, const std::set<std::string>& allowed, const std::string& path,
                Errors& errors) {
  for (const auto& [key, value] : object.items())
    if (!allowed.count(key)) errors.add(path + "." + key, "unknown key");
}

/// doc[key] when it is a non-empty array; otherwise reports it and returns null.
const json* entries(const json& doc, const std::string& key, const std::string& what,
                    Errors& errors) {
  if (doc.contains(key) && doc[key].is_array() && !doc[key].empty()) return &doc[key];
  errors.add(key, "expected a non-empty array of " + what);
  return nullptr;
}

void read_inputs(const json& doc, Plan& plan, Errors& errors) {
  const json* inputs =
      entries(doc, "inputs", "{\"mesh\"|\"scene\"|\"volume\"|\"glob\": PATH}", errors);
  if (!inputs) return;
  std::set<std::string> used;
  for (std::size_t i = 0; i < inputs->size(); ++i) {
    const json& in = (*inputs)[i];
    const std::string path = "inputs[" + std::to_string(i) + "]";
    if (in.is_string()) {  // shorthand for {"mesh": PATH}
      Input input{Input::Kind::mesh,
                  unique_name(safe_name(stem_of(in.get<std::string>())), used),
                  in.get<std::string>(),
                  plan.base / in.get<std::string>(),
                  0,
                  path};
      plan.inputs.push_back(input);
      continue;
    }
    if (!in.is_object()) {
      errors.add(path, "expected an object such as {\"mesh\": \"a.stl\"}");
      continue;
    }
    std::vector<std::string> kinds;
    for (const char* k : {"mesh", "scene", "volume", "glob"})
      if (in.contains(k)) kinds.push_back(k);
    if (kinds.size() != 1 || !in[kinds[0]].is_string()) {
      errors.add(path, "give exactly one of \"mesh\", \"scene\", \"volume\", \"glob\" with a path");
      continue;
    }
    const std::string kind = kinds[0], shown = in[kind].get<std::string>();
    check_keys(in, {kind, "name", "labels"}, path, errors);
    if (in.contains("name") && (!in["name"].is_string() || in["name"].get<std::string>().empty()))
      errors.add(path + ".name", "expected a non-empty string");
    if (in.contains("labels") && kind != "volume")
      errors.add(path + ".labels", "only for a volume");
    const std::string given =
        in.contains("name") && in["name"].is_string() ? in["name"].get<std::string>() : "";
    if (kind == "glob") {
      if (!given.empty()) errors.add(path + ".name", "a glob names its inputs after their files");
      const auto files = expand_glob(plan.base / shown);
      if (files.empty()) errors.add(path + ".glob", "no file matches \"" + shown + "\"");
      for (const auto& f : files)
        plan.inputs.push_back({Input::Kind::mesh, unique_name(safe_name(stem_of(f)), used),
                               f.lexically_relative(plan.base).string(), f, 0, path});
      continue;
    }
    const std::string name = safe_name(given.empty() ? stem_of(shown) : given);
    if (kind == "mesh" || kind == "scene") {
      plan.inputs.push_back({kind == "mesh" ? Input::Kind::mesh : Input::Kind::scene,
                             unique_name(name, used), shown, plan.base / shown, 0, path});
      continue;
    }
    std::vector<int> labels;
    if (in.contains("labels")) {
      const json& l = in["labels"];
      if (!l.is_array() || l.empty() || !std::all_of(l.begin(), l.end(), [](const json& v) {
            return v.is_number_integer() && v.get<long long>() > 0 &&
                   v.get<long long>() <= 2147483647;
          })) {
        errors.add(path + ".labels", "expected a non-empty array of positive label values");
        continue;
      }
      for (const auto& v : l) labels.push_back(v.get<int>());
    } else {
      try {  // every nonzero label of the volume
        const io::LabelVolume volume = io::read_label_volume(plan.base / shown);
        const auto counts = io::label_voxel_counts(volume);
        std::set<int> found;
        for (const auto& layer : counts)
          for (const auto& [value, n] : layer)
            if (value != 0 && n > 0) found.insert(value);
        labels.assign(found.begin(), found.end());
        if (labels.empty()) errors.add(path + ".volume", "the volume has no nonzero label");
      } catch (const Error& e) {
        errors.add(path + ".volume", std::string(e.what()) + " (or list its \"labels\")");
        continue;
      }
    }
    std::set<int> seen;
    for (int label : labels) {
      if (!seen.insert(label).second) continue;
      plan.inputs.push_back({Input::Kind::volume_label,
                             unique_name(name + "-label" + std::to_string(label), used), shown,
                             plan.base / shown, label, path});
    }
  }
}

void read_views(const json& doc, Plan& plan, Errors& errors) {
  json views = doc.contains("views") ? doc["views"] : json::array({"anterior"});
  if (!views.is_array() || views.empty()) {
    errors.add("views",
               "expected a non-empty array of view names, {\"camera\": FILE} or {\"orbit\": N}");
    return;
  }
  std::set<std::string> used;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const json& v = views[i];
    const std::string path = "views[" + std::to_string(i) + "]";
    auto anatomical = [&](const std::string& name, const std::string& where) -> bool {
      if (parse_anatomical_view(lower(name))) return true;
      errors.add(where, "unknown view \"" + name +
                            "\" (anterior, posterior, left, right, superior, inferior)");
      return false;
    };
    if (v.is_string()) {
      if (anatomical(v.get<std::string>(), path))
        plan.views.push_back({View::Kind::anatomical,
                              unique_name(lower(v.get<std::string>()), used),
                              lower(v.get<std::string>()),
                              "",
                              {},
                              0,
                              1,
                              path});
      continue;
    }
    if (!v.is_object()) {
      errors.add(path, "expected a view name, {\"camera\": FILE} or {\"orbit\": N}");
      continue;
    }
    if (v.contains("camera")) {
      check_keys(v, {"camera", "name"}, path, errors);
      if (!v["camera"].is_string()) {
        errors.add(path + ".camera", "expected a camera JSON file");
        continue;
      }
      const std::string shown = v["camera"].get<std::string>();
      try {
        validate_camera(read_camera(plan.base / shown), shown);
      } catch (const Error& e) {
        errors.add(path + ".camera", e.what());
        continue;
      }
      const std::string name = v.contains("name") && v["name"].is_string()
                                   ? v["name"].get<std::string>()
                                   : stem_of(shown);
      plan.views.push_back({View::Kind::camera, unique_name(safe_name(name), used), "", shown,
                            plan.base / shown, 0, 1, path});
    } else if (v.contains("orbit")) {
      check_keys(v, {"orbit", "from", "name"}, path, errors);
      if (!v["orbit"].is_number_integer() || v["orbit"].get<long long>() < 1 ||
          v["orbit"].get<long long>() > 3600) {
        errors.add(path + ".orbit", "expected a number of views from 1 to 3600");
        continue;
      }
      std::string from = "anterior";
      if (v.contains("from")) {
        if (!v["from"].is_string() || !anatomical(v["from"].get<std::string>(), path + ".from"))
          continue;
        from = lower(v["from"].get<std::string>());
      }
      const std::string base = v.contains("name") && v["name"].is_string()
                                   ? safe_name(v["name"].get<std::string>())
                                   : "orbit";
      const int n = v["orbit"].get<int>();
      const int digits = static_cast<int>(std::to_string(std::max(0, n - 1)).size());
      for (int k = 0; k < n; ++k) {
        std::string step = std::to_string(k);
        step.insert(0, static_cast<std::size_t>(digits) - step.size(), '0');
        plan.views.push_back(
            {View::Kind::orbit, unique_name(base + step, used), from, "", {}, k, n, path});
      }
    } else {
      errors.add(path, "expected a view name, {\"camera\": FILE} or {\"orbit\": N}");
    }
  }
}

void read_styles(const json& doc, Plan& plan, Errors& errors) {
  const json* styles =
      entries(doc, "styles", "{\"command\": \"lines\"|\"render\"|\"hatch\", ...}", errors);
  if (!styles) return;
  std::set<std::string> used;
  for (std::size_t i = 0; i < styles->size(); ++i) {
    const json& s = (*styles)[i];
    const std::string path = "styles[" + std::to_string(i) + "]";
    if (!s.is_object() || !s.contains("command") || !s["command"].is_string()) {
      errors.add(path, "expected an object with \"command\": \"lines\", \"render\" or \"hatch\"");
      continue;
    }
    Style style;
    style.json_path = path;
    style.command = s["command"].get<std::string>();
    if (!drawing_commands().count(style.command)) {
      std::string known;
      for (const auto& [name, add] : drawing_commands())
        known += (known.empty() ? "" : ", ") + name;
      errors.add(path + ".command",
                 "unknown command \"" + style.command + "\" (this build: " + known + ")");
      continue;
    }
    if (s.contains("name") && (!s["name"].is_string() || s["name"].get<std::string>().empty())) {
      errors.add(path + ".name", "expected a non-empty string");
      continue;
    }
    style.name = safe_name(s.contains("name") ? s["name"].get<std::string>() : style.command);
    if (used.count(style.name))
      errors.add(path + ".name", "\"" + style.name + "\" is used by an earlier style");
    used.insert(style.name);

    const auto& allowed = command_formats().at(style.command);
    json formats = s.contains("formats") ? s["formats"] : json::array({allowed.front()});
    if (formats.is_string()) formats = json::array({formats});
    bool formats_ok = formats.is_array() && !formats.empty();
    for (const auto& f : formats) {
      if (!f.is_string() ||
          std::find(allowed.begin(), allowed.end(), lower(f.get<std::string>())) == allowed.end()) {
        formats_ok = false;
        break;
      }
      if (std::find(style.formats.begin(), style.formats.end(), lower(f.get<std::string>())) ==
          style.formats.end())
        style.formats.push_back(lower(f.get<std::string>()));
    }
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    if (!formats_ok)
      errors.add(path + ".formats", "expected an array of " + list + " for " + style.command);
    else if (style.command == "render" &&
             std::find(style.formats.begin(), style.formats.end(), "png") == style.formats.end())
      errors.add(path + ".formats",
                 "render always makes a png (add \"png\"; \"svg\" is its --svg)");

    const auto parser = make_parser(style.command);
    for (const auto& [key, value] : s.items()) {
      if (key == "command" || key == "name" || key == "formats") continue;
      const std::string kpath = path + "." + key;
      if (const auto r = reserved_keys().find(key); r != reserved_keys().end()) {
        errors.add(kpath, "not a style option: " + r->second);
        continue;
      }
      const CLI::Option* opt =
          key.size() > 1 ? parser->sub->get_option_no_throw("--" + key) : nullptr;
      if (!opt) {
        errors.add(kpath, "\"" + style.command + "\" has no option --" + key + " (see fabrica " +
                              style.command + " --help)");
        continue;
      }
      const bool flag = opt->get_type_size_max() == 0;
      if (flag && !value.is_boolean()) {
        errors.add(kpath, "--" + key + " is a flag: expected true or false");
        continue;
      }
      if (!flag && !(value.is_string() || value.is_number() ||
                     (value.is_array() && !value.empty() &&
                      std::all_of(value.begin(), value.end(),
                                  [](const json& x) { return x.is_string() || x.is_number(); })))) {
        errors.add(kpath, "expected a string, a number or an array of them");
        continue;
      }
      style.options.emplace_back(key, value);
      // The value through the command's own parser (types, ranges, choices).
      Style one = style;
      one.options = {{key, value}};
      std::vector<std::string> args{style.command, "input.off"}, recorded;
      append_style_options(one, plan, *parser->sub, args, recorded);
      args.insert(args.end(), {"-o", "output." + allowed.front()});
      std::string problem = check_args(args);
      if (problem.empty() && key == "size") {
        std::string e;
        if (!parse_size_value(value, e)) problem = e;
      }
      // Family lists, checked the way the commands check them.
      if (problem.empty() && (key == "types" || key == "lines" || key == "with-lines")) {
        try {
          parse_family_list(args[3], "--" + key, {}, key != "types");
        } catch (const Error& e) {
          problem = e.what();
        }
      }
      if (!problem.empty()) errors.add(kpath, problem);
    }
    plan.styles.push_back(std::move(style));
  }
}

}  // namespace

std::string check_args(const std::vector<std::string>& args) {
  try {
    auto parser = make_parser(args.at(0));
    std::vector<std::string> reversed(args.rbegin(), args.rend());
    parser->app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return e.what();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

void run_args(const std::vector<std::string>& args) {
  auto parser = make_parser(args.at(0));
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    parser->app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    throw InputError(std::string("fabrica ") + args.at(0) + ": " + e.what());
  }
  if (parser->action) parser->action();
}

std::string file_hash(const fs::path& path) {
  require_regular_file(path, path.string());  // a FIFO would block the batch forever
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open for reading");
  std::uint64_t h = 1469598103934665603ull;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    for (std::streamsize k = 0; k < in.gcount(); ++k) {
      h ^= static_cast<unsigned char>(buffer[static_cast<std::size_t>(k)]);
      h *= 1099511628211ull;
    }
  }
  if (in.bad()) throw InputError(path.string() + ": read error");
  char text[32];
  std::snprintf(text, sizeof text, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
  return text;
}

Item Plan::item(std::size_t index) const {
  Item it;
  it.index = index;
  const std::size_t s = index % styles.size(), v = (index / styles.size()) % views.size(),
                    i = index / (styles.size() * views.size());
  it.input = &inputs.at(i);
  it.view = &views.at(v);
  it.style = &styles.at(s);
  for (const auto& run : runs(it, {}))
    it.outputs.insert(it.outputs.end(), run.outputs.begin(), run.outputs.end());
  return it;
}

std::string Plan::orbit_camera_file(const Item& item) {
  return ".batch/cameras/" + item.input->name + "-" + item.view->name + "-" + item.style->name +
         ".json";
}

std::vector<Run> Plan::runs(const Item& item, const fs::path& dir) const {
  const Style& style = *item.style;
  const auto parser = make_parser(style.command);
  auto output_of = [&](const std::string& ext) {
    return substitute(output, {{"input", item.input->name},
                               {"view", item.view->name},
                               {"style", style.name},
                               {"ext", ext},
                               {"index", std::to_string(item.index)}});
  };
  std::vector<std::vector<std::string>> groups;  // formats made by one run
  if (style.command == "render") {
    groups.push_back({"png"});
    if (std::find(style.formats.begin(), style.formats.end(), "svg") != style.formats.end())
      groups.back().push_back("svg");
  } else {
    for (const auto& f : style.formats) groups.push_back({f});
  }
  std::vector<Run> out;
  for (const auto& group : groups) {
    Run run;
    auto both = [&](const std::string& arg, const std::string& shown) {
      run.args.push_back(arg);
      run.recorded.push_back(shown);
    };
    both(style.command, style.command);
    both(item.input->kind == Input::Kind::volume_label
             ? (dir / ".batch" / "volumes" / (item.input->name + ".ply")).string()
             : item.input->path.string(),
         item.input->kind == Input::Kind::volume_label
             ? item.input->shown + "#label" + std::to_string(item.input->label)
             : item.input->shown);
    if (item.view->kind == View::Kind::anatomical) {
      both("--view", "--view");
      both(item.view->anatomical, item.view->anatomical);
    } else {
      both("--camera", "--camera");
      if (item.view->kind == View::Kind::orbit)
        both((dir / orbit_camera_file(item)).string(), orbit_camera_file(item));
      else
        both(item.view->camera.string(), item.view->shown);
    }
    const bool style_size = std::any_of(style.options.begin(), style.options.end(),
                                        [](const auto& o) { return o.first == "size"; });
    if (size && !style_size) {
      both("--size", "--size");
      both(size_text(*size), size_text(*size));
    }
    append_style_options(style, *this, *parser->sub, run.args, run.recorded);
    both("--quiet", "--quiet");
    for (std::size_t k = 0; k < group.size(); ++k) {
      const std::string rel = output_of(group[k]);
      both(k == 0 ? "-o" : "--" + group[k], k == 0 ? "-o" : "--" + group[k]);
      both((dir / rel).string(), rel);
      run.outputs.push_back(rel);
    }
    out.push_back(std::move(run));
  }
  return out;
}

Plan read_plan(const fs::path& manifest) {
  Plan plan;
  plan.manifest = manifest;
  plan.base = fs::absolute(manifest).parent_path();
  std::ifstream in(manifest, std::ios::binary);
  if (!in) throw InputError(manifest.string() + ": cannot open the manifest");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(manifest.string() + ": not valid JSON (" + e.what() + ")");
  }
  plan.manifest_hash = file_hash(manifest);
  if (!doc.is_object()) throw InputError(manifest.string() + ": expected a JSON object");
  Errors errors;
  check_keys(doc, {"inputs", "views", "styles", "size", "output"}, "$", errors);
  if (doc.contains("size")) {
    std::string e;
    plan.size = parse_size_value(doc["size"], e);
    if (!plan.size) errors.add("size", e);
  }
  if (doc.contains("output")) {
    if (!doc["output"].is_string())
      errors.add("output", "expected a pattern such as \"{input}/{style}-{view}.{ext}\"");
    else
      plan.output = doc["output"].get<std::string>();
  }
  const fs::path pattern(plan.output);
  if (plan.output.find("{ext}") == std::string::npos)
    errors.add("output", "the pattern must contain {ext}");
  if (pattern.is_absolute() ||
      std::any_of(pattern.begin(), pattern.end(), [](const fs::path& p) { return p == ".."; }))
    errors.add("output", "must be a relative path inside the output folder (no leading / or ..)");
  read_inputs(doc, plan, errors);
  read_views(doc, plan, errors);
  read_styles(doc, plan, errors);
  for (const auto& input : plan.inputs)
    for (const auto& style : plan.styles)
      for (const auto& f : style.formats)
        if (input.kind == Input::Kind::scene && style.command == "lines" && f != "svg" &&
            f != "pdf")
          errors.add(style.json_path + ".formats",
                     "a scene's lines are written as svg or pdf (a layer per structure), not " + f +
                         " (" + input.json_path + " is a scene)");
  if (errors.list.empty()) {  // every output distinct
    std::map<std::string, std::size_t> seen;
    for (std::size_t k = 0; k < plan.item_count(); ++k)
      for (const auto& o : plan.item(k).outputs)
        if (const auto [it, fresh] = seen.emplace(o, k); !fresh) {
          errors.add("output", "items " + std::to_string(it->second) + " and " + std::to_string(k) +
                                   " would both write " + o +
                                   " (use {input}, {view}, {style} and {ext})");
          break;
        }
  }
  std::vector<std::string> listed;  // in manifest order, each once
  for (const auto& e : errors.list)
    if (std::find(listed.begin(), listed.end(), e) == listed.end()) listed.push_back(e);
  errors.list = listed;
  if (!errors.list.empty()) {
    std::string message = manifest.string() + ": " + std::to_string(errors.list.size()) +
                          " problem(s) in the manifest, nothing was done:";
    for (const auto& e : errors.list) message += "\n  " + e;
    throw InputError(message);
  }
  return plan;
}

}  // namespace fabrica::cli::batch
