// A point on a triangulated surface: a face and barycentric coordinates
// with respect to its three corners (in the face's corner order). Points on
// an edge have the barycentric coordinate of the opposite corner equal to 0;
// points at a vertex have one coordinate equal to 1. Lines and strokes are
// polylines of such points, so they stay anchored on the surface.
#pragma once

#include <cstdint>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

struct SurfacePoint {
  std::int32_t face = -1;
  Vec3 bary = Vec3::Zero();

  bool valid() const { return face >= 0; }
  /// Position in space: the barycentric combination of the face's corners.
  Vec3 position(const TriangleMesh& mesh) const {
    const Face& f = mesh.faces[static_cast<std::size_t>(face)];
    return bary[0] * mesh.positions[f[0]] + bary[1] * mesh.positions[f[1]] +
           bary[2] * mesh.positions[f[2]];
  }
};

}  // namespace fabrica
