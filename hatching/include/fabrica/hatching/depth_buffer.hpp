// Compatibility names: hatching's depth buffer and projector are core's
// (one rasteriser and one projector for lines/ and hatching/):
// fabrica/core/depth_raster.hpp (DepthBuffer, render_depth with faces) and
// fabrica/core/projector.hpp (Projector). New code should use those.
#pragma once

#include "fabrica/core/camera.hpp"
#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/projector.hpp"

namespace fabrica::hatching {

using ImageProjector = fabrica::Projector;
using DepthBuffer = fabrica::DepthBuffer;

/// Depth and the face seen at every pixel: render_depth(mesh, camera, true).
inline DepthBuffer rasterize_depth(const TriangleMesh& mesh, const Camera& camera) {
  return render_depth(mesh, camera, /*faces=*/true);
}

}  // namespace fabrica::hatching
