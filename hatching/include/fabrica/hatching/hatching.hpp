// Shading-stroke hatching after Singh & Schaefer 2010, "Suggestive Hatching"
// (docs/algorithms.md §9): strokes that follow the gradient of the diffuse
// intensity I, spaced in image space by a hierarchical proximity grid so that
// their density tracks the tone 1 − I.
//
// Per view: I and its piecewise-constant face gradient (intensity_field.hpp);
// a CPU depth/ID buffer at image resolution; optionally the intensity ridges
// (intensity_ridges.hpp), rasterised into the grid first so strokes keep away
// from them. Seeds are the lattice points of grid levels 0..seed_depth,
// coarse to fine; a seed at level L is used when it lies on the visible
// front-facing surface, I ≤ threshold, L ≤ d(I), and no earlier stroke (or
// ridge) is closer than the level's cell size s_L. From a seed the stroke is
// traced exactly across faces along −∇I and +∇I (the gradient itself, not
// its perpendicular: strokes run across isophotes), until one of the
// StrokeEnd reasons. At every sample (≤ sample_spacing_px apart) the
// proximity test uses level ⌊d(I)⌋ with the density rule
//     d(I) = 2 log2( S (1 − max(I, 0)) / stroke_width_px ),  S = max(W, H),
// clamped to [0, grid_depth]: a stroke of that width in cells of size
// S/√2^d covers the fraction 1 − I of the image. Finished strokes are marked
// into every level.
//
// Deterministic: the same StrokeSet at any thread count (the per-vertex and
// per-face work is parallel; tracing is sequential).
#pragma once

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/intensity_field.hpp"
#include "fabrica/hatching/intensity_ridges.hpp"
#include "fabrica/hatching/stroke_set.hpp"

namespace fabrica::hatching {

struct HatchingOptions {
  Light light;  ///< default: at the eye
  /// Strokes stop where I exceeds this (1 = no threshold, the paper's setting).
  double intensity_threshold = 1.0;
  /// Deepest proximity level used for truncation; -1 = automatic: 20 at
  /// 800 px (the paper), + 2 per doubling of the image side.
  int grid_depth = -1;
  /// Deepest seeding level; -1 = grid_depth − 2 (the paper's 18 at 800 px).
  int seed_depth = -1;
  /// false: truncate every stroke at grid_depth regardless of tone (the
  /// paper's "uniform maximum depth", Figure 5 left).
  bool adaptive_depth = true;
  /// Width of the drawn strokes in pixels (enters the density rule).
  double stroke_width_px = 1.0;
  /// Maximum stroke length in pixels, half on each side of the seed; 0 = none.
  double max_length_px = 0.0;
  /// Strokes shorter than this (pixels) are dropped.
  double min_length_px = 1.0;
  /// Image-space spacing of the visibility and proximity tests along a stroke.
  double sample_spacing_px = 0.5;
  /// A stroke point is occluded when the depth buffer holds a surface nearer
  /// by more than this many mean edge lengths (and not a face sharing a vertex).
  double occlusion_tolerance = 1.0;
  /// Detect intensity ridges and keep strokes away from them.
  bool ridge_removal = true;
  RidgeOptions ridges;
};

/// d(I) above, unclamped (−inf for I ≥ 1).
double density_depth(double intensity, double image_side, double stroke_width_px = 1.0);
/// The proximity level used at intensity I: ⌊d(I)⌋ clamped to [0, grid_depth].
int truncation_level(double intensity, double image_side, double stroke_width_px, int grid_depth);
/// The automatic grid depth for an image side S: round(20 + 2 log2(S / 800)), ≥ 0.
int default_grid_depth(double image_side);

/// Hatches `surface` seen by `camera` (camera.width × camera.height pixels).
/// Throws InputError for an invalid camera or options.
StrokeSet hatch(const Surface& surface, const Camera& camera, const HatchingOptions& options = {});

/// Same with a given field (e.g. a synthetic intensity); options.light is
/// ignored. The field must have one value per vertex and face.
StrokeSet hatch(const Surface& surface, const Camera& camera, const IntensityField& field,
                const HatchingOptions& options);

}  // namespace fabrica::hatching
