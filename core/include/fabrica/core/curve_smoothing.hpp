// The curve smoother: straightens a SurfaceCurve towards a geodesic.
//
// smooth_surface_curve() follows the "curve smoothing and splitting step" of
// Lawonn, Gasteiger, Rössl & Preim, "Adaptive and robust curve smoothing on
// surface meshes", Computers & Graphics 40 (2014), and Lawonn's dissertation
// (Magdeburg 2014, ch. 3); see docs/algorithms.md §10 and docs/curves.md.
// Interior points lie on mesh edges; each one slides along its edge towards
// the point where the curve is straight in the unfolding of the edge's two
// faces (zero geodesic curvature); a point that reaches a mesh vertex is
// re-routed through the vertex's triangle fan on the side whose angle is
// below pi (the splitting step), points that become redundant are removed,
// and a run of points around one vertex is solved as a block in the vertex's
// unfolded fan (collapsing onto the vertex when the passage through it is
// shortest). Every operation is a Gauss–Seidel step that never lengthens the
// curve (up to vertex snapping), so the length is non-increasing over
// iterations.
//
// Units and the sign of turning angles: see fabrica/core/surface_curve.hpp.
#pragma once

#include <cstddef>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface_curve.hpp"
#include "fabrica/core/topology.hpp"

namespace fabrica {

struct CurveSmoothingOptions {
  /// Maximal number of iterations (sweeps over the curve).
  int iterations = 100;
  /// Damping in (0,1]: each point moves this fraction of the way to its
  /// straightened position per iteration (1 = all the way).
  double step = 1.0;
  /// Stop early when no point moved more than tolerance * curve length in
  /// an iteration and the sequence of points did not change.
  double tolerance = 1e-10;
  /// A point within this fraction of its edge's length from a vertex is put
  /// on the vertex (and then re-routed by the splitting step); at most 0.001.
  double vertex_snap = 1e-6;
  /// Re-route the curve around vertices it passes through when that makes
  /// it shorter (the splitting step). Without it a point that reaches a
  /// vertex stays there.
  bool split_at_vertices = true;
};

struct CurveSmoothingResult {
  /// The smoothed curve. Endpoints of an open curve are the input's,
  /// unchanged. Every other point lies on a mesh edge (one barycentric
  /// coordinate exactly 0) or at a vertex where the curve cannot be
  /// shortened locally (a saddle vertex, a boundary, a non-manifold vertex).
  /// Segment i (points i, i+1) lies in points[i].face.
  SurfaceCurve curve;
  /// Curve length before the first iteration ([0]) and after each iteration.
  std::vector<double> length_history;
  /// Total absolute turning angle (total_absolute_turning) likewise.
  std::vector<double> turning_history;
  int iterations = 0;        ///< iterations performed
  bool converged = false;    ///< stopped by `tolerance` before `iterations`
  bool collapsed = false;    ///< a closed curve shrank to fewer than 3 points and was stopped
  std::size_t splits = 0;    ///< vertex passages re-routed
  std::size_t removals = 0;  ///< points removed (redundant or coinciding)
};
using SmoothingResult = CurveSmoothingResult;

/// Straightens `curve` on the surface (see the top of this file and
/// docs/curves.md). Preconditions (InputError otherwise): those of
/// validate_surface_curve; every point except the endpoints of an open curve
/// lies on a mesh edge or at a vertex (not inside a face); options.step in
/// (0,1], iterations >= 0, vertex_snap in [0, 0.001], tolerance >= 0.
/// Endpoints of an open curve stay fixed (a free end would let the curve
/// shrink away); a closed curve stays closed. Deterministic, single-threaded.
CurveSmoothingResult smooth_surface_curve(const TriangleMesh& mesh, const Topology& topology,
                                          const SurfaceCurve& curve,
                                          const CurveSmoothingOptions& options = {});

}  // namespace fabrica
