// Curves on a triangulated surface: representation, validation, conversions
// and discrete geodesic curvature.
//
// A SurfaceCurve is a polyline of SurfacePoints (face + barycentrics), open
// or closed. Consecutive points must lie on a common face, so every segment
// runs inside one triangle and the curve never leaves the surface.
//
// The curve smoother, smooth_surface_curve(), is declared in
// fabrica/core/curve_smoothing.hpp.
//
// Units: lengths in mesh units (mm); angles in radians. Sign convention of
// the geodesic curvature (turning angle): positive when the curve turns left
// seen from outside, i.e. counter-clockwise about the outward normal of a
// counter-clockwise oriented mesh. At a vertex with total angle theta, split
// by the curve into theta_left + theta_right, the turning angle is
// pi - 2 pi theta_left / theta (Polthier & Schmies 1998), zero when the
// curve halves the angle.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface_point.hpp"
#include "fabrica/core/topology.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

/// A polyline on the surface. A closed curve's last point joins its first
/// (the first point is not repeated at the end).
struct SurfaceCurve {
  std::vector<SurfacePoint> points;
  bool closed = false;

  std::size_t size() const { return points.size(); }
  /// Number of segments: size()-1 when open, size() when closed (0 if < 2 points).
  std::size_t segment_count() const {
    if (points.size() < 2) return 0;
    return closed ? points.size() : points.size() - 1;
  }
};

/// A point on an undirected mesh edge: (1-t) p[edge(e)[0]] + t p[edge(e)[1]],
/// with Topology's edge numbering (edge(e)[0] < edge(e)[1]).
struct EdgePoint {
  std::int32_t edge = -1;
  double t = 0.0;
};

/// Tolerance on barycentric coordinates used by the helpers below: a
/// coordinate within this of 0 counts as 0 (the point is on an edge or at a
/// vertex), and the coordinates of a valid point may miss [0,1] and sum 1
/// by this much.
inline constexpr double kBarycentricTolerance = 1e-9;

/// 3D position of every point, in order.
std::vector<Vec3> curve_positions(const TriangleMesh& mesh, const SurfaceCurve& curve);

/// Length of the polyline (including the closing segment of a closed curve).
double curve_length(const TriangleMesh& mesh, const SurfaceCurve& curve);

/// Clamps coordinates within `tolerance` of 0 to exactly 0, clamps small
/// negatives, and renormalises to sum 1, so a point meant to lie on an edge
/// or at a vertex lies exactly there. The face is unchanged.
SurfacePoint snap_barycentrics(const SurfacePoint& point, double tolerance = kBarycentricTolerance);

/// The edge a point lies on (exactly one barycentric coordinate within
/// `tolerance` of 0), as (edge, t); std::nullopt for points inside a face or
/// at a vertex. Precondition: point.face is a face of `topology`.
std::optional<EdgePoint> to_edge_point(const TriangleMesh& mesh, const Topology& topology,
                                       const SurfacePoint& point,
                                       double tolerance = kBarycentricTolerance);

/// The mesh vertex a point lies at (two coordinates within `tolerance` of
/// 0), or std::nullopt.
std::optional<std::int32_t> to_vertex(const TriangleMesh& mesh, const SurfacePoint& point,
                                      double tolerance = kBarycentricTolerance);

/// The SurfacePoint of an edge point, expressed in the lowest-numbered face
/// of the edge. Throws InputError if the edge index is out of range, the
/// edge has no face, or t is not in [0,1].
SurfacePoint from_edge_point(const TriangleMesh& mesh, const Topology& topology,
                             const EdgePoint& point);

/// The lowest-numbered face that contains both points (each point's nonzero
/// barycentric corners are corners of it), or -1. Points on an edge belong
/// to every face of the edge, points at a vertex to every face of the vertex.
std::int32_t common_face(const TriangleMesh& mesh, const Topology& topology, const SurfacePoint& a,
                         const SurfacePoint& b, double tolerance = kBarycentricTolerance);

/// Throws InputError, prefixed with `what`, unless: the topology was built
/// from this mesh; every point has a face index in range and finite
/// barycentrics in [-tolerance, 1+tolerance] summing to 1 within tolerance;
/// every pair of consecutive points (and last-first if closed) lies on a
/// common face; a closed curve has at least 3 points. The message names the
/// point index and face.
void validate_surface_curve(const TriangleMesh& mesh, const Topology& topology,
                            const SurfaceCurve& curve, const std::string& what = "surface curve",
                            double tolerance = kBarycentricTolerance);

/// Discrete geodesic curvature of the curve as a turning angle (radians) at
/// each point, signed as described at the top of this file. Edge points: the
/// angle between the two segments in the unfolding of the edge's two faces.
/// Vertex points: Polthier–Schmies, pi - 2 pi theta_left / theta (at a
/// boundary vertex, pi minus the angle on the side without the boundary gap,
/// signed by that side). Points inside a face: the angle in the face plane.
/// Endpoints of open curves, and points where it is undefined (degenerate
/// faces, non-manifold vertices, coinciding neighbours), get 0.
/// Throws like validate_surface_curve.
std::vector<double> geodesic_turning_angles(const TriangleMesh& mesh, const Topology& topology,
                                            const SurfaceCurve& curve);

/// Sum of |turning angle| over the points (the total absolute geodesic curvature).
double total_absolute_turning(const TriangleMesh& mesh, const Topology& topology,
                              const SurfaceCurve& curve);

}  // namespace fabrica
