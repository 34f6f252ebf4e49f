#include "fabrica/render/scene.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"

namespace fabrica::render {

StructureStyle default_style(Role role) {
  StructureStyle s;
  if (role == Role::focus) {
    s.shading = Shading::lambert;
    s.color = {0.93f, 0.87f, 0.80f, 1.0f};
    s.opacity = 1.0;
    s.families = {LineFamily::contour, LineFamily::boundary, LineFamily::apparent};
    s.lines.color = {0.0f, 0.0f, 0.0f, 1.0f};
    s.lines.width = 2.0;
  } else {
    s.shading = Shading::lambert;
    s.color = {0.78f, 0.84f, 0.92f, 1.0f};
    s.opacity = 0.25;
    s.ambient = 0.5;
    s.families = {LineFamily::contour, LineFamily::boundary};
    s.lines.color = {0.25f, 0.3f, 0.4f, 0.5f};
    s.lines.width = 1.2;
    s.lines.contour_width_factor = 1.0;
  }
  return s;
}

namespace {

std::string lower(std::string_view s) {
  std::string r(s);
  std::transform(r.begin(), r.end(), r.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return r;
}

Color color_from_json(const nlohmann::json& j, const std::string& what) {
  if (!j.is_array() || (j.size() != 3 && j.size() != 4))
    throw InputError(what + " must be an array [r, g, b] or [r, g, b, a] of numbers in [0, 1]");
  float c[4] = {0, 0, 0, 1};
  for (std::size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number()) throw InputError(what + " must contain numbers");
    const double v = j[i].get<double>();
    if (!(v >= 0.0 && v <= 1.0)) throw InputError(what + " components must be in [0, 1]");
    c[i] = static_cast<float>(v);
  }
  return {c[0], c[1], c[2], c[3]};
}

nlohmann::json color_to_json(const Color& c) {
  return {c.r, c.g, c.b, c.a};
}

double number(const nlohmann::json& j, const char* key, double lo, double hi,
              const std::string& what) {
  const auto& v = j.at(key);
  if (!v.is_number()) throw InputError(what + ": '" + key + "' must be a number");
  const double d = v.get<double>();
  if (!(d >= lo && d <= hi))
    throw InputError(what + ": '" + key + "' must be between " + std::to_string(lo) + " and " +
                     std::to_string(hi));
  return d;
}

std::string text(const nlohmann::json& j, const char* key, const std::string& what) {
  const auto& v = j.at(key);
  if (!v.is_string()) throw InputError(what + ": '" + key + "' must be a string");
  return v.get<std::string>();
}

}  // namespace

const char* to_string(Role r) {
  return r == Role::focus ? "focus" : "context";
}
const char* to_string(Shading s) {
  switch (s) {
    case Shading::none:
      return "none";
    case Shading::flat:
      return "flat";
    case Shading::lambert:
      return "lambert";
    case Shading::toon:
      return "toon";
  }
  return "?";
}
const char* to_string(HiddenLines h) {
  switch (h) {
    case HiddenLines::omit:
      return "omit";
    case HiddenLines::dashed:
      return "dashed";
    case HiddenLines::show:
      return "show";
  }
  return "?";
}
std::optional<Role> parse_role(std::string_view s) {
  const auto l = lower(s);
  if (l == "focus") return Role::focus;
  if (l == "context") return Role::context;
  return std::nullopt;
}
std::optional<Shading> parse_shading(std::string_view s) {
  const auto l = lower(s);
  if (l == "none") return Shading::none;
  if (l == "flat") return Shading::flat;
  if (l == "lambert") return Shading::lambert;
  if (l == "toon") return Shading::toon;
  return std::nullopt;
}
std::optional<HiddenLines> parse_hidden_lines(std::string_view s) {
  const auto l = lower(s);
  if (l == "omit" || l == "hide" || l == "hidden") return HiddenLines::omit;
  if (l == "dashed") return HiddenLines::dashed;
  if (l == "show") return HiddenLines::show;
  return std::nullopt;
}

SceneSpec scene_spec_from_json(const nlohmann::json& j, const std::filesystem::path& base_dir,
                               const std::string& what) {
  if (!j.is_object()) throw InputError(what + ": a scene must be a JSON object");
  SceneSpec spec;
  try {
    if (j.contains("background"))
      spec.background = color_from_json(j["background"], what + ": background");
    if (j.contains("transparent")) spec.transparent = j.at("transparent").get<bool>();
    if (j.contains("camera")) spec.camera = camera_from_json(j["camera"], what + ": camera");
    if (j.contains("view")) {
      const std::string v = text(j, "view", what);
      spec.view = parse_anatomical_view(v);
      if (!spec.view)
        throw InputError(what + ": unknown view '" + v +
                         "' (anterior, posterior, left, right, superior, inferior)");
    }
    if (!j.contains("structures") || !j["structures"].is_array() || j["structures"].empty())
      throw InputError(what + ": 'structures' must be a non-empty array");
    std::size_t index = 0;
    for (const auto& s : j["structures"]) {
      const std::string w = what + ": structures[" + std::to_string(index++) + "]";
      if (!s.is_object()) throw InputError(w + " must be an object");
      StructureSpec st;
      if (!s.contains("mesh")) throw InputError(w + ": 'mesh' (a file path) is required");
      st.mesh = text(s, "mesh", w);
      if (st.mesh.is_relative()) st.mesh = base_dir / st.mesh;
      st.name = s.contains("name") ? text(s, "name", w) : st.mesh.stem().string();
      if (s.contains("role")) {
        const auto r = parse_role(text(s, "role", w));
        if (!r) throw InputError(w + ": role must be \"focus\" or \"context\"");
        st.role = *r;
      }
      st.style = default_style(st.role);
      if (s.contains("space")) {
        const std::string sp = lower(text(s, "space", w));
        if (sp == "lps")
          st.space = Space::lps;
        else if (sp == "ras")
          st.space = Space::ras;
        else
          throw InputError(w + ": space must be \"lps\" or \"ras\"");
      }
      if (s.contains("shading")) {
        const auto sh = parse_shading(text(s, "shading", w));
        if (!sh) throw InputError(w + ": shading must be none, flat, lambert or toon");
        st.style.shading = *sh;
      }
      if (s.contains("color")) st.style.color = color_from_json(s["color"], w + ": color");
      if (s.contains("opacity")) st.style.opacity = number(s, "opacity", 0.0, 1.0, w);
      if (s.contains("ambient")) st.style.ambient = number(s, "ambient", 0.0, 1.0, w);
      if (s.contains("toon_levels"))
        st.style.toon_levels = static_cast<int>(number(s, "toon_levels", 2, 16, w));
      if (s.contains("lines")) {
        if (!s["lines"].is_array())
          throw InputError(w + ": 'lines' must be an array of family names");
        st.style.families.clear();
        for (const auto& f : s["lines"]) {
          if (!f.is_string()) throw InputError(w + ": 'lines' must contain family names");
          const auto fam = parse_family(f.get<std::string>());
          if (!fam) throw InputError(w + ": unknown line family '" + f.get<std::string>() + "'");
          st.style.families.push_back(*fam);
        }
      }
      if (s.contains("line_color"))
        st.style.lines.color = color_from_json(s["line_color"], w + ": line_color");
      if (s.contains("line_width")) st.style.lines.width = number(s, "line_width", 0.0, 200.0, w);
      if (s.contains("taper")) st.style.lines.taper = number(s, "taper", 0.0, 0.5, w);
      if (s.contains("fade")) st.style.lines.fade_by_strength = s.at("fade").get<bool>();
      if (s.contains("hidden")) {
        const auto h = parse_hidden_lines(text(s, "hidden", w));
        if (!h) throw InputError(w + ": hidden must be omit, dashed or show");
        st.style.lines.hidden = *h;
      }
      if (s.contains("hybrid")) st.style.hybrid_apparent_ridges = s.at("hybrid").get<bool>();
      if (s.contains("smooth")) st.style.smooth = static_cast<int>(number(s, "smooth", 0, 1000, w));
      spec.structures.push_back(std::move(st));
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(what + ": " + e.what());
  }
  return spec;
}

nlohmann::json scene_spec_to_json(const SceneSpec& spec) {
  nlohmann::json j;
  j["background"] = color_to_json(spec.background);
  j["transparent"] = spec.transparent;
  if (spec.camera) j["camera"] = camera_to_json(*spec.camera);
  if (spec.view) j["view"] = to_string(*spec.view);
  nlohmann::json list = nlohmann::json::array();
  for (const auto& s : spec.structures) {
    nlohmann::json o;
    o["name"] = s.name;
    o["mesh"] = s.mesh.generic_string();
    o["role"] = to_string(s.role);
    if (s.space) o["space"] = *s.space == Space::lps ? "lps" : "ras";
    o["shading"] = to_string(s.style.shading);
    o["color"] = color_to_json(s.style.color);
    o["opacity"] = s.style.opacity;
    o["ambient"] = s.style.ambient;
    o["toon_levels"] = s.style.toon_levels;
    nlohmann::json fams = nlohmann::json::array();
    for (auto f : s.style.families) fams.push_back(family_name(f));
    o["lines"] = fams;
    o["line_color"] = color_to_json(s.style.lines.color);
    o["line_width"] = s.style.lines.width;
    o["taper"] = s.style.lines.taper;
    o["fade"] = s.style.lines.fade_by_strength;
    o["hidden"] = to_string(s.style.lines.hidden);
    o["hybrid"] = s.style.hybrid_apparent_ridges;
    if (s.style.smooth > 0) o["smooth"] = s.style.smooth;
    list.push_back(o);
  }
  j["structures"] = list;
  return j;
}

SceneSpec read_scene_spec(const std::filesystem::path& path) {
  const std::string text = read_input_file(path, path.string() + " (scene file)", kMaxJsonBytes);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path.string() + ": not valid JSON (" + e.what() + ")");
  }
  return scene_spec_from_json(j, path.parent_path(), path.string());
}

void write_scene_spec(const SceneSpec& spec, const std::filesystem::path& path) {
  const std::string text = scene_spec_to_json(spec).dump(2) + "\n";
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace fabrica::render
