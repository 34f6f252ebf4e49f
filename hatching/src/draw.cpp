#include "fabrica/hatching/draw.hpp"

#include <algorithm>
#include <cctype>
#include <sstream>

#include "fabrica/core/error.hpp"
#include "fabrica/core/suggest.hpp"

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

const char* to_string(HatchingMethod method) {
  return method == HatchingMethod::confis ? "confis" : "shading";
}

HatchingMethod parse_hatching_method(const std::string& text) {
  const std::string t = lower(text);
  if (t == "shading") return HatchingMethod::shading;
  if (t == "confis") return HatchingMethod::confis;
  throw InputError("--method: unknown method \"" + text + "\" (use shading or confis)" +
                   did_you_mean(t, {"shading", "confis"}));
}

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
  if (options.method == HatchingMethod::confis) {
    const hatching::ConfisOptions& c = options.confis;
    auto bad = [](const std::string& option, const std::string& what, double value) {
      std::ostringstream text;
      text << option << ": " << what << " (got " << value << ")";
      throw InputError(text.str());
    };
    if (!(c.contour_margin > 0.0 && c.contour_margin <= 1.0))
      bad("--contour-margin", "must be in (0, 1] (a bound on n.v)", c.contour_margin);
    if (!(c.feature_regions.convex_threshold > 0.0) ||
        !std::isfinite(c.feature_regions.convex_threshold))
      bad("--convex-threshold", "must be a positive number", c.feature_regions.convex_threshold);
    if (!(c.feature_regions.concave_threshold > 0.0) ||
        !std::isfinite(c.feature_regions.concave_threshold))
      bad("--concave-threshold", "must be a positive number", c.feature_regions.concave_threshold);
    if (!(c.field.umbilic_threshold >= 0.0) || !std::isfinite(c.field.umbilic_threshold))
      bad("--umbilic-threshold", "must be a number >= 0", c.field.umbilic_threshold);
    if (!(c.spacing_px > 0.0) || !std::isfinite(c.spacing_px))
      bad("--spacing", "must be a positive number of pixels", c.spacing_px);
    if (!(c.min_length_px >= 0.0) || !std::isfinite(c.min_length_px))
      bad("--min-length", "must be >= 0 pixels", c.min_length_px);
    if (!(c.max_length_px >= 0.0) || !std::isfinite(c.max_length_px))
      bad("--max-length", "must be >= 0 pixels (0 = no limit)", c.max_length_px);
    if (!(c.stroke_width_px > 0.0) || !std::isfinite(c.stroke_width_px))
      bad("--stroke-width", "must be a positive number of pixels", c.stroke_width_px);
    if (!(c.min_weight >= 0.0 && c.min_weight <= 1.0))
      bad("--min-weight", "must be in [0, 1]", c.min_weight);
    if (!c.contours && !c.features)
      throw InputError("--no-contours and --no-features: nothing left to draw; keep one");
    hatching::validate(c);  // the rest, with the library's messages
    return;
  }
  const double angle = options.hatching.ridges.min_angle_deg;
  if (!(angle >= 0.0 && angle < 180.0))
    throw InputError("--ridge-angle: must be in [0, 180) degrees (got " + std::to_string(angle) +
                     ")");
}

hatching::StrokeSet draw_hatching(const Surface& surface, const Camera& camera,
                                  const DrawHatchingOptions& options) {
  if (options.method == HatchingMethod::confis) {
    validate(options);
    return hatching::confis(surface, camera, options.confis);
  }
  hatching::HatchingOptions o = options.hatching;
  o.light = parse_light(options.light, camera);
  validate(options);
  return hatching::hatch(surface, camera, o);
}

}  // namespace fabrica
