// The diffuse-intensity field that shading strokes follow (Singh & Schaefer
// 2010, "Suggestive Hatching", §3.1; docs/algorithms.md §9).
//
//  - Per vertex I_i = n_i · l_i, UNCLAMPED (negative in shadow, so the field
//    stays consistent there; the density rule uses max(I, 0)). n_i is the
//    Surface's unit vertex normal; l_i the unit vector towards the light:
//    the view vector (light at the eye, the default), a fixed direction, or
//    towards a point light.
//  - Gouraud: I is linear over each face (barycentric interpolation).
//  - Face gradient ∇I|_T = 1/(2 A_T) Σ_k I_k (n_T × e_k), e_k = p_{k+2} − p_{k+1}
//    (the §1 form; the seed's printed formula reverses the cross product and
//    drops the ½). Piecewise constant, in the face plane, units 1/mm.
//    Recomputed for every view and light.
//  - facing_i = n_i · v_i (v towards the eye), for back-face tests of strokes.
// Degenerate faces get a zero gradient, never NaN.
#pragma once

#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica::hatching {

enum class LightKind {
  eye,        ///< co-located with the viewer: l = view vector (paper default)
  direction,  ///< distant light: `vector` is the direction towards the light (world)
  point,      ///< point light at `vector` (world coordinates, mm)
};

struct Light {
  LightKind kind = LightKind::eye;
  Vec3 vector = Vec3::Zero();
};

struct IntensityField {
  std::vector<double> vertex_intensity;  ///< I_i = n_i · l_i, unclamped
  std::vector<double> vertex_facing;     ///< n_i · v_i (> 0: front-facing)
  std::vector<Vec3> face_gradient;       ///< ∇I per face (1/mm), zero on degenerate faces
};

/// Computes the field for one view and light (parallel, deterministic).
/// Throws InputError for a zero light direction, or a point light that
/// coincides with a vertex.
IntensityField compute_intensity_field(const Surface& surface, const Camera& camera,
                                       const Light& light = {});

/// Piecewise-constant gradients of any per-vertex field with linear
/// interpolation: ∇f|_T = 1/(2 A_T) Σ_k f_k (n_T × e_k); zero on degenerate
/// faces. Parallel, deterministic.
std::vector<Vec3> face_gradients(const Surface& surface, const std::vector<double>& vertex_values);

/// Gradient of the barycentric coordinate of corner k of a face:
/// (n_T × e_k) / (2 A_T); zero for a degenerate face.
Vec3 barycentric_gradient(const Surface& surface, std::size_t face, int k);

}  // namespace fabrica::hatching
