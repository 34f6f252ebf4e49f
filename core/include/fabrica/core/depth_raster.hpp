// The CPU depth rasteriser shared by hidden-line removal (lines/,
// docs/algorithms.md §3.5 item 2, §11.3) and hatching (stroke seeds and
// occlusion): a buffer of linear eye depth at image resolution, optionally
// with the face seen at each pixel. Projection with fabrica::Projector
// (projector.hpp). Deterministic: the buffer keeps the minimum depth (ties
// to the lower face index), which does not depend on the drawing order, so
// it is bit-identical at any thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

namespace detail {
/// Whether render_depth draws with its AVX2 row kernel: whether the build
/// has it (x86-64 GCC or Clang) and the CPU has AVX2, unless set to false
/// (tests and bench/drive_lines compare it with the portable kernel this
/// way; both give the same bits). Set it only while no render_depth runs.
std::atomic<bool>& depth_raster_avx2_enabled();

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
/// Pixel (x, y) covers [x, x+1) x [y, y+1) and is sampled at its centre.
struct DepthBuffer {
  int width = 0, height = 0;
  std::vector<float> depth;
  /// The face seen per pixel (-1 where empty) when rendered with faces;
  /// empty otherwise. Ties in depth go to the lower face index.
  std::vector<std::int32_t> face;
  float at(int x, int y) const { return depth[static_cast<std::size_t>(y) * width + x]; }
  /// Face seen at an image point (-1 outside the image, on background, or
  /// when the buffer was rendered without faces).
  std::int32_t face_at(const Vec2& pixel) const {
    const int i = static_cast<int>(pixel.x()), j = static_cast<int>(pixel.y());
    if (face.empty() || pixel.x() < 0.0 || pixel.y() < 0.0 || i >= width || j >= height) return -1;
    return face[static_cast<std::size_t>(j) * width + i];
  }
  /// Depth at an image point (+infinity outside the image).
  float depth_at(const Vec2& pixel) const {
    const int i = static_cast<int>(pixel.x()), j = static_cast<int>(pixel.y());
    if (pixel.x() < 0.0 || pixel.y() < 0.0 || i >= width || j >= height)
      return std::numeric_limits<float>::infinity();
    return depth[static_cast<std::size_t>(j) * width + i];
  }
  /// Minimum over the 3x3 pixels around (x, y), clamped to the image;
  /// +infinity outside the image.
  float min3x3(double x, double y) const;
  /// Maximum over the same window (+infinity where any pixel is empty).
  float max3x3(double x, double y) const;
  /// render_depth's working memory, reused when the buffer is rendered again.
  detail::RasterScratchSlot scratch;
};

/// Rasterises every triangle of `mesh` seen by `camera` (width x height
/// from the camera) with perspective-correct depth. In a perspective view
/// triangles with a corner on or behind the eye plane are skipped (no near
/// clipping); an orthographic view draws every triangle. A pixel is covered when its centre
/// has no negative barycentric weight (shared edges: both triangles); the
/// buffer holds the minimum depth, bit-identical at any thread count and to
/// a plain loop over every triangle and every pixel of its box (the binning
/// and the skipping of hidden back faces in depth_raster.cpp change nothing).
/// With `faces`, DepthBuffer::face holds the face seen at each pixel too.
DepthBuffer render_depth(const TriangleMesh& mesh, const Camera& camera, bool faces = false);
/// The same into `out`, reusing its storage and working memory (no
/// allocation when the mesh and image sizes are unchanged: keep one
/// DepthBuffer per view for redraws). Throws InputError when a side of the
/// image exceeds 32000 pixels.
void render_depth(const TriangleMesh& mesh, const Camera& camera, DepthBuffer& out,
                  bool faces = false);

}  // namespace fabrica
