#include "fabrica/hatching/draw.hpp"

#include <algorithm>
#include <cctype>
#include <sstream>

#include "fabrica/core/error.hpp"

namespace fabrica {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

Vec3 parse_vec3(const std::string& text, const std::string& what) {
  Vec3 v;
  char comma1 = 0, comma2 = 0;
  std::istringstream in(text);
  if (!(in >> v.x() >> comma1 >> v.y() >> comma2 >> v.z()) || comma1 != ',' || comma2 != ',' ||
      !v.allFinite())
    throw InputError(what + ": expected three numbers X,Y,Z (got \"" + text + "\")");
  std::string rest;
  if (in >> rest) throw InputError(what + ": unexpected \"" + rest + "\" after X,Y,Z");
  return v;
}

}  // namespace

hatching::Light parse_light(const std::string& text, const Camera& camera) {
  hatching::Light light;
  const std::string t = lower(text);
  if (t == "eye" || t == "headlight") return light;
  const auto colon = t.find(':');
  if (colon == std::string::npos)
    throw InputError("--light: use eye, dir:X,Y,Z, view:X,Y,Z or point:X,Y,Z (got \"" + text +
                     "\")");
  const std::string kind = t.substr(0, colon);
  const Vec3 v = parse_vec3(t.substr(colon + 1), "--light " + kind);
  if (kind == "dir" || kind == "direction") {
    light.kind = hatching::LightKind::direction;
    light.vector = v;
  } else if (kind == "view") {
    light.kind = hatching::LightKind::direction;
    light.vector = v.x() * camera.right() + v.y() * camera.true_up() - v.z() * camera.forward();
  } else if (kind == "point") {
    light.kind = hatching::LightKind::point;
    light.vector = v;
  } else {
    throw InputError("--light: unknown kind \"" + kind + "\" (use eye, dir, view or point)");
  }
  if (light.kind == hatching::LightKind::direction && !(light.vector.norm() > 0.0))
    throw InputError("--light: the direction must not be zero");
  return light;
}

void validate(const DrawHatchingOptions& options) {
  const double angle = options.hatching.ridges.min_angle_deg;
  if (!(angle >= 0.0 && angle < 180.0))
    throw InputError("--ridge-angle: must be in [0, 180) degrees (got " + std::to_string(angle) +
                     ")");
}

hatching::StrokeSet draw_hatching(const Surface& surface, const Camera& camera,
                                  const DrawHatchingOptions& options) {
  hatching::HatchingOptions o = options.hatching;
  o.light = parse_light(options.light, camera);
  validate(options);
  return hatching::hatch(surface, camera, o);
}

}  // namespace fabrica
