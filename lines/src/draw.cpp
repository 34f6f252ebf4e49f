#include "fabrica/lines/draw.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/core/heap.hpp"

namespace fabrica {

std::vector<LineFamily> thresholded_families() {
  return {LineFamily::suggestive, LineFamily::highlight,  LineFamily::ridge,
          LineFamily::valley,     LineFamily::apparent,   LineFamily::pel,
          LineFamily::laplacian,  LineFamily::demarcating};
}

const double* family_threshold(const LineOptions& o, LineFamily family) {
  switch (family) {
    case LineFamily::suggestive:
      return &o.suggestive.threshold;
    case LineFamily::highlight:
      return &o.highlight.threshold;
    case LineFamily::ridge:
      return &o.ridge.threshold;
    case LineFamily::valley:
      return &o.valley.threshold;
    case LineFamily::apparent:
      return &o.apparent.threshold;
    case LineFamily::pel:
      return &o.pel.threshold;
    case LineFamily::laplacian:
      return &o.laplacian.threshold;
    case LineFamily::demarcating:
      return &o.demarcating.threshold;
    default:
      return nullptr;
  }
}

double* family_threshold(LineOptions& o, LineFamily family) {
  return const_cast<double*>(family_threshold(static_cast<const LineOptions&>(o), family));
}

void validate(const DrawLinesOptions& options) {
  const LineOptions& o = options.lines;
  for (LineFamily f : thresholded_families()) {
    const double t = *family_threshold(o, f);
    if (!(t >= 0.0 && std::isfinite(t)))
      throw InputError(std::string("--") + family_name(f) +
                       "-threshold must be a non-negative number");
  }
  if (o.feature_size < 0.0 || !std::isfinite(o.feature_size))
    throw InputError("--feature-size must be a positive length in mesh units");
  if (options.smooth < 0) throw InputError("--smooth must be >= 0 (iterations; 0 = off)");
  if (!(options.min_length_px >= 0.0) || !std::isfinite(options.min_length_px))
    throw InputError("--min-length must be a non-negative number of pixels");
}

std::size_t LineDrawing::segment_count() const {
  std::size_t n = 0;
  for (const auto& [family, count] : segments) n += count;
  return n;
}

std::pair<std::size_t, std::size_t> LineDrawing::visible_vertices() const {
  std::size_t visible = 0, total = 0;
  for (const auto& p : lines.polylines)
    for (const auto& v : p.vertices) visible += v.visible, ++total;
  return {total, visible};
}

LineDrawer::LineDrawer(const Surface& surface, DrawLinesOptions options)
    : surface_(&surface),
      options_((validate(options), std::move(options))),
      extractor_(surface, options_.lines) {}

void LineDrawer::set_options(DrawLinesOptions options) {
  validate(options);
  options_ = std::move(options);
  extractor_.set_options(options_.lines);
}

namespace {

// Chaining of one view's segment soups; the soups (the view's largest
// arrays: ~150 B a segment) are freed once chained, before smoothing and the
// depth raster allocate theirs, so the two do not add up in the peak memory.
// One at a time (`one_by_one`, one drawing): each soup chained (a parallel
// loop) and freed before the next, so that no two soups' chaining scratch
// is alive at once and the chained lines take the memory of the soups
// before them; the same lines (chain_segments(soups) chains each soup on
// its own and concatenates the results in soup order).
LineDrawing chain_soups(std::vector<SegmentSoup>&& soups, double feature_size, const Camera& camera,
                        const DrawLinesOptions& options, bool one_by_one = false) {
  std::vector<SegmentSoup> view = std::move(soups);
  LineDrawing drawing;
  drawing.feature_size = feature_size;
  for (const auto& s : view) drawing.segments.emplace_back(s.family, s.segments.size());
  ChainOptions chain;
  chain.camera = camera;
  chain.min_length_px = options.min_length_px;
  if (!one_by_one) {
    drawing.lines = chain_segments(view, chain);
    return drawing;
  }
  std::vector<std::vector<Polyline>> parts(view.size());
  std::size_t total = 0;
  for (std::size_t i = 0; i < view.size(); ++i) {
    parts[i] = chain_segments(view[i], chain);
    total += parts[i].size();
    std::vector<LineSegment>().swap(view[i].segments);
  }
  drawing.lines.polylines.reserve(total);
  for (auto& part : parts)
    for (auto& pl : part) drawing.lines.polylines.push_back(std::move(pl));
  return drawing;
}

// Smoothing (on the surface, before visibility tests the positions) and
// hidden-line removal of a chained drawing.
void smooth_and_hide(LineDrawing& drawing, const Surface& surface, const Camera& camera,
                     const DrawLinesOptions& options, const DepthBuffer* depth) {
  if (options.smooth > 0) {
    LineSmoothingOptions so;
    so.iterations = options.smooth;
    smooth_lines(drawing.lines, surface, so);  // polylines it cannot smooth stay as they are
  }
  if (options.visibility)
    compute_visibility(drawing.lines, surface, camera, options.visibility_options, depth);
}

}  // namespace

LineDrawing LineDrawer::draw(const Camera& camera, const DepthBuffer* depth) {
  LineDrawing drawing =
      chain_soups(extractor_.extract(camera), extractor_.feature_size(), camera, options_);
  smooth_and_hide(drawing, *surface_, camera, options_, depth);
  return drawing;
}

LineDrawing draw_lines(const Surface& surface, const Camera& camera,
                       const DrawLinesOptions& options) {
  // One drawing, so nothing is kept for a next view, and the three phases'
  // working memory is not alive at once (docs/PERFORMANCE.md, peak memory):
  // the extractor (line precompute, view fields, about half the peak on
  // igea) is freed once the segments are extracted; only then is the depth
  // buffer rendered (its raster scratch, projected corners and binned
  // triangles, ~3x the buffer, in the memory it left), and the soups are
  // freed once chained, so neither the buffer nor the scratch adds to the
  // extraction's peak.
  validate(options);
  // The face normals and areas that the Surface computes for the curvature
  // fits are not kept (asked before the extractor computes the curvature:
  // the fits then read float copies, and the doubles are freed before
  // them), unless a family of this drawing reads them (creases, mesh-edge
  // contours, and the gradient operator of PELs and Laplacian lines),
  // which would compute them again.
  const auto& fam = options.lines.families;
  const auto has = [&](LineFamily f) { return std::find(fam.begin(), fam.end(), f) != fam.end(); };
  if (!has(LineFamily::crease) && !has(LineFamily::pel) && !has(LineFamily::laplacian) &&
      !(has(LineFamily::contour) && options.lines.contour.mesh_edges))
    surface.release_face_quantities();
  // Built first, so that bad options are reported before anything is
  // computed, as LineDrawer does (its precompute is filled on extraction).
  auto extractor = std::make_unique<LineExtractor>(surface, options.lines);
  extractor->set_one_shot(true);  // its per-view inputs freed as each pass is through
  // The families whose view fields read the curvature derivatives: these
  // are computed now, so that the curvature fits' scratch (~45 bytes per
  // corner) and the face quantities are freed before the depth raster and
  // the view fields allocate theirs (the same values as computed later).
  for (LineFamily f :
       {LineFamily::contour, LineFamily::ridge, LineFamily::valley, LineFamily::demarcating,
        LineFamily::suggestive, LineFamily::highlight, LineFamily::apparent})
    if (has(f)) {
      (void)surface.curvature_derivatives();
      break;
    }
  const double feature_size = extractor->feature_size();
  std::vector<SegmentSoup> soups = extractor->extract(camera);
  extractor.reset();
  // The soups as long as their segments (their chunked growth left ~40 %
  // unused on igea), then the freed pages of the view fields and the
  // extraction's scratch back to the system: the raster below would reuse
  // only part of them.
  for (auto& soup : soups) soup.segments.shrink_to_fit();
  return_free_heap_pages();
  // The depth raster before chaining: its buffer and scratch (corners,
  // binned triangles: ~15 MB on igea) go in the large holes the view fields
  // left, which the chained lines' many small blocks would break up (after
  // chaining the raster grew the heap by ~5 MB; docs/PERFORMANCE.md).
  DepthBuffer depth;
  if (options.visibility) {
    validate_camera(camera);  // (the extraction did; not when it has no family)
    render_depth(surface.mesh(), camera, depth);
    depth.scratch = detail::RasterScratchSlot();
    return_free_heap_pages();  // (its scratch)
  }
  LineDrawing drawing = chain_soups(std::move(soups), feature_size, camera, options, true);
  smooth_and_hide(drawing, surface, camera, options, options.visibility ? &depth : nullptr);
  return drawing;
}

nlohmann::json drawing_header(const LineDrawing& drawing, const Surface& surface,
                              const Camera& camera, const DrawLinesOptions& options) {
  const LineOptions& opt = options.lines;
  nlohmann::json counts = nlohmann::json::object(), types = nlohmann::json::array();
  for (const auto& [family, count] : drawing.segments) {
    counts[family_name(family)] = count;
    types.push_back(family_name(family));
  }
  nlohmann::json header = camera_to_json(camera);
  header["nv"] = surface.vertex_count();
  header["nf"] = surface.face_count();
  header["feature_size"] = drawing.feature_size;
  nlohmann::json& thresholds = header["thresholds"] = nlohmann::json::object();
  for (LineFamily f : thresholded_families())
    thresholds[family_name(f)] = *family_threshold(opt, f);
  thresholds["crease_angle_deg"] = opt.crease.angle_deg;
  header["types"] = types;
  header["segments"] = counts;
  header["visibility"] = options.visibility;
  if (options.smooth > 0) header["smooth"] = options.smooth;
  return header;
}

}  // namespace fabrica
