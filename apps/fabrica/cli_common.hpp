// Option parsing shared by the drawing commands (lines, render, hatch), so
// every command accepts the same spellings and reports the same errors.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/prepare.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/line_set.hpp"
#if __has_include("fabrica/render/renderer.hpp")
#include "fabrica/render/context.hpp"
#include "fabrica/render/draw.hpp"
#include "fabrica/render/renderer.hpp"
#endif

namespace CLI {
class App;
}

namespace fabrica::cli {

/// ASCII lower case (option values are case-insensitive).
std::string lower(std::string s);

/// "WIDTHxHEIGHT" in pixels, each between 1 and max_pixels; throws
/// InputError naming `option` otherwise.
std::pair<int, int> parse_size(const std::string& text, int max_pixels = 16384,
                               const std::string& option = "--size");

/// "lps" or "ras" (any case) for --space; throws InputError otherwise.
Space parse_space(const std::string& text, const std::string& option = "--space");

/// A comma-separated list of line family names (docs/lines/), or a keyword:
/// "default" (= default_set), "reference"/"rtsc" (the families of the rtsc
/// reference files), "all", and "none" when allow_none. Duplicates are
/// dropped, order is kept. Throws InputError naming `option` for an unknown
/// name, or for an empty list unless allow_none.
std::vector<LineFamily> parse_family_list(const std::string& text, const std::string& option,
                                          const std::vector<LineFamily>& default_set,
                                          bool allow_none);

/// An anatomical view name (any case) for --view; throws InputError naming
/// `option`, the known views and the closest one ("did you mean").
AnatomicalView parse_view(const std::string& text, const std::string& option = "--view");

/// One line on stderr when a mesh (read with `source`) had no coordinate-space tag and LPS was
/// assumed (the anatomical views depend on it): "fabrica COMMAND: warning:
/// PATH has no space tag: assumed LPS ...". Nothing when quiet.
void warn_if_space_assumed(SpaceSource source, const std::string& path, const std::string& command,
                           bool quiet = false);

/// After a command-line parse error: "did you mean" for an unknown command
/// (argv[1]) or the first unknown --option of the chosen command, e.g.
/// "unknown option '--veiw' (did you mean '--view'?)"; "" when nothing is close.
std::string parse_error_hint(CLI::App& app, int argc, char** argv);

/// A mesh as the drawing commands use it: fabrica::prepare_mesh's result
/// wrapped in a Surface whose lazily computed geometry (normals, curvature,
/// ...) is kept with it.
struct LoadedSurface {
  std::shared_ptr<const Surface> surface;
  io::MeshFileInfo info;
  std::vector<std::string> messages;  ///< PreparedMesh::messages(): what preparation changed

  /// fabrica::draw_lines(*surface, camera, options), or, once
  /// keep_line_drawers(true) was called (`fabrica batch`), the same drawing
  /// (the same bits) through a LineDrawer kept with this surface, so that the
  /// view-independent line precompute is made once for all the views and
  /// styles of an input instead of once per item. Throws what draw_lines throws.
  LineDrawing draw_lines(const Camera& camera, const DrawLinesOptions& options) const;

 private:
  mutable std::mutex drawer_mutex_;
  mutable std::unique_ptr<LineDrawer> drawer_;
};

/// Whether LoadedSurface::draw_lines keeps a LineDrawer per loaded surface:
/// for a process that draws many views of the same meshes (`fabrica batch`),
/// at the price of the precompute's memory (~half the peak of one drawing)
/// held as long as the mesh is cached. Off by default (one drawing, least memory).
void keep_line_drawers(bool keep);

/// fabrica::prepare_mesh(path, options) as a Surface, or the one made by an
/// earlier call with the same file (same path, size and modification time)
/// and the same options, so that `fabrica batch` reads and precomputes an
/// input once per worker for all its views and styles. The process keeps at
/// most two meshes, both of the last input read (for a scene, loaded with
/// load_scene_surfaces, two per structure of that scene), so memory stays flat.
/// Throws what prepare_mesh throws.
std::shared_ptr<const LoadedSurface> load_prepared_surface(const std::filesystem::path& path,
                                                           const PrepareOptions& options);

/// A view framed for a width × height picture (e.g. anatomical_camera of a
/// mesh's box, render::view_camera of a scene).
using ViewFramer = std::function<Camera(AnatomicalView view, int width, int height)>;

struct ChosenCamera {
  Camera camera;
  std::string what;        ///< for messages: the camera file, "--view NAME", ...
  bool from_view = false;  ///< framed from an anatomical view (depends on the space)
};

/// How every drawing command (lines, render, hatch; a mesh or a scene) turns
/// --camera FILE, --view NAME and --size WxH into its camera (docs/cli.md,
/// "Cameras and sizes"): a camera file, or else `given` (a scene's own
/// camera) when no --view is named, keeps its framing and takes --size when
/// given; a view (--view, else `default_view`) is framed by `frame` at the
/// requested size (--size, else `default_size`), so its framing fits that
/// aspect ratio. Validated (InputError naming what is wrong).
ChosenCamera choose_camera(const std::string& camera_file, const std::string& view,
                           const std::string& size, std::pair<int, int> default_size,
                           const ViewFramer& frame, const std::optional<Camera>& given = {},
                           const std::string& given_what = {},
                           const std::string& default_view = "anterior");

/// True for an input the drawing commands read as a scene (a .json file).
bool is_scene_file(const std::filesystem::path& path);

#if __has_include("fabrica/render/renderer.hpp")
/// The scene's meshes prepared as render::load_scene does, through
/// load_prepared_surface (so `fabrica batch` reuses them between items: the
/// scene's meshes are cached together as one input).
render::SceneSurfaces load_scene_surfaces(render::SceneSpec spec);

/// choose_camera for a scene read from `input`: its own camera when no
/// --camera or --view is given, else its view (default anterior) framed by
/// render::view_camera with `frame`.
ChosenCamera choose_scene_camera(const render::SceneSurfaces& scene, render::Frame frame,
                                 const std::string& camera_file, const std::string& view,
                                 const std::string& size, std::pair<int, int> default_size,
                                 const std::string& input);

/// --frame focus|all (empty: the scene's, else render::default_frame).
render::Frame frame_option(const std::string& text, const render::SceneSpec& spec);

/// A headless renderer for `options`: a new one (its GL context ends with
/// it), or, once keep_headless_renderer(true) was called (a `fabrica batch`
/// worker), the process's one, created at first use and kept between items:
/// one GL context per worker. Throws what render::create_headless_context throws.
std::shared_ptr<render::Renderer> headless_renderer(const render::HeadlessOptions& options);
/// Turns keeping on or off; off also lets go of the kept renderer.
void keep_headless_renderer(bool keep);
#endif

/// The allocator keeps freed blocks of up to 32 MiB for reuse instead of
/// handing them back to the system and faulting in fresh zeroed pages for
/// the next use (glibc's mallopt; nothing elsewhere). The `fabrica`
/// program: the next phase's arrays (~8 % less CPU for `fabrica lines` on a
/// 270k-face mesh, same peak memory); the viewer: every frame's line
/// vertices and GL buffers. Only where a program, not the library, decides
/// it (docs/library.md, "The allocator").
void keep_freed_memory_for_reuse();

}  // namespace fabrica::cli
