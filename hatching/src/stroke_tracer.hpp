// The stroke tracer shared by shading hatching (hatching.cpp, §9) and ConFIS
// streamlines (confis.cpp, §9a): exact face-to-face tracing of a piecewise-
// constant direction field, sampled visibility / proximity / image / length
// tests, exact stops where a per-vertex linear quantity crosses a bound, and
// the coarse-to-fine seeding over the proximity grid's lattice points.
// Private to fabrica::hatching.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/projector.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/proximity_grid.hpp"
#include "fabrica/hatching/stroke_set.hpp"

namespace fabrica::hatching::detail {

/// What the tracer follows and where it must stop.
struct TraceField {
  /// Per face: the direction to follow (any length; zero = no direction).
  const std::vector<Vec3>* face_direction = nullptr;
  /// false: a vector field, followed as sign · direction; a neighbour whose
  /// direction points back across the edge is an extremum (shading).
  /// true: a line field; each face's sign is chosen to continue the current
  /// direction, and only a neighbour that still points back stops (ConFIS).
  bool line_field = false;
  /// Per vertex: the value stored in StrokeVertex::intensity; strokes stop
  /// where it exceeds `value_threshold` (exact); it also sets the proximity
  /// level when `adaptive` (the density rule of §9).
  const std::vector<double>* value = nullptr;
  double value_threshold = 1.0;
  /// Per vertex n·v: strokes stop where it becomes negative (exact).
  const std::vector<double>* facing = nullptr;
  /// Optional per-vertex region functions, linear over each face: a point
  /// is inside when ANY of them is >= 0; strokes stop where all are < 0
  /// (exact, StrokeEnd::region). Empty: everywhere is inside.
  std::vector<const std::vector<double>*> regions;
};

struct TraceSettings {
  double sample_spacing_px = 0.5;
  double occlusion_tolerance_mm = 0.0;
  bool adaptive = true;  ///< proximity level from the value (§9 density rule), else grid_depth
  double stroke_width_px = 1.0;
  int grid_depth = 0;  ///< truncation level (the deepest level when adaptive)
};

struct TraceState {
  std::int32_t face = -1;
  Vec3 bary = Vec3::Zero();
  Vec3 position = Vec3::Zero();
  Vec2 pixel = Vec2::Zero();
  double value = 0.0;
};

class Tracer {
 public:
  Tracer(const Surface& surface, const TraceField& field, const TraceSettings& settings,
         const Projector& projector, const DepthBuffer& depth, ProximityGrid& grid);

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
  /// Proximity level at a value (§9 density rule, or the fixed grid depth).
  int level_for(double value) const;
  /// Not hidden by a nearer surface in the depth buffer.
  bool visible(std::int32_t face, const Vec2& pixel, double depth) const;
  /// Inside the field's region (true when it has none).
  bool in_region(std::int32_t face, const Vec3& bary) const;
  StrokeVertex make_vertex(std::int32_t face, const Vec3& bary, const Vec3& x, const Vec2& pixel,
                           double value) const;
  /// Traces from `start` along sign · direction; appends the vertices after
  /// the start. `max_length` in pixels (0 = none); `length` accumulates.
  StrokeEnd trace(const TraceState& start, double sign, double max_length,
                  std::vector<StrokeVertex>& out, double& length) const;

 private:
  std::optional<StrokeEnd> check_sample(std::int32_t face, const Vec3& x, double value,
                                        Vec2& pixel) const;
  bool shares_vertex(std::int32_t a, std::int32_t b) const;

  const Surface& surface_;
  const TraceField& field_;
  TraceSettings settings_;
  const Projector& projector_;
  const DepthBuffer& depth_;
  ProximityGrid& grid_;
  const Topology& topology_;
  const std::vector<Vec3>& positions_;
  const std::vector<Face>& faces_;
  double side_;
};

struct SeedingSettings {
  int seed_depth = 0;
  double max_length_px = 0.0;  ///< whole stroke, half on each side of the seed (0 = none)
  double min_length_px = 1.0;
};

/// Levels 0..seed_depth coarse to fine, each level's new lattice points in
/// order: a point on the visible surface whose surface point passes `accept`
/// (face, bary, value there, level) and is not blocked at its level becomes a
/// seed; the stroke is traced both ways (−direction first), kept when at
/// least min_length_px long, marked into the grid and appended.
void seed_and_trace(const Surface& surface, const TraceField& field, Tracer& tracer,
                    const Projector& projector, const DepthBuffer& depth, ProximityGrid& grid,
                    const SeedingSettings& settings,
                    const std::function<bool(std::int32_t, const Vec3&, double, int)>& accept,
                    StrokeSet& result);

}  // namespace fabrica::hatching::detail
