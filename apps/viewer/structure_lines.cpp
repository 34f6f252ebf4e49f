#include "structure_lines.hpp"

#include "fabrica/hatching/hatching.hpp"
#include "fabrica/render/draw.hpp"

namespace fabrica::viewer {

LineSet structure_lines(LineDrawer& drawer, const render::StructureStyle& style,
                        const LineOptions& thresholds, const Camera& camera) {
  const DrawLinesOptions options = render::structure_line_options(style, thresholds);
  if (options.lines.families.empty()) return {};
  drawer.set_options(options);
  return drawer.draw(camera).lines;
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
