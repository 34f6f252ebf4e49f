// ViewFields: the per-view, per-vertex scalars and vectors every
// view-dependent line family is extracted from, recomputed for each camera
// in parallel (TBB, deterministic). Nothing view-independent lives here: it
// stays cached in the Surface (curvature) or in LinePrecompute (ridges,
// demarcating curves, the gradient operator, the Laplacian of the normals).
//
// Definitions (docs/algorithms.md §0, §4, §6; DeCarlo et al. 2003/2004; Judd et
// al. 2007), with v the unit view vector at the vertex (towards the eye for
// perspective, as rtsc), n the vertex normal, (e1, e2, k1, k2) the principal
// frame (|k1| >= |k2|, convex positive), (a, b, c, d) the curvature
// derivative tensor, u = v·e1, w = v·e2 (u² + w² = sin²θ):
//   ndotv          n·v = cos θ                                   (unitless)
//   kr             K_r = k1 u² + k2 w² = κ_r sin²θ               (1/mm)
//   sc_num         N = C_w - 2 (n·v) τ_r², C_w = (a u³ + 3b u²w + 3c u w² + d w³)/sin²θ,
//                  τ_r = (k2 - k1) u w / sin²θ; N/(n·v) = tan θ D_ŵ κ_r  (1/mm²)
//   q1             largest eigenvalue of QᵀQ, Q = S P⁻¹ (rtsc stores q1², 1/mm²)
//   t1             its unit eigenvector in principal coordinates
//   t1_world       t1[0] e1 + t1[1] e2 (unit tangent vector)
//   dt1q1          D_t1 q1 by Judd's one-sided finite differences (§6.2), 1/mm³
//   apparent_vertex  E = dt1q1 · t1_world (the apparent-ridge kernel's
//                  field), with dt1q1, q1 and the position: one record
//                  per vertex
//   light          f = n·l (headlight l = v, or a fixed direction), unclamped
//   light_gradient ∇f at the vertex (1/mm); light_laplacian Δf (1/mm²)
// Vertices where the Surface marks curvature invalid get zeros.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

class LinePrecompute;

/// Which groups of fields to compute (the rest stay empty).
struct ViewFieldsRequest {
  bool radial = true;    ///< ndotv, kr (contours, suggestive contours, highlights)
  bool sc_test = true;   ///< sc_num (suggestive contours and highlights)
  bool apparent = true;  ///< q1, t1, t1_world, dt1q1, apparent_vertex
  /// With a value t (rtsc's q1 threshold in 1/mm², as the apparent-ridge
  /// extractor uses): dt1q1 is computed only at the vertices of faces with a
  /// corner where q1 > t, the only ones an apparent ridge with that
  /// threshold reads, and is 0 elsewhere; ViewFields::signs gets kQ1Above.
  /// q1, t1 and t1_world are always computed everywhere. nullopt: everywhere.
  std::optional<double> apparent_cull_threshold;
  /// With a value m (and apparent_cull_threshold): kQ1Above, and so the
  /// vertices dt1q1 is computed around and the faces the apparent-ridge
  /// kernel reads, only where also n·v >= m (not where n·v < m). For a
  /// closed opaque surface seen from outside whose hidden lines are
  /// omitted, m < 0 skips work on faces that cannot be seen (the viewer's
  /// moving frames, ApparentOptions::min_ndotv). nullopt: no such limit.
  std::optional<double> apparent_min_ndotv;
  /// With a value s (the suggestive-contour test's shift in 1/mm², as the
  /// extractor uses: threshold / feature size²) and sc_test:
  /// ViewFields::signs gets kScOffFront and kScOffBack for the test
  /// numerator N = sc_num - s · n·v, so faces the test rejects at every
  /// corner are rejected from the sign bytes. nullopt: no such bits.
  std::optional<double> suggestive_test_shift;
  bool light = false;  ///< light, light_gradient(_norm), light_laplacian, light_faces
  bool pel = false;    ///< pel_h, pel_maximum (PELs): D_w|∇f| and -D_w D_w|∇f|
  /// Light direction (towards the light) for PELs / Laplacian lines;
  /// nullopt = headlight (v at each vertex).
  std::optional<Vec3> light_direction;
  /// Where PELs and Laplacian lines can be kept (the smallest of their
  /// thresholds, 1/mm, and whether both cull back faces): pel_h and
  /// pel_maximum are then only computed around the faces that can carry a
  /// kept line and are zero elsewhere (see ViewFields). The defaults
  /// compute them everywhere.
  double light_threshold = -std::numeric_limits<double>::infinity();
  bool light_cull_backfaces = false;
};

/// Bits of ViewFields::signs: one byte per vertex, filled with the radial
/// group, so face loops can reject most faces from a small array. Exact
/// comparisons (NaN sets neither of a > 0 / < 0 pair).
enum ViewSign : std::uint8_t {
  kNdotvPositive = 1,  ///< n·v > 0
  kNdotvNegative = 2,  ///< n·v < 0
  kNdotvNotBack = 4,   ///< !(n·v <= 0): not culled as back-facing
  kKrPositive = 8,     ///< K_r > 0
  kKrNegative = 16,    ///< K_r < 0
  /// !(q1 <= apparent_cull_threshold) (only with a threshold) and, with
  /// apparent_min_ndotv m, !(n·v < m)
  kQ1Above = 32,
  /// With a suggestive_test_shift s and N = sc_num - s · n·v (only then):
  kScOffFront = 64,  ///< N <= 0 and n·v >= 0
  kScOffBack = 128,  ///< N >= 0 and n·v <= 0
};

/// What the apparent-ridge kernel reads at a face corner, in one 64-byte
/// cache line: the sign-free field E = dt1q1 · t1_world (1/mm³), D_t1 q1,
/// q1 and the vertex position (copies of ViewFields::dt1q1, q1 and the
/// Surface's position).
struct alignas(64) ApparentVertex {
  Vec3 field;
  double dt1q1;
  double q1;
  Vec3 position;
};
static_assert(sizeof(ApparentVertex) == 64);

struct ViewFields {
  Camera camera;
  std::vector<double> ndotv, kr, sc_num;
  std::vector<double> q1, dt1q1;
  std::vector<Vec2> t1;
  std::vector<Vec3> t1_world;
  /// Per vertex: E = dt1q1 · t1_world, the sign-free field whose zero set
  /// the apparent-ridge kernel extracts, and the other per-corner inputs of
  /// that kernel. With apparent_cull_threshold, guaranteed current only at
  /// the corners of faces with a corner where q1 > threshold (the only ones
  /// the kernel reads); elsewhere they may hold an earlier view's values.
  std::vector<ApparentVertex> apparent_vertex;
  std::vector<std::uint8_t> signs;                ///< ViewSign bits (with the radial group)
  std::optional<double> apparent_cull_threshold;  ///< as requested
  std::optional<double> apparent_min_ndotv;       ///< as requested (with the threshold)
  std::optional<double> suggestive_test_shift;    ///< as requested (with sc_num)
  std::vector<double> light, light_laplacian;
  std::vector<Vec3> light_gradient;
  /// |∇f| (1/mm; with `light`), D_w|∇f| (1/mm²) and -D_w D_w|∇f| (1/mm³,
  /// > 0 where |∇f| is a maximum along w = ∇f/|∇f|; with `pel`).
  /// A face "can carry a line" when some corner has |∇f| > light_threshold
  /// (less a relative 1e-9 margin) and, with light_cull_backfaces, some
  /// corner has n·v > 0; light_faces lists them (ascending). pel_h is exact
  /// at their corners and the corners' neighbours, pel_maximum at their
  /// corners; both are 0 at vertices that no such face needs. Extraction
  /// with a threshold >= light_threshold (and culling if
  /// light_cull_backfaces) visits only light_faces and is exact.
  std::vector<double> light_gradient_norm, pel_h, pel_maximum;
  std::vector<std::int32_t> light_faces;
  double light_threshold = -std::numeric_limits<double>::infinity();  ///< as requested
  bool light_cull_backfaces = false;                                  ///< as requested
};

/// Computes the requested fields for `camera` (validated first; InputError
/// on a bad camera). `precompute` is needed only for `light`/`pel` (it holds
/// the gradient operator and ΔN); pass nullptr otherwise.
ViewFields compute_view_fields(const Surface& surface, const Camera& camera,
                               const ViewFieldsRequest& request = {},
                               const LinePrecompute* precompute = nullptr);

/// Recomputes into an existing ViewFields (reuses its buffers: no allocation
/// per frame once sized).
void update_view_fields(ViewFields& fields, const Surface& surface, const Camera& camera,
                        const ViewFieldsRequest& request = {},
                        const LinePrecompute* precompute = nullptr);

}  // namespace fabrica
