// The curvature direction field and the two masks of ConFIS (Lawonn, Moench
// & Preim 2013; docs/algorithms.md §9a), shared by ConFIS streamlines
// (confis.hpp) and surface LIC (render/).
//
// Conventions (docs/algorithms.md §0, §2.2): outward normals; the shape
// operator is the derivative of the outward normal, so convex regions have
// positive curvature (a sphere of radius R: k1 = k2 = +1/R); the MAXIMAL
// principal curvature is k1, the one of larger MAGNITUDE (|k1| >= |k2|), and
// e1 its direction. s_f is Surface::feature_size() (§2.6).
//
// (a) Direction field, per face, view-independent (compute once per mesh):
//     the corners' e1, projected into the face plane, are averaged as a LINE
//     field (doubled angles, weighted by the anisotropy |k1 − k2|), so a
//     corner's sign does not matter. A face is RELIABLE when the mean
//     anisotropy of its corners, |k1 − k2| · s_f, is at least
//     `umbilic_threshold` and the corners agree (coherence, the length of the
//     mean doubled-angle unit vector, at least `min_coherence`; 0.5 ≈ corners
//     within 60° of each other). Unreliable faces (umbilic regions, e.g. a
//     whole sphere, or flat ones) get a direction filled in from reliable
//     neighbours, ring by ring; a connected piece without any reliable face
//     (a sphere) gets the world z axis projected into each face (the x axis
//     where the face is within ~17° of facing ±z), smooth but for the poles. Signs are then aligned
//     by breadth-first propagation over the face graph from the lowest-index face of each connected
//     piece, neighbours in corner order: a neighbour is flipped when its direction makes an obtuse
//     angle with the face it is reached from. A line field need not be orientable (it can turn half
//     round an umbilic), so a few edges may still join opposite signs
//     (`seam_edges`); tracers choose the sign per face by continuity.
//     Directions are unit vectors in the face plane, zero only on degenerate
//     faces; never NaN.
// (b) Feature regions, view-independent: the scalar s_i = k1_i · s_f
//     (dimensionless; > 0 convex, < 0 concave) and the feature level
//         φ_i = max(s_i / t_convex, −s_i / t_concave) − 1
//     (≥ 0 inside: s ≥ t_convex, strongly convex, or s ≤ −t_concave,
//     strongly concave), set to −1 at umbilic vertices, where there is no
//     direction to draw. Inside a face φ is linear (a point is in the region
//     when its interpolated φ ≥ 0). Strength clamp(φ, 0, 1): 0 at the region's
//     border, 1 where |s| reaches twice the threshold.
// (c) Contour margin, per view: facing_i = n_i · v_i (v towards the eye,
//     Camera::view_vector), inside when 0 ≤ facing < ε; strength
//     clamp(1 − facing/ε, 0, 1): 1 at the contour (and on back faces, so
//     that it interpolates well up to the contour), 0 from the margin's inner
//     border on. Linear inside a face like φ.
//
// All functions run in parallel and give the same result at any thread
// count. They throw InputError for out-of-range options.
#pragma once

#include <cstdint>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica::hatching {

struct CurvatureFieldOptions {
  /// Umbilic test: a face is unreliable when the mean of |k1 − k2| · s_f
  /// over its corners is below this (>= 0).
  double umbilic_threshold = 0.01;
  /// Corners' e1 must agree: coherence in [0, 1] at least this.
  double min_coherence = 0.5;
};

struct CurvatureField {
  std::vector<Vec3> face_direction;         ///< unit, in the face plane, sign-aligned
  std::vector<std::uint8_t> face_reliable;  ///< 1: from e1; 0: umbilic / disagreeing, filled
  std::vector<double> vertex_anisotropy;    ///< |k1 − k2| · s_f (0 at invalid vertices)
  double feature_size = 1.0;                ///< s_f used
  std::size_t reliable_faces = 0;
  std::size_t seam_edges = 0;  ///< interior edges whose two directions are still opposed
};

/// The maximal-curvature direction field of (a). Needs the Surface's curvature.
CurvatureField compute_curvature_field(const Surface& surface,
                                       const CurvatureFieldOptions& options = {});

struct FeatureRegionOptions {
  /// Strongly convex: s = k1 · s_f ≥ this (> 0; rtsc's ridge default is 0.1).
  double convex_threshold = 0.1;
  /// Strongly concave: s ≤ −this (> 0).
  double concave_threshold = 0.1;
};

struct FeatureRegions {
  std::vector<double> scalar;         ///< s_i = k1_i · s_f
  std::vector<double> level;          ///< φ_i (≥ 0 inside), −1 at umbilic or invalid vertices
  std::vector<double> strength;       ///< clamp(φ_i, 0, 1)
  std::vector<std::uint8_t> mask;     ///< φ_i ≥ 0
  std::vector<std::uint8_t> umbilic;  ///< |k1 − k2| · s_f below the umbilic threshold
};

/// The feature regions of (b). The umbilic test uses `field`'s options'
/// threshold, passed again here.
FeatureRegions compute_feature_regions(const Surface& surface,
                                       const FeatureRegionOptions& options = {},
                                       double umbilic_threshold = 0.01);

struct ContourMargin {
  double epsilon = 0.0;
  std::vector<double> facing;      ///< n_i · v_i
  std::vector<double> strength;    ///< clamp(1 − facing/ε, 0, 1)
  std::vector<std::uint8_t> mask;  ///< 0 ≤ facing < ε
};

/// The contour margin of (c) for one view; ε in (0, 1].
ContourMargin compute_contour_margin(const Surface& surface, const Camera& camera, double epsilon);

/// Throws InputError naming the option when one is out of range.
void validate(const CurvatureFieldOptions& options);
void validate(const FeatureRegionOptions& options);

}  // namespace fabrica::hatching
