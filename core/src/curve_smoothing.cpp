// The curve smoother: Gauss–Seidel smoothing and splitting steps of Lawonn
// et al. 2014 on a surface curve's canonical nodes (see curve_smoothing.hpp
// and docs/algorithms.md §10).
#include "fabrica/core/curve_smoothing.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <sstream>
#include <utility>

#include "fabrica/core/error.hpp"
#include "surface_curve_nodes.hpp"

namespace fabrica {

using namespace curve_detail;

namespace {

/// A vertex passage is re-routed only on a side whose angle is below pi by this much.
constexpr double kAngleEpsilon = 1e-9;
/// New points of a split stay this fraction of the edge length away from the far vertex.
constexpr double kSplitMargin = 0.01;

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
