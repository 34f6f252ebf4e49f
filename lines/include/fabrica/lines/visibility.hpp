// Hidden-line removal for vector output (docs/algorithms.md §3.5 item 2, §11.3):
// the mesh is rasterised on the CPU into a depth buffer of linear eye depth
// at image resolution; each polyline is sampled every <= 1 px and a sample
// is visible when its depth <= (depth of the 3x3 pixels around it) + epsilon,
// where the window's depth is its MAXIMUM by default. The minimum (see
// docs/algorithms.md §3.5) hides interpolated contours: at a silhouette
// the surface in front of the contour point, one pixel inside, is nearer by
// about sqrt(2 r px) (r the radius of curvature, px the pixel size), far more
// than any sensible epsilon. With the maximum a sample is visible when some
// pixel of the window shows nothing nearer than it, so lines at silhouettes
// survive and lines behind other parts are hidden except within one pixel of
// the occluder's outline. Visibility switches only after `hysteresis` consecutive samples
// agree, and a vertex is inserted where it switches, so chains do not
// flicker. Deterministic at any thread count (depth uses min, which is
// order independent).
#pragma once

#include <memory>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica {

namespace detail {
struct RasterScratch;
/// render_depth's working memory (projected corners, binned triangles),
/// kept between calls on the same DepthBuffer; copies start empty.
class RasterScratchSlot {
 public:
  RasterScratchSlot();
  ~RasterScratchSlot();
  RasterScratchSlot(const RasterScratchSlot&);
  RasterScratchSlot& operator=(const RasterScratchSlot&);
  RasterScratchSlot(RasterScratchSlot&&) noexcept;
  RasterScratchSlot& operator=(RasterScratchSlot&&) noexcept;
  RasterScratch& get();

 private:
  std::unique_ptr<RasterScratch> scratch_;
};
}  // namespace detail

/// Linear eye depth per pixel (row-major, y down); +infinity where empty.
struct DepthBuffer {
  int width = 0, height = 0;
  std::vector<float> depth;
  float at(int x, int y) const { return depth[static_cast<std::size_t>(y) * width + x]; }
  /// Minimum over the 3x3 pixels around (x, y), clamped to the image;
  /// +infinity outside the image.
  float min3x3(double x, double y) const;
  /// Maximum over the same window (+infinity where any pixel is empty).
  float max3x3(double x, double y) const;
  /// render_depth's working memory, reused when the buffer is rendered again.
  detail::RasterScratchSlot scratch;
};

/// Rasterises every triangle of `mesh` seen by `camera` (width x height
/// from the camera) with perspective-correct depth. Triangles with a corner
/// behind the near plane are skipped. A pixel is covered when its centre
/// has no negative barycentric weight (shared edges: both triangles); the
/// buffer holds the minimum depth, bit-identical at any thread count and to
/// a plain loop over every triangle and every pixel of its box (the binning
/// and the skipping of hidden back faces in visibility.cpp change nothing).
DepthBuffer render_depth(const TriangleMesh& mesh, const Camera& camera);
/// The same into `out`, reusing its storage and working memory (no
/// allocation when the mesh and image sizes are unchanged: keep one
/// DepthBuffer per view for redraws). Throws InputError when a side of the
/// image exceeds 32000 pixels.
void render_depth(const TriangleMesh& mesh, const Camera& camera, DepthBuffer& out);

struct VisibilityOptions {
  /// Depth tolerance in mm; <= 0 uses half the median edge length.
  double epsilon = 0.0;
  double sample_spacing_px = 1.0;
  int hysteresis = 2;  ///< consecutive samples needed to switch state
  /// Compare with the window's maximum (default) or minimum depth.
  bool window_minimum = false;
};

/// Sets LineVertex::visible on every polyline (inserting vertices where
/// visibility changes). Uses `depth` if given, otherwise renders one.
void compute_visibility(LineSet& lines, const Surface& surface, const Camera& camera,
                        const VisibilityOptions& options = {}, const DepthBuffer* depth = nullptr);

}  // namespace fabrica
