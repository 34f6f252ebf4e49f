// Camera: eye, look-at centre, up, vertical field of view, projection and
// image size, as JSON; anatomical preset views fitted to a mesh.
//
// Image coordinates: pixels, x to the right, y DOWN, origin at the top-left
// corner of the image (as SVG and PNG). Depth: linear distance in front of
// the eye along the viewing axis (mm), positive in front.
// The per-vertex view vector is v = normalize(eye - p) for perspective (as
// rtsc) and the constant direction towards the viewer for orthographic.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

enum class Projection { perspective, orthographic };

struct Camera {
  Vec3 eye{0.0, 0.0, 1.0};
  Vec3 center{0.0, 0.0, 0.0};
  Vec3 up{0.0, 1.0, 0.0};
  double fov_deg = 40.0;  ///< vertical field of view (orthographic: the height seen at `center`)
  Projection projection = Projection::perspective;
  int width = 1024;
  int height = 1024;
  /// Clip distances along the viewing axis; <= 0 means "choose from the scene".
  double near_plane = 0.0;
  double far_plane = 0.0;

  /// Unit vector from the eye towards the centre.
  Vec3 forward() const { return (center - eye).normalized(); }
  /// Orthonormal camera basis: right, true up (both unit, perpendicular to forward()).
  Vec3 right() const;
  Vec3 true_up() const;
  /// Unit view vector at p: towards the eye (perspective) or -forward() (orthographic).
  Vec3 view_vector(const Vec3& p) const {
    return projection == Projection::perspective ? Vec3((eye - p).normalized()) : Vec3(-forward());
  }
  double aspect() const { return static_cast<double>(width) / static_cast<double>(height); }
};

/// Largest image side in pixels any command draws (docs/reliability.md).
inline constexpr int kMaxImageSide = 16384;
/// Narrowest field of view (degrees): narrower ones project a mesh to pixel
/// coordinates beyond what the image-space algorithms can index.
inline constexpr double kMinFovDeg = 1e-3;

/// Throws InputError (prefixed with `what`) when the camera cannot be used:
/// eye == centre, zero or parallel up vector, field of view outside
/// [kMinFovDeg, 180), image size outside 1..kMaxImageSide, non-finite numbers.
void validate_camera(const Camera& camera, const std::string& what = "camera");

/// Pixel position and linear depth of a point.
struct ProjectedPoint {
  Vec2 pixel;    ///< x right, y down, origin top-left
  double depth;  ///< distance in front of the eye along forward(); <= 0 behind the eye
};
ProjectedPoint project(const Camera& camera, const Vec3& p);

/// World -> eye (OpenGL convention: camera looks down -z) and eye -> clip
/// (OpenGL convention, depth in [-1,1]) matrices.
Eigen::Matrix4d view_matrix(const Camera& camera);
Eigen::Matrix4d projection_matrix(const Camera& camera, double near_plane, double far_plane);
/// Near and far planes that enclose a bounding sphere (uses the camera's own if set).
std::pair<double, double> clip_planes(const Camera& camera, const Vec3& sphere_center, double sphere_radius);

/// JSON keys: eye, center, up (arrays of 3), fov_deg, projection
/// ("perspective" | "orthographic"), width, height, near, far; missing keys
/// keep defaults and extra keys are ignored (so the header of a reference
/// .seg file is a valid camera).
Camera camera_from_json(const nlohmann::json& j, const std::string& what = "camera");
nlohmann::json camera_to_json(const Camera& camera);
/// Reads a camera JSON file, or the `# {json}` header line of a .seg file.
Camera read_camera(const std::filesystem::path& path);
void write_camera(const Camera& camera, const std::filesystem::path& path);

/// Anatomical standard views. Camera position / view-up in RAS: right +X/+Z,
/// left -X/+Z, anterior +Y/+Z, posterior -Y/+Z, superior +Z/+Y, inferior -Z/+Y;
/// for LPS coordinates x and y are negated.
enum class AnatomicalView { anterior, posterior, left, right, superior, inferior };
std::optional<AnatomicalView> parse_anatomical_view(std::string_view name);
const char* to_string(AnatomicalView view);
/// A perspective camera looking at the bounding sphere of `box` from the
/// given side, at a distance where the sphere fills the view with a 5% margin.
Camera anatomical_camera(AnatomicalView view, const BoundingBox& box, Space space, int width = 1024,
                         int height = 1024, double fov_deg = 30.0);

}  // namespace fabrica
