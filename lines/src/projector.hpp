// Private: project() with the camera basis computed once. core's project()
// rebuilds forward/right/up (three normalisations and a tangent) on every
// call, which dominated chaining and visibility. The arithmetic below is the
// same, in the same order, so the results are bit-identical to project().
#pragma once

#include <cmath>
#include <numbers>

#include "fabrica/core/camera.hpp"

namespace fabrica::detail {

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

 private:
  Vec3 eye_, f_, r_, u_;
  double half_h_, ortho_h_, aspect_;
  int width_, height_;
  bool perspective_;
};

}  // namespace fabrica::detail
