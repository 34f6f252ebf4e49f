// Surface curves and their smoothing (Lawonn et al. 2014; see the header).
//
// Internally a curve is a sequence of Nodes in canonical form: a mesh vertex,
// a point strictly inside an edge (edge id + t), or a point strictly inside
// a face (only fixed endpoints). A node "lies in" face f when every vertex
// carrying nonzero weight is a corner of f; two nodes can be joined by a
// segment when some face holds both.
#include "fabrica/core/surface_curve.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "fabrica/core/error.hpp"

namespace fabrica {

namespace {

constexpr double kPi = std::numbers::pi;
/// A vertex passage is re-routed only on a side whose angle is below pi by this much.
constexpr double kAngleEpsilon = 1e-9;
/// New points of a split stay this fraction of the edge length away from the far vertex.
constexpr double kSplitMargin = 0.01;

double cross2(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

int corner_of_face(const Face& F, std::int32_t v) {
  for (int k = 0; k < 3; ++k)
    if (F[k] == v) return k;
  return -1;
}

enum class NodeKind { vertex, edge, face };

struct Node {
  NodeKind kind = NodeKind::vertex;
  std::int32_t id = -1;           ///< vertex, edge or face index
  double t = 0.0;                 ///< edge nodes: position along edge(id)
  Vec3 bary = Vec3::Zero();       ///< face nodes
  bool fixed = false;             ///< endpoint of an open curve
  std::int32_t input_index = -1;  ///< fixed nodes: index of the input point
};

/// The vertices with nonzero weight of a node, and their weights.
struct Support {
  int count = 0;
  std::array<std::int32_t, 3> vertex{-1, -1, -1};
  std::array<double, 3> weight{0.0, 0.0, 0.0};
};

/// The triangle fan of a vertex, unfolded around it: faces in
/// counter-clockwise order, each starting at angle `alpha` (cumulative
/// interior angles). Ray j is the edge from v to faces[j].w1; an open fan
/// (boundary vertex) has one more ray, to the last face's w2.
struct FanFace {
  std::int32_t face = -1;
  std::int32_t w1 = -1, w2 = -1;        ///< the other corners, CCW after v
  std::int32_t edge1 = -1, edge2 = -1;  ///< edges (v,w1) and (v,w2)
  double alpha = 0.0, gamma = 0.0;      ///< start angle, interior angle at v
  double l1 = 0.0, l2 = 0.0;            ///< |w1 - v|, |w2 - v|
  Vec2 w2_local = Vec2::Zero();         ///< w2 in the face's frame (v at 0, w1 on +x)
};

struct Fan {
  bool valid = false;
  bool closed = false;
  std::int32_t vertex = -1;
  std::vector<FanFace> faces;
  double total = 0.0;  ///< total angle at the vertex

  int ray_count() const {
    const int n = static_cast<int>(faces.size());
    return closed ? n : n + 1;
  }
  int position_count() const { return 2 * static_cast<int>(faces.size()) + (closed ? 0 : 1); }
  std::int32_t ray_edge(int j) const {
    return j < static_cast<int>(faces.size()) ? faces[j].edge1 : faces.back().edge2;
  }
  std::int32_t ray_vertex(int j) const {
    return j < static_cast<int>(faces.size()) ? faces[j].w1 : faces.back().w2;
  }
  double ray_alpha(int j) const {
    return j < static_cast<int>(faces.size()) ? faces[j].alpha : total;
  }
  double ray_length(int j) const {
    return j < static_cast<int>(faces.size()) ? faces[j].l1 : faces.back().l2;
  }
};

/// Where a node lies in a fan: on ray j (position 2j) or inside face j
/// (position 2j+1); polar coordinates (r, phi) in the unfolding.
struct FanPosition {
  bool ok = false;
  int position = -1;
  double r = 0.0;
  double phi = 0.0;
};

/// The curve's neighbours of a node unfolded into the plane of an edge:
/// the edge from (0,0) (vertex edge(e)[0]) to (L,0), the previous point's
/// face above the x axis, the next point's face below.
struct EdgeUnfolding {
  bool ok = false;
  Vec2 prev = Vec2::Zero();
  Vec2 next = Vec2::Zero();
  double length = 0.0;
  double orientation = 1.0;  ///< -1 when the unfolding mirrors the mesh orientation
};

class CurveGeometry {
 public:
  CurveGeometry(const TriangleMesh& mesh, const Topology& topology)
      : mesh_(mesh), topology_(topology) {}

  const Vec3& point(std::int32_t v) const { return mesh_.positions[static_cast<std::size_t>(v)]; }
  const Face& face(std::int32_t f) const { return mesh_.faces[static_cast<std::size_t>(f)]; }
  const Topology& topology() const { return topology_; }

  int corner_of(std::int32_t f, std::int32_t v) const { return corner_of_face(face(f), v); }

  Support support(const Node& n) const {
    Support s;
    switch (n.kind) {
      case NodeKind::vertex:
        s.count = 1;
        s.vertex[0] = n.id;
        s.weight[0] = 1.0;
        break;
      case NodeKind::edge: {
        const auto& e = topology_.edge(static_cast<std::size_t>(n.id));
        s.count = 2;
        s.vertex = {e[0], e[1], -1};
        s.weight = {1.0 - n.t, n.t, 0.0};
        break;
      }
      case NodeKind::face: {
        const Face& F = face(n.id);
        for (int k = 0; k < 3; ++k)
          if (n.bary[k] != 0.0) {
            s.vertex[s.count] = F[k];
            s.weight[s.count] = n.bary[k];
            ++s.count;
          }
        break;
      }
    }
    return s;
  }

  Vec3 position(const Node& n) const {
    const Support s = support(n);
    Vec3 p = Vec3::Zero();
    for (int i = 0; i < s.count; ++i) p += s.weight[i] * point(s.vertex[i]);
    return p;
  }

  bool in_face(std::int32_t f, const Node& n) const {
    if (n.kind == NodeKind::face) return n.id == f;
    const Support s = support(n);
    for (int i = 0; i < s.count; ++i)
      if (corner_of(f, s.vertex[i]) < 0) return false;
    return true;
  }

  /// Barycentric coordinates of n in face f (precondition: in_face(f, n)).
  Vec3 bary_in(std::int32_t f, const Node& n) const {
    if (n.kind == NodeKind::face) return n.bary;
    const Support s = support(n);
    Vec3 b = Vec3::Zero();
    for (int i = 0; i < s.count; ++i) b[corner_of(f, s.vertex[i])] = s.weight[i];
    return b;
  }

  /// Faces a node lies in, increasing index (a view valid while `n` lives).
  std::span<const std::int32_t> faces_of(const Node& n) const {
    switch (n.kind) {
      case NodeKind::vertex:
        return topology_.vertex_faces(static_cast<std::size_t>(n.id));
      case NodeKind::edge:
        return topology_.edge_faces(static_cast<std::size_t>(n.id));
      case NodeKind::face:
        break;
    }
    return {&n.id, 1};
  }

  std::int32_t common_face(const Node& a, const Node& b) const {
    for (const std::int32_t f : faces_of(a))
      if (in_face(f, b)) return f;
    return -1;
  }

  bool same_point(const Node& a, const Node& b, double snap) const {
    if (a.kind != b.kind || a.id != b.id) return false;
    switch (a.kind) {
      case NodeKind::vertex:
        return true;
      case NodeKind::edge:
        return std::abs(a.t - b.t) <= snap;
      case NodeKind::face:
        return (a.bary - b.bary).cwiseAbs().maxCoeff() <= snap;
    }
    return false;
  }

  /// The edge joining vertices a and b, or -1.
  std::int32_t find_edge(std::int32_t a, std::int32_t b) const {
    const auto nb = topology_.vertex_neighbors(static_cast<std::size_t>(a));
    const auto it = std::lower_bound(nb.begin(), nb.end(), b);
    if (it == nb.end() || *it != b) return -1;
    return topology_.vertex_edges(
        static_cast<std::size_t>(a))[static_cast<std::size_t>(it - nb.begin())];
  }

  /// The unfolded fan of v, built on first use and cached.
  const Fan& fan(std::int32_t v) const {
    const auto it = fans_.find(v);
    if (it != fans_.end()) return it->second;
    return fans_.emplace(v, build_fan(v)).first->second;
  }

  Fan build_fan(std::int32_t v) const {
    Fan fan;
    fan.vertex = v;
    const auto faces = topology_.vertex_faces(static_cast<std::size_t>(v));
    const auto corners = topology_.vertex_face_corners(static_cast<std::size_t>(v));
    const std::size_t n = faces.size();
    if (n == 0) return fan;
    // A face whose clockwise neighbour (across edge (v, w1)) is missing starts an open fan.
    std::size_t start = 0;
    int open_starts = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (topology_.face_neighbor(static_cast<std::size_t>(faces[i]), (corners[i] + 2) % 3) < 0) {
        if (open_starts == 0) start = i;
        ++open_starts;
      }
    if (open_starts > 1) return fan;  // several sectors: non-manifold or broken orientation
    fan.closed = open_starts == 0;
    std::int32_t f = faces[start];
    int k = corners[start];
    const Vec3& pv = point(v);
    while (true) {
      const Face& F = face(f);
      FanFace ff;
      ff.face = f;
      ff.w1 = F[(k + 1) % 3];
      ff.w2 = F[(k + 2) % 3];
      ff.edge1 = topology_.face_edge(static_cast<std::size_t>(f), (k + 2) % 3);
      ff.edge2 = topology_.face_edge(static_cast<std::size_t>(f), (k + 1) % 3);
      const Vec3 a = point(ff.w1) - pv, b = point(ff.w2) - pv;
      ff.l1 = a.norm();
      ff.l2 = b.norm();
      ff.gamma = std::atan2(a.cross(b).norm(), a.dot(b));
      ff.w2_local = ff.l2 * Vec2(std::cos(ff.gamma), std::sin(ff.gamma));
      ff.alpha = fan.total;
      fan.total += ff.gamma;
      fan.faces.push_back(ff);
      if (fan.faces.size() > n) return fan;
      const std::int32_t g = topology_.face_neighbor(static_cast<std::size_t>(f), (k + 1) % 3);
      if (g < 0) {
        if (fan.closed) return fan;
        break;
      }
      if (g == faces[start]) {
        if (!fan.closed || face(g)[(corners[start] + 1) % 3] != ff.w2) return fan;
        break;
      }
      const int kg = corner_of(g, v);
      if (kg < 0 || face(g)[(kg + 1) % 3] != ff.w2) return fan;  // inconsistent orientation
      f = g;
      k = kg;
    }
    fan.valid = fan.faces.size() == n && fan.total > 0.0;
    return fan;
  }

  FanPosition locate(const Fan& fan, const Node& q) const {
    FanPosition out;
    const int n = static_cast<int>(fan.faces.size());
    for (int j = 0; j < n; ++j) {
      const FanFace& ff = fan.faces[j];
      if (!in_face(ff.face, q)) continue;
      const Vec3 b = bary_in(ff.face, q);
      const double b1 = b[corner_of(ff.face, ff.w1)];
      const double b2 = b[corner_of(ff.face, ff.w2)];
      const Vec2 local = b1 * Vec2(ff.l1, 0.0) + b2 * ff.w2_local;
      out.r = local.norm();
      if (b2 == 0.0) {
        out.position = 2 * j;
        out.phi = ff.alpha;
      } else if (b1 == 0.0) {
        out.position = 2 * (j + 1);
        out.phi = ff.alpha + ff.gamma;
        if (fan.closed && j + 1 == n) {
          out.position = 0;
          out.phi = 0.0;
        }
      } else {
        out.position = 2 * j + 1;
        out.phi = ff.alpha + std::clamp(std::atan2(local.y(), local.x()), 0.0, ff.gamma);
      }
      out.ok = out.r > 0.0 && std::isfinite(out.phi);
      return out;
    }
    return out;
  }

  EdgeUnfolding unfold_edge(const Node& node, const Node& prev, const Node& next) const {
    EdgeUnfolding u;
    const auto& e = topology_.edge(static_cast<std::size_t>(node.id));
    const auto faces = topology_.edge_faces(static_cast<std::size_t>(node.id));
    std::int32_t fp = -1, fn = -1;
    for (const std::int32_t f : faces) {
      if (!in_face(f, prev)) continue;
      for (const std::int32_t g : faces)
        if (g != f && in_face(g, next)) {
          fp = f;
          fn = g;
          break;
        }
      if (fp >= 0) break;
    }
    if (fp < 0) return u;
    const Vec3& pa = point(e[0]);
    const Vec3 axis = point(e[1]) - pa;
    u.length = axis.norm();
    if (!(u.length > 0.0)) return u;
    const Vec3 ex = axis / u.length;
    auto third = [&](std::int32_t f) {
      const Face& F = face(f);
      for (int k = 0; k < 3; ++k)
        if (F[k] != e[0] && F[k] != e[1]) return F[k];
      return F[0];
    };
    const std::int32_t cp = third(fp), cn = third(fn);
    auto layout = [&](std::int32_t c, double side) {
      const Vec3 d = point(c) - pa;
      return Vec2(d.dot(ex), side * d.cross(ex).norm());
    };
    const Vec2 up = layout(cp, 1.0), down = layout(cn, -1.0);
    if (!(up.y() > 1e-12 * u.length) || !(-down.y() > 1e-12 * u.length)) return u;  // degenerate
    auto place = [&](const Node& q, std::int32_t c, const Vec2& pc) {
      const Support s = support(q);
      Vec2 p = Vec2::Zero();
      for (int i = 0; i < s.count; ++i) {
        if (s.vertex[i] == e[1])
          p += s.weight[i] * Vec2(u.length, 0.0);
        else if (s.vertex[i] == c)
          p += s.weight[i] * pc;
      }
      return p;
    };
    u.prev = place(prev, cp, up);
    u.next = place(next, cn, down);
    const int ia = corner_of(fp, e[0]), ib = corner_of(fp, e[1]);
    u.orientation = (ia + 1) % 3 == ib ? 1.0 : -1.0;
    u.ok = true;
    return u;
  }

 private:
  const TriangleMesh& mesh_;
  const Topology& topology_;
  mutable std::unordered_map<std::int32_t, Fan> fans_;
};

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

/// The Gauss–Seidel smoothing and splitting steps on a node sequence.
class Smoother {
 public:
  Smoother(const CurveGeometry& geometry, bool closed, const CurveSmoothingOptions& options,
           std::vector<Node> nodes)
      : g_(geometry), closed_(closed), options_(options), nodes_(std::move(nodes)) {}

  const std::vector<Node>& nodes() const { return nodes_; }
  /// Largest distance a point moved in block steps since the last call.
  double take_block_move() { return std::exchange(block_move_, 0.0); }
  std::size_t size() const { return nodes_.size(); }

  double length() const {
    const std::size_t n = nodes_.size();
    if (n < 2) return 0.0;
    double sum = 0.0;
    const std::size_t segments = closed_ ? n : n - 1;
    for (std::size_t i = 0; i < segments; ++i)
      sum += (g_.position(nodes_[(i + 1) % n]) - g_.position(nodes_[i])).norm();
    return sum;
  }

  double total_turning() const {
    const std::size_t n = nodes_.size();
    if (n < 3) return 0.0;
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!interior(i)) continue;
      const Node& prev = nodes_[(i + n - 1) % n];
      const Node& next = nodes_[(i + 1) % n];
      sum += std::abs(turning_angle(g_, prev, nodes_[i], next));
    }
    return sum;
  }

  /// Moves every edge point towards its straightened position; returns the
  /// largest distance moved and sets `kind_changed` if a point reached a vertex.
  double sweep(bool& kind_changed) {
    const std::size_t n = nodes_.size();
    double max_move = 0.0;
    if (n < 3) return max_move;
    for (std::size_t i = 0; i < n; ++i) {
      Node& node = nodes_[i];
      if (node.fixed || node.kind != NodeKind::edge || !interior(i)) continue;
      const Node& prev = nodes_[(i + n - 1) % n];
      const Node& next = nodes_[(i + 1) % n];
      const EdgeUnfolding u = g_.unfold_edge(node, prev, next);
      if (!u.ok || !(u.prev.y() > 0.0) || !(u.next.y() < 0.0)) continue;
      // Where the segment prev-next crosses the edge's line in the unfolding.
      const double x =
          u.prev.x() + (u.next.x() - u.prev.x()) * u.prev.y() / (u.prev.y() - u.next.y());
      const double target = std::clamp(x / u.length, 0.0, 1.0);
      if (!std::isfinite(target)) continue;
      const double t = node.t + options_.step * (target - node.t);
      const auto& e = g_.topology().edge(static_cast<std::size_t>(node.id));
      double moved = std::abs(t - node.t) * u.length;
      if (t <= options_.vertex_snap) {
        moved = node.t * u.length;
        node = make_vertex(e[0]);
        kind_changed = true;
      } else if (t >= 1.0 - options_.vertex_snap) {
        moved = (1.0 - node.t) * u.length;
        node = make_vertex(e[1]);
        kind_changed = true;
      } else {
        node.t = t;
      }
      max_move = std::max(max_move, moved);
    }
    return max_move;
  }

  /// Merges coinciding consecutive points and removes points whose
  /// neighbours share a face (the straight segment between the neighbours
  /// is no longer). Returns whether anything changed.
  bool simplify(std::size_t& removals) {
    bool changed_any = false;
    for (std::size_t pass = 0; pass <= nodes_.size() + 1; ++pass) {
      bool changed = false;
      std::vector<Node> out;
      out.reserve(nodes_.size());
      for (const Node& node : nodes_) {
        if (!out.empty() && g_.same_point(out.back(), node, options_.vertex_snap) &&
            !(node.fixed && out.back().fixed)) {
          if (node.fixed) out.back() = node;
          ++removals;
          changed = true;
          continue;
        }
        out.push_back(node);
      }
      while (closed_ && out.size() > 1 &&
             g_.same_point(out.back(), out.front(), options_.vertex_snap)) {
        out.pop_back();
        ++removals;
        changed = true;
      }
      nodes_ = std::move(out);
      const std::size_t n = nodes_.size();
      if (closed_ && n < 3) return true;
      out.clear();
      for (std::size_t i = 0; i < n; ++i) {
        const Node& node = nodes_[i];
        const std::size_t remaining = out.size() + (n - i);
        if (node.fixed || !interior(i) || (closed_ && remaining <= 2)) {
          out.push_back(node);
          continue;
        }
        const Node& prev = out.empty() ? nodes_[n - 1] : out.back();
        const Node& next = i + 1 < n ? nodes_[i + 1] : out.front();
        if (g_.common_face(prev, next) >= 0) {
          ++removals;
          changed = true;
          continue;
        }
        out.push_back(node);
      }
      nodes_ = std::move(out);
      if (closed_ && nodes_.size() < 3) return true;
      changed = collapse_onto_vertices(removals) || changed;
      if (!changed) break;
      changed_any = true;
    }
    return changed_any;
  }

  /// Block step for runs of consecutive edge points whose edges all share
  /// a vertex v (the curve passes near v): when the fan sector between the
  /// run's neighbours, on the run's side, spans at least pi, the shortest
  /// passage is through v and the run collapses onto v; otherwise a run of
  /// two or more points is put at once where the straight segment crosses
  /// the sector's edges. Without this block step, points converging onto a
  /// vertex from both sides (a geodesic through a flat or saddle vertex)
  /// approach it only like 1/iterations.
  bool collapse_onto_vertices(std::size_t& removals) {
    const std::size_t n = nodes_.size();
    if (n < 3) return false;
    bool changed = false;
    std::vector<Node> out;
    out.reserve(n);
    std::vector<Node> straight;
    std::size_t i = 0;
    while (i < n) {
      const Node& node = nodes_[i];
      if (node.fixed || node.kind != NodeKind::edge || !interior(i)) {
        out.push_back(node);
        ++i;
        continue;
      }
      const auto& e = g_.topology().edge(static_cast<std::size_t>(node.id));
      bool done = false;
      for (const std::int32_t v : {e[0], e[1]}) {
        auto on_edge_of_v = [&](const Node& q) {
          if (q.fixed || q.kind != NodeKind::edge) return false;
          const auto& qe = g_.topology().edge(static_cast<std::size_t>(q.id));
          return qe[0] == v || qe[1] == v;
        };
        std::size_t j = i;
        while (j + 1 < n && on_edge_of_v(nodes_[j + 1])) ++j;
        const std::size_t run = j - i + 1;
        // A single point is handled by the smoothing step (its target is
        // clamped to v when the straight line passes beyond v).
        if (run < 2) continue;
        if (j + 1 == n && !closed_) continue;
        if (closed_ && out.size() + (n - i) - run + 1 < 3) continue;
        const Node prev = out.empty() ? nodes_[n - 1] : out.back();
        const Node next = j + 1 < n ? nodes_[j + 1] : (out.empty() ? nodes_[0] : out.front());
        const FanSides sides = fan_sides(v, prev, next);
        if (!sides.ok) continue;
        const FanPosition r = g_.locate(sides.fan(), node);
        if (!r.ok) continue;
        const bool ccw = sides.ccw_side_holds(r.position);
        if (ccw ? !sides.ccw_ok : !sides.cw_ok) continue;
        const double angle = ccw ? sides.ccw_angle : sides.cw_angle;
        double current = (g_.position(nodes_[i]) - g_.position(prev)).norm() +
                         (g_.position(next) - g_.position(nodes_[j])).norm();
        for (std::size_t k = i; k < j; ++k)
          current += (g_.position(nodes_[k + 1]) - g_.position(nodes_[k])).norm();
        double length = 0.0;
        bool through_vertex = false;
        const bool straightened =
            angle < kPi - kAngleEpsilon &&
            straighten_in_fan(v, sides, ccw, straight, length, through_vertex);
        if (angle >= kPi - kAngleEpsilon || through_vertex) {
          // Through v is shortest (up to the snapping distance).
          if (!through_vertex && !(sides.p.r + sides.q.r <= current)) continue;
          out.push_back(make_vertex(v));
          removals += run - 1;
          changed = true;
        } else {
          if (!straightened || !(length <= current)) continue;
          if (straight.size() == run) {
            for (std::size_t k = 0; k < run; ++k) {
              const Node& old = nodes_[i + k];
              if (straight[k].id != old.id) changed = true;
              const auto& se = g_.topology().edge(static_cast<std::size_t>(old.id));
              const double l = (g_.point(se[1]) - g_.point(se[0])).norm();
              block_move_ = std::max(block_move_, std::abs(straight[k].t - old.t) * l);
            }
          } else {
            changed = true;
            removals += run > straight.size() ? run - straight.size() : 0;
          }
          out.insert(out.end(), straight.begin(), straight.end());
        }
        i = j + 1;
        done = true;
        break;
      }
      if (!done) {
        out.push_back(node);
        ++i;
      }
    }
    nodes_ = std::move(out);
    return changed;
  }

  /// Re-routes the curve around every vertex it passes through, on the side
  /// of the vertex whose angle is below pi. Returns whether anything changed.
  bool split(std::size_t& splits) {
    const std::size_t n = nodes_.size();
    if (n < 3) return false;
    bool changed = false;
    std::vector<Node> out;
    out.reserve(n + 8);
    std::vector<Node> inserted;
    for (std::size_t i = 0; i < n; ++i) {
      const Node& node = nodes_[i];
      if (node.kind != NodeKind::vertex || node.fixed || !interior(i)) {
        out.push_back(node);
        continue;
      }
      const Node prev = out.empty() ? nodes_[n - 1] : out.back();
      const Node next = i + 1 < n ? nodes_[i + 1] : out.front();
      if (split_vertex(node.id, prev, next, inserted)) {
        out.insert(out.end(), inserted.begin(), inserted.end());
        ++splits;
        changed = true;
      } else {
        out.push_back(node);
      }
    }
    nodes_ = std::move(out);
    return changed;
  }

 private:
  bool interior(std::size_t i) const { return closed_ || (i > 0 && i + 1 < nodes_.size()); }

  static Node make_vertex(std::int32_t v) {
    Node n;
    n.kind = NodeKind::vertex;
    n.id = v;
    return n;
  }

  /// The two sides of vertex v between the curve's neighbours prev and
  /// next, in v's unfolded fan.
  struct FanSides {
    bool ok = false;
    const Fan* fan_ptr = nullptr;
    FanPosition p, q;
    const Fan& fan() const { return *fan_ptr; }
    bool ccw_ok = false, cw_ok = false;
    double ccw_angle = 0.0, cw_angle = 0.0;

    /// Whether fan position `position` lies strictly between p and q counter-clockwise.
    bool ccw_side_holds(int position) const {
      if (!fan().closed) return p.position < position && position < q.position;
      const int count = fan().position_count();
      const int to_q = ((q.position - p.position) % count + count) % count;
      const int to_r = ((position - p.position) % count + count) % count;
      return to_r > 0 && to_r < to_q;
    }
  };

  FanSides fan_sides(std::int32_t v, const Node& prev, const Node& next) const {
    FanSides s;
    s.fan_ptr = &g_.fan(v);
    if (!s.fan().valid) return s;
    s.p = g_.locate(s.fan(), prev);
    s.q = g_.locate(s.fan(), next);
    if (!s.p.ok || !s.q.ok || s.p.position == s.q.position) return s;
    if (s.fan().closed) {
      s.ccw_angle = s.q.phi - s.p.phi + (s.q.position < s.p.position ? s.fan().total : 0.0);
      s.ccw_angle = std::clamp(s.ccw_angle, 0.0, s.fan().total);
      s.cw_angle = s.fan().total - s.ccw_angle;
      s.ccw_ok = s.cw_ok = true;
    } else {
      s.ccw_ok = s.q.position > s.p.position;
      s.cw_ok = s.q.position < s.p.position;
      s.ccw_angle = std::max(s.q.phi - s.p.phi, 0.0);
      s.cw_angle = std::max(s.p.phi - s.q.phi, 0.0);
    }
    s.ok = true;
    return s;
  }

  /// Points where the straight segment from prev to next crosses the fan's
  /// edges on one side (angle below pi), in the unfolding of that sector;
  /// `length` is the resulting prev-to-next length. Points that would fall
  /// beyond an edge's far vertex are pulled towards v so that the path is
  /// still shorter than the passage through v.
  bool straighten_in_fan(std::int32_t v, const FanSides& sides, bool ccw,
                         std::vector<Node>& inserted, double& length, bool& through_vertex) const {
    inserted.clear();
    through_vertex = false;
    const Fan& fan = sides.fan();
    const FanPosition& p = sides.p;
    const FanPosition& q = sides.q;
    const double angle = ccw ? sides.ccw_angle : sides.cw_angle;
    if (!(angle < kPi - kAngleEpsilon)) return false;

    // The rays strictly between prev and next on that side, and their
    // angles beta from prev's direction.
    struct Ray {
      int index;
      double beta;
    };
    std::vector<Ray> rays;
    const int count = fan.position_count();
    const int n_faces = static_cast<int>(fan.faces.size());
    int pos = p.position;
    bool wrapped = false;
    for (int guard = 0; guard <= count; ++guard) {
      if (ccw) {
        ++pos;
        if (fan.closed && pos == count) {
          pos = 0;
          wrapped = true;
        }
      } else {
        --pos;
        if (fan.closed && pos < 0) {
          pos = count - 1;
          wrapped = true;
        }
      }
      if (pos == q.position || pos < 0 || pos >= count) break;
      if (pos % 2 != 0) continue;
      const int j = fan.closed ? (pos / 2) % n_faces : pos / 2;
      double alpha = fan.ray_alpha(j);
      if (ccw && wrapped) alpha += fan.total;
      if (!ccw && wrapped) alpha -= fan.total;
      const double beta = ccw ? alpha - p.phi : p.phi - alpha;
      rays.push_back({j, std::clamp(beta, 0.0, angle)});
    }
    if (rays.empty()) return false;

    const Vec2 qp(p.r, 0.0);
    const Vec2 qn = q.r * Vec2(std::cos(angle), std::sin(angle));
    const Vec2 d = qn - qp;
    const double numerator = cross2(qp, d);
    std::vector<double> rho_star(rays.size()), ell(rays.size());
    std::vector<Vec2> dir(rays.size());
    for (std::size_t r = 0; r < rays.size(); ++r) {
      dir[r] = Vec2(std::cos(rays[r].beta), std::sin(rays[r].beta));
      const double denominator = cross2(dir[r], d);
      ell[r] = fan.ray_length(rays[r].index);
      if (!(denominator > 0.0) || !(ell[r] > 0.0)) return false;
      rho_star[r] = numerator / denominator;
      if (!std::isfinite(rho_star[r]) || !(rho_star[r] > 0.0)) return false;
    }
    // A straight segment passing within the snapping distance of v counts as
    // passing through v (so splitting and collapsing agree and terminate).
    for (std::size_t r = 0; r < rays.size(); ++r)
      if (rho_star[r] < 2.0 * options_.vertex_snap * ell[r]) {
        through_vertex = true;
        return false;
      }
    const double lower = std::max(2.0 * options_.vertex_snap, 1e-12);
    std::vector<double> fraction(rays.size());
    auto path_length = [&](double lambda) {
      double sum = 0.0;
      Vec2 last = qp;
      for (std::size_t r = 0; r < rays.size(); ++r) {
        fraction[r] = std::clamp(lambda * rho_star[r] / ell[r], lower, 1.0 - kSplitMargin);
        const Vec2 point = fraction[r] * ell[r] * dir[r];
        sum += (point - last).norm();
        last = point;
      }
      return sum + (qn - last).norm();
    };
    const double via_vertex = p.r + q.r;
    const double shorter = via_vertex * (1.0 - 1e-12);
    // First clamp each point to its edge; if that is not shorter, shrink the
    // straight segment towards v until it fits inside the fan (always shorter).
    length = path_length(1.0);
    if (!(length < shorter)) {
      double lambda = 1.0;
      for (std::size_t r = 0; r < rays.size(); ++r)
        lambda = std::min(lambda, (1.0 - kSplitMargin) * ell[r] / rho_star[r]);
      length = path_length(lambda);
      if (!(length < shorter)) return false;
    }
    for (std::size_t r = 0; r < rays.size(); ++r) {
      Node node;
      node.kind = NodeKind::edge;
      node.id = fan.ray_edge(rays[r].index);
      if (node.id < 0) return false;
      const auto& e = g_.topology().edge(static_cast<std::size_t>(node.id));
      node.t = e[0] == v ? fraction[r] : 1.0 - fraction[r];
      inserted.push_back(node);
    }
    return true;
  }

  /// The splitting step at vertex v between prev and next: unfold the fan
  /// sector on the side with angle below pi (the smaller one if both are),
  /// and put new points where the straight segment from prev to next
  /// crosses the sector's edges. Always shorter than the passage through v.
  bool split_vertex(std::int32_t v, const Node& prev, const Node& next,
                    std::vector<Node>& inserted) const {
    inserted.clear();
    const FanSides sides = fan_sides(v, prev, next);
    if (!sides.ok) return false;
    const bool ccw_ok = sides.ccw_ok && sides.ccw_angle < kPi - kAngleEpsilon;
    const bool cw_ok = sides.cw_ok && sides.cw_angle < kPi - kAngleEpsilon;
    if (!ccw_ok && !cw_ok) return false;  // locally shortest through v (e.g. a saddle)
    const bool ccw = ccw_ok && (!cw_ok || sides.ccw_angle <= sides.cw_angle);
    double length = 0.0;
    bool through_vertex = false;
    return straighten_in_fan(v, sides, ccw, inserted, length, through_vertex);
  }

  const CurveGeometry& g_;
  bool closed_;
  double block_move_ = 0.0;  ///< largest move made by collapse_onto_vertices since last asked
  const CurveSmoothingOptions& options_;
  std::vector<Node> nodes_;
};

}  // namespace

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

CurveSmoothingResult smooth_surface_curve(const TriangleMesh& mesh, const Topology& topology,
                                          const SurfaceCurve& curve,
                                          const CurveSmoothingOptions& options) {
  const std::string what = "curve smoothing";
  {
    std::ostringstream s;
    if (!(options.step > 0.0 && options.step <= 1.0))
      s << what << ": step must be in (0,1], got " << options.step;
    else if (options.iterations < 0)
      s << what << ": iterations must be >= 0, got " << options.iterations;
    else if (!(options.vertex_snap >= 0.0 && options.vertex_snap <= 1e-3))
      s << what << ": vertex_snap must be in [0, 0.001], got " << options.vertex_snap;
    else if (!(options.tolerance >= 0.0))
      s << what << ": tolerance must be >= 0, got " << options.tolerance;
    if (!s.str().empty()) throw InputError(s.str());
  }
  std::vector<Node> nodes = curve_nodes(mesh, topology, curve, what, kBarycentricTolerance);
  const std::size_t n = nodes.size();
  for (std::size_t i = 0; i < n; ++i) {
    nodes[i].input_index = static_cast<std::int32_t>(i);
    const bool endpoint = !curve.closed && (i == 0 || i + 1 == n);
    if (endpoint) {
      nodes[i].fixed = true;
      continue;
    }
    if (nodes[i].kind == NodeKind::face) {
      std::ostringstream s;
      s << what << ": " << point_label(i, curve.points[i])
        << " lies inside its face, not on a mesh edge; every point of the curve except the "
           "endpoints of an open curve must lie on an edge (one barycentric coordinate 0)";
      throw InputError(s.str());
    }
    if (nodes[i].kind == NodeKind::edge) {
      const auto& e = topology.edge(static_cast<std::size_t>(nodes[i].id));
      if (nodes[i].t <= options.vertex_snap) {
        nodes[i] = Node{NodeKind::vertex, e[0], 0.0, Vec3::Zero(), false, -1};
      } else if (nodes[i].t >= 1.0 - options.vertex_snap) {
        nodes[i] = Node{NodeKind::vertex, e[1], 0.0, Vec3::Zero(), false, -1};
      }
    }
  }

  const CurveGeometry g(mesh, topology);
  Smoother smoother(g, curve.closed, options, std::move(nodes));
  CurveSmoothingResult result;
  result.length_history.push_back(smoother.length());
  result.turning_history.push_back(smoother.total_turning());
  for (int it = 0; it < options.iterations; ++it) {
    if (curve.closed && smoother.size() < 3) {
      result.collapsed = true;
      break;
    }
    if (smoother.size() < 3) {
      result.converged = true;
      break;
    }
    bool changed = false;
    const double moved = smoother.sweep(changed);
    changed = smoother.simplify(result.removals) || changed;
    if (options.split_at_vertices) {
      changed = smoother.split(result.splits) || changed;
      changed = smoother.simplify(result.removals) || changed;
    }
    const double moved_all = std::max(moved, smoother.take_block_move());
    ++result.iterations;
    const double length = smoother.length();
    result.length_history.push_back(length);
    result.turning_history.push_back(smoother.total_turning());
    if (curve.closed && smoother.size() < 3) {
      result.collapsed = true;
      break;
    }
    if (!changed && moved_all <= options.tolerance * length) {
      result.converged = true;
      break;
    }
  }

  // Back to SurfacePoints: each point in the face it shares with the next one.
  const std::vector<Node>& out = smoother.nodes();
  const std::size_t m = out.size();
  result.curve.closed = curve.closed;
  result.curve.points.reserve(m);
  for (std::size_t i = 0; i < m; ++i) {
    const Node& node = out[i];
    const Node* neighbour = nullptr;
    if (i + 1 < m)
      neighbour = &out[i + 1];
    else if (curve.closed && m > 1)
      neighbour = &out[0];
    else if (i > 0)
      neighbour = &out[i - 1];
    if (node.fixed) {
      const SurfacePoint& original = curve.points[static_cast<std::size_t>(node.input_index)];
      if (neighbour == nullptr || g.in_face(original.face, *neighbour)) {
        result.curve.points.push_back(original);
        continue;
      }
    }
    std::int32_t f = neighbour != nullptr ? g.common_face(node, *neighbour) : -1;
    if (f < 0) f = g.faces_of(node).front();
    result.curve.points.push_back(SurfacePoint{f, g.bary_in(f, node)});
  }
  return result;
}

}  // namespace fabrica
