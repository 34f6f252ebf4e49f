// ConFIS: contour- and feature-based illustrative streamlines (Lawonn,
// Moench & Preim, "Streamlines for Illustrative Real-Time Rendering",
// EuroVis 2013; docs/algorithms.md §9a, user page docs/confis.md).
//
// Streamlines of the maximal-curvature direction field (curvature_field.hpp)
// traced exactly across triangles by the hatching tracer (§9), evenly spaced
// in image space by the proximity grid, and drawn only where a point lies in
// the contour margin (0 ≤ n·v < ε) or in a feature region (strongly convex
// or concave, k1 · s_f beyond a threshold). Each stroke vertex carries a
// style weight in [0, 1] (StrokeVertex::weight): the larger of the margin's
// strength (1 at the contour, 0 at the margin's inner border) and the
// feature region's (0 at its border, 1 at twice the threshold), raised to
// `min_weight` at least; the SVG and PNG writers scale width and opacity by it.
//
// Spacing: seeds come from the grid levels 0..L_s, L_s = round(2 log2(S /
// spacing_px)), S = max(width, height), so seeds are at least s_{L_s} ≈
// spacing_px from every earlier stroke; strokes are cut where another is
// closer than half of that (level L_s + 2; Jobard & Lefer's d_test = d_sep/2).
// The spacing is therefore quantised to the grid's √2 steps.
//
// Cost: the field and feature regions are per mesh (ConfisPrecompute, reuse
// it across views); per view: the margin, a depth buffer and the tracing.
// Deterministic: the same StrokeSet at any thread count.
#pragma once

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/curvature_field.hpp"
#include "fabrica/hatching/stroke_set.hpp"

namespace fabrica::hatching {

struct ConfisOptions {
  /// Contour margin width ε on n·v, in (0, 1]: strokes within it near the contour.
  double contour_margin = 0.3;
  /// Draw in the contour margin / in the feature regions (at least one).
  bool contours = true;
  bool features = true;
  /// Feature thresholds on k1 · s_f (convex, concave).
  FeatureRegionOptions feature_regions;
  /// Umbilic detection and the direction field.
  CurvatureFieldOptions field;
  /// Distance between neighbouring streamlines in pixels (> 0).
  double spacing_px = 6.0;
  /// Streamlines shorter than this (pixels) are dropped (>= 0).
  double min_length_px = 8.0;
  /// Longest streamline in pixels, half on each side of the seed; 0 = none.
  double max_length_px = 0.0;
  /// Width of the strokes where the style weight is 1, in pixels (> 0).
  double stroke_width_px = 1.0;
  /// Lowest style weight at the masks' borders, in [0, 1].
  double min_weight = 0.15;
  /// Image-space spacing of the visibility and proximity tests (> 0).
  double sample_spacing_px = 0.5;
  /// Occlusion tolerance in mean edge lengths (>= 0), as hatching's.
  double occlusion_tolerance = 1.0;
};

/// The per-mesh, view-independent part.
struct ConfisPrecompute {
  CurvatureField field;
  FeatureRegions regions;
};

/// Throws InputError naming the option when one is out of range.
void validate(const ConfisOptions& options);

/// The direction field and feature regions for `options` (parallel).
ConfisPrecompute precompute_confis(const Surface& surface, const ConfisOptions& options = {});

/// ConFIS strokes for one view with a precompute made for the same surface
/// and options (InputError if it does not match the mesh).
StrokeSet confis(const Surface& surface, const Camera& camera, const ConfisPrecompute& pre,
                 const ConfisOptions& options = {});
/// Same, precomputing first.
StrokeSet confis(const Surface& surface, const Camera& camera, const ConfisOptions& options = {});

/// The grid level whose cells are spacing_px: round(2 log2(image_side / spacing_px)), >= 0.
int confis_spacing_level(double image_side, double spacing_px);

}  // namespace fabrica::hatching
