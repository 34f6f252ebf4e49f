// One call for a rendered illustration (issue 16): a scene description
// (focus and context structures with their styles) whose meshes are read and
// prepared once, feature lines drawn per structure through fabrica::draw_lines,
// and the picture made headless. `fabrica render`, the viewer's export, the
// batch runner and the Python module render through this.
//
//   auto scene = fabrica::render::load_scene(fabrica::render::read_scene_spec("s.json"));
//   const fabrica::Camera camera = fabrica::render::view_camera(scene,
//   fabrica::AnatomicalView::anterior); const auto picture = fabrica::render::render_scene(scene,
//   camera); fabrica::render::write_png(picture.image, "out.png");
#pragma once

#include <functional>

#include <memory>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/lines/writers.hpp"
#include "fabrica/render/context.hpp"
#include "fabrica/render/image.hpp"
#include "fabrica/render/renderer.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::render {

/// A scene description with its surfaces (one per spec.structures entry,
/// same order) and their common bounding box and space (the first mesh's).
struct SceneSurfaces {
  SceneSpec spec;
  std::vector<std::shared_ptr<const Surface>> surfaces;
  BoundingBox box;
  Space space = Space::lps;
  /// The focus structures' common bounding box (valid when has_focus).
  BoundingBox focus_box;
  bool has_focus = false;
  /// Mesh files read without a space tag (LPS assumed), for the CLI's warning.
  std::vector<std::string> assumed_space;

  /// Appends a structure whose surface is already in memory.
  void add(StructureSpec structure, std::shared_ptr<const Surface> surface);
};

/// Reads every structure's mesh (its `space` override applies) and prepares
/// it as fabrica::prepare_mesh does (oriented outward). InputError names the
/// file.
SceneSurfaces load_scene(SceneSpec spec);

/// The same with the surfaces made by `loader` (for example a cache that
/// reuses surfaces already prepared: `fabrica batch`). The loader must
/// prepare them as prepare_mesh does.
using SurfaceLoader = std::function<std::shared_ptr<const Surface>(const StructureSpec&)>;
SceneSurfaces load_scene(SceneSpec spec, const SurfaceLoader& loader);

/// The anatomical view of the whole scene (its bounding box and space), or,
/// with Frame::focus and a focus present, fitted to the focus structures
/// (render::fit_camera), framed for a width × height picture (the framing
/// depends on the aspect ratio: `--view` with `--size` frames at that size).
Camera view_camera(const SceneSurfaces& scene, AnatomicalView view, Frame frame = Frame::all,
                   int width = 1024, int height = 1024);

/// The families a structure's style draws on the CPU: its families less
/// apparent ridges when the hybrid GPU method draws them.
std::vector<LineFamily> object_space_families(const StructureStyle& style);

/// How `fabrica render`, the batch runner and the viewer draw a structure's
/// lines (fabrica::LineDrawer): the object-space families with the
/// thresholds of `thresholds`, chains of at least 3 pixels, the style's
/// smoothing, no CPU visibility (the renderer tests depth on the GPU).
DrawLinesOptions structure_line_options(const StructureStyle& style,
                                        const LineOptions& thresholds = {});

/// The scene the renderer draws: a render mesh per structure and its
/// chained feature lines for `camera` (object space, 3 px minimum length,
/// the style's smoothing; hybrid apparent ridges left to the GPU).
Scene build_scene(const SceneSurfaces& scene, const Camera& camera);

/// --backend egl|osmesa (empty: FABRICA_GL_BACKEND, else automatic);
/// InputError with the CLI's message for another name.
HeadlessOptions headless_options(const std::string& backend);

struct RenderedScene {
  Image image;      ///< RGBA, camera.width × camera.height
  Scene scene;      ///< what was drawn (with the lines)
  Backend backend;  ///< the GL backend that drew it
};

/// build_scene + Renderer::render on `renderer`.
RenderedScene render_scene(Renderer& renderer, const SceneSurfaces& scene, const Camera& camera,
                           const RenderOptions& options = {});
/// Renders a scene already built by build_scene (e.g. with hatching strokes
/// added as polyline layers: `fabrica hatch -o OUT.png`) on `renderer`.
RenderedScene render_scene(Renderer& renderer, Scene drawn, const Camera& camera,
                           const RenderOptions& options = {});
/// The same on a new headless context (Error(unavailable) when none).
RenderedScene render_scene(const SceneSurfaces& scene, const Camera& camera,
                           const RenderOptions& options = {}, const HeadlessOptions& headless = {});

/// The drawn scene's lines for vector output, with visibility computed on
/// the CPU: a focus (opaque) structure's lines are hidden by the opaque
/// structures, a ghosted one's by every surface.
LineSet vector_lines(const SceneSurfaces& scene, const Scene& drawn, const Camera& camera);

/// The drawn scene as vector layers, one per structure: context structures
/// first, then focus (drawn over them), each in scene order; its lines with
/// CPU visibility as vector_lines computes it; stroke colour, opacity, width,
/// contour factor, taper, strength fading and hidden lines (omit, dashed,
/// show) from the structure's LineStyle; role "focus" or "context".
/// `reference_size` is RenderOptions::line_reference_size.
std::vector<LineLayer> vector_layers(const SceneSurfaces& scene, const Scene& drawn,
                                     const Camera& camera, double reference_size = 1024.0);
/// fabrica::write_layered_svg / write_layered_pdf of vector_layers(), with
/// `overlay` (the annotation, render/annotate.hpp) over the structures.
void write_scene_svg(const std::filesystem::path& path, const SceneSurfaces& scene,
                     const Scene& drawn, const Camera& camera, double reference_size = 1024.0,
                     const VectorOverlay* overlay = nullptr);
void write_scene_pdf(const std::filesystem::path& path, const SceneSurfaces& scene,
                     const Scene& drawn, const Camera& camera, double reference_size = 1024.0,
                     const VectorOverlay* overlay = nullptr);

}  // namespace fabrica::render
