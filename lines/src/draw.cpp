#include "fabrica/lines/draw.hpp"

#include <cmath>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica {

namespace {
void check_threshold(double t, const char* name) {
  if (!(t >= 0.0 && std::isfinite(t)))
    throw InputError(std::string("--") + name + "-threshold must be a non-negative number");
}
}  // namespace

void validate(const DrawLinesOptions& options) {
  const LineOptions& o = options.lines;
  for (auto [t, n] : {std::pair{o.suggestive.threshold, "suggestive"},
                      {o.highlight.threshold, "highlight"},
                      {o.ridge.threshold, "ridge"},
                      {o.valley.threshold, "valley"},
                      {o.apparent.threshold, "apparent"},
                      {o.pel.threshold, "pel"},
                      {o.laplacian.threshold, "laplacian"},
                      {o.demarcating.threshold, "demarcating"}})
    check_threshold(t, n);
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

LineDrawing LineDrawer::draw(const Camera& camera, const DepthBuffer* depth) {
  const std::vector<SegmentSoup> soups = extractor_.extract(camera);
  LineDrawing drawing;
  drawing.feature_size = extractor_.feature_size();
  for (const auto& s : soups) drawing.segments.emplace_back(s.family, s.segments.size());
  ChainOptions chain;
  chain.camera = camera;
  chain.min_length_px = options_.min_length_px;
  drawing.lines = chain_segments(soups, chain);
  if (options_.smooth > 0) {  // on the surface, before visibility tests the positions
    LineSmoothingOptions so;
    so.iterations = options_.smooth;
    smooth_lines(drawing.lines, *surface_, so);  // polylines it cannot smooth stay as they are
  }
  if (options_.visibility)
    compute_visibility(drawing.lines, *surface_, camera, options_.visibility_options, depth);
  return drawing;
}

LineDrawing draw_lines(const Surface& surface, const Camera& camera,
                       const DrawLinesOptions& options) {
  return LineDrawer(surface, options).draw(camera);
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
  header["thresholds"] = {{"suggestive", opt.suggestive.threshold},
                          {"highlight", opt.highlight.threshold},
                          {"ridge", opt.ridge.threshold},
                          {"valley", opt.valley.threshold},
                          {"apparent", opt.apparent.threshold},
                          {"pel", opt.pel.threshold},
                          {"laplacian", opt.laplacian.threshold},
                          {"demarcating", opt.demarcating.threshold},
                          {"crease_angle_deg", opt.crease.angle_deg}};
  header["types"] = types;
  header["segments"] = counts;
  header["visibility"] = options.visibility;
  if (options.smooth > 0) header["smooth"] = options.smooth;
  return header;
}

}  // namespace fabrica
