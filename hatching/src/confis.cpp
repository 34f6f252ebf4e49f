// ConFIS streamlines; see confis.hpp and docs/algorithms.md §9a.
#include "fabrica/hatching/confis.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/projector.hpp"
#include "fabrica/hatching/proximity_grid.hpp"
#include "stroke_tracer.hpp"

namespace fabrica::hatching {

void validate(const ConfisOptions& o) {
  auto bad = [](const std::string& what) { throw InputError("confis: " + what); };
  if (!(o.contour_margin > 0.0 && o.contour_margin <= 1.0))
    bad("the contour margin (epsilon on n.v) must be in (0, 1]");
  if (!o.contours && !o.features) bad("draw contours, features or both");
  validate(o.feature_regions);
  validate(o.field);
  if (!(o.spacing_px > 0.0) || !std::isfinite(o.spacing_px))
    bad("the streamline spacing must be a positive number of pixels");
  if (!(o.min_length_px >= 0.0) || !std::isfinite(o.min_length_px))
    bad("the minimum length must be >= 0 pixels");
  if (!(o.max_length_px >= 0.0) || !std::isfinite(o.max_length_px))
    bad("the maximum length must be >= 0 pixels (0 = no limit)");
  if (!(o.stroke_width_px > 0.0) || !std::isfinite(o.stroke_width_px))
    bad("the stroke width must be positive");
  if (!(o.min_weight >= 0.0 && o.min_weight <= 1.0)) bad("the minimum weight must be in [0, 1]");
  if (!(o.sample_spacing_px > 0.0) || !std::isfinite(o.sample_spacing_px))
    bad("the sample spacing must be positive");
  if (!(o.occlusion_tolerance >= 0.0)) bad("the occlusion tolerance must be >= 0");
}

int confis_spacing_level(double image_side, double spacing_px) {
  const double d = 2.0 * std::log2(image_side / spacing_px);
  if (!(d > 0.0)) return 0;
  return static_cast<int>(std::lround(std::min(d, 38.0)));
}

ConfisPrecompute precompute_confis(const Surface& surface, const ConfisOptions& options) {
  validate(options);
  ConfisPrecompute pre;
  pre.field = compute_curvature_field(surface, options.field);
  pre.regions =
      compute_feature_regions(surface, options.feature_regions, options.field.umbilic_threshold);
  return pre;
}

StrokeSet confis(const Surface& surface, const Camera& camera, const ConfisOptions& options) {
  validate_camera(camera, "confis camera");
  return confis(surface, camera, precompute_confis(surface, options), options);
}

StrokeSet confis(const Surface& surface, const Camera& camera, const ConfisPrecompute& pre,
                 const ConfisOptions& options) {
  validate_camera(camera, "confis camera");
  validate(options);
  if (pre.field.face_direction.size() != surface.face_count() ||
      pre.regions.level.size() != surface.vertex_count())
    throw InputError("confis: the precompute does not match the mesh (made for another surface)");

  StrokeSet result;
  result.width = camera.width;
  result.height = camera.height;
  const double side = std::max(camera.width, camera.height);
  int spacing_level = confis_spacing_level(side, options.spacing_px);
  // Marks are kept to spacing level + 4; stay within the grid's memory bound.
  while (spacing_level > 0 &&
         ProximityGrid::cell_count(camera.width, camera.height, spacing_level + 2) >
             ProximityGrid::kMaxCells)
    --spacing_level;
  result.grid_depth = spacing_level + 2;
  result.seed_depth = spacing_level;
  const std::size_t nv = surface.vertex_count();
  if (surface.face_count() == 0) return result;

  // Per view: the contour margin as a region function (ε − n·v ≥ 0 inside;
  // n·v ≥ 0 is the tracer's back-face stop) and its strength.
  const ContourMargin margin = compute_contour_margin(surface, camera, options.contour_margin);
  std::vector<double> margin_region(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v)
      margin_region[v] = options.contour_margin - margin.facing[v];
  });

  detail::TraceField field;
  field.face_direction = &pre.field.face_direction;
  field.line_field = true;
  field.value = &margin.facing;
  field.value_threshold = std::numeric_limits<double>::infinity();
  field.facing = &margin.facing;
  if (options.contours) field.regions.push_back(&margin_region);
  if (options.features) field.regions.push_back(&pre.regions.level);
  detail::TraceSettings settings;
  settings.sample_spacing_px = options.sample_spacing_px;
  settings.occlusion_tolerance_mm = options.occlusion_tolerance * surface.mean_edge_length();
  settings.adaptive = false;
  settings.stroke_width_px = options.stroke_width_px;
  settings.grid_depth = result.grid_depth;

  const Projector projector(camera);
  const DepthBuffer depth = render_depth(surface.mesh(), camera, /*faces=*/true);
  ProximityGrid grid(camera.width, camera.height, result.grid_depth);
  detail::Tracer tracer(surface, field, settings, projector, depth, grid);
  detail::SeedingSettings seeding;
  seeding.seed_depth = spacing_level;
  seeding.max_length_px = options.max_length_px;
  seeding.min_length_px = options.min_length_px;
  detail::seed_and_trace(
      surface, field, tracer, projector, depth, grid, seeding,
      [](std::int32_t, const Vec3&, double, int) { return true; }, result);

  // Style weights: how deep inside the masks each vertex is.
  for (Stroke& stroke : result.strokes)
    for (StrokeVertex& v : stroke.vertices) {
      double w = 0.0;
      if (options.contours)
        w = std::max(w, tracer.vertex_value(margin.strength, v.anchor.face, v.anchor.bary));
      if (options.features)
        w = std::max(w, tracer.vertex_value(pre.regions.strength, v.anchor.face, v.anchor.bary));
      v.weight = std::clamp(std::max(w, options.min_weight), 0.0, 1.0);
    }
  return result;
}

}  // namespace fabrica::hatching
