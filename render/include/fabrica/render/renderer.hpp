// Renderer: draws a Scene for a Camera into an Image (headless export, golden
// tests, the viewer's screenshots share this path). Per tile: opaque
// structures (depth A), ghosted structures by weighted blended OIT, a depth
// of every surface (depth B), hybrid apparent ridges, then lines as quads
// depth-tested against A (lines of opaque structures) or B (of ghosted
// ones). Images larger than the GL limit (or max_tile_size) are rendered in
// tiles with a 2-pixel overlap, so tiled and untiled output agree.
#pragma once

#include <memory>
#include <optional>

#include "fabrica/core/camera.hpp"
#include "fabrica/render/context.hpp"
#include "fabrica/render/image.hpp"
#include "fabrica/render/lic.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::render {

/// Hybrid apparent ridges (seed 000; docs/algorithms.md §6.4). The defaults are the
/// seed's method; per_fragment, sign_free and float_target are the thesis'
/// future-work improvements.
struct HybridOptions {
  /// q = 2^tau q1; empty = default_tau(feature size).
  std::optional<double> tau;
  double lambda = 1.5;        ///< direction weight of the filter (0 = Laplacian)
  double threshold = 0.2;     ///< the seed's clamp: lines where the filter response exceeds it
  bool fade = true;           ///< grey 1 - v; false: black above the threshold
  bool per_fragment = false;  ///< evaluate q1, t1 per fragment ("Phong-like")
  bool sign_free = false;     ///< store t1 as the double angle
  bool float_target = false;  ///< RGBA32F instead of 8-bit channels
  double saturation = 1.0;    ///< q is clamped to [0, saturation] (1 = the seed's colour range)
  Color color{0.0f, 0.0f, 0.0f, 1.0f};
};

/// tau = log2(k s_f^2) with k = 0.25, since q1 has units of 1/length^2
/// (docs/algorithms.md §6.4); 0 when the feature size is unknown.
double default_tau(double feature_size);

struct RenderOptions {
  bool transparent_background = false;
  /// Line widths are given for an image whose smaller side is this many pixels
  /// (as fabrica::lines styles the SVG).
  double line_reference_size = 1024.0;
  bool scale_lines_with_image = true;
  /// Largest tile side in pixels (0 = the backend's limit, at most 4096).
  int max_tile_size = 0;
  /// Hidden-line depth tolerance in mm (0 = automatic from the meshes).
  double depth_tolerance = 0.0;
  HybridOptions hybrid;
  /// Surface LIC of the structures whose style has `lic` (docs/lic.md).
  LicOptions lic;
  /// Draw the ghosted structures' transparency pass at half resolution in
  /// each axis and composite it upscaled (bilinear) over the full-resolution
  /// picture: a quarter of the blended pixels (the viewer while the camera
  /// moves; docs/algorithms.md §16). Applies to a picture of one tile
  /// without cutaway; otherwise ignored. Off: the picture is unchanged.
  bool ghosts_half_resolution = false;
  /// Line quads reach half a pixel past each line's half width instead of a
  /// pixel: the anti-aliased edge's coverage (half width + 0.5 - distance)
  /// is zero there, so the pixels of straight runs are the same with about
  /// a fifth fewer fragments; at sharp joins (miters) and along tapers a few
  /// pixels differ. The viewer while the camera moves; off: unchanged.
  bool tight_line_quads = false;
};

/// Where one render_hybrid frame spends its time (filled when asked for; the
/// benchmark's breakdown). *_gpu_ms: GL_TIME_ELAPSED of stage 1 (clear and
/// draw into the (q, t1) target) and stage 2 (clear of the colour target and
/// the filter pass) as the driver reports it; *_ms: wall clock of each stage
/// with a glFinish after it, and of the readback (glReadPixels and the copy
/// into the Image). Profiling adds the glFinish calls; llvmpipe serialises the
/// stages anyway (stage 2 samples stage 1's target, the readback waits for
/// stage 2).
struct HybridFrameProfile {
  double stage1_gpu_ms = 0.0, stage2_gpu_ms = 0.0;
  double stage1_ms = 0.0, stage2_ms = 0.0, readback_ms = 0.0;
};

class Renderer {
 public:
  /// Takes ownership of a context (headless or window).
  explicit Renderer(std::unique_ptr<GlContext> context);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  GlContext& context();

  /// Renders at camera.width x camera.height. Throws InputError for an empty
  /// scene or a structure without mesh, Error(unavailable) if GL runs out of
  /// memory, Error(internal) on shader failures.
  Image render(const Scene& scene, const Camera& camera, const RenderOptions& options = {});

  /// The same picture without reading it back: drawn on the GPU and copied
  /// (scaled linearly when the sizes differ) into `framebuffer` of this
  /// renderer's context, width x height pixels from its origin; colours
  /// premultiplied by alpha. The picture must fit one tile (at most the GL
  /// limit, 4096, a side; InputError otherwise). The viewer's window draws
  /// through this; exports read back through render().
  void render_to_framebuffer(const Scene& scene, const Camera& camera, const RenderOptions& options,
                             unsigned int framebuffer, int width, int height);

  /// The hybrid method alone on one mesh (stage 1, stage 2, readback), black
  /// lines on white (or transparent). `bare` runs the same passes with
  /// trivial shaders (the benchmark's baseline).
  /// With `profile`, the stages' times are added to it (summed over tiles).
  Image render_hybrid(const std::shared_ptr<const RenderMesh>& mesh, const Camera& camera,
                      const HybridOptions& options, bool transparent = false, bool bare = false,
                      HybridFrameProfile* profile = nullptr);

  /// Stage 1 only: the packed (q, t1) buffer as an image (for figures and tests).
  Image render_hybrid_buffer(const std::shared_ptr<const RenderMesh>& mesh, const Camera& camera,
                             const HybridOptions& options);

  /// The LIC pass alone on one mesh (needs RenderMesh::lic_field): per pixel
  /// red = the LIC value v, green = the feature mask (0 where the mesh is not
  /// visible), 8 bits each; what lic_reference computes on the CPU.
  Image render_lic_buffer(const std::shared_ptr<const RenderMesh>& mesh, const Camera& camera,
                          const LicOptions& options);

 private:
  struct BlitTarget {
    unsigned int framebuffer;
    int width, height;
  };
  void draw(const Scene& scene, const Camera& camera, const RenderOptions& options, Image* out,
            const BlitTarget* blit);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fabrica::render
