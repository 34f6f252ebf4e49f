// Shading-stroke hatching (Singh & Schaefer 2010); see hatching.hpp.
#include "fabrica/hatching/hatching.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/projector.hpp"
#include "fabrica/hatching/proximity_grid.hpp"

namespace fabrica::hatching {

const char* to_string(StrokeEnd end) {
  switch (end) {
    case StrokeEnd::threshold:
      return "threshold";
    case StrokeEnd::extremum:
      return "extremum";
    case StrokeEnd::boundary:
      return "boundary";
    case StrokeEnd::back_facing:
      return "back_facing";
    case StrokeEnd::occluded:
      return "occluded";
    case StrokeEnd::length:
      return "length";
    case StrokeEnd::proximity:
      return "proximity";
    case StrokeEnd::outside_image:
      return "outside_image";
    case StrokeEnd::step_limit:
      return "step_limit";
  }
  return "unknown";
}

double density_depth(double intensity, double image_side, double stroke_width_px) {
  const double tone = 1.0 - std::max(intensity, 0.0);
  if (!(tone > 0.0)) return -std::numeric_limits<double>::infinity();
  return 2.0 * std::log2(image_side * tone / stroke_width_px);
}

int truncation_level(double intensity, double image_side, double stroke_width_px, int grid_depth) {
  const double d = density_depth(intensity, image_side, stroke_width_px);
  if (!(d > 0.0)) return 0;
  if (d >= grid_depth) return grid_depth;
  return static_cast<int>(std::floor(d));
}

int default_grid_depth(double image_side) {
  return std::max(0, static_cast<int>(std::lround(20.0 + 2.0 * std::log2(image_side / 800.0))));
}

namespace {

constexpr std::size_t kMaxSteps = 200000;  // faces crossed per direction
constexpr int kMaxZeroSteps = 64;          // consecutive zero-length steps (vertex fans)
/// Relative size below which a rate of change counts as round-off (a
/// direction parallel to an edge).
constexpr double kParallelTol = 1e-9;

struct TraceState {
  std::int32_t face = -1;
  Vec3 bary = Vec3::Zero();
  Vec3 position = Vec3::Zero();
  Vec2 pixel = Vec2::Zero();
  double intensity = 0.0;
};

class Tracer {
 public:
  Tracer(const Surface& surface, const IntensityField& field, const HatchingOptions& options,
         const Projector& projector, const DepthBuffer& depth, ProximityGrid& grid, int grid_depth)
      : surface_(surface),
        field_(field),
        options_(options),
        projector_(projector),
        depth_(depth),
        grid_(grid),
        topology_(surface.topology()),
        positions_(surface.positions()),
        faces_(surface.faces()),
        grid_depth_(grid_depth),
        side_(grid.side()),
        occlusion_tolerance_(options.occlusion_tolerance * surface.mean_edge_length()) {}

  double vertex_value(const std::vector<double>& values, std::int32_t face,
                      const Vec3& bary) const {
    const Face& t = faces_[static_cast<std::size_t>(face)];
    return bary[0] * values[static_cast<std::size_t>(t[0])] +
           bary[1] * values[static_cast<std::size_t>(t[1])] +
           bary[2] * values[static_cast<std::size_t>(t[2])];
  }
  Vec3 position(std::int32_t face, const Vec3& bary) const {
    const Face& t = faces_[static_cast<std::size_t>(face)];
    return bary[0] * positions_[static_cast<std::size_t>(t[0])] +
           bary[1] * positions_[static_cast<std::size_t>(t[1])] +
           bary[2] * positions_[static_cast<std::size_t>(t[2])];
  }
  int level_for(double intensity) const {
    if (!options_.adaptive_depth) return grid_depth_;
    return truncation_level(intensity, side_, options_.stroke_width_px, grid_depth_);
  }
  bool shares_vertex(std::int32_t a, std::int32_t b) const {
    const Face& fa = faces_[static_cast<std::size_t>(a)];
    const Face& fb = faces_[static_cast<std::size_t>(b)];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (fa[i] == fb[j]) return true;
    return false;
  }

  /// Visibility of a point on `face` (pixel and depth given): not hidden by a
  /// nearer surface in the depth buffer.
  bool visible(std::int32_t face, const Vec2& pixel, double depth) const {
    const std::int32_t seen = depth_.face_at(pixel);
    if (seen < 0 || seen == face || shares_vertex(seen, face)) return true;
    return depth <= static_cast<double>(depth_.depth_at(pixel)) + occlusion_tolerance_;
  }

  /// Tests one sample of a stroke; fills its pixel.
  std::optional<StrokeEnd> check_sample(std::int32_t face, const Vec3& x, double intensity,
                                        Vec2& pixel) const {
    const ProjectedPoint pp = projector_.project(x);
    pixel = pp.pixel;
    if (!(pp.depth > 0.0) || !(pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < depth_.width &&
                               pixel.y() < depth_.height))
      return StrokeEnd::outside_image;
    if (!visible(face, pixel, pp.depth)) return StrokeEnd::occluded;
    if (grid_.blocked(pixel, level_for(intensity))) return StrokeEnd::proximity;
    return std::nullopt;
  }

  StrokeVertex make_vertex(std::int32_t face, const Vec3& bary, const Vec3& x, const Vec2& pixel,
                           double intensity) const {
    StrokeVertex v;
    v.anchor.face = face;
    v.anchor.bary = bary;
    v.position = x;
    v.pixel = pixel;
    v.intensity = intensity;
    return v;
  }

  /// Traces from `start` along sign·∇I; appends the vertices after the start.
  StrokeEnd trace(const TraceState& start, double sign, double max_length,
                  std::vector<StrokeVertex>& out, double& length) const {
    std::int32_t face = start.face;
    Vec3 bary = start.bary;
    Vec3 x = start.position;
    Vec2 pixel = start.pixel;
    double intensity = start.intensity;
    int zero_steps = 0;
    const auto& I = field_.vertex_intensity;
    const auto& facing = field_.vertex_facing;
    for (std::size_t step = 0; step < kMaxSteps; ++step) {
      const std::size_t f = static_cast<std::size_t>(face);
      const Vec3 g = sign * field_.face_gradient[f];
      Vec3 db;
      for (int k = 0; k < 3; ++k) db[k] = barycentric_gradient(surface_, f, k).dot(g);
      // Exit: the first barycentric coordinate to reach zero. A coordinate
      // that is already zero and changes only by round-off means the stroke
      // runs along that edge (e.g. a seed on a mesh edge parallel to ∇I); it
      // leaves through the edge's end instead.
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
      if (exit < 0 || !std::isfinite(t_exit)) return StrokeEnd::extremum;  // ∇I = 0 here
      Vec3 b1 = bary + t_exit * db;
      b1[exit] = 0.0;
      for (int k = 0; k < 3; ++k) b1[k] = std::max(b1[k], 0.0);
      b1 /= b1.sum();
      const Vec3 x1 = position(face, b1);
      const double i0 = intensity, i1 = vertex_value(I, face, b1);
      const double f0 = vertex_value(facing, face, bary), f1 = vertex_value(facing, face, b1);

      // Exact stops inside this face: intensity threshold, back-facing.
      double u_stop = 1.0;
      std::optional<StrokeEnd> stop_reason;
      if (i1 > options_.intensity_threshold) {
        const double u = i1 > i0 ? (options_.intensity_threshold - i0) / (i1 - i0) : 0.0;
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

      // Sampled stops: visibility, proximity, image border, length.
      const Vec2 end_pixel = projector_.project(position(face, bary + u_stop * (b1 - bary))).pixel;
      const double span = (end_pixel - pixel).norm();
      const int samples =
          std::max(1, static_cast<int>(std::ceil(span / options_.sample_spacing_px)));
      double u_good = 0.0;
      Vec2 pixel_good = pixel;
      for (int s = 1; s <= samples; ++s) {
        const double u = u_stop * static_cast<double>(s) / samples;
        const Vec3 xs = x + u * (x1 - x);
        const double is = i0 + u * (i1 - i0);
        Vec2 ps;
        std::optional<StrokeEnd> why = check_sample(face, xs, is, ps);
        const double step_length = (ps - pixel_good).norm();
        if (!why && max_length > 0.0 && length + step_length > max_length) why = StrokeEnd::length;
        if (why) {
          if (u_good > 0.0) {
            const Vec3 bg = bary + u_good * (b1 - bary);
            out.push_back(
                make_vertex(face, bg, x + u_good * (x1 - x), pixel_good, i0 + u_good * (i1 - i0)));
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
              make_vertex(face, bg, x + u_stop * (x1 - x), pixel_good, i0 + u_stop * (i1 - i0)));
        }
        return *stop_reason;
      }
      out.push_back(make_vertex(face, b1, x1, pixel_good, i1));

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
      const Vec3 g_next = sign * field_.face_gradient[static_cast<std::size_t>(next)];
      // Extremum: the neighbour's direction points back across the edge. A
      // direction along the edge (zero up to round-off) is not a turn back.
      const Vec3 into = barycentric_gradient(surface_, static_cast<std::size_t>(next), opposite);
      if (into.dot(g_next) < -kParallelTol * into.norm() * g_next.norm())
        return StrokeEnd::extremum;
      face = next;
      bary = nb / nb.sum();
      x = x1;
      pixel = pixel_good;
      intensity = i1;
    }
    return StrokeEnd::step_limit;
  }

 private:
  const Surface& surface_;
  const IntensityField& field_;
  const HatchingOptions& options_;
  const Projector& projector_;
  const DepthBuffer& depth_;
  ProximityGrid& grid_;
  const Topology& topology_;
  const std::vector<Vec3>& positions_;
  const std::vector<Face>& faces_;
  int grid_depth_;
  double side_;
  double occlusion_tolerance_;
};

void validate_options(const HatchingOptions& o) {
  auto bad = [](const std::string& what) { throw InputError("hatching: " + what); };
  if (!(o.stroke_width_px > 0.0)) bad("stroke width must be positive");
  if (!(o.sample_spacing_px > 0.0)) bad("sample spacing must be positive");
  if (!(o.max_length_px >= 0.0)) bad("maximum stroke length must be >= 0 (0 = no limit)");
  if (!(o.min_length_px >= 0.0)) bad("minimum stroke length must be >= 0");
  if (!std::isfinite(o.intensity_threshold)) bad("intensity threshold must be finite");
  if (!(o.occlusion_tolerance >= 0.0)) bad("occlusion tolerance must be >= 0");
  if (o.grid_depth > 40 || o.grid_depth < -1)
    bad("grid depth must be in [0, 40] (or -1 for automatic)");
  if (o.seed_depth > 40 || o.seed_depth < -1)
    bad("seed depth must be in [0, 40] (or -1 for automatic)");
}

}  // namespace

StrokeSet hatch(const Surface& surface, const Camera& camera, const HatchingOptions& options) {
  validate_camera(camera, "hatching camera");
  validate_options(options);
  const IntensityField field = compute_intensity_field(surface, camera, options.light);
  return hatch(surface, camera, field, options);
}

StrokeSet hatch(const Surface& surface, const Camera& camera, const IntensityField& field,
                const HatchingOptions& options) {
  validate_camera(camera, "hatching camera");
  validate_options(options);
  if (field.vertex_intensity.size() != surface.vertex_count() ||
      field.vertex_facing.size() != surface.vertex_count() ||
      field.face_gradient.size() != surface.face_count())
    throw InputError(
        "hatching: the intensity field does not match the mesh (one value per vertex and face)");

  StrokeSet result;
  result.width = camera.width;
  result.height = camera.height;
  const double side = std::max(camera.width, camera.height);
  int grid_depth = options.grid_depth >= 0 ? options.grid_depth : default_grid_depth(side);
  // The automatic depth stays within the grid's memory bound (it is 29 at
  // 16384 px, whose grid would need 4 GiB); an explicit one is checked by the grid.
  if (options.grid_depth < 0)
    while (grid_depth > 0 && ProximityGrid::cell_count(camera.width, camera.height, grid_depth) >
                                 ProximityGrid::kMaxCells)
      --grid_depth;
  const int seed_depth = std::min(
      grid_depth, options.seed_depth >= 0 ? options.seed_depth : std::max(0, grid_depth - 2));
  result.grid_depth = grid_depth;
  result.seed_depth = seed_depth;
  if (surface.face_count() == 0) return result;

  const Projector projector(camera);
  const DepthBuffer depth = render_depth(surface.mesh(), camera, /*faces=*/true);
  ProximityGrid grid(camera.width, camera.height, grid_depth);
  Tracer tracer(surface, field, options, projector, depth, grid, grid_depth);

  // Intensity ridges go into the grid first, so strokes keep their distance.
  if (options.ridge_removal) {
    const IntensityRidges ridges = detect_intensity_ridges(surface, field, options.ridges);
    result.stats.ridge_segments = ridges.segments.size();
    for (const RidgeSegment& seg : ridges.segments) {
      StrokeVertex ends[2];
      bool shown = true;
      const SurfacePoint* anchors[2] = {&seg.a, &seg.b};
      const Vec3* where[2] = {&seg.pa, &seg.pb};
      for (int k = 0; k < 2 && shown; ++k) {
        const ProjectedPoint pp = projector.project(*where[k]);
        const double facing =
            tracer.vertex_value(field.vertex_facing, anchors[k]->face, anchors[k]->bary);
        shown =
            pp.depth > 0.0 && facing >= 0.0 && tracer.visible(anchors[k]->face, pp.pixel, pp.depth);
        ends[k] = tracer.make_vertex(
            anchors[k]->face, anchors[k]->bary, *where[k], pp.pixel,
            tracer.vertex_value(field.vertex_intensity, anchors[k]->face, anchors[k]->bary));
      }
      if (!shown) continue;
      grid.mark_segment(ends[0].pixel, ends[1].pixel);
      result.ridges.push_back({ends[0], ends[1]});
    }
  }

  const auto& faces = surface.faces();
  const auto& positions = surface.positions();
  const auto& face_normals = surface.face_normals();
  std::vector<StrokeVertex> backward, forward;
  std::vector<Vec2> pixels;
  for (int level = 0; level <= seed_depth; ++level) {
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
      seed.intensity = tracer.vertex_value(field.vertex_intensity, face, bary);
      if (tracer.vertex_value(field.vertex_facing, face, bary) < 0.0) continue;
      if (seed.intensity > options.intensity_threshold) continue;
      if (options.adaptive_depth &&
          level > density_depth(seed.intensity, side, options.stroke_width_px))
        continue;
      seed.pixel = projector.project(seed.position).pixel;
      if (grid.blocked(seed.pixel, level)) continue;  // s_level >= the truncation cell size
      if (!(field.face_gradient[f].squaredNorm() > 0.0)) continue;
      ++result.stats.seeds;

      backward.clear();
      forward.clear();
      double back_length = 0.0, fore_length = 0.0;
      const double half = 0.5 * options.max_length_px;
      const StrokeEnd dark = tracer.trace(seed, -1.0, half, backward, back_length);
      const StrokeEnd bright = tracer.trace(seed, +1.0, half, forward, fore_length);
      const double length = back_length + fore_length;
      if (length < options.min_length_px || backward.size() + forward.size() == 0) {
        ++result.stats.short_strokes;
        continue;
      }
      Stroke stroke;
      stroke.vertices.reserve(backward.size() + forward.size() + 1);
      stroke.vertices.assign(backward.rbegin(), backward.rend());
      stroke.seed_vertex = stroke.vertices.size();
      stroke.vertices.push_back(
          tracer.make_vertex(face, bary, seed.position, seed.pixel, seed.intensity));
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
  return result;
}

}  // namespace fabrica::hatching
