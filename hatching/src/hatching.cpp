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
#include "stroke_tracer.hpp"

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
    case StrokeEnd::region:
      return "region";
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
  detail::TraceField trace_field;
  trace_field.face_direction = &field.face_gradient;
  trace_field.value = &field.vertex_intensity;
  trace_field.value_threshold = options.intensity_threshold;
  trace_field.facing = &field.vertex_facing;
  detail::TraceSettings settings;
  settings.sample_spacing_px = options.sample_spacing_px;
  settings.occlusion_tolerance_mm = options.occlusion_tolerance * surface.mean_edge_length();
  settings.adaptive = options.adaptive_depth;
  settings.stroke_width_px = options.stroke_width_px;
  settings.grid_depth = grid_depth;
  detail::Tracer tracer(surface, trace_field, settings, projector, depth, grid);

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

  detail::SeedingSettings seeding;
  seeding.seed_depth = seed_depth;
  seeding.max_length_px = options.max_length_px;
  seeding.min_length_px = options.min_length_px;
  auto accept = [&](std::int32_t, const Vec3&, double intensity, int level) {
    if (intensity > options.intensity_threshold) return false;
    return !(options.adaptive_depth &&
             level > density_depth(intensity, side, options.stroke_width_px));
  };
  detail::seed_and_trace(surface, trace_field, tracer, projector, depth, grid, seeding, accept,
                         result);
  return result;
}

}  // namespace fabrica::hatching
