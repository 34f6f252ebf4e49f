// The one place where the viewer turns a structure and a camera into the
// lines the renderer draws: through the structure's fabrica::LineDrawer with
// render::structure_line_options, the options `fabrica render` and the batch
// runner draw with (object-space families without the apparent ridges when
// the GPU draws them, chains of at least 3 pixels, the style's smoothing).
#pragma once

#include <optional>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/render/scene.hpp"
#include "lines_worker.hpp"

namespace fabrica::viewer {

/// Lines of one structure for one camera. `drawer` holds the structure's
/// view-independent precomputation (built once per mesh by the loader) and
/// is re-optioned here when the families, thresholds or smoothing change.
/// `apparent_min_ndotv`: ApparentOptions::min_ndotv (moving_apparent_min_ndotv).
LineSet structure_lines(LineDrawer& drawer, const render::StructureStyle& style,
                        const LineOptions& thresholds, const Camera& camera,
                        std::optional<double> apparent_min_ndotv = {});

/// While the camera moves, the apparent ridges of a structure that hides
/// its own back are looked for only where n·v >= this
/// (ApparentOptions::min_ndotv): faces turned further away lie behind its
/// front, so their lines would be drawn only to fail the depth test (on
/// the igea seen from the front, 39 % of the merged apparent-ridge
/// vertices lay on faces with n·v < -0.2).
constexpr double kMovingApparentMinNdotv = -0.2;

/// kMovingApparentMinNdotv where a structure hides its own back from
/// `camera`: opaque, the focus (context may be clipped or cut open), `mesh` closed with outward
/// faces, hidden lines omitted, and the mesh's bounding sphere wholly
/// beyond the eye and the near plane; nullopt otherwise (and for the still
/// frames: their lines are the exported ones).
std::optional<double> moving_apparent_min_ndotv(const render::RenderMesh& mesh, render::Role role,
                                                const render::StructureStyle& style,
                                                const Camera& camera);

/// Fewer vertices for drawing while the camera moves: every polyline keeps
/// its first and last vertex and those needed so that its picture under
/// `camera` stays within `tolerance_px` pixels of the original (a vertex is
/// dropped where it lies within that distance of the segment joining the
/// vertices kept around it, and its strength within `strength_tolerance` of
/// the value interpolated there). Polylines are never joined; vertices not
/// in front of the eye are kept with their neighbours. Closed polylines stay
/// closed with at least 3 vertices. `edge_faces` is cleared where vertices
/// go. Returns the number of vertices removed.
std::size_t merge_collinear(LineSet& lines, const Camera& camera, double tolerance_px,
                            double strength_tolerance);

/// While the camera moves an opaque structure is drawn from its coarsest
/// level whose mean edge is at most this many pixels long at the mesh's
/// centre (the full mesh when no level is that fine; moving_level). A
/// chord of 7 px strays 49 / (8 r) px from an outline of radius r px
/// (0.03 px at r = 200): the outline stays smooth, and the chain of levels
/// halving the faces puts the chosen one's edges between 4.9 and 7 px.
constexpr double kMovingEdgePx = 7.0;

/// The level an opaque structure is drawn with (and its lines extracted
/// from) while the camera moves: the index of the coarsest of `levels`
/// whose mean edge length, seen at the distance of `full`'s centre by
/// `camera`, is at most kMovingEdgePx pixels; -1 (the full mesh) when none
/// is, or when the eye is within the mesh's bounding sphere.
int moving_level(const render::RenderMesh& full, const std::vector<MovingLevel>& levels,
                 const Camera& camera);

/// Shading strokes of one structure for one camera (fabrica::hatching,
/// "Suggestive Hatching"), as a layer drawn under its lines; as
/// `fabrica hatch`, strokes are `width` reference pixels wide, untapered.
render::PolylineLayer structure_hatching(const Surface& surface, const Camera& camera,
                                         double width);

}  // namespace fabrica::viewer
