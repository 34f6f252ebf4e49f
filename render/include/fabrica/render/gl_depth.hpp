// The depth buffer of hidden-line removal (fabrica::DepthBuffer,
// core/depth_raster.hpp) rendered by GL where a context exists, instead of
// the CPU rasteriser: the mesh is uploaded once, each view draws it into a
// float target holding the linear eye depth (mm along the viewing
// direction, as render_depth) and reads it back, rows flipped to the
// buffer's y-down order. compute_visibility() then samples it as it samples
// the CPU buffer (docs/rendering.md, "Hidden lines from the GL depth
// buffer").
//
// Differences from render_depth (all at single pixels, within the
// visibility test's tolerances): GL's edge rule (a pixel centre exactly on
// a shared edge goes to one triangle, not both), clipping at a near plane
// (the CPU raster drops triangles with a corner behind the eye instead), and
// depth interpolated in float on the GPU. No face ids (DepthBuffer::face is
// left empty).
#pragma once

#include <memory>

#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/render/context.hpp"

namespace fabrica::render {

class GlDepthRenderer {
 public:
  /// Uploads `mesh` (positions relative to its bounding-box centre, as
  /// float) into `context`, which must outlive this object and be current
  /// whenever it is used. Throws InputError for an empty mesh.
  GlDepthRenderer(GlContext& context, const TriangleMesh& mesh);
  ~GlDepthRenderer();
  GlDepthRenderer(const GlDepthRenderer&) = delete;
  GlDepthRenderer& operator=(const GlDepthRenderer&) = delete;

  /// The mesh's linear eye depth seen by `camera` (camera.width x
  /// camera.height pixels; +infinity where empty) into `out`, reusing its
  /// storage. Throws InputError when a side exceeds the context's largest
  /// framebuffer.
  void render(const Camera& camera, DepthBuffer& out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fabrica::render
