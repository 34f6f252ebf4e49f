// Projector: fabrica::project() with the camera basis computed once.
//
// project(camera, p) rebuilds forward/right/up (three normalisations and a
// tangent) on every call; a Projector does that once, so projecting many
// points (visibility sampling, chaining, stroke tracing, depth rasterising)
// costs a few dot products per point. The arithmetic is the same, in the
// same order, as project() (which is implemented with it), so the results
// are bit-identical. Also the inverse: the viewing ray through an image
// point, and the size of a pixel at a given depth.
//
// Image coordinates: x right, y down, in pixels ([0, width) x [0, height));
// depth is the linear eye depth along the viewing direction (mm in front of
// the eye; negative behind it).
#pragma once

#include <cmath>
#include <numbers>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

class Projector {
 public:
  explicit Projector(const Camera& c)
      : eye_(c.eye),
        f_(c.forward()),
        r_(c.right()),
        u_(c.true_up()),
        half_h_(std::tan(0.5 * c.fov_deg * (std::numbers::pi / 180.0))),
        ortho_h_((c.center - c.eye).norm() * half_h_),
        aspect_(c.aspect()),
        width_(c.width),
        height_(c.height),
        perspective_(c.projection == Projection::perspective) {}

  /// Image position and linear depth of `p` (as project(camera, p)).
  ProjectedPoint operator()(const Vec3& p) const {
    const Vec3 d = p - eye_;
    const double depth = d.dot(f_);
    double x, y;
    if (perspective_) {
      x = d.dot(r_) / (depth * half_h_);
      y = d.dot(u_) / (depth * half_h_);
    } else {
      x = d.dot(r_) / ortho_h_;
      y = d.dot(u_) / ortho_h_;
    }
    x /= aspect_;
    return {Vec2(0.5 * (x + 1.0) * width_, 0.5 * (1.0 - y) * height_), depth};
  }
  ProjectedPoint project(const Vec3& p) const { return (*this)(p); }

  /// The viewing ray through an image point: origin and unit direction
  /// (perspective: from the eye; orthographic: parallel to the view).
  void ray(const Vec2& pixel, Vec3& origin, Vec3& direction) const {
    const double x = (2.0 * pixel.x() / width_ - 1.0) * aspect_;
    const double y = 1.0 - 2.0 * pixel.y() / height_;
    if (perspective_) {
      origin = eye_;
      direction = (f_ + x * half_h_ * r_ + y * half_h_ * u_).normalized();
    } else {
      origin = eye_ + x * ortho_h_ * r_ + y * ortho_h_ * u_;
      direction = f_;
    }
  }

  /// Size in mm of one pixel at linear depth `depth`.
  double pixel_size(double depth) const {
    const double h = perspective_ ? depth * half_h_ : ortho_h_;
    return 2.0 * h / height_;
  }

  int width() const { return width_; }
  int height() const { return height_; }
  bool perspective() const { return perspective_; }
  /// The terms of operator() (for vector versions of it, which must use
  /// the same operations): the eye, the unit forward, right and up
  /// vectors, tan(fov / 2), the orthographic half height and the aspect.
  const Vec3& eye() const { return eye_; }
  const Vec3& forward() const { return f_; }
  const Vec3& right() const { return r_; }
  const Vec3& up() const { return u_; }
  double half_height() const { return half_h_; }
  double ortho_half_height() const { return ortho_h_; }
  double aspect() const { return aspect_; }

 private:
  Vec3 eye_, f_, r_, u_;
  double half_h_, ortho_h_, aspect_;
  int width_, height_;
  bool perspective_;
};

}  // namespace fabrica
