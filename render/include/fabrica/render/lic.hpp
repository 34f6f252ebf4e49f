// Surface line integral convolution (issue 21, item 2; docs/lic.md,
// docs/algorithms.md §14): noise attached to the surface, smeared along the
// screen projection of the maximal-curvature direction field inside the
// feature regions, and multiplied into the shading. The renderer's LIC pass
// (Renderer::render, StructureStyle::lic) runs it on the GPU; lic_reference
// below is the same method on the CPU (same noise, same kernel, same mask),
// the tests' reference.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/render/render_mesh.hpp"

namespace fabrica {
class Surface;
}

namespace fabrica::render {

struct LicOptions {
  /// Half length of the convolution kernel along the field, in noise cells
  /// (the streak length relative to the grain; > 0, at most 64).
  double kernel_length = 8.0;
  /// Edge of a noise cell on the surface in mm; 0 = automatic: the mesh's
  /// bounding-sphere radius / 200 (about 2 pixels when the mesh fills a
  /// 1024-pixel picture). The noise lives on the surface, so a larger export
  /// shows the same pattern with more pixels per cell.
  double noise_scale = 0.0;
  /// How much of the shading the texture replaces, in [0, 1]: the shaded
  /// colour is multiplied by mix(1, v, strength * mask) (v the LIC value).
  double strength = 0.8;
};

/// Throws InputError naming `what` (e.g. "--lic-length") for a value out of range.
void validate(const LicOptions& options, const std::string& what = "lic");

/// The noise cell edge in mm for `mesh` (options.noise_scale or the automatic one).
double lic_noise_cell(const RenderMesh& mesh, const LicOptions& options);

/// Kernel geometry in pixels: `steps` samples each side of the pixel,
/// `step_px` apart (steps = ceil(length_px), at most kLicMaxSteps; 0 when the
/// kernel is shorter than a pixel).
struct LicKernel {
  int steps = 0;
  float step_px = 1.0f;
  float gain = 1.0f;  ///< contrast stretch of the averaged noise around 0.5
  /// Hann weights 0.5 + 0.5 cos(pi i / (steps + 1)) of steps 1..steps
  /// (weights[i - 1]); the centre weighs 1. Passed to the shader as is.
  std::vector<float> weights;
};
inline constexpr int kLicMaxSteps = 24;
LicKernel lic_kernel(const LicOptions& options, double cell_mm, double px_per_mm);

/// Pixels per mm at the camera's focus distance (the renderer's line and
/// kernel scale).
double camera_px_per_mm(const Camera& camera);

/// Solid value noise in [0, 1) at p (in noise cells): a hashed value per
/// integer lattice point, smoothstep-trilinear between them. Bit-for-bit the
/// function of shaders/lic_noise.glsl (the interpolation in float).
float lic_noise(float x, float y, float z);

/// What the LIC pass needs of a surface, per vertex: `direction` (3 floats)
/// the maximal-curvature LINE direction, the area-weighted doubled-angle
/// mean of its faces' directions in the shared curvature field
/// (fabrica/hatching/curvature_field.hpp, default options), unit, zero where
/// none; `level` the feature level phi of the feature regions (>= 0 inside,
/// the mask is clamp(phi, 0, 1)).
struct LicField {
  std::vector<float> direction, level;
};
LicField compute_lic_field(const Surface& surface);

/// compute_lic_field, computed once per surface while it is alive (a
/// process-wide cache keyed by the surface; thread-safe): build_scene,
/// render_scene and `fabrica batch` reuse it for every view of a mesh.
std::shared_ptr<const LicField> cached_lic_field(const std::shared_ptr<const Surface>& surface);

/// Sets mesh.lic_field and mesh.lic_level from compute_lic_field(surface)
/// (the cached one with the shared_ptr); the mesh must be made from the same
/// surface.
void set_lic_field(RenderMesh& mesh, const Surface& surface);
void set_lic_field(RenderMesh& mesh, const std::shared_ptr<const Surface>& surface);

/// The LIC pass's two images on the CPU for one mesh (its own occluder),
/// rasterised at pixel centres: `value` the LIC value v in [0, 1] per pixel
/// (row 0 at the top, as Image), `mask` the feature mask clamp(phi, 0, 1)
/// (0 where the mesh is not visible, where the visible face is a back face,
/// or outside the feature regions), both quantised as the GPU pass's RGBA8
/// target holds them. Needs mesh.lic_field and mesh.lic_level.
struct LicBuffer {
  int width = 0, height = 0;
  std::vector<float> value, mask;
};
LicBuffer lic_reference(const RenderMesh& mesh, const Camera& camera, const LicOptions& options);

}  // namespace fabrica::render
