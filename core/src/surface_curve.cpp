// Surface curves: validation, conversions and turning angles (see the
// header). The curve smoother is in curve_smoothing.cpp; both work on the
// canonical nodes of surface_curve_nodes.hpp.
#include "fabrica/core/surface_curve.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "fabrica/core/error.hpp"
#include "surface_curve_nodes.hpp"

namespace fabrica {

namespace curve_detail {

/// Signed angle between d1 and d2 about the unit normal n.
double signed_angle(const Vec3& d1, const Vec3& d2, const Vec3& n) {
  if (d1.squaredNorm() == 0.0 || d2.squaredNorm() == 0.0) return 0.0;
  return std::atan2(n.dot(d1.cross(d2)), d1.dot(d2));
}

/// Turning angle at a node given its neighbours (see the header).
double turning_angle(const CurveGeometry& g, const Node& prev, const Node& node, const Node& next) {
  if (node.kind == NodeKind::edge) {
    const EdgeUnfolding u = g.unfold_edge(node, prev, next);
    if (u.ok) {
      const Vec2 x(node.t * u.length, 0.0);
      const Vec2 d1 = x - u.prev, d2 = u.next - x;
      if (d1.squaredNorm() == 0.0 || d2.squaredNorm() == 0.0) return 0.0;
      return u.orientation * std::atan2(cross2(d1, d2), d1.dot(d2));
    }
  } else if (node.kind == NodeKind::vertex) {
    const Fan& fan = g.fan(node.id);
    if (!fan.valid) return 0.0;
    const FanPosition p = g.locate(fan, prev), q = g.locate(fan, next);
    if (!p.ok || !q.ok) return 0.0;
    if (fan.closed) {
      double right = q.phi - p.phi;
      if (q.position < p.position) right += fan.total;
      right = std::clamp(right, 0.0, fan.total);
      const double left = fan.total - right;
      return kPi - 2.0 * kPi * left / fan.total;
    }
    if (q.position > p.position) return -(kPi - (q.phi - p.phi));
    if (q.position < p.position) return kPi - (p.phi - q.phi);
    return 0.0;
  }
  // Inside a face, or a point whose neighbours share its face: measure in that face.
  for (const std::int32_t f : g.faces_of(node)) {
    if (!g.in_face(f, prev) || !g.in_face(f, next)) continue;
    const Face& F = g.face(f);
    const Vec3 normal = (g.point(F[1]) - g.point(F[0])).cross(g.point(F[2]) - g.point(F[0]));
    if (!(normal.norm() > 0.0)) return 0.0;
    const Vec3 x = g.position(node);
    return signed_angle(x - g.position(prev), g.position(next) - x, normal.normalized());
  }
  return 0.0;
}

std::string point_label(std::size_t i, const SurfacePoint& p) {
  std::ostringstream s;
  s << "point " << i << " (face " << p.face << ")";
  return s.str();
}

void check_topology_matches(const TriangleMesh& mesh, const Topology& topology,
                            const std::string& what) {
  if (topology.face_count() != mesh.face_count() ||
      topology.vertex_count() != mesh.vertex_count()) {
    std::ostringstream s;
    s << what << ": the topology (" << topology.vertex_count() << " vertices, "
      << topology.face_count() << " faces) was not built from this mesh (" << mesh.vertex_count()
      << " vertices, " << mesh.face_count() << " faces); build Topology(mesh) for the same mesh";
    throw InputError(s.str());
  }
}

/// Checks one point and converts it to canonical form (coordinates within
/// `tolerance` of 0 become 0).
Node to_node(const TriangleMesh& mesh, const Topology& topology, const SurfacePoint& p,
             std::size_t index, const std::string& what, double tolerance) {
  if (p.face < 0 || static_cast<std::size_t>(p.face) >= mesh.face_count()) {
    std::ostringstream s;
    s << what << ": " << point_label(index, p) << " has a face index out of range (the mesh has "
      << mesh.face_count() << " faces)";
    throw InputError(s.str());
  }
  const Vec3& b = p.bary;
  if (!b.allFinite() || b.minCoeff() < -tolerance || b.maxCoeff() > 1.0 + tolerance ||
      std::abs(b.sum() - 1.0) > tolerance) {
    std::ostringstream s;
    s << what << ": " << point_label(index, p) << " has invalid barycentric coordinates (" << b[0]
      << ", " << b[1] << ", " << b[2] << "); they must be finite, in [0,1] and sum to 1";
    throw InputError(s.str());
  }
  const SurfacePoint q = snap_barycentrics(p, tolerance);
  const Face& F = mesh.faces[static_cast<std::size_t>(q.face)];
  int nonzero = 0;
  for (int k = 0; k < 3; ++k) nonzero += q.bary[k] != 0.0 ? 1 : 0;
  Node n;
  if (nonzero == 1) {
    int k = 0;
    q.bary.maxCoeff(&k);
    n.kind = NodeKind::vertex;
    n.id = F[k];
  } else if (nonzero == 2) {
    int k = 0;
    q.bary.minCoeff(&k);
    n.kind = NodeKind::edge;
    n.id = topology.face_edge(static_cast<std::size_t>(q.face), k);
    if (n.id < 0) {
      std::ostringstream s;
      s << what << ": " << point_label(index, p)
        << " lies on a degenerate edge (both ends are the same vertex)";
      throw InputError(s.str());
    }
    const auto& e = topology.edge(static_cast<std::size_t>(n.id));
    n.t = q.bary[corner_of_face(F, e[1])];
  } else {
    n.kind = NodeKind::face;
    n.id = q.face;
    n.bary = q.bary;
  }
  return n;
}

/// Checks a curve and converts it to canonical nodes.
std::vector<Node> curve_nodes(const TriangleMesh& mesh, const Topology& topology,
                              const SurfaceCurve& curve, const std::string& what,
                              double tolerance) {
  check_topology_matches(mesh, topology, what);
  if (curve.closed && curve.points.size() < 3) {
    std::ostringstream s;
    s << what << ": a closed curve needs at least 3 points, got " << curve.points.size();
    throw InputError(s.str());
  }
  std::vector<Node> nodes;
  nodes.reserve(curve.points.size());
  for (std::size_t i = 0; i < curve.points.size(); ++i)
    nodes.push_back(to_node(mesh, topology, curve.points[i], i, what, tolerance));
  const CurveGeometry g(mesh, topology);
  const std::size_t n = nodes.size();
  const std::size_t pairs = curve.segment_count();
  for (std::size_t i = 0; i < pairs; ++i) {
    const std::size_t j = (i + 1) % n;
    if (g.common_face(nodes[i], nodes[j]) < 0) {
      std::ostringstream s;
      s << what << ": " << point_label(i, curve.points[i]) << " and "
        << point_label(j, curve.points[j])
        << " do not lie on a common face; consecutive points must share a triangle so that "
           "the segment between them stays on the surface";
      throw InputError(s.str());
    }
  }
  return nodes;
}

}  // namespace curve_detail

using namespace curve_detail;

std::vector<Vec3> curve_positions(const TriangleMesh& mesh, const SurfaceCurve& curve) {
  std::vector<Vec3> out;
  out.reserve(curve.points.size());
  for (std::size_t i = 0; i < curve.points.size(); ++i) {
    const SurfacePoint& p = curve.points[i];
    if (p.face < 0 || static_cast<std::size_t>(p.face) >= mesh.face_count()) {
      std::ostringstream s;
      s << "surface curve: " << point_label(i, p) << " has a face index out of range (the mesh has "
        << mesh.face_count() << " faces)";
      throw InputError(s.str());
    }
    out.push_back(p.position(mesh));
  }
  return out;
}

double curve_length(const TriangleMesh& mesh, const SurfaceCurve& curve) {
  const std::vector<Vec3> p = curve_positions(mesh, curve);
  const std::size_t n = p.size();
  double sum = 0.0;
  for (std::size_t i = 0; i < curve.segment_count(); ++i) sum += (p[(i + 1) % n] - p[i]).norm();
  return sum;
}

SurfacePoint snap_barycentrics(const SurfacePoint& point, double tolerance) {
  SurfacePoint q = point;
  for (int k = 0; k < 3; ++k)
    if (q.bary[k] <= tolerance) q.bary[k] = 0.0;
  const double sum = q.bary.sum();
  if (sum > 0.0 && std::isfinite(sum)) q.bary /= sum;
  return q;
}

std::optional<EdgePoint> to_edge_point(const TriangleMesh& mesh, const Topology& topology,
                                       const SurfacePoint& point, double tolerance) {
  const Node n = to_node(mesh, topology, point, 0, "to_edge_point", std::max(tolerance, 0.0));
  if (n.kind != NodeKind::edge) return std::nullopt;
  return EdgePoint{n.id, n.t};
}

std::optional<std::int32_t> to_vertex(const TriangleMesh& mesh, const SurfacePoint& point,
                                      double tolerance) {
  if (point.face < 0 || static_cast<std::size_t>(point.face) >= mesh.face_count())
    return std::nullopt;
  const SurfacePoint q = snap_barycentrics(point, tolerance);
  int zeros = 0, k = 0;
  for (int c = 0; c < 3; ++c) {
    if (q.bary[c] == 0.0)
      ++zeros;
    else
      k = c;
  }
  if (zeros != 2) return std::nullopt;
  return mesh.faces[static_cast<std::size_t>(q.face)][k];
}

SurfacePoint from_edge_point(const TriangleMesh& mesh, const Topology& topology,
                             const EdgePoint& point) {
  if (point.edge < 0 || static_cast<std::size_t>(point.edge) >= topology.edge_count()) {
    std::ostringstream s;
    s << "edge point: edge index " << point.edge << " is out of range (the mesh has "
      << topology.edge_count() << " edges)";
    throw InputError(s.str());
  }
  if (!(point.t >= 0.0 && point.t <= 1.0)) {
    std::ostringstream s;
    s << "edge point: parameter t = " << point.t << " on edge " << point.edge
      << " must lie in [0,1]";
    throw InputError(s.str());
  }
  const auto faces = topology.edge_faces(static_cast<std::size_t>(point.edge));
  if (faces.empty() || static_cast<std::size_t>(faces[0]) >= mesh.face_count()) {
    std::ostringstream s;
    s << "edge point: edge " << point.edge << " belongs to no face of this mesh";
    throw InputError(s.str());
  }
  const auto& e = topology.edge(static_cast<std::size_t>(point.edge));
  const Face& F = mesh.faces[static_cast<std::size_t>(faces[0])];
  SurfacePoint out;
  out.face = faces[0];
  out.bary[corner_of_face(F, e[0])] = 1.0 - point.t;
  out.bary[corner_of_face(F, e[1])] = point.t;
  return out;
}

std::int32_t common_face(const TriangleMesh& mesh, const Topology& topology, const SurfacePoint& a,
                         const SurfacePoint& b, double tolerance) {
  check_topology_matches(mesh, topology, "common_face");
  const Node na = to_node(mesh, topology, a, 0, "common_face", tolerance);
  const Node nb = to_node(mesh, topology, b, 1, "common_face", tolerance);
  return CurveGeometry(mesh, topology).common_face(na, nb);
}

void validate_surface_curve(const TriangleMesh& mesh, const Topology& topology,
                            const SurfaceCurve& curve, const std::string& what, double tolerance) {
  curve_nodes(mesh, topology, curve, what, tolerance);
}

std::vector<double> geodesic_turning_angles(const TriangleMesh& mesh, const Topology& topology,
                                            const SurfaceCurve& curve) {
  const std::vector<Node> nodes =
      curve_nodes(mesh, topology, curve, "surface curve", kBarycentricTolerance);
  const CurveGeometry g(mesh, topology);
  const std::size_t n = nodes.size();
  std::vector<double> out(n, 0.0);
  if (n < 3) return out;
  for (std::size_t i = 0; i < n; ++i) {
    if (!curve.closed && (i == 0 || i + 1 == n)) continue;
    const Node& prev = nodes[(i + n - 1) % n];
    const Node& next = nodes[(i + 1) % n];
    if (g.same_point(prev, nodes[i], 0.0) || g.same_point(next, nodes[i], 0.0)) continue;
    out[i] = turning_angle(g, prev, nodes[i], next);
  }
  return out;
}

double total_absolute_turning(const TriangleMesh& mesh, const Topology& topology,
                              const SurfaceCurve& curve) {
  double sum = 0.0;
  for (const double a : geodesic_turning_angles(mesh, topology, curve)) sum += std::abs(a);
  return sum;
}

}  // namespace fabrica
