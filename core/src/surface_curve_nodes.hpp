// Private to core: the canonical node form of a surface curve and the mesh
// queries on it (triangle fans, edge unfoldings, turning angles), shared by
// the curve representation (surface_curve.cpp) and the curve smoother
// (curve_smoothing.cpp).
//
// A node is a mesh vertex, a point strictly inside an edge (edge id + t), or
// a point strictly inside a face (only fixed endpoints). A node "lies in"
// face f when every vertex carrying nonzero weight is a corner of f; two
// nodes can be joined by a segment when some face holds both.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "fabrica/core/surface_curve.hpp"

namespace fabrica::curve_detail {

inline constexpr double kPi = std::numbers::pi;

inline double cross2(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

inline int corner_of_face(const Face& F, std::int32_t v) {
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
  std::int32_t find_edge(std::int32_t a, std::int32_t b) const { return topology_.find_edge(a, b); }

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
double signed_angle(const Vec3& d1, const Vec3& d2, const Vec3& n);

/// Turning angle at a node given its neighbours (see surface_curve.hpp).
double turning_angle(const CurveGeometry& g, const Node& prev, const Node& node, const Node& next);

/// "point i (face f)", for messages.
std::string point_label(std::size_t i, const SurfacePoint& p);

/// Throws InputError, prefixed with `what`, unless `topology` was built from `mesh`.
void check_topology_matches(const TriangleMesh& mesh, const Topology& topology,
                            const std::string& what);

/// Checks one point and converts it to canonical form (coordinates within
/// `tolerance` of 0 become 0).
Node to_node(const TriangleMesh& mesh, const Topology& topology, const SurfacePoint& p,
             std::size_t index, const std::string& what, double tolerance);

/// Checks a curve and converts it to canonical nodes.
std::vector<Node> curve_nodes(const TriangleMesh& mesh, const Topology& topology,
                              const SurfaceCurve& curve, const std::string& what, double tolerance);

}  // namespace fabrica::curve_detail
