// The one place where the viewer turns a structure and a camera into the
// lines the renderer draws: through the structure's fabrica::LineDrawer with
// render::structure_line_options, the options `fabrica render` and the batch
// runner draw with (object-space families without the apparent ridges when
// the GPU draws them, chains of at least 3 pixels, the style's smoothing).
#pragma once

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::viewer {

/// Lines of one structure for one camera. `drawer` holds the structure's
/// view-independent precomputation (built once per mesh by the loader) and
/// is re-optioned here when the families, thresholds or smoothing change.
LineSet structure_lines(LineDrawer& drawer, const render::StructureStyle& style,
                        const LineOptions& thresholds, const Camera& camera);

/// Shading strokes of one structure for one camera (fabrica::hatching,
/// "Suggestive Hatching"), as a layer drawn under its lines; as
/// `fabrica hatch`, strokes are `width` reference pixels wide, untapered.
render::PolylineLayer structure_hatching(const Surface& surface, const Camera& camera,
                                         double width);

}  // namespace fabrica::viewer
