#include "fabrica/render/scene.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"
#include "fabrica/core/suggest.hpp"

namespace fabrica::render {

std::string to_hex(const Color& c) {
  auto byte = [](float v) {
    return static_cast<int>(std::lround(std::clamp(static_cast<double>(v), 0.0, 1.0) * 255.0));
  };
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", byte(c.r), byte(c.g), byte(c.b));
  return buf;
}

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

// Where a value sits in the scene, for messages: "structures[2].opacity".
std::string at(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

const char* type_name(const nlohmann::json& v) {
  return v.type_name();
}

// Every key of `object` must be one of `known`; else InputError naming the
// path and the closest known key.
void check_keys(const nlohmann::json& object, const std::vector<std::string>& known,
                const std::string& what, const std::string& path) {
  for (const auto& item : object.items())
    if (std::find(known.begin(), known.end(), item.key()) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw InputError(what + ": " + at(path, item.key()) + ": unknown key" +
                       did_you_mean(item.key(), known) + " (known here: " + list + ")");
    }
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
              const std::string& what, const std::string& path) {
  const auto& v = j.at(key);
  if (!v.is_number())
    throw InputError(what + ": " + at(path, key) + " must be a number (got " + type_name(v) + ")");
  const double d = v.get<double>();
  if (!(d >= lo && d <= hi))
    throw InputError(what + ": " + at(path, key) + " must be between " + std::to_string(lo) +
                     " and " + std::to_string(hi));
  return d;
}

std::string text(const nlohmann::json& j, const char* key, const std::string& what,
                 const std::string& path) {
  const auto& v = j.at(key);
  if (!v.is_string())
    throw InputError(what + ": " + at(path, key) + " must be a string (got " + type_name(v) + ")");
  return v.get<std::string>();
}

bool boolean(const nlohmann::json& j, const char* key, const std::string& what,
             const std::string& path) {
  const auto& v = j.at(key);
  if (!v.is_boolean())
    throw InputError(what + ": " + at(path, key) + " must be true or false (got " + type_name(v) +
                     ")");
  return v.get<bool>();
}

// An enumerated value: parsed, or InputError listing the choices.
template <typename T, typename Parse>
T choice(const nlohmann::json& j, const char* key, Parse parse,
         const std::vector<std::string>& choices, const std::string& what,
         const std::string& path) {
  const std::string v = text(j, key, what, path);
  const std::optional<T> parsed = parse(v);
  if (parsed) return *parsed;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
  throw InputError(what + ": " + at(path, key) + ": unknown value '" + v + "'" +
                   did_you_mean(v, choices) + " (use " + list + ")");
}

const std::vector<std::string> kSceneKeys = {"background", "transparent", "camera",     "view",
                                             "frame",      "structures",  "annotation", "lic",
                                             "clip",       "cutaway"};
const std::vector<std::string> kAnnotationKeys = {"labels", "legend", "scale_bar", "orientation",
                                                  "font_size"};
const std::vector<std::string> kLicKeys = {"kernel_length", "noise_scale", "strength"};
const std::vector<std::string> kClipKeys = {"point", "normal"};
const std::vector<std::string> kCutawayKeys = {"enabled", "margin_px", "fade_px", "rim",
                                               "rim_color"};
// structures[].hatching as an object: numbers with their ranges (lo, hi,
// whether lo itself is allowed), the flags, and "method".
struct HatchingNumber {
  const char* key;
  double lo, hi;
  bool lo_allowed;
};
const HatchingNumber kHatchingNumbers[] = {
    {"contour_margin", 0.0, 1.0, false},    {"convex_threshold", 0.0, 1e6, false},
    {"concave_threshold", 0.0, 1e6, false}, {"umbilic_threshold", 0.0, 1e6, true},
    {"spacing", 0.0, 1e6, false},           {"min_weight", 0.0, 1.0, true},
    {"min_length", 0.0, 1e6, true},         {"max_length", 0.0, 1e6, true}};
const std::vector<std::string> kHatchingFlags = {"no_contours", "no_features"};
const std::vector<std::string> kHatchingMethods = {"shading", "confis"};

Vec3 vec3_from_json(const nlohmann::json& j, const std::string& what) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    throw InputError(what + " must be an array of three numbers");
  const Vec3 v(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  if (!v.allFinite()) throw InputError(what + " must be finite");
  return v;
}
const std::vector<std::string> kStructureKeys = {
    "name",    "mesh",        "role",   "space",      "shading",    "color",   "opacity",
    "ambient", "toon_levels", "lines",  "line_color", "line_width", "taper",   "fade",
    "hidden",  "hybrid",      "smooth", "lic",        "label",      "hatching"};
const std::vector<std::string> kCameraKeys = {"eye",   "center", "up",   "fov_deg", "projection",
                                              "width", "height", "near", "far"};
const std::vector<std::string> kViews = {"anterior", "posterior", "left",
                                         "right",    "superior",  "inferior"};

}  // namespace

namespace {

HatchingSpec hatching_spec(const nlohmann::json& j, const std::string& what,
                           const std::string& path) {
  std::vector<std::string> known = {"method"};
  for (const auto& n : kHatchingNumbers) known.push_back(n.key);
  known.insert(known.end(), kHatchingFlags.begin(), kHatchingFlags.end());
  check_keys(j, known, what, path);
  HatchingSpec h;
  if (j.contains("method")) {
    h.method = lower(text(j, "method", what, path));
    if (std::find(kHatchingMethods.begin(), kHatchingMethods.end(), h.method) ==
        kHatchingMethods.end())
      throw InputError(what + ": " + at(path, "method") + ": unknown method \"" +
                       j["method"].get<std::string>() + "\" (use shading or confis)" +
                       did_you_mean(h.method, kHatchingMethods));
  }
  for (const auto& n : kHatchingNumbers) {
    if (!j.contains(n.key)) continue;
    const double v = number(j, n.key, n.lo, n.hi, what, path);
    if (!n.lo_allowed && !(v > n.lo))
      throw InputError(what + ": " + at(path, n.key) + " must be greater than " +
                       std::to_string(n.lo));
    h.numbers[n.key] = v;
  }
  for (const auto& key : kHatchingFlags)
    if (j.contains(key)) h.flags[key] = boolean(j, key.c_str(), what, path);
  const std::string method = h.method.empty() ? "confis" : h.method;
  if (method == "shading")
    for (const auto& [key, v] : h.numbers)
      if (key != "min_length" && key != "max_length")
        throw InputError(what + ": " + at(path, key) + ": only for \"method\": \"confis\"");
  if (method == "shading" && !h.flags.empty())
    throw InputError(what + ": " + at(path, h.flags.begin()->first) +
                     ": only for \"method\": \"confis\"");
  return h;
}

}  // namespace

const char* to_string(Frame f) {
  return f == Frame::focus ? "focus" : "all";
}
std::optional<Frame> parse_frame(std::string_view s) {
  const auto l = lower(s);
  if (l == "focus") return Frame::focus;
  if (l == "all") return Frame::all;
  return std::nullopt;
}

Frame default_frame(const SceneSpec& spec, std::optional<Frame> frame) {
  if (frame) return *frame;
  if (spec.frame) return *spec.frame;
  const auto has = [&](Role r) {
    return std::any_of(spec.structures.begin(), spec.structures.end(),
                       [r](const StructureSpec& s) { return s.role == r; });
  };
  return has(Role::focus) && has(Role::context) ? Frame::focus : Frame::all;
}

Camera fit_camera(AnatomicalView view, const BoundingBox& box, Space space, int width, int height,
                  double fill) {
  Camera c = anatomical_camera(view, box, space, width, height);
  if (!(fill > 0.0 && fill <= 1.0)) fill = 0.6;
  // Projected half-extent of the box (fraction of the picture's half size);
  // the perspective projection is not linear in the distance, so a few
  // rounds of "move the eye so the fraction becomes `fill`" converge.
  auto extent = [&](const Camera& cam) {
    double e = 0.0;
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner((k & 1) ? box.max.x() : box.min.x(), (k & 2) ? box.max.y() : box.min.y(),
                        (k & 4) ? box.max.z() : box.min.z());
      const ProjectedPoint p = project(cam, corner);
      if (!(p.depth > 0.0)) return std::numeric_limits<double>::infinity();
      e = std::max({e, std::abs(p.pixel.x() - 0.5 * cam.width) / (0.5 * cam.width),
                    std::abs(p.pixel.y() - 0.5 * cam.height) / (0.5 * cam.height)});
    }
    return e;
  };
  for (int round = 0; round < 8; ++round) {
    const double e = extent(c);
    if (!std::isfinite(e) || e <= 0.0) break;
    const double distance = (c.eye - c.center).norm();
    const double wanted = distance * e / fill;
    if (std::abs(wanted - distance) < 1e-4 * distance) break;
    c.eye = c.center - c.forward() * wanted;
  }
  return c;
}

namespace {

// fabrica's anatomical palette (docs/segmentation.md): the conventions of
// anatomical atlases and of 3D Slicer's and TotalSegmentator's colour
// tables (arteries red, veins blue, bone ivory, liver red-brown, ...), with
// values of our own. Exact names first, then keywords in this order.
struct PaletteEntry {
  const char* key;
  Color color;
};
const PaletteEntry kPaletteExact[] = {
    {"aorta", {0.80f, 0.16f, 0.14f, 1.0f}},
    {"liver", {0.60f, 0.28f, 0.20f, 1.0f}},
    {"spleen", {0.52f, 0.22f, 0.42f, 1.0f}},
    {"pancreas", {0.93f, 0.76f, 0.52f, 1.0f}},
    {"gallbladder", {0.42f, 0.62f, 0.30f, 1.0f}},
    {"stomach", {0.88f, 0.60f, 0.56f, 1.0f}},
    {"esophagus", {0.86f, 0.58f, 0.54f, 1.0f}},
    {"trachea", {0.72f, 0.84f, 0.90f, 1.0f}},
    {"heart", {0.72f, 0.22f, 0.22f, 1.0f}},
    {"brain", {0.90f, 0.76f, 0.72f, 1.0f}},
    {"spinal_cord", {0.96f, 0.90f, 0.58f, 1.0f}},
    {"urinary_bladder", {0.90f, 0.80f, 0.44f, 1.0f}},
    {"prostate", {0.84f, 0.64f, 0.60f, 1.0f}},
    {"thyroid_gland", {0.84f, 0.52f, 0.44f, 1.0f}},
    {"inferior_vena_cava", {0.22f, 0.38f, 0.78f, 1.0f}},
    {"superior_vena_cava", {0.22f, 0.38f, 0.78f, 1.0f}},
};
const PaletteEntry kPaletteKeywords[] = {
    {"vena_cava", {0.22f, 0.38f, 0.78f, 1.0f}},  {"vein", {0.28f, 0.44f, 0.84f, 1.0f}},
    {"vena", {0.28f, 0.44f, 0.84f, 1.0f}},       {"arter", {0.84f, 0.22f, 0.20f, 1.0f}},
    {"aort", {0.80f, 0.16f, 0.14f, 1.0f}},       {"trunk", {0.84f, 0.22f, 0.20f, 1.0f}},
    {"kidney", {0.72f, 0.40f, 0.28f, 1.0f}},     {"adrenal", {0.90f, 0.68f, 0.28f, 1.0f}},
    {"lung", {0.95f, 0.72f, 0.75f, 1.0f}},       {"atri", {0.72f, 0.22f, 0.22f, 1.0f}},
    {"ventric", {0.72f, 0.22f, 0.22f, 1.0f}},    {"myocard", {0.72f, 0.22f, 0.22f, 1.0f}},
    {"duoden", {0.92f, 0.70f, 0.62f, 1.0f}},     {"bowel", {0.92f, 0.70f, 0.62f, 1.0f}},
    {"colon", {0.90f, 0.66f, 0.56f, 1.0f}},      {"intestin", {0.92f, 0.70f, 0.62f, 1.0f}},
    {"vertebra", {0.93f, 0.89f, 0.78f, 1.0f}},   {"rib", {0.93f, 0.89f, 0.78f, 1.0f}},
    {"sternum", {0.93f, 0.89f, 0.78f, 1.0f}},    {"clavic", {0.93f, 0.89f, 0.78f, 1.0f}},
    {"scapula", {0.93f, 0.89f, 0.78f, 1.0f}},    {"humerus", {0.93f, 0.89f, 0.78f, 1.0f}},
    {"femur", {0.93f, 0.89f, 0.78f, 1.0f}},      {"hip", {0.93f, 0.89f, 0.78f, 1.0f}},
    {"sacrum", {0.93f, 0.89f, 0.78f, 1.0f}},     {"skull", {0.93f, 0.89f, 0.78f, 1.0f}},
    {"bone", {0.93f, 0.89f, 0.78f, 1.0f}},       {"cartilage", {0.80f, 0.88f, 0.86f, 1.0f}},
    {"autochthon", {0.74f, 0.38f, 0.36f, 1.0f}}, {"iliopsoas", {0.74f, 0.38f, 0.36f, 1.0f}},
    {"gluteus", {0.74f, 0.38f, 0.36f, 1.0f}},    {"muscle", {0.74f, 0.38f, 0.36f, 1.0f}},
};
const Color kCycle[] = {
    {0.72f, 0.80f, 0.92f, 1.0f}, {0.92f, 0.80f, 0.66f, 1.0f}, {0.74f, 0.88f, 0.74f, 1.0f},
    {0.90f, 0.76f, 0.86f, 1.0f}, {0.94f, 0.90f, 0.66f, 1.0f}, {0.70f, 0.88f, 0.88f, 1.0f},
};

}  // namespace

std::optional<Color> anatomical_color(std::string_view name) {
  std::string key = lower(name);
  std::replace(key.begin(), key.end(), ' ', '_');
  std::replace(key.begin(), key.end(), '-', '_');
  for (const auto& e : kPaletteExact)
    if (key == e.key) return e.color;
  for (const auto& e : kPaletteKeywords)
    if (key.find(e.key) != std::string::npos) return e.color;
  return std::nullopt;
}

Color cycle_color(std::size_t index) {
  return kCycle[index % (sizeof kCycle / sizeof kCycle[0])];
}

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
  check_keys(j, kSceneKeys, what, "");
  SceneSpec spec;
  try {
    if (j.contains("background"))
      spec.background = color_from_json(j["background"], what + ": background");
    if (j.contains("transparent")) spec.transparent = boolean(j, "transparent", what, "");
    if (j.contains("camera")) {
      if (!j["camera"].is_object()) throw InputError(what + ": camera must be an object");
      check_keys(j["camera"], kCameraKeys, what, "camera");
      spec.camera = camera_from_json(j["camera"], what + ": camera");
    }
    if (j.contains("view"))
      spec.view = choice<AnatomicalView>(j, "view", parse_anatomical_view, kViews, what, "");
    if (j.contains("frame"))
      spec.frame = choice<Frame>(j, "frame", parse_frame, {"focus", "all"}, what, "");
    if (j.contains("annotation")) {
      const auto& a = j["annotation"];
      if (!a.is_object())
        throw InputError(what +
                         ": annotation must be an object (keys labels, legend, scale_bar, "
                         "orientation, font_size)");
      check_keys(a, kAnnotationKeys, what, "annotation");
      AnnotationSpec& an = spec.annotation;
      if (a.contains("labels")) an.labels = boolean(a, "labels", what, "annotation");
      if (a.contains("legend")) an.legend = boolean(a, "legend", what, "annotation");
      if (a.contains("scale_bar")) an.scale_bar = boolean(a, "scale_bar", what, "annotation");
      if (a.contains("orientation")) an.orientation = boolean(a, "orientation", what, "annotation");
      if (a.contains("font_size"))
        an.font_size = number(a, "font_size", 4.0, 200.0, what, "annotation");
    }
    if (j.contains("lic")) {
      if (!j["lic"].is_object())
        throw InputError(what + ": lic must be an object {kernel_length, noise_scale, strength}");
      check_keys(j["lic"], kLicKeys, what, "lic");
      const auto& l = j["lic"];
      if (l.contains("kernel_length"))
        spec.lic.kernel_length = number(l, "kernel_length", 1e-3, 64.0, what, "lic");
      if (l.contains("noise_scale"))
        spec.lic.noise_scale = number(l, "noise_scale", 0.0, 1e6, what, "lic");
      if (l.contains("strength")) spec.lic.strength = number(l, "strength", 0.0, 1.0, what, "lic");
    }
    if (j.contains("clip")) {
      const auto& c = j["clip"];
      if (!c.is_object() || !c.contains("point") || !c.contains("normal"))
        throw InputError(what + ": clip must be an object with \"point\" and \"normal\"");
      check_keys(c, kClipKeys, what, "clip");
      ClipPlane plane;
      plane.point = vec3_from_json(c["point"], what + ": clip.point");
      plane.normal = vec3_from_json(c["normal"], what + ": clip.normal");
      if (!(plane.normal.norm() > 1e-12))
        throw InputError(what + ": clip.normal must not be the zero vector");
      spec.clip = plane;
    }
    if (j.contains("cutaway")) spec.cutaway = cutaway_from_json(j["cutaway"], what);
    if (!j.contains("structures") || !j["structures"].is_array() || j["structures"].empty())
      throw InputError(what + ": 'structures' must be a non-empty array");
    std::vector<std::string> family_names;
    for (int f = 0; f < kLineFamilyCount; ++f)
      family_names.emplace_back(family_name(static_cast<LineFamily>(f)));
    std::size_t index = 0;
    for (const auto& s : j["structures"]) {
      const std::string path = "structures[" + std::to_string(index++) + "]";
      const std::string w = what + ": " + path;
      if (!s.is_object()) throw InputError(w + " must be an object");
      check_keys(s, kStructureKeys, what, path);
      StructureSpec st;
      if (!s.contains("mesh")) throw InputError(w + ": 'mesh' (a file path) is required");
      st.mesh = text(s, "mesh", what, path);
      if (st.mesh.is_relative()) st.mesh = base_dir / st.mesh;
      st.name = s.contains("name") ? text(s, "name", what, path) : st.mesh.stem().string();
      if (s.contains("role"))
        st.role = choice<Role>(s, "role", parse_role, {"focus", "context"}, what, path);
      st.style = default_style(st.role);
      if (s.contains("space")) {
        const auto parse_space = [](std::string_view v) -> std::optional<Space> {
          const std::string l = lower(v);
          if (l == "lps") return Space::lps;
          if (l == "ras") return Space::ras;
          return std::nullopt;
        };
        st.space = choice<Space>(s, "space", parse_space, {"lps", "ras"}, what, path);
      }
      if (s.contains("shading"))
        st.style.shading = choice<Shading>(s, "shading", parse_shading,
                                           {"none", "flat", "lambert", "toon"}, what, path);
      if (s.contains("color")) st.style.color = color_from_json(s["color"], w + ".color");
      if (s.contains("opacity")) st.style.opacity = number(s, "opacity", 0.0, 1.0, what, path);
      if (s.contains("ambient")) st.style.ambient = number(s, "ambient", 0.0, 1.0, what, path);
      if (s.contains("toon_levels"))
        st.style.toon_levels = static_cast<int>(number(s, "toon_levels", 2, 16, what, path));
      if (s.contains("lines")) {
        if (!s["lines"].is_array()) throw InputError(w + ".lines must be an array of family names");
        st.style.families.clear();
        std::size_t k = 0;
        for (const auto& f : s["lines"]) {
          const std::string fp = path + ".lines[" + std::to_string(k++) + "]";
          if (!f.is_string())
            throw InputError(what + ": " + fp + " must be a family name (got " + type_name(f) +
                             ")");
          const auto fam = parse_family(f.get<std::string>());
          if (!fam)
            throw InputError(what + ": " + fp + ": unknown line family '" + f.get<std::string>() +
                             "'" + did_you_mean(f.get<std::string>(), family_names));
          st.style.families.push_back(*fam);
        }
      }
      if (s.contains("line_color"))
        st.style.lines.color = color_from_json(s["line_color"], w + ".line_color");
      if (s.contains("line_width"))
        st.style.lines.width = number(s, "line_width", 0.0, 200.0, what, path);
      if (s.contains("taper")) st.style.lines.taper = number(s, "taper", 0.0, 0.5, what, path);
      if (s.contains("fade")) st.style.lines.fade_by_strength = boolean(s, "fade", what, path);
      if (s.contains("hidden"))
        st.style.lines.hidden = choice<HiddenLines>(s, "hidden", parse_hidden_lines,
                                                    {"omit", "dashed", "show"}, what, path);
      if (s.contains("hybrid")) st.style.hybrid_apparent_ridges = boolean(s, "hybrid", what, path);
      if (s.contains("lic")) st.style.lic = boolean(s, "lic", what, path);
      if (s.contains("smooth"))
        st.style.smooth = static_cast<int>(number(s, "smooth", 0, 1000, what, path));
      if (s.contains("label")) {
        const auto& l = s["label"];
        if (l.is_boolean()) {
          st.show_label = l.get<bool>();
        } else if (l.is_string() && !l.get<std::string>().empty()) {
          st.label = l.get<std::string>();
          if (std::any_of(st.label.begin(), st.label.end(),
                          [](char c) { return static_cast<unsigned char>(c) < 0x20; }))
            throw InputError(what + ": " + path +
                             ".label must not contain control characters (tabs, new lines)");
        } else {
          throw InputError(what + ": " + path +
                           ".label must be a non-empty string or true/false (got " +
                           (l.is_string() ? std::string("an empty string") : type_name(l)) + ")");
        }
      }
      if (s.contains("hatching")) {
        if (s["hatching"].is_object()) {
          st.hatching = true;
          st.hatching_options = hatching_spec(s["hatching"], what, at(path, "hatching"));
        } else {
          st.hatching = boolean(s, "hatching", what, path);
        }
      }
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
  if (spec.frame) j["frame"] = to_string(*spec.frame);
  if (spec.annotation.any())
    j["annotation"] = {{"labels", spec.annotation.labels},
                       {"legend", spec.annotation.legend},
                       {"scale_bar", spec.annotation.scale_bar},
                       {"orientation", spec.annotation.orientation},
                       {"font_size", spec.annotation.font_size}};
  if (std::any_of(spec.structures.begin(), spec.structures.end(),
                  [](const StructureSpec& s) { return s.style.lic; }))
    j["lic"] = {{"kernel_length", spec.lic.kernel_length},
                {"noise_scale", spec.lic.noise_scale},
                {"strength", spec.lic.strength}};
  if (spec.clip)
    j["clip"] = {{"point", {spec.clip->point.x(), spec.clip->point.y(), spec.clip->point.z()}},
                 {"normal", {spec.clip->normal.x(), spec.clip->normal.y(), spec.clip->normal.z()}}};
  const Cutaway defaults;
  const Cutaway& cut = spec.cutaway;
  if (cut.enabled || cut.margin_px != defaults.margin_px || cut.fade_px != defaults.fade_px ||
      cut.rim || to_hex(cut.rim_color) != to_hex(defaults.rim_color) ||
      cut.rim_color.a != defaults.rim_color.a)
    j["cutaway"] = cutaway_to_json(cut);
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
    if (s.style.lic) o["lic"] = true;
    if (s.style.smooth > 0) o["smooth"] = s.style.smooth;
    if (!s.show_label)
      o["label"] = false;
    else if (!s.label.empty())
      o["label"] = s.label;
    if (s.hatching) o["hatching"] = *s.hatching;
    if (s.hatching.value_or(false) && s.hatching_options != HatchingSpec{}) {
      nlohmann::json h = nlohmann::json::object();
      if (!s.hatching_options.method.empty()) h["method"] = s.hatching_options.method;
      for (const auto& [key, v] : s.hatching_options.numbers) h[key] = v;
      for (const auto& [key, v] : s.hatching_options.flags) h[key] = v;
      o["hatching"] = h;
    }
    list.push_back(o);
  }
  j["structures"] = list;
  return j;
}

double cutaway_keep(const Cutaway& c, double distance, double scale) {
  const double margin = c.margin_px * scale, fade = c.fade_px * scale;
  if (!(distance > margin)) return 0.0;
  if (!(distance < margin + fade)) return 1.0;
  const double t = (distance - margin) / fade;
  return t * t * (3.0 - 2.0 * t);
}

Cutaway cutaway_from_json(const nlohmann::json& c, const std::string& what, Cutaway cut) {
  if (!c.is_object())
    throw InputError(what +
                     ": cutaway must be an object {enabled, margin_px, fade_px, rim, rim_color}");
  check_keys(c, kCutawayKeys, what, "cutaway");
  try {
    if (c.contains("enabled")) cut.enabled = boolean(c, "enabled", what, "cutaway");
    if (c.contains("margin_px"))
      cut.margin_px = number(c, "margin_px", 0.0, kCutawayMaxPx, what, "cutaway");
    if (c.contains("fade_px"))
      cut.fade_px = number(c, "fade_px", 0.0, kCutawayMaxPx, what, "cutaway");
    if (c.contains("rim")) cut.rim = boolean(c, "rim", what, "cutaway");
    if (c.contains("rim_color"))
      cut.rim_color = color_from_json(c["rim_color"], what + ": cutaway.rim_color");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(what + ": cutaway: " + e.what());
  }
  return cut;
}

nlohmann::json cutaway_to_json(const Cutaway& c) {
  return {{"enabled", c.enabled},
          {"margin_px", c.margin_px},
          {"fade_px", c.fade_px},
          {"rim", c.rim},
          {"rim_color", color_to_json(c.rim_color)}};
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
