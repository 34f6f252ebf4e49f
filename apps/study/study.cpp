#include "study.hpp"

#include <algorithm>
#include <fstream>
#include <map>
#include <set>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "log.hpp"

namespace fabrica::study {
namespace {

enum class Kind { flag, value, paths };

/// The options of each `fabrica` command a technique may set (docs/cli.md),
/// without those the study sets itself (input, -o, --camera, --view, --size,
/// --quiet) or that write extra files.
const std::map<std::string, std::map<std::string, Kind>>& command_options() {
  static const std::map<std::string, std::map<std::string, Kind>> options = {
      {"render",
       {{"style", Kind::value},
        {"lines", Kind::value},
        {"hybrid-ar", Kind::flag},
        {"tau", Kind::value},
        {"lambda", Kind::value},
        {"threshold", Kind::value},
        {"no-fade", Kind::flag},
        {"per-fragment", Kind::flag},
        {"sign-free", Kind::flag},
        {"float-target", Kind::flag},
        {"context", Kind::paths},
        {"context-opacity", Kind::value},
        {"smooth", Kind::value},
        {"line-width", Kind::value},
        {"hidden", Kind::value},
        {"transparent", Kind::flag},
        {"backend", Kind::value},
        {"space", Kind::value}}},
      {"lines",
       {{"space", Kind::value},
        {"types", Kind::value},
        {"feature-size", Kind::value},
        {"suggestive-threshold", Kind::value},
        {"highlight-threshold", Kind::value},
        {"ridge-threshold", Kind::value},
        {"valley-threshold", Kind::value},
        {"apparent-threshold", Kind::value},
        {"pel-threshold", Kind::value},
        {"laplacian-threshold", Kind::value},
        {"demarcating-threshold", Kind::value},
        {"crease-angle", Kind::value},
        {"light", Kind::value},
        {"mesh-edge-contours", Kind::flag},
        {"no-visibility", Kind::flag},
        {"hidden", Kind::value},
        {"min-length", Kind::value},
        {"smooth", Kind::value},
        {"width", Kind::value},
        {"no-fade", Kind::flag},
        {"no-taper", Kind::flag},
        {"keep-orientation", Kind::flag}}},
      {"hatch",
       {{"space", Kind::value},
        {"light", Kind::value},
        {"threshold", Kind::value},
        {"grid-depth", Kind::value},
        {"seed-depth", Kind::value},
        {"uniform-depth", Kind::flag},
        {"stroke-width", Kind::value},
        {"max-length", Kind::value},
        {"min-length", Kind::value},
        {"no-ridge-removal", Kind::flag},
        {"ridge-angle", Kind::value},
        {"draw-ridges", Kind::flag},
        {"with-lines", Kind::value},
        {"line-width", Kind::value},
        {"transparent", Kind::flag},
        {"backend", Kind::value},
        {"threads", Kind::value}}}};
  return options;
}

/// Validation context: the file and a JSON path, for one-line messages.
struct Where {
  std::string file;
  std::string path;
  Where at(const std::string& key) const { return {file, path.empty() ? key : path + "." + key}; }
  Where at(std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(file + ": " + (path.empty() ? "(top level)" : path) + ": " + what);
  }
};

void check_keys(const nlohmann::json& j, const Where& w,
                std::initializer_list<const char*> allowed) {
  if (!j.is_object()) w.fail("expected a JSON object");
  for (const auto& [key, value] : j.items()) {
    if (std::find_if(allowed.begin(), allowed.end(), [&](const char* a) { return key == a; }) ==
        allowed.end()) {
      w.at(key).fail("unknown key (known here: " +
                     join(std::vector<std::string>(allowed.begin(), allowed.end()), ", ") + ")");
    }
  }
}

std::string get_string(const nlohmann::json& j, const char* key, const Where& w, bool required,
                       const std::string& fallback = {}) {
  if (!j.contains(key)) {
    if (required) w.at(key).fail("missing (required)");
    return fallback;
  }
  if (!j[key].is_string()) w.at(key).fail("expected a string");
  return j[key].get<std::string>();
}

int get_int(const nlohmann::json& j, const char* key, const Where& w, int fallback, int lo,
            int hi) {
  if (!j.contains(key)) return fallback;
  if (!j[key].is_number_integer()) w.at(key).fail("expected an integer");
  const auto v = j[key].get<long long>();
  if (v < lo || v > hi)
    w.at(key).fail("must be between " + std::to_string(lo) + " and " + std::to_string(hi) +
                   " (got " + std::to_string(v) + ")");
  return static_cast<int>(v);
}

std::filesystem::path resolve(const std::filesystem::path& base, const std::string& p) {
  const std::filesystem::path path(p);
  return path.is_absolute() ? path : base / path;
}

Technique parse_technique(const nlohmann::json& j, const Where& w,
                          const std::filesystem::path& base) {
  if (!j.is_object()) w.fail("expected a JSON object");
  Technique t;
  t.name = get_string(j, "name", w, true);
  if (!valid_name(t.name))
    w.at("name").fail("use 1 to 64 of A-Z a-z 0-9 _ - (got \"" + t.name + "\")");
  t.command = get_string(j, "command", w, true);
  const auto cmd = command_options().find(t.command);
  if (cmd == command_options().end())
    w.at("command").fail("must be render, lines or hatch (got \"" + t.command + "\")");
  for (const auto& [key, value] : j.items()) {
    if (key == "name" || key == "command") continue;
    const auto opt = cmd->second.find(key);
    if (opt == cmd->second.end())
      w.at(key).fail("unknown key: not an option of `fabrica " + t.command +
                     "` that a study may set (see `fabrica " + t.command + " --help`)");
    switch (opt->second) {
      case Kind::flag:
        if (!value.is_boolean()) w.at(key).fail("expected true or false (a flag)");
        break;
      case Kind::value:
        if (!value.is_string() && !value.is_number()) w.at(key).fail("expected a string or number");
        break;
      case Kind::paths: {
        nlohmann::json list = value.is_array() ? value : nlohmann::json::array({value});
        for (auto& p : list) {
          if (!p.is_string()) w.at(key).fail("expected a path or a list of paths");
          p = resolve(base, p.get<std::string>()).string();
        }
        t.options[key] = list;
        continue;
      }
    }
    t.options[key] = value;
  }
  return t;
}

Model parse_model(const nlohmann::json& j, const Where& w, const std::filesystem::path& base) {
  check_keys(j, w, {"mesh", "scene", "name"});
  Model m;
  if (j.contains("mesh") == j.contains("scene"))
    w.fail("give exactly one of \"mesh\" or \"scene\"");
  const char* key = j.contains("mesh") ? "mesh" : "scene";
  m.scene = !j.contains("mesh");
  m.path = resolve(base, get_string(j, key, w, true));
  if (!std::filesystem::is_regular_file(m.path))
    w.at(key).fail(m.path.string() + " does not exist (paths are relative to the study file)");
  m.name = get_string(j, "name", w, false, m.path.stem().string());
  if (!valid_name(m.name))
    w.at("name").fail("model name \"" + m.name +
                      "\" is not 1 to 64 of A-Z a-z 0-9 _ -; set \"name\"");
  return m;
}

View parse_view(const nlohmann::json& j, const Where& w, const std::filesystem::path& base) {
  View v;
  if (j.is_string()) {
    v.name = j.get<std::string>();
    if (!parse_anatomical_view(v.name))
      w.fail("unknown view \"" + v.name +
             "\" (anterior, posterior, left, right, superior, inferior, or {\"camera\": PATH})");
    return v;
  }
  check_keys(j, w, {"camera", "name"});
  v.camera = resolve(base, get_string(j, "camera", w, true));
  if (!std::filesystem::is_regular_file(v.camera))
    w.at("camera").fail(v.camera.string() + " does not exist");
  v.name = get_string(j, "name", w, false, v.camera.stem().string());
  if (!valid_name(v.name)) w.at("name").fail("view name is not 1 to 64 of A-Z a-z 0-9 _ -");
  return v;
}

Block parse_block(const nlohmann::json& j, const Where& w, const Study& s) {
  if (!j.is_object()) w.fail("expected a JSON object");
  const std::string task = get_string(j, "task", w, true);
  Block b;
  const int max_n = 100000;
  if (task == "gauge") {
    check_keys(j, w,
               {"task", "points_per_stimulus", "instructions", "practice", "attention_checks",
                "techniques", "question"});
    b.task = Task::gauge;
    b.points_per_stimulus = get_int(j, "points_per_stimulus", w, 4, 1, 1000);
    b.question = "Turn the gauge so that its disc lies flat on the surface.";
  } else if (task == "2afc") {
    check_keys(j, w,
               {"task", "question", "pairs", "repeats", "instructions", "practice",
                "attention_checks", "techniques"});
    b.task = Task::afc2;
    if (j.contains("pairs") && j["pairs"] != "all")
      w.at("pairs").fail("only \"all\" is supported (every pair of techniques)");
    b.repeats = get_int(j, "repeats", w, 1, 1, max_n);
    b.question = "Which picture shows the shape better?";
  } else if (task == "likert") {
    check_keys(j, w,
               {"task", "scale", "question", "instructions", "practice", "attention_checks",
                "techniques"});
    b.task = Task::likert;
    b.scale = get_int(j, "scale", w, 7, 2, 11);
    b.question = "How well does the picture show the shape?";
  } else if (task == "ranking") {
    check_keys(j, w, {"task", "question", "instructions", "practice", "techniques"});
    b.task = Task::ranking;
    b.question = "Order the pictures from best (left) to worst (right).";
  } else {
    w.at("task").fail("must be gauge, 2afc, likert or ranking (got \"" + task + "\")");
  }
  b.question = get_string(j, "question", w, false, b.question);
  b.instructions = get_string(j, "instructions", w, false);
  b.practice = get_int(j, "practice", w, 0, 0, 1000);
  b.attention_checks = get_int(j, "attention_checks", w, 0, 0, 1000);
  if (j.contains("techniques")) {
    const auto& list = j["techniques"];
    if (!list.is_array()) w.at("techniques").fail("expected a list of technique names");
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (!list[i].is_string()) w.at("techniques").at(i).fail("expected a technique name");
      const std::string n = list[i].get<std::string>();
      if (std::none_of(s.techniques.begin(), s.techniques.end(),
                       [&](const Technique& t) { return t.name == n; }))
        w.at("techniques").at(i).fail("no technique named \"" + n + "\"");
      b.techniques.push_back(n);
    }
  } else {
    for (const auto& t : s.techniques) b.techniques.push_back(t.name);
  }
  if ((b.task == Task::afc2 || b.task == Task::ranking) && b.techniques.size() < 2)
    w.fail(std::string(task_name(b.task)) + " needs at least two techniques");
  return b;
}

template <class T, class F>
std::vector<T> parse_list(const nlohmann::json& j, const char* key, const Where& w, F&& parse) {
  if (!j.contains(key)) w.at(key).fail("missing (required)");
  const auto& list = j[key];
  if (!list.is_array() || list.empty()) w.at(key).fail("expected a non-empty list");
  std::vector<T> out;
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    out.push_back(parse(list[i], w.at(key).at(i)));
    if constexpr (requires { out.back().name; })
      if (!names.insert(out.back().name).second)
        w.at(key).at(i).fail("the name \"" + out.back().name + "\" is used twice");
  }
  return out;
}

}  // namespace

const char* task_name(Task task) {
  switch (task) {
    case Task::gauge:
      return "gauge";
    case Task::afc2:
      return "2afc";
    case Task::likert:
      return "likert";
    case Task::ranking:
      return "ranking";
  }
  return "?";
}

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](unsigned char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

const Technique& Study::technique(const std::string& n) const {
  return techniques[technique_index(n)];
}

std::size_t Study::technique_index(const std::string& n) const {
  for (std::size_t i = 0; i < techniques.size(); ++i)
    if (techniques[i].name == n) return i;
  throw Error(ErrorKind::internal, "no technique named " + n);
}

Study parse_study(const nlohmann::json& j, const std::filesystem::path& file) {
  const Where w{file.string(), ""};
  check_keys(j, w,
             {"name", "seed", "techniques", "models", "views", "size", "blocks", "welcome",
              "goodbye", "break_every", "description"});
  const std::filesystem::path base = file.parent_path();
  Study s;
  s.file = file;
  s.name = get_string(j, "name", w, true);
  if (!j.contains("seed") || !j["seed"].is_number_unsigned())
    w.at("seed").fail(
        "expected a non-negative integer (required: it makes every plan reproducible)");
  s.seed = j["seed"].get<std::uint64_t>();
  s.techniques = parse_list<Technique>(
      j, "techniques", w,
      [&](const nlohmann::json& t, const Where& tw) { return parse_technique(t, tw, base); });
  s.models = parse_list<Model>(j, "models", w, [&](const nlohmann::json& m, const Where& mw) {
    return parse_model(m, mw, base);
  });
  s.views = parse_list<View>(j, "views", w, [&](const nlohmann::json& v, const Where& vw) {
    return parse_view(v, vw, base);
  });
  for (std::size_t m = 0; m < s.models.size(); ++m)
    for (const auto& t : s.techniques)
      if (s.models[m].scene && t.command != "render")
        w.at("models").at(m).fail("a scene is drawn by render techniques only; technique \"" +
                                  t.name + "\" uses " + t.command + " (give the mesh instead)");
  if (j.contains("size")) {
    const auto& size = j["size"];
    if (!size.is_array() || size.size() != 2 || !size[0].is_number_integer() ||
        !size[1].is_number_integer() || size[0].get<long long>() < 16 ||
        size[1].get<long long>() < 16 || size[0].get<long long>() > 4096 ||
        size[1].get<long long>() > 4096)  // long long: a huge int64 must not wrap into range
      w.at("size").fail("expected [WIDTH, HEIGHT] in pixels, each 16 to 4096");
    s.width = size[0].get<int>();
    s.height = size[1].get<int>();
  }
  s.blocks = parse_list<Block>(j, "blocks", w, [&](const nlohmann::json& b, const Where& bw) {
    return parse_block(b, bw, s);
  });
  s.welcome = get_string(j, "welcome", w, false,
                         "Welcome, and thank you for taking part in \"" + s.name + "\".");
  s.goodbye = get_string(j, "goodbye", w, false, "Thank you! The study is complete.");
  get_string(j, "description", w, false);
  s.break_every = get_int(j, "break_every", w, 0, 0, 100000);
  return s;
}

Study read_study(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot read the study file (does it exist?)");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path.string() + ": not valid JSON (" + e.what() + ")");
  }
  return parse_study(j, path);
}

}  // namespace fabrica::study
