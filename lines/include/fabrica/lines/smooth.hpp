// Smoothing chained feature lines on the surface (docs/algorithms.md §10, §11).
//
// Every polyline of a LineSet is a curve on the surface: its points carry a
// surface anchor (face + barycentric coordinates) and most lie on mesh edges,
// because they are zero crossings on edges. smooth_lines() converts each
// polyline of the chosen families into a SurfaceCurve and straightens it
// with the foundation's smooth_surface_curve() (Lawonn, Gasteiger, Rössl &
// Preim, "Adaptive and robust curve smoothing on surface meshes", Computers
// & Graphics 40, 2014; docs/curves.md): a few Gauss–Seidel sweeps slide the
// edge points along their edges towards zero geodesic curvature, which
// removes the zig-zag that zero crossings pick up on noisy or irregular
// meshes. The smoothed line stays exactly on the surface (anchors are
// rewritten; positions are the anchors' positions), and its length and
// total absolute geodesic curvature never increase.
//
// Points that are not on an edge or a vertex (face centroids where three
// crossings join — ridges, valleys, apparent ridges — and test-function clip
// points inside a face) are kept fixed, exactly as they are, like the two
// endpoints of an open polyline: the polyline is smoothed piecewise between
// them. Closed loops stay closed. Polylines whose anchors break the surface
// curve rules (a face index out of range, non-finite or invalid barycentric
// coordinates, consecutive points that share no face) are left unchanged
// and counted. A closed loop that would shrink below three points is
// smoothed with fewer iterations (halved until it survives), or left
// unchanged and counted if even one iteration collapses it (loops of 3–4
// points around one vertex).
//
// Per-point attributes: a smoothed polyline gets new points (points are
// removed, moved, and inserted where the curve is re-routed around a
// vertex), so each new point takes the strength and visibility of the old
// polyline at the same fraction of arc length between the same two fixed
// points (for a loop without fixed points, arc length measured from where
// the new first point projects onto the old loop): strength is interpolated
// linearly, visibility is that of the old edge the parameter falls in.
// Fixed points keep their own attributes and their exact position. Smooth
// before compute_visibility(), which tests the smoothed positions.
//
// Deterministic: polylines are smoothed independently (in parallel with
// TBB), each by the single-threaded core routine, and the statistics are
// summed in polyline order, so the result has the same bits at any thread
// count. Units: lengths in mesh units (mm).
#pragma once

#include <cstddef>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica {

/// The families smoothed by default: every family except `boundary` and
/// `crease`, which run along mesh edges by definition (smoothing would pull
/// them off the edges they mark).
std::vector<LineFamily> default_smoothed_families();

struct LineSmoothingOptions {
  /// Sweeps of smooth_surface_curve per polyline (its `iterations`); 0 turns
  /// smoothing off. One removes most of the zig-zag that zero crossings
  /// pick up on noisy meshes (on igea, 88% of the total absolute geodesic
  /// curvature; 3 iterations 94%); many straighten a line towards a
  /// geodesic and shrink closed loops (about 0.7 h² κ_g per iteration, h the
  /// edge length, κ_g the geodesic curvature).
  int iterations = 3;
  /// Damping in (0,1]: fraction of the way to the straightened position per
  /// sweep (CurveSmoothingOptions::step).
  double step = 1.0;
  /// Re-route lines around vertices they pass through when that is shorter
  /// (CurveSmoothingOptions::split_at_vertices).
  bool split_at_vertices = true;
  /// Fraction of an edge's length within which a point counts as being at
  /// the vertex, in [0, 0.001] (CurveSmoothingOptions::vertex_snap).
  double vertex_snap = 1e-6;
  /// Families to smooth; polylines of other families are left unchanged.
  std::vector<LineFamily> families = default_smoothed_families();
};

struct LineSmoothingStats {
  std::size_t polylines = 0;      ///< polylines of the chosen families
  std::size_t smoothed = 0;       ///< of these, smoothed (possibly unchanged geometry)
  std::size_t too_short = 0;      ///< open polylines of < 3 points: nothing to move
  std::size_t invalid = 0;        ///< left unchanged: anchors break the surface-curve rules
  std::size_t collapsed = 0;      ///< loops left unchanged: 1 iteration leaves < 3 points
  std::size_t fixed_points = 0;   ///< interior points inside a face, kept fixed
  std::size_t points_before = 0;  ///< points of the smoothed polylines before
  std::size_t points_after = 0;   ///< and after
  double length_before = 0.0;     ///< length of the smoothed polylines before (mm)
  double length_after = 0.0;      ///< and after (never more, up to vertex snapping)
};

/// Smooths the polylines of `lines` in place (see the top of this file).
/// `topology` must be built from `mesh` and the anchors must refer to
/// `mesh`. Throws InputError only for bad options (iterations < 0, step
/// outside (0,1], vertex_snap outside [0, 0.001]); bad polylines are counted
/// and left unchanged.
LineSmoothingStats smooth_lines(LineSet& lines, const TriangleMesh& mesh, const Topology& topology,
                                const LineSmoothingOptions& options = {});
/// The same with the Surface's mesh and topology.
LineSmoothingStats smooth_lines(LineSet& lines, const Surface& surface,
                                const LineSmoothingOptions& options = {});

}  // namespace fabrica
