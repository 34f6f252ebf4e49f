// Ridges of the diffuse intensity I (Singh & Schaefer 2010, §4; docs/algorithms.md
// §9): the curves that attract shading strokes although they are bright.
//
// 1. Vertex gradient: G_i = angle-weighted mean of the face gradients around
//    vertex i (weights: interior angle at i, after Thürmer & Wüthrich 1998), E_i = dominant
//    eigenvector of the weighted covariance Σ w ∇I_T ∇I_Tᵀ (taken in the
//    vertex tangent plane, where the face gradients nearly lie), and
//    ∇I(p_i) = (G_i · E_i) E_i — stable where face gradients oppose.
// 2. Candidate on edge (p1, p2) unless ∇I(p1), ∇I(p2) are within
//    `min_angle_deg` (20°): p_r = (|∇I2| p1 + |∇I1| p2) / (|∇I1| + |∇I2|).
// 3. Two test directions: the dominant eigenvector of the covariance of
//    {∇I1, ∇I2} and of {N1 × ∇I1, N2 × ∇I2}. For each, step from p_r into
//    both faces of the edge (direction projected into each face plane) to
//    the opposite edges (p_f, p_b), interpolate the vertex gradients there,
//    and accept when the second difference
//    [∇I(p_f)·(p_f − p_r) − ∇I(p_b)·(p_r − p_b)] / (|p_f − p_r| + |p_r − p_b|) < 0
//    and the first derivatives change sign. Either direction suffices. A
//    direction along the edge itself (an edge crossing the ridge at right
//    angles) cannot step into a face; the construction's limit, p_f and p_b
//    = the edge's end points, is used instead. A ridge running exactly
//    through vertices (∇I(p_i) = 0 there) gives zero first derivatives, not
//    a sign change, and is not found; generic meshes do not do that.
// 4. Ridge points are joined per face (two points: one segment; three: each
//    to the face centroid). Boundary and non-manifold edges carry none.
#pragma once

#include <vector>

#include "fabrica/core/surface.hpp"
#include "fabrica/core/surface_point.hpp"
#include "fabrica/hatching/intensity_field.hpp"

namespace fabrica::hatching {

struct RidgeOptions {
  /// Edges whose end-point gradients differ by less than this angle carry no
  /// ridge point (the paper's 20°).
  double min_angle_deg = 20.0;
};

struct RidgeSegment {
  SurfacePoint a, b;  ///< anchors (the face containing the segment)
  Vec3 pa = Vec3::Zero(), pb = Vec3::Zero();
};

struct IntensityRidges {
  std::vector<Vec3> vertex_gradient;  ///< ∇I(p_i) = (G_i·E_i) E_i, 1/mm
  std::vector<RidgeSegment> segments;
};

/// Stable per-vertex gradients of I (step 1 above), in parallel.
std::vector<Vec3> intensity_vertex_gradients(const Surface& surface, const IntensityField& field);

/// Detects the intensity ridges of `field` (steps 1–4), deterministic.
IntensityRidges detect_intensity_ridges(const Surface& surface, const IntensityField& field,
                                        const RidgeOptions& options = {});

}  // namespace fabrica::hatching
