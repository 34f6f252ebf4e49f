// Smoothing chained feature lines on the surface (see the header).
#include "fabrica/lines/smooth.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

#include "fabrica/core/curve_smoothing.hpp"
#include "fabrica/core/error.hpp"

namespace fabrica {

std::vector<LineFamily> default_smoothed_families() {
  std::vector<LineFamily> out;
  for (int f = 0; f < kLineFamilyCount; ++f) {
    const auto family = static_cast<LineFamily>(f);
    if (family != LineFamily::boundary && family != LineFamily::crease) out.push_back(family);
  }
  return out;
}

namespace {

enum class Outcome { untouched, smoothed, too_short, invalid, collapsed };

struct PolylineReport {
  Outcome outcome = Outcome::untouched;
  std::size_t fixed_points = 0;
  std::size_t points_before = 0, points_after = 0;
  double length_before = 0.0, length_after = 0.0;
};

/// Face index in range, finite barycentrics in [-tol, 1+tol] summing to 1.
bool valid_anchor(const TriangleMesh& mesh, const SurfacePoint& p) {
  if (p.face < 0 || static_cast<std::size_t>(p.face) >= mesh.face_count()) return false;
  if (!p.bary.allFinite()) return false;
  for (int k = 0; k < 3; ++k)
    if (p.bary[k] < -kBarycentricTolerance || p.bary[k] > 1.0 + kBarycentricTolerance) return false;
  return std::abs(p.bary.sum() - 1.0) <= kBarycentricTolerance;
}

/// A point strictly inside its face (a centroid join or a clip point): not
/// movable by the core smoother, so it is kept fixed. Same classification as
/// to_edge_point / to_vertex (a coordinate within the tolerance of 0 is 0).
bool inside_face(const SurfacePoint& p) {
  return p.bary[0] > kBarycentricTolerance && p.bary[1] > kBarycentricTolerance &&
         p.bary[2] > kBarycentricTolerance;
}

/// Whether face f holds p (every corner of p's face with nonzero weight is a
/// corner of f). Precondition: valid_anchor(p), f in range.
bool holds(const TriangleMesh& mesh, std::int32_t f, const SurfacePoint& p) {
  if (f == p.face) return true;
  const Face& F = mesh.faces[static_cast<std::size_t>(f)];
  const Face& P = mesh.faces[static_cast<std::size_t>(p.face)];
  for (int k = 0; k < 3; ++k)
    if (std::abs(p.bary[k]) > kBarycentricTolerance && P[k] != F[0] && P[k] != F[1] && P[k] != F[2])
      return false;
  return true;
}

/// A face holding both points: a's or b's own face when it does (the usual
/// case, cheap), otherwise common_face (lowest-numbered), or -1.
std::int32_t shared_face(const TriangleMesh& mesh, const Topology& topology, const SurfacePoint& a,
                         const SurfacePoint& b) {
  if (holds(mesh, a.face, b)) return a.face;
  if (holds(mesh, b.face, a)) return b.face;
  return common_face(mesh, topology, a, b);
}

/// Attributes of an old run sampled by arc length: the old points in order
/// (a loop unrolled with its first point repeated at the end).
class ArcSampler {
 public:
  explicit ArcSampler(std::vector<const LineVertex*> points) : points_(std::move(points)) {
    cumulative_.assign(points_.size(), 0.0);
    for (std::size_t i = 1; i < points_.size(); ++i)
      cumulative_[i] =
          cumulative_[i - 1] + (points_[i]->position - points_[i - 1]->position).norm();
  }
  double length() const { return cumulative_.empty() ? 0.0 : cumulative_.back(); }

  /// Strength (linear) and visibility (of the edge the parameter falls in)
  /// at arc length s in [0, length()]; `fraction` in [0,1] is used instead
  /// when the run has zero length.
  void sample(double s, double fraction, LineVertex& out) const {
    const std::size_t n = points_.size();
    if (n == 1) {
      out.strength = points_[0]->strength;
      out.visible = points_[0]->visible;
      return;
    }
    std::size_t k = 0;
    double w = 0.0;
    if (length() > 0.0) {
      s = std::clamp(s, 0.0, length());
      // Last k with cumulative_[k] <= s, limited to the last edge.
      const auto it = std::upper_bound(cumulative_.begin(), cumulative_.end(), s);
      k = std::min<std::size_t>(static_cast<std::size_t>(it - cumulative_.begin()), n - 1);
      k = k == 0 ? 0 : k - 1;
      k = std::min(k, n - 2);
      const double edge = cumulative_[k + 1] - cumulative_[k];
      w = edge > 0.0 ? std::clamp((s - cumulative_[k]) / edge, 0.0, 1.0) : 0.0;
    } else {
      const double x = std::clamp(fraction, 0.0, 1.0) * static_cast<double>(n - 1);
      k = std::min(static_cast<std::size_t>(x), n - 2);
      w = x - static_cast<double>(k);
    }
    const float a = points_[k]->strength, b = points_[k + 1]->strength;
    out.strength = static_cast<float>((1.0 - w) * a + w * b);
    out.visible = w < 1.0 ? points_[k]->visible : points_[k + 1]->visible;
  }

  /// Arc length of the point of the polyline nearest to p (first one on ties).
  double project(const Vec3& p) const {
    double best = std::numeric_limits<double>::infinity(), best_s = 0.0;
    for (std::size_t i = 0; i + 1 < points_.size(); ++i) {
      const Vec3 a = points_[i]->position, d = points_[i + 1]->position - a;
      const double dd = d.squaredNorm();
      const double t = dd > 0.0 ? std::clamp((p - a).dot(d) / dd, 0.0, 1.0) : 0.0;
      const double dist = (a + t * d - p).squaredNorm();
      if (dist < best) {
        best = dist;
        best_s = cumulative_[i] + t * (cumulative_[i + 1] - cumulative_[i]);
      }
    }
    return best_s;
  }

 private:
  std::vector<const LineVertex*> points_;
  std::vector<double> cumulative_;
};

double path_length(const std::vector<LineVertex>& v, bool closed) {
  double sum = 0.0;
  for (std::size_t i = 1; i < v.size(); ++i) sum += (v[i].position - v[i - 1].position).norm();
  if (closed && v.size() > 1) sum += (v.front().position - v.back().position).norm();
  return sum;
}

/// The core smoother's result, or nothing when it rejects the curve.
std::optional<CurveSmoothingResult> try_smooth(const TriangleMesh& mesh, const Topology& topology,
                                               const SurfaceCurve& curve,
                                               const CurveSmoothingOptions& core) {
  try {
    return smooth_surface_curve(mesh, topology, curve, core);
  } catch (const InputError&) {
    return std::nullopt;
  }
}

/// Smooths one run of an open curve between two fixed points (old indices
/// `run`, in order) and appends its points, without the last one, to `out`.
/// Returns false if the core rejected the run.
bool smooth_run(const TriangleMesh& mesh, const Topology& topology, const Polyline& pl,
                const std::vector<std::size_t>& run, const CurveSmoothingOptions& core,
                std::vector<LineVertex>& out) {
  const LineVertex& first = pl.vertices[run.front()];
  if (run.size() < 3) {  // two fixed points side by side: nothing moves
    out.push_back(first);
    return true;
  }
  SurfaceCurve curve;
  curve.closed = false;
  curve.points.reserve(run.size());
  for (const std::size_t i : run) curve.points.push_back(pl.vertices[i].anchor);
  const std::optional<CurveSmoothingResult> r = try_smooth(mesh, topology, curve, core);
  if (!r) return false;
  const auto& pts = r->curve.points;
  if (pts.size() < 2) return false;
  std::vector<const LineVertex*> old;
  old.reserve(run.size());
  for (const std::size_t i : run) old.push_back(&pl.vertices[i]);
  const ArcSampler sampler(std::move(old));
  // Arc length along the new run, scaled to the old run's length.
  std::vector<Vec3> positions(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) positions[i] = pts[i].position(mesh);
  positions.front() = first.position;
  positions.back() = pl.vertices[run.back()].position;
  double new_length = 0.0;
  for (std::size_t i = 1; i < positions.size(); ++i)
    new_length += (positions[i] - positions[i - 1]).norm();
  const double scale = new_length > 0.0 ? sampler.length() / new_length : 0.0;
  double s = 0.0;
  LineVertex v = first;
  v.anchor = pts.front();
  out.push_back(v);
  for (std::size_t i = 1; i + 1 < pts.size(); ++i) {
    s += (positions[i] - positions[i - 1]).norm();
    LineVertex w;
    w.anchor = pts[i];
    w.position = positions[i];
    sampler.sample(s * scale, static_cast<double>(i) / static_cast<double>(pts.size() - 1), w);
    out.push_back(w);
  }
  return true;
}

/// Smooths a closed polyline without fixed points as one closed curve.
bool smooth_loop(const TriangleMesh& mesh, const Topology& topology, const Polyline& pl,
                 const CurveSmoothingOptions& core, std::vector<LineVertex>& out, bool& collapsed) {
  SurfaceCurve curve;
  curve.closed = true;
  for (const auto& v : pl.vertices) curve.points.push_back(v.anchor);
  const std::optional<CurveSmoothingResult> r = try_smooth(mesh, topology, curve, core);
  if (!r) return false;
  const auto& pts = r->curve.points;
  if (r->collapsed || pts.size() < 3) {
    collapsed = true;
    return false;
  }
  std::vector<const LineVertex*> old;
  old.reserve(pl.vertices.size() + 1);
  for (const auto& v : pl.vertices) old.push_back(&v);
  old.push_back(&pl.vertices.front());
  const ArcSampler sampler(std::move(old));
  std::vector<Vec3> positions(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) positions[i] = pts[i].position(mesh);
  double new_length = 0.0;
  for (std::size_t i = 0; i < positions.size(); ++i)
    new_length += (positions[(i + 1) % positions.size()] - positions[i]).norm();
  const double scale = new_length > 0.0 ? sampler.length() / new_length : 0.0;
  const double s0 = sampler.project(positions[0]);
  double s = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (i > 0) s += (positions[i] - positions[i - 1]).norm();
    LineVertex w;
    w.anchor = pts[i];
    w.position = positions[i];
    double at = s0 + s * scale;
    if (sampler.length() > 0.0) at = std::fmod(at, sampler.length());
    sampler.sample(at, static_cast<double>(i) / static_cast<double>(pts.size()), w);
    out.push_back(w);
  }
  return true;
}

PolylineReport smooth_polyline(const TriangleMesh& mesh, const Topology& topology, Polyline& pl,
                               const CurveSmoothingOptions& core) {
  PolylineReport report;
  const std::size_t n = pl.vertices.size();
  if (!pl.closed && n < 3) {
    report.outcome = Outcome::too_short;
    return report;
  }
  // The surface-curve rules, checked without exceptions.
  if (pl.closed && n < 3) {
    report.outcome = Outcome::invalid;
    return report;
  }
  for (const auto& v : pl.vertices)
    if (!valid_anchor(mesh, v.anchor) || !v.position.allFinite()) {
      report.outcome = Outcome::invalid;
      return report;
    }
  const std::size_t pairs = pl.closed ? n : n - 1;
  for (std::size_t i = 0; i < pairs; ++i)
    if (shared_face(mesh, topology, pl.vertices[i].anchor, pl.vertices[(i + 1) % n].anchor) < 0) {
      report.outcome = Outcome::invalid;
      return report;
    }

  // Fixed points: points inside a face, and the ends of an open polyline.
  std::vector<std::size_t> fixed;
  for (std::size_t i = 0; i < n; ++i) {
    const bool inside = inside_face(pl.vertices[i].anchor);
    report.fixed_points += inside ? 1 : 0;
    if (inside || (!pl.closed && (i == 0 || i + 1 == n))) fixed.push_back(i);
  }

  std::vector<LineVertex> out;
  out.reserve(n + n / 4);
  bool ok = true, collapsed = false;
  if (pl.closed && fixed.empty()) {
    // A small loop that would shrink below 3 points is smoothed with fewer
    // iterations (halved until it survives).
    CurveSmoothingOptions fewer = core;
    while (true) {
      out.clear();
      collapsed = false;
      ok = smooth_loop(mesh, topology, pl, fewer, out, collapsed);
      if (ok || !collapsed || fewer.iterations <= 1) break;
      fewer.iterations /= 2;
    }
  } else {
    // Runs between consecutive fixed points; a loop's runs wrap around and
    // the output starts at its first fixed point.
    const std::size_t runs = pl.closed ? fixed.size() : fixed.size() - 1;
    std::vector<std::size_t> run;
    for (std::size_t k = 0; k < runs && ok; ++k) {
      const std::size_t a = fixed[k];
      std::size_t b = k + 1 < fixed.size() ? fixed[k + 1] : fixed[0] + n;
      run.clear();
      for (std::size_t i = a; i <= b; ++i) run.push_back(i % n);
      ok = smooth_run(mesh, topology, pl, run, core, out);
    }
    if (ok && !pl.closed) out.push_back(pl.vertices.back());
    if (ok && pl.closed && out.size() < 3) {
      ok = false;
      collapsed = true;
    }
  }
  if (!ok) {
    report.outcome = collapsed ? Outcome::collapsed : Outcome::invalid;
    report.fixed_points = 0;
    return report;
  }
  // The faces of the result's segments: segment i lies in out[i]'s face
  // (guaranteed by the core; checked so a broken polyline is never returned).
  const std::size_t m = out.size();
  const std::size_t segments = pl.closed ? m : m - 1;
  std::vector<std::int32_t> edge_faces(segments, -1);
  for (std::size_t i = 0; i < segments; ++i) {
    edge_faces[i] = shared_face(mesh, topology, out[i].anchor, out[(i + 1) % m].anchor);
    if (edge_faces[i] < 0) {
      report.outcome = Outcome::invalid;
      report.fixed_points = 0;
      return report;
    }
  }
  report.outcome = Outcome::smoothed;
  report.points_before = n;
  report.points_after = m;
  report.length_before = path_length(pl.vertices, pl.closed);
  report.length_after = path_length(out, pl.closed);
  pl.vertices = std::move(out);
  pl.edge_faces = std::move(edge_faces);
  return report;
}

}  // namespace

LineSmoothingStats smooth_lines(LineSet& lines, const TriangleMesh& mesh, const Topology& topology,
                                const LineSmoothingOptions& options) {
  {
    std::ostringstream s;
    if (options.iterations < 0)
      s << "line smoothing: iterations must be >= 0, got " << options.iterations;
    else if (!(options.step > 0.0 && options.step <= 1.0))
      s << "line smoothing: step must be in (0,1], got " << options.step;
    else if (!(options.vertex_snap >= 0.0 && options.vertex_snap <= 1e-3))
      s << "line smoothing: vertex_snap must be in [0, 0.001], got " << options.vertex_snap;
    if (!s.str().empty()) throw InputError(s.str());
  }
  std::array<bool, kLineFamilyCount> chosen{};
  for (const LineFamily f : options.families) chosen[static_cast<std::size_t>(f)] = true;

  LineSmoothingStats stats;
  std::vector<std::size_t> todo;
  for (std::size_t i = 0; i < lines.polylines.size(); ++i)
    if (chosen[static_cast<std::size_t>(lines.polylines[i].family)]) todo.push_back(i);
  stats.polylines = todo.size();
  if (options.iterations == 0 || todo.empty()) return stats;

  CurveSmoothingOptions core;
  core.iterations = options.iterations;
  core.step = options.step;
  core.vertex_snap = options.vertex_snap;
  core.split_at_vertices = options.split_at_vertices;

  std::vector<PolylineReport> reports(todo.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, todo.size(), 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k)
                        reports[k] =
                            smooth_polyline(mesh, topology, lines.polylines[todo[k]], core);
                    });
  for (const PolylineReport& r : reports) {  // in polyline order: deterministic sums
    switch (r.outcome) {
      case Outcome::smoothed:
        ++stats.smoothed;
        break;
      case Outcome::too_short:
        ++stats.too_short;
        break;
      case Outcome::invalid:
        ++stats.invalid;
        break;
      case Outcome::collapsed:
        ++stats.collapsed;
        break;
      case Outcome::untouched:
        break;
    }
    stats.fixed_points += r.fixed_points;
    stats.points_before += r.points_before;
    stats.points_after += r.points_after;
    stats.length_before += r.length_before;
    stats.length_after += r.length_after;
  }
  return stats;
}

LineSmoothingStats smooth_lines(LineSet& lines, const Surface& surface,
                                const LineSmoothingOptions& options) {
  return smooth_lines(lines, surface.mesh(), surface.topology(), options);
}

}  // namespace fabrica
