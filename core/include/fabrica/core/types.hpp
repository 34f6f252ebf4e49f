// Basic value types shared by every module. Geometry is double precision on
// the CPU (float only where data goes to the GPU). Units are millimetres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

namespace fabrica {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;

/// A triangle as three vertex indices, counter-clockwise seen from outside.
using Face = std::array<std::int32_t, 3>;

}  // namespace fabrica
