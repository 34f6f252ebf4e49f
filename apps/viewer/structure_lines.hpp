// The one place where the viewer turns a structure and a camera into the
// lines the renderer draws (the same steps as `fabrica render`: object-space
// families without the apparent ridges when the GPU draws them, chained with
// a 3-pixel minimum, smoothed on the surface when asked). When the one-call
// pipeline of the library (fabrica::draw_lines) lands, this is the function
// to replace.
#pragma once

#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::viewer {

/// The families extracted on the CPU: the style's, less apparent ridges
/// when the style draws them by the hybrid GPU method.
std::vector<LineFamily> object_space_families(const render::StructureStyle& style);

/// Lines of one structure for one camera. `extractor` holds the structure's
/// view-independent precomputation (built once per mesh) and is re-optioned
/// here when the families or thresholds change.
LineSet structure_lines(LineExtractor& extractor, const Surface& surface,
                        const render::StructureStyle& style, const LineOptions& thresholds,
                        const Camera& camera);

/// Shading strokes of one structure for one camera (fabrica::hatching,
/// "Suggestive Hatching"), as a layer drawn under its lines; as
/// `fabrica hatch`, strokes are `width` reference pixels wide, untapered.
render::PolylineLayer structure_hatching(const Surface& surface, const Camera& camera,
                                         double width);

}  // namespace fabrica::viewer
