// Annotation of a rendered scene (issue 17, item 5): structure labels with
// leader lines, a legend, a scale bar in mm and an orientation marker with
// the patient axes, computed once and drawn identically into the PNG
// (draw_annotation) and the SVG/PDF (as the vector overlay of
// write_scene_svg / write_scene_pdf). docs/rendering.md#annotation,
// docs/algorithms.md §13.
//
//   const auto note = fabrica::render::annotate_scene(scene, camera, spec.annotation);
//   fabrica::render::draw_annotation(picture.image, note.overlay);
//   fabrica::render::write_scene_svg("out.svg", scene, picture.scene, camera, 1024, &note.overlay);
#pragma once

#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/lines/writers.hpp"
#include "fabrica/render/draw.hpp"
#include "fabrica/render/image.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::render {

/// A structure's label as placed: the text, its anchor (a pixel where the
/// structure is what the picture shows, the deepest inside that region),
/// the leader from the anchor to the text's box, and the box (x, y, w, h).
struct PlacedLabel {
  std::size_t structure = 0;  ///< index in the scene
  std::string text;
  Vec2 anchor = Vec2::Zero();
  Vec2 leader_end = Vec2::Zero();
  double box[4] = {0, 0, 0, 0};
};

struct Annotation {
  VectorOverlay overlay;            ///< everything to draw, in order
  std::vector<PlacedLabel> labels;  ///< in placement order
  /// Labels that were asked for but not drawn, with the reason (not visible
  /// in this view; no free place outside the silhouettes).
  std::vector<std::string> skipped;
  double font_px = 0.0;               ///< the label font size in pixels
  double px_per_mm = 0.0;             ///< of the scale bar (0 when none)
  double scale_bar_mm = 0.0;          ///< its length in mm
  bool scale_at_focus_depth = false;  ///< perspective: exact at the focus depth only
};

/// Pixels per millimetre of `camera` for a length perpendicular to the
/// viewing axis at `depth` (mm in front of the eye; ignored when
/// orthographic).
double pixels_per_mm(const Camera& camera, double depth);

/// What each pixel of the picture shows: the index of the front-most opaque
/// structure there, or where none is, of the front-most ghosted one
/// (opacity < 1); -1 for the background. Row-major, camera.width × height.
std::vector<int> structure_map(const SceneSurfaces& scene, const Camera& camera);

/// The annotation `options` asks for (every part off: an empty overlay).
/// Sizes scale with the picture (font_size is in pixels at 1024 px).
Annotation annotate_scene(const SceneSurfaces& scene, const Camera& camera,
                          const AnnotationSpec& options);

/// Draws the overlay onto `image` (anti-aliased strokes, texts in fabrica's
/// stroke font), blending over its alpha.
void draw_annotation(Image& image, const VectorOverlay& overlay);

}  // namespace fabrica::render
