// One call for a line drawing (issue 16): extract the requested families for
// a camera, chain them into polylines, optionally smooth them on the surface,
// and remove hidden lines. `fabrica lines`, `render`, `hatch --with-lines`,
// the viewer, the batch runner and the Python module all draw lines through
// this, so the same options give the same lines everywhere.
//
//   fabrica::Surface surface = fabrica::to_surface(fabrica::prepare_mesh("veins.stl"));
//   fabrica::DrawLinesOptions options;
//   options.lines.families = {fabrica::LineFamily::contour, fabrica::LineFamily::apparent};
//   const fabrica::LineDrawing drawing = fabrica::draw_lines(surface, camera, options);
//   fabrica::write_svg("out.svg", drawing.lines, camera);
//
// For many cameras over one surface (an orbit, the viewer, a batch of views)
// keep a LineDrawer: it holds the view-independent precomputation
// (LineExtractor) and recomputes only what depends on the view.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/lines/smooth.hpp"
#include "fabrica/lines/visibility.hpp"

namespace fabrica {

struct DrawLinesOptions {
  /// Families (in output order), thresholds, feature size, light.
  LineOptions lines;
  /// Drop chains whose projected length is below this many pixels
  /// (`fabrica lines` uses 3, and 0 for .seg output).
  double min_length_px = 3.0;
  /// Smoothing iterations on the surface before visibility (0 = off).
  int smooth = 0;
  /// Hidden-line removal against the surface's CPU depth buffer; off keeps
  /// every vertex marked visible (the renderer tests depth on the GPU).
  bool visibility = true;
  VisibilityOptions visibility_options;
};

/// The families that have a dimensionless threshold (suggestive, highlight,
/// ridge, valley, apparent, pel, laplacian, demarcating), in that order.
std::vector<LineFamily> thresholded_families();
/// The threshold of `family` in `options` (`--<family>-threshold`); nullptr
/// for a family without one.
double* family_threshold(LineOptions& options, LineFamily family);
const double* family_threshold(const LineOptions& options, LineFamily family);

/// Throws InputError with the CLI's one-line message when an option is out
/// of range (negative or non-finite threshold, feature size, min length,
/// negative smoothing).
void validate(const DrawLinesOptions& options);

struct LineDrawing {
  /// Chained polylines (in family order), smoothed and with visibility.
  LineSet lines;
  /// Raw segments extracted per family, in the requested order.
  std::vector<std::pair<LineFamily, std::size_t>> segments;
  /// The feature size the thresholds were scaled by (mm).
  double feature_size = 0.0;

  std::size_t segment_count() const;
  /// Vertices of all polylines, and of these the visible ones.
  std::pair<std::size_t, std::size_t> visible_vertices() const;
};

/// Keeps the view-independent work for one surface; draw() per camera.
class LineDrawer {
 public:
  /// Validates `options` (InputError). `surface` must outlive the drawer.
  LineDrawer(const Surface& surface, DrawLinesOptions options = {});
  const DrawLinesOptions& options() const { return options_; }
  /// Changes families, thresholds, smoothing or visibility (validated;
  /// InputError) keeping the view-independent precomputation.
  void set_options(DrawLinesOptions options);
  const Surface& surface() const { return *surface_; }
  double feature_size() const { return extractor_.feature_size(); }
  /// `depth`, when given, is the depth buffer visibility tests against
  /// instead of the surface's own (e.g. a scene of several surfaces).
  LineDrawing draw(const Camera& camera, const DepthBuffer* depth = nullptr);

 private:
  const Surface* surface_;
  DrawLinesOptions options_;
  LineExtractor extractor_;
};

/// One drawing: the same as LineDrawer(surface, options).draw(camera), with
/// less memory at the peak (nothing is kept for a next view: the depth
/// raster's scratch and the extractor are freed as soon as they are done).
LineDrawing draw_lines(const Surface& surface, const Camera& camera,
                       const DrawLinesOptions& options = {});

/// What `fabrica lines` records beside the lines (.json and .seg headers):
/// the camera, vertex and face counts, feature size, thresholds, families,
/// segment counts per family, visibility and smoothing.
nlohmann::json drawing_header(const LineDrawing& drawing, const Surface& surface,
                              const Camera& camera, const DrawLinesOptions& options);

}  // namespace fabrica
