// The shared stroke tracer; see stroke_tracer.hpp and docs/algorithms.md §9.
#include "stroke_tracer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fabrica/hatching/hatching.hpp"
#include "fabrica/hatching/intensity_field.hpp"

namespace fabrica::hatching::detail {

namespace {

constexpr std::size_t kMaxSteps = 200000;  // faces crossed per direction
constexpr int kMaxZeroSteps = 64;          // consecutive zero-length steps (vertex fans)
/// Relative size below which a rate of change counts as round-off (a
/// direction parallel to an edge).
constexpr double kParallelTol = 1e-9;
/// Line fields: a stroke that moves less than a pixel while crossing this
/// many faces is circling (e.g. between faces whose directions run along
/// their shared edge) and ends as an extremum.
constexpr std::size_t kProgressSteps = 256;
/// A region function this far below zero still counts as inside (round-off
/// at a point where a stroke stopped or crossed an edge).
constexpr double kRegionTol = 1e-12;

}  // namespace

Tracer::Tracer(const Surface& surface, const TraceField& field, const TraceSettings& settings,
               const Projector& projector, const DepthBuffer& depth, ProximityGrid& grid)
    : surface_(surface),
      field_(field),
      settings_(settings),
      projector_(projector),
      depth_(depth),
      grid_(grid),
      topology_(surface.topology()),
      positions_(surface.positions()),
      faces_(surface.faces()),
      side_(grid.side()) {}

int Tracer::level_for(double value) const {
  if (!settings_.adaptive) return settings_.grid_depth;
  return truncation_level(value, side_, settings_.stroke_width_px, settings_.grid_depth);
}

bool Tracer::shares_vertex(std::int32_t a, std::int32_t b) const {
  const Face& fa = faces_[static_cast<std::size_t>(a)];
  const Face& fb = faces_[static_cast<std::size_t>(b)];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (fa[i] == fb[j]) return true;
  return false;
}

bool Tracer::visible(std::int32_t face, const Vec2& pixel, double depth) const {
  const std::int32_t seen = depth_.face_at(pixel);
  if (seen < 0 || seen == face || shares_vertex(seen, face)) return true;
  return depth <= static_cast<double>(depth_.depth_at(pixel)) + settings_.occlusion_tolerance_mm;
}

bool Tracer::in_region(std::int32_t face, const Vec3& bary) const {
  if (field_.regions.empty()) return true;
  for (const std::vector<double>* r : field_.regions)
    if (vertex_value(*r, face, bary) >= -kRegionTol) return true;
  return false;
}

std::optional<StrokeEnd> Tracer::check_sample(std::int32_t face, const Vec3& x, double value,
                                              Vec2& pixel) const {
  const ProjectedPoint pp = projector_.project(x);
  pixel = pp.pixel;
  if (!(pp.depth > 0.0) || !(pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < depth_.width &&
                             pixel.y() < depth_.height))
    return StrokeEnd::outside_image;
  if (!visible(face, pixel, pp.depth)) return StrokeEnd::occluded;
  if (grid_.blocked(pixel, level_for(value))) return StrokeEnd::proximity;
  return std::nullopt;
}

StrokeVertex Tracer::make_vertex(std::int32_t face, const Vec3& bary, const Vec3& x,
                                 const Vec2& pixel, double value) const {
  StrokeVertex v;
  v.anchor.face = face;
  v.anchor.bary = bary;
  v.position = x;
  v.pixel = pixel;
  v.intensity = value;
  return v;
}

StrokeEnd Tracer::trace(const TraceState& start, double sign, double max_length,
                        std::vector<StrokeVertex>& out, double& length) const {
  std::int32_t face = start.face;
  Vec3 bary = start.bary;
  Vec3 x = start.position;
  Vec2 pixel = start.pixel;
  double value = start.value;
  int zero_steps = 0;
  const auto& values = *field_.value;
  const auto& facing = *field_.facing;
  const auto& directions = *field_.face_direction;
  Vec3 g = sign * directions[static_cast<std::size_t>(face)];
  Vec2 checkpoint = pixel;
  for (std::size_t step = 0; step < kMaxSteps; ++step) {
    if (field_.line_field && step > 0 && step % kProgressSteps == 0) {
      if ((pixel - checkpoint).norm() < 1.0) return StrokeEnd::extremum;
      checkpoint = pixel;
    }
    const std::size_t f = static_cast<std::size_t>(face);
    Vec3 db;
    for (int k = 0; k < 3; ++k) db[k] = barycentric_gradient(surface_, f, k).dot(g);
    // Exit: the first barycentric coordinate to reach zero. A coordinate
    // that is already zero and changes only by round-off means the stroke
    // runs along that edge (e.g. a seed on a mesh edge parallel to the
    // field); it leaves through the edge's end instead.
    const double rate_tol = kParallelTol * db.cwiseAbs().maxCoeff();
    double t_exit = std::numeric_limits<double>::infinity();
    int exit = -1;
    for (int k = 0; k < 3; ++k) {
      if (db[k] < 0.0 && !(bary[k] <= 0.0 && db[k] >= -rate_tol)) {
        const double t = std::max(bary[k], 0.0) / -db[k];
        if (t < t_exit) {
          t_exit = t;
          exit = k;
        }
      }
    }
    if (exit < 0 || !std::isfinite(t_exit)) return StrokeEnd::extremum;  // no direction here
    Vec3 b1 = bary + t_exit * db;
    b1[exit] = 0.0;
    for (int k = 0; k < 3; ++k) b1[k] = std::max(b1[k], 0.0);
    b1 /= b1.sum();
    const Vec3 x1 = position(face, b1);
    const double v0 = value, v1 = vertex_value(values, face, b1);
    const double f0 = vertex_value(facing, face, bary), f1 = vertex_value(facing, face, b1);

    // Exact stops inside this face: value threshold, back-facing, region.
    double u_stop = 1.0;
    std::optional<StrokeEnd> stop_reason;
    if (v1 > field_.value_threshold) {
      const double u = v1 > v0 ? (field_.value_threshold - v0) / (v1 - v0) : 0.0;
      u_stop = std::clamp(u, 0.0, 1.0);
      stop_reason = StrokeEnd::threshold;
    }
    if (f1 < 0.0) {
      const double u = f0 > 0.0 ? f0 / (f0 - f1) : 0.0;
      if (u < u_stop || !stop_reason) {
        u_stop = std::min(u_stop, std::clamp(u, 0.0, 1.0));
        stop_reason = StrokeEnd::back_facing;
      }
    }
    if (!field_.regions.empty()) {
      // Each region function is linear in u, so its inside is a prefix
      // [0, a] or a suffix [b, 1] of the step; the union is left at the
      // largest a unless some suffix starts before it.
      double a_max = -1.0, b_min = 2.0;
      for (const std::vector<double>* r : field_.regions) {
        const double r0 = vertex_value(*r, face, bary), r1 = vertex_value(*r, face, b1);
        if (r0 >= -kRegionTol)
          a_max = std::max(a_max, r1 >= 0.0 ? 1.0 : std::max(r0, 0.0) / (std::max(r0, 0.0) - r1));
        else if (r1 >= 0.0)
          b_min = std::min(b_min, r0 / (r0 - r1));
      }
      if (a_max < 1.0 && b_min > a_max) {
        const double u = std::max(a_max, 0.0);
        if (u < u_stop || !stop_reason) {
          u_stop = std::min(u_stop, u);
          stop_reason = StrokeEnd::region;
        }
      }
    }

    // Sampled stops: visibility, proximity, image border, length.
    const Vec2 end_pixel = projector_.project(position(face, bary + u_stop * (b1 - bary))).pixel;
    const double span = (end_pixel - pixel).norm();
    const int samples =
        std::max(1, static_cast<int>(std::ceil(span / settings_.sample_spacing_px)));
    double u_good = 0.0;
    Vec2 pixel_good = pixel;
    for (int s = 1; s <= samples; ++s) {
      const double u = u_stop * static_cast<double>(s) / samples;
      const Vec3 xs = x + u * (x1 - x);
      const double vs = v0 + u * (v1 - v0);
      Vec2 ps;
      std::optional<StrokeEnd> why = check_sample(face, xs, vs, ps);
      const double step_length = (ps - pixel_good).norm();
      if (!why && max_length > 0.0 && length + step_length > max_length) why = StrokeEnd::length;
      if (why) {
        if (u_good > 0.0) {
          const Vec3 bg = bary + u_good * (b1 - bary);
          out.push_back(
              make_vertex(face, bg, x + u_good * (x1 - x), pixel_good, v0 + u_good * (v1 - v0)));
        }
        return *why;
      }
      length += step_length;
      u_good = u;
      pixel_good = ps;
    }
    if (stop_reason) {
      if (u_stop > 0.0) {
        const Vec3 bg = bary + u_stop * (b1 - bary);
        out.push_back(
            make_vertex(face, bg, x + u_stop * (x1 - x), pixel_good, v0 + u_stop * (v1 - v0)));
      }
      return *stop_reason;
    }
    out.push_back(make_vertex(face, b1, x1, pixel_good, v1));

    // Cross the exit edge into the neighbour.
    zero_steps = t_exit > 0.0 ? 0 : zero_steps + 1;
    if (zero_steps > kMaxZeroSteps) return StrokeEnd::extremum;
    const std::int32_t next = topology_.face_neighbor(f, exit);
    if (next < 0) return StrokeEnd::boundary;
    const Face& from = faces_[f];
    const Face& to = faces_[static_cast<std::size_t>(next)];
    Vec3 nb = Vec3::Zero();
    int opposite = -1;
    for (int k = 0; k < 3; ++k) {
      bool found = false;
      for (int m = 0; m < 3; ++m) {
        if (m != exit && to[k] == from[m]) {
          nb[k] = b1[m];
          found = true;
        }
      }
      if (!found) opposite = k;
    }
    if (opposite < 0) return StrokeEnd::boundary;  // malformed adjacency
    Vec3 g_next = sign * directions[static_cast<std::size_t>(next)];
    // A line field has no sign of its own: continue the current direction.
    if (field_.line_field && g_next.dot(g) < 0.0) g_next = -g_next;
    // Extremum: the neighbour's direction points back across the edge. A
    // direction along the edge (zero up to round-off) is not a turn back.
    const Vec3 into = barycentric_gradient(surface_, static_cast<std::size_t>(next), opposite);
    if (into.dot(g_next) < -kParallelTol * into.norm() * g_next.norm()) return StrokeEnd::extremum;
    face = next;
    bary = nb / nb.sum();
    x = x1;
    pixel = pixel_good;
    value = v1;
    g = g_next;
  }
  return StrokeEnd::step_limit;
}

void seed_and_trace(const Surface& surface, const TraceField& field, Tracer& tracer,
                    const Projector& projector, const DepthBuffer& depth, ProximityGrid& grid,
                    const SeedingSettings& settings,
                    const std::function<bool(std::int32_t, const Vec3&, double, int)>& accept,
                    StrokeSet& result) {
  const auto& faces = surface.faces();
  const auto& positions = surface.positions();
  const auto& face_normals = surface.face_normals();
  std::vector<StrokeVertex> backward, forward;
  std::vector<Vec2> pixels;
  for (int level = 0; level <= settings.seed_depth; ++level) {
    for (const Vec2& candidate : grid.new_lattice_points(level)) {
      ++result.stats.candidates;
      const std::int32_t face = depth.face_at(candidate);
      if (face < 0) continue;
      const std::size_t f = static_cast<std::size_t>(face);
      // The surface point under the candidate: the viewing ray meets the face plane.
      Vec3 origin, direction;
      projector.ray(candidate, origin, direction);
      const Vec3& n = face_normals[f];
      const double denom = n.dot(direction);
      if (!(std::abs(denom) > 1e-12)) continue;
      const Vec3& p0 = positions[static_cast<std::size_t>(faces[f][0])];
      const Vec3 hit = origin + (n.dot(p0 - origin) / denom) * direction;
      Vec3 bary;
      for (int k = 0; k < 3; ++k) {
        const Vec3& a = positions[static_cast<std::size_t>(faces[f][(k + 1) % 3])];
        const Vec3& b = positions[static_cast<std::size_t>(faces[f][(k + 2) % 3])];
        bary[k] = std::max(0.0, (b - a).cross(hit - a).dot(n));
      }
      const double sum = bary.sum();
      if (!(sum > 0.0)) continue;
      bary /= sum;
      TraceState seed;
      seed.face = face;
      seed.bary = bary;
      seed.position = tracer.position(face, bary);
      seed.value = tracer.vertex_value(*field.value, face, bary);
      if (tracer.vertex_value(*field.facing, face, bary) < 0.0) continue;
      if (!tracer.in_region(face, bary)) continue;
      if (!accept(face, bary, seed.value, level)) continue;
      seed.pixel = projector.project(seed.position).pixel;
      if (grid.blocked(seed.pixel, level)) continue;  // s_level >= the truncation cell size
      if (!((*field.face_direction)[f].squaredNorm() > 0.0)) continue;
      ++result.stats.seeds;

      backward.clear();
      forward.clear();
      double back_length = 0.0, fore_length = 0.0;
      const double half = 0.5 * settings.max_length_px;
      const StrokeEnd dark = tracer.trace(seed, -1.0, half, backward, back_length);
      const StrokeEnd bright = tracer.trace(seed, +1.0, half, forward, fore_length);
      const double length = back_length + fore_length;
      if (length < settings.min_length_px || backward.size() + forward.size() == 0) {
        ++result.stats.short_strokes;
        continue;
      }
      Stroke stroke;
      stroke.vertices.reserve(backward.size() + forward.size() + 1);
      stroke.vertices.assign(backward.rbegin(), backward.rend());
      stroke.seed_vertex = stroke.vertices.size();
      stroke.vertices.push_back(
          tracer.make_vertex(face, bary, seed.position, seed.pixel, seed.value));
      stroke.vertices.insert(stroke.vertices.end(), forward.begin(), forward.end());
      stroke.seed_level = level;
      stroke.dark_end = dark;
      stroke.bright_end = bright;
      stroke.length_px = length;
      ++result.stats.ends[static_cast<std::size_t>(dark)];
      ++result.stats.ends[static_cast<std::size_t>(bright)];
      pixels.clear();
      for (const StrokeVertex& v : stroke.vertices) pixels.push_back(v.pixel);
      grid.mark_polyline(pixels);
      result.strokes.push_back(std::move(stroke));
    }
  }
}

}  // namespace fabrica::hatching::detail
