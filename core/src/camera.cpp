#include "fabrica/core/camera.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"
#include "fabrica/core/projector.hpp"

namespace fabrica {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

Vec3 vec3_from_json(const nlohmann::json& j, const char* key, const std::string& what) {
  const auto& a = j.at(key);
  if (!a.is_array() || a.size() != 3)
    throw InputError(what + ": '" + key + "' must be an array of 3 numbers");
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    if (!a[i].is_number()) throw InputError(what + ": '" + key + "' must be an array of 3 numbers");
    v[i] = a[i].get<double>();
  }
  return v;
}

}  // namespace

Vec3 Camera::right() const {
  const Vec3 r = forward().cross(up);
  return r.normalized();
}

Vec3 Camera::true_up() const {
  return right().cross(forward()).normalized();
}

void validate_camera(const Camera& c, const std::string& what) {
  if (!c.eye.allFinite() || !c.center.allFinite() || !c.up.allFinite() || !std::isfinite(c.fov_deg))
    throw InputError(what + ": eye, center, up and fov_deg must be finite numbers");
  const double distance = (c.center - c.eye).norm();
  if (!(distance > 0.0))
    throw InputError(what + ": eye and center are the same point; move the eye");
  if (!(c.up.norm() > 0.0))
    throw InputError(what + ": up vector is zero; give a direction such as [0,1,0]");
  const Vec3 f = (c.center - c.eye) / distance;
  if (f.cross(c.up.normalized()).norm() < 1e-6)
    throw InputError(what + ": up vector is parallel to the viewing direction; choose another up");
  if (!(c.fov_deg >= kMinFovDeg && c.fov_deg < 180.0))
    throw InputError(what + ": fov_deg must be at least " + std::to_string(kMinFovDeg) +
                     " and below 180 degrees (got " + std::to_string(c.fov_deg) + ")");
  if (c.width <= 0 || c.height <= 0 || c.width > kMaxImageSide || c.height > kMaxImageSide)
    throw InputError(what + ": width and height must be pixel counts from 1 to " +
                     std::to_string(kMaxImageSide) + " (got " + std::to_string(c.width) + "x" +
                     std::to_string(c.height) + ")");
}

ProjectedPoint project(const Camera& c, const Vec3& p) {
  return Projector(c)(p);
}

Eigen::Matrix4d view_matrix(const Camera& c) {
  const Vec3 f = c.forward(), r = c.right(), u = c.true_up();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = r.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -r.dot(c.eye);
  m(1, 3) = -u.dot(c.eye);
  m(2, 3) = f.dot(c.eye);
  return m;
}

Eigen::Matrix4d projection_matrix(const Camera& c, double n, double f) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  const double half_h = std::tan(0.5 * c.fov_deg * kDegToRad);
  if (c.projection == Projection::perspective) {
    m(0, 0) = 1.0 / (half_h * c.aspect());
    m(1, 1) = 1.0 / half_h;
    m(2, 2) = -(f + n) / (f - n);
    m(2, 3) = -2.0 * f * n / (f - n);
    m(3, 2) = -1.0;
  } else {
    const double h = (c.center - c.eye).norm() * half_h;
    m(0, 0) = 1.0 / (h * c.aspect());
    m(1, 1) = 1.0 / h;
    m(2, 2) = -2.0 / (f - n);
    m(2, 3) = -(f + n) / (f - n);
    m(3, 3) = 1.0;
  }
  return m;
}

std::pair<double, double> clip_planes(const Camera& c, const Vec3& sphere_center,
                                      double sphere_radius) {
  const double center_depth = (sphere_center - c.eye).dot(c.forward());
  double n = c.near_plane > 0 ? c.near_plane : center_depth - 1.01 * sphere_radius;
  double f = c.far_plane > 0 ? c.far_plane : center_depth + 1.01 * sphere_radius;
  const double min_near = 1e-4 * std::max(f, 1e-9);
  if (c.projection == Projection::perspective && n < min_near) n = min_near;
  if (f <= n) f = n + std::max(1e-6, 2.0 * sphere_radius);
  return {n, f};
}

namespace {

/// An image side from JSON: a whole number that fits an int (its range is
/// validate_camera's). A float such as 5e25 converted to int would be
/// undefined behaviour (fuzz_camera finding), an int64 would wrap.
int pixel_count(const nlohmann::json& v, const char* key, const std::string& what) {
  if (!v.is_number())
    throw InputError(what + ": " + key + " must be a whole number of pixels (got " +
                     std::string(v.type_name()) + ")");
  const double d = v.get<double>();
  if (!(d >= -2147483648.0 && d <= 2147483647.0) || d != std::floor(d))
    throw InputError(what + ": " + key + " must be a whole number of pixels from 1 to " +
                     std::to_string(kMaxImageSide) + " (got " + v.dump() + ")");
  return static_cast<int>(d);
}

}  // namespace

Camera camera_from_json(const nlohmann::json& j, const std::string& what) {
  if (!j.is_object()) throw InputError(what + ": a camera must be a JSON object");
  Camera c;
  try {
    if (j.contains("eye")) c.eye = vec3_from_json(j, "eye", what);
    if (j.contains("center")) c.center = vec3_from_json(j, "center", what);
    if (j.contains("up")) c.up = vec3_from_json(j, "up", what);
    if (j.contains("fov_deg")) c.fov_deg = j.at("fov_deg").get<double>();
    if (j.contains("projection")) {
      // Reference .seg headers describe it in words: "perspective, square image, ...".
      const auto p = j.at("projection").get<std::string>();
      if (p.rfind("perspective", 0) == 0)
        c.projection = Projection::perspective;
      else if (p.rfind("orthographic", 0) == 0)
        c.projection = Projection::orthographic;
      else
        throw InputError(what + ": projection must be \"perspective\" or \"orthographic\" (got \"" +
                         p + "\")");
    }
    if (j.contains("width")) c.width = pixel_count(j.at("width"), "width", what);
    if (j.contains("height")) c.height = pixel_count(j.at("height"), "height", what);
    if (j.contains("near")) c.near_plane = j.at("near").get<double>();
    if (j.contains("far")) c.far_plane = j.at("far").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(what + ": " + e.what());
  }
  validate_camera(c, what);
  return c;
}

nlohmann::json camera_to_json(const Camera& c) {
  auto arr = [](const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  nlohmann::json j;
  j["eye"] = arr(c.eye);
  j["center"] = arr(c.center);
  j["up"] = arr(c.up);
  j["fov_deg"] = c.fov_deg;
  j["projection"] = c.projection == Projection::perspective ? "perspective" : "orthographic";
  j["width"] = c.width;
  j["height"] = c.height;
  if (c.near_plane > 0) j["near"] = c.near_plane;
  if (c.far_plane > 0) j["far"] = c.far_plane;
  return j;
}

Camera read_camera(const std::filesystem::path& path) {
  std::string text = read_input_file(path, path.string() + " (camera file)", kMaxJsonBytes);
  // A reference .seg file: the first line is "# {json}".
  if (text.rfind("# ", 0) == 0) text = text.substr(2, text.find('\n') - 2);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path.string() + ": not a valid camera JSON: " + e.what());
  }
  return camera_from_json(j, path.string());
}

void write_camera(const Camera& camera, const std::filesystem::path& path) {
  write_file_atomically(path,
                        [&](std::ostream& out) { out << camera_to_json(camera).dump(2) << '\n'; });
}

std::optional<AnatomicalView> parse_anatomical_view(std::string_view name) {
  if (name == "anterior") return AnatomicalView::anterior;
  if (name == "posterior") return AnatomicalView::posterior;
  if (name == "left") return AnatomicalView::left;
  if (name == "right") return AnatomicalView::right;
  if (name == "superior") return AnatomicalView::superior;
  if (name == "inferior") return AnatomicalView::inferior;
  return std::nullopt;
}

const char* to_string(AnatomicalView view) {
  switch (view) {
    case AnatomicalView::anterior:
      return "anterior";
    case AnatomicalView::posterior:
      return "posterior";
    case AnatomicalView::left:
      return "left";
    case AnatomicalView::right:
      return "right";
    case AnatomicalView::superior:
      return "superior";
    case AnatomicalView::inferior:
      return "inferior";
  }
  return "anterior";
}

Camera anatomical_camera(AnatomicalView view, const BoundingBox& box, Space space, int width,
                         int height, double fov_deg) {
  // Direction from the centre to the camera, and view-up, in RAS.
  Vec3 dir = Vec3::UnitY(), up = Vec3::UnitZ();
  switch (view) {
    case AnatomicalView::right:
      dir = {1, 0, 0};
      up = {0, 0, 1};
      break;
    case AnatomicalView::left:
      dir = {-1, 0, 0};
      up = {0, 0, 1};
      break;
    case AnatomicalView::anterior:
      dir = {0, 1, 0};
      up = {0, 0, 1};
      break;
    case AnatomicalView::posterior:
      dir = {0, -1, 0};
      up = {0, 0, 1};
      break;
    case AnatomicalView::superior:
      dir = {0, 0, 1};
      up = {0, 1, 0};
      break;
    case AnatomicalView::inferior:
      dir = {0, 0, -1};
      up = {0, 1, 0};
      break;
  }
  if (space == Space::lps) {
    dir.x() = -dir.x();
    dir.y() = -dir.y();
    up.x() = -up.x();
    up.y() = -up.y();
  }
  const double radius = std::max(0.5 * box.diagonal(), 1e-9);
  // Fit the sphere in the narrower of the two fields of view, 5% margin.
  const double half_v = 0.5 * fov_deg * kDegToRad;
  const double half_h = std::atan(std::tan(half_v) * static_cast<double>(width) / height);
  const double half = std::min(half_v, half_h);
  const double distance = 1.05 * radius / std::sin(half);
  Camera c;
  c.center = box.center();
  c.eye = c.center + distance * dir;
  c.up = up;
  c.fov_deg = fov_deg;
  c.width = width;
  c.height = height;
  return c;
}

}  // namespace fabrica
