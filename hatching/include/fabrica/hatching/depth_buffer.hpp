// A CPU depth (z) and face-ID buffer of a mesh at image resolution, used to
// decide which surface point a pixel sees (stroke seeds) and whether a point
// on a stroke is hidden (occlusion). Also a fast projector that agrees with
// fabrica::project().
//
// Pixels: x right, y down; pixel (i, j) covers [i, i+1) × [j, j+1) and is
// sampled at its centre. Depth is the camera's linear depth (mm in front of
// the eye), interpolated perspective-correctly. Faces with a corner on or
// behind the eye plane are skipped (no near clipping). Ties between faces at
// equal depth go to the lower face index, so the buffer is the same at any
// thread count.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica::hatching {

/// Projection with the camera's basis precomputed (same numbers as project()).
class ImageProjector {
 public:
  explicit ImageProjector(const Camera& camera);
  ProjectedPoint project(const Vec3& p) const;
  /// The viewing ray through an image point: origin and unit direction.
  void ray(const Vec2& pixel, Vec3& origin, Vec3& direction) const;
  /// Size in mm of one pixel at linear depth `depth`.
  double pixel_size(double depth) const;
  const Camera& camera() const { return camera_; }

 private:
  Camera camera_;
  Vec3 forward_, right_, up_;
  double half_h_ = 1.0, ortho_h_ = 1.0, aspect_ = 1.0;
  bool perspective_ = true;
};

struct DepthBuffer {
  int width = 0, height = 0;
  std::vector<float> depth;        ///< +inf where no face is seen
  std::vector<std::int32_t> face;  ///< -1 where no face is seen

  /// Face seen at an image point (-1 outside the image or on background).
  std::int32_t face_at(const Vec2& pixel) const {
    const int i = static_cast<int>(pixel.x()), j = static_cast<int>(pixel.y());
    if (pixel.x() < 0.0 || pixel.y() < 0.0 || i >= width || j >= height) return -1;
    return face[static_cast<std::size_t>(j) * width + i];
  }
  float depth_at(const Vec2& pixel) const {
    const int i = static_cast<int>(pixel.x()), j = static_cast<int>(pixel.y());
    if (pixel.x() < 0.0 || pixel.y() < 0.0 || i >= width || j >= height)
      return std::numeric_limits<float>::infinity();
    return depth[static_cast<std::size_t>(j) * width + i];
  }
};

/// Rasterises every face of `mesh` for `camera` (camera.width × camera.height).
/// Parallel over image bands, deterministic.
DepthBuffer rasterize_depth(const TriangleMesh& mesh, const Camera& camera);

}  // namespace fabrica::hatching
