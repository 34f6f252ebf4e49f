#include "structure_lines.hpp"

#include <algorithm>

#include "fabrica/hatching/hatching.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/smooth.hpp"

namespace fabrica::viewer {

std::vector<LineFamily> object_space_families(const render::StructureStyle& style) {
  std::vector<LineFamily> families = style.families;
  if (style.hybrid_apparent_ridges)
    families.erase(std::remove(families.begin(), families.end(), LineFamily::apparent),
                   families.end());
  return families;
}

LineSet structure_lines(LineExtractor& extractor, const Surface& surface,
                        const render::StructureStyle& style, const LineOptions& thresholds,
                        const Camera& camera) {
  LineOptions options = thresholds;
  options.families = object_space_families(style);
  if (options.families.empty()) return {};
  extractor.set_options(options);
  ChainOptions chain;
  chain.camera = camera;
  chain.min_length_px = 3.0;
  LineSet lines = chain_segments(extractor.extract(camera), chain);
  if (style.smooth > 0) {
    LineSmoothingOptions smoothing;
    smoothing.iterations = style.smooth;
    smooth_lines(lines, surface, smoothing);
  }
  return lines;
}

render::PolylineLayer structure_hatching(const Surface& surface, const Camera& camera,
                                         double width) {
  hatching::HatchingOptions options;
  options.stroke_width_px = width;
  const hatching::StrokeSet strokes = hatching::hatch(surface, camera, options);
  render::PolylineLayer layer;
  layer.name = "hatching";
  layer.style.width = width;
  layer.style.contour_width_factor = 1.0;
  layer.style.taper = 0.0;
  layer.style.fade_by_strength = false;
  for (const hatching::Stroke& stroke : strokes.strokes) {
    std::vector<Vec3> points;
    points.reserve(stroke.vertices.size());
    for (const hatching::StrokeVertex& v : stroke.vertices) points.push_back(v.position);
    layer.polylines.push_back(std::move(points));
  }
  return layer;
}

}  // namespace fabrica::viewer
