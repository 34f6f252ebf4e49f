// Viewer: the state of a fabrica-viewer session (structures, camera, the
// loader and lines workers, the renderer on the window's GL context) and
// the frame loop. The script commands (script.cpp) and the ImGui panels
// (ui.cpp) both act through this class, so a scripted session and a
// clicked one do the same things.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/render/renderer.hpp"
#include "fabrica/render/window_context.hpp"
#include "lines_worker.hpp"
#include "loader.hpp"

namespace fabrica::viewer {

struct ViewerStructure {
  int id = 0;
  std::string name;
  std::filesystem::path mesh_file;  ///< empty for a label of a volume (written on save-scene)
  std::optional<Space> space;
  bool visible = true;
  render::Role role = render::Role::context;
  render::StructureStyle style;
  LineOptions thresholds;  ///< line thresholds (the scene JSON has no keys for them)
  bool hatching = false;   ///< shading strokes under the lines (not in scene JSON)
  double hatching_width = 1.0;
  std::shared_ptr<const Surface> surface;
  std::shared_ptr<const render::RenderMesh> mesh;            ///< without curvature
  std::shared_ptr<const render::RenderMesh> mesh_curvature;  ///< made when hybrid is on
  std::shared_ptr<LineSource> lines;
  std::shared_ptr<const render::RenderMesh> mesh_lod;  ///< see LoadedStructure
  std::shared_ptr<LineSource> lines_lod;
  std::vector<MovingLevel> moving_levels;  ///< see LoadedStructure
};

/// A point picked on a surface.
struct SurfacePick {
  int structure = -1;  ///< index into structures()
  Vec3 point = Vec3::Zero();
  double k1 = 0.0, k2 = 0.0;  ///< principal curvatures (1/mm), interpolated
};

/// The context's clipping plane (issue 18, item 4): off, facing the eye
/// (follows the camera), facing an anatomical side, or a fixed plane (read
/// from a scene). The plane passes through the focus's centre moved
/// `offset` mm along its normal; context on the normal's side is removed.
struct ClipSettings {
  enum class Mode { off, view, side, fixed };
  Mode mode = Mode::off;
  AnatomicalView side = AnatomicalView::anterior;
  double offset = 0.0;
  render::ClipPlane fixed;
};

struct FrameStats {
  std::uint64_t frame = 0;
  double ms_frame = 0.0, ms_gpu_submit = 0.0, ms_lines = 0.0;
  std::uint64_t lines_age = 0;
};

struct ViewerOptions {
  int width = 1280, height = 800;
  bool visible = true;
  /// Mouse input (orbit, pan, zoom, picking, hover); off in script mode.
  bool interactive = true;
  std::filesystem::path frame_log;
};

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& options);
  ~Viewer();

  // --- session
  void open(const std::filesystem::path& path);
  /// Draws frames until loading and lines are done.
  void wait();
  bool should_close() const;
  void request_close() { close_requested_ = true; }
  /// One frame: events, adopted loads, lines, the picture, the UI.
  void frame();

  // --- structures
  std::vector<ViewerStructure>& structures() { return structures_; }
  /// Index of the structure called `name`; throws InputError listing the names.
  std::size_t find(const std::string& name) const;
  /// Makes structure i the focus (the others become context).
  void focus(std::size_t i);
  void set_role(std::size_t i, render::Role role);
  /// Applies scene JSON keys (name, role, shading, color, opacity, lines, ...)
  /// to structure i; throws InputError for an unknown key or a bad value.
  void set_keys(std::size_t i, const nlohmann::json& keys);
  /// Call after editing a structure's style: lines and meshes follow.
  void style_changed() {
    lines_dirty_ = true;
    redraw_ = true;
  }

  // --- camera
  Camera& camera() { return camera_; }
  void set_camera(const Camera& camera);
  /// `animate`: the camera turns and moves there over 0.4 s (interactive
  /// use; scripts jump, so their frames are reproducible).
  void view(AnatomicalView view, bool animate = false);
  /// Keeps the direction, moves the eye so the focus (or everything) fills the view.
  void fit_to_selection(bool animate = false);
  /// Turns the eye about the view's up axis through the centre.
  void orbit(double degrees);
  /// True while an animated camera transition runs.
  bool transitioning() const { return to_.has_value(); }
  void camera_changed() { ++camera_revision_; }

  // --- clipping plane
  ClipSettings& clip() { return clip_; }
  /// The plane for the current camera, if clipping is on.
  std::optional<render::ClipPlane> clip_plane() const;
  /// `clip off`, `clip view [OFFSET]`, `clip SIDE [OFFSET]` (script and UI).
  void set_clip(ClipSettings::Mode mode, AnatomicalView side = AnatomicalView::anterior,
                double offset = 0.0);

  // --- cutaway (issue 18, item 4): the scene's "cutaway" (render::Cutaway)
  const render::Cutaway& cutaway() const { return cutaway_; }
  /// `cutaway on|off [MARGIN_PX [FADE_PX]]`, `cutaway KEY=VALUE...` (script)
  /// and the Structures panel; validated as the scene key is.
  void set_cutaway(const render::Cutaway& cutaway);

  // --- outputs
  render::Image screenshot(int width, int height, bool transparent);
  /// The lines of the current view, hidden lines removed, as SVG or PDF (by extension).
  void export_svg(const std::filesystem::path& path);
  /// Draws a frame and writes the window as shown (panels included) as PNG.
  void capture_window(const std::filesystem::path& path);
  void save_scene(const std::filesystem::path& path);
  /// The structure under pixel (x, y) of the window's view (GPU id buffer,
  /// then the exact point by a ray against that structure's triangles).
  std::optional<SurfacePick> pick(int x, int y);
  /// A click at pixel (x, y): focuses the structure there, or adds a
  /// measuring point in measure mode.
  void click_at(int x, int y);

  // --- state for the UI
  const std::vector<std::string>& errors() const { return errors_; }
  void report_error(const std::string& message);
  void clear_errors() { errors_.clear(); }
  const FrameStats& last_frame() const { return stats_; }
  Loader& loader() { return loader_; }
  std::vector<std::filesystem::path>& recent_files() { return recent_; }
  render::Color& background() { return background_; }
  bool& transparent() { return transparent_; }
  render::HybridOptions& hybrid() { return hybrid_; }
  std::vector<SurfacePick>& measure_points() { return measure_; }
  bool& measure_mode() { return measure_mode_; }
  std::optional<SurfacePick>& hover() { return hover_; }
  render::WindowContext& window() { return *window_; }
  /// Fraction of the window's resolution drawn while the camera moves
  /// (1 = full; the still picture is always full resolution).
  float& moving_scale() { return moving_scale_; }
  /// While the camera moves: ghosted structures drawn with their level of
  /// detail (a coarse copy of the mesh, and lines from it), opaque ones
  /// from the coarser copy whose triangles fit the pixels (moving_level;
  /// their lines from the full mesh), and every
  /// structure's lines with near-collinear vertices merged (within half a
  /// pixel); the still picture and every export use the full meshes and lines.
  bool& simplify_while_moving() { return simplify_while_moving_; }
  /// With simplify_while_moving: the opaque structures' lines, too, come
  /// from the coarse copy they are drawn with while the camera moves (off
  /// by default: fewer suggestive contours and ridges in motion, about
  /// half the CPU of a frame of the orbit benchmark).
  bool& coarse_lines_while_moving() { return coarse_lines_while_moving_; }

 private:
  BoundingBox scene_box(bool focus_only) const;
  /// True when the shown structures need lines for the current camera.
  bool lines_pending() const;
  Space scene_space() const;
  void adopt_loaded();
  /// Posts a lines job for `camera` when anything changed; returns its
  /// version. `lod`: ghosted structures' lines from their level of detail,
  /// opaque ones drawn from the level that fits the camera (moving_level),
  /// and all lines merged (LinesJob::merge_px), for a moving camera.
  std::uint64_t post_lines(const Camera& camera, bool force, bool lod = false);
  /// `fading`: opacities on their way after a role change (the window only;
  /// exports always draw the styles as they are).
  render::Scene build_scene(const std::shared_ptr<const LinesResult>& lines, bool fading = false,
                            bool share_lines = false);
  render::RenderOptions render_options(bool transparent) const;
  /// The window's picture (a texture and its framebuffer) at width x height.
  void ensure_picture(int width, int height);
  void write_frame_log();
  void handle_input();

  ViewerOptions options_;
  render::WindowContext* window_ = nullptr;  // owned by renderer_
  std::unique_ptr<render::Renderer> renderer_;
  Loader loader_;
  LinesWorker lines_worker_;
  std::vector<ViewerStructure> structures_;
  int next_id_ = 1;
  Camera camera_;
  bool camera_set_ = false;
  std::uint64_t camera_revision_ = 0, posted_revision_ = ~0ull;
  bool lines_dirty_ = true;
  std::uint64_t lines_version_ = 0;
  render::Color background_{1.0f, 1.0f, 1.0f, 1.0f};
  bool transparent_ = false;
  render::HybridOptions hybrid_;
  ClipSettings clip_;
  render::Cutaway cutaway_;
  std::vector<std::string> errors_;
  std::vector<std::filesystem::path> recent_;
  std::vector<SurfacePick> measure_;
  std::optional<SurfacePick> hover_;
  FrameStats stats_;
  std::ofstream frame_log_;
  unsigned int picture_fbo_ = 0, picture_ = 0;
  int picture_w_ = 0, picture_h_ = 0;
  bool has_picture_ = false;
  bool close_requested_ = false;
  bool redraw_ = true;
  std::pair<std::uint64_t, std::uint64_t> drawn_{0, 0};
  float moving_scale_ = 0.5f;
  bool simplify_while_moving_ = true;
  bool coarse_lines_while_moving_ = false;
  bool posted_lod_ = false;
  std::uint64_t last_frame_revision_ = 0;
  bool last_frame_moving_ = false;
  bool drawn_scaled_ = false;
  std::filesystem::path capture_;
  // camera transition (animated views)
  std::optional<Camera> from_, to_;
  std::chrono::steady_clock::time_point transition_start_;
  void start_transition(const Camera& target);
  // focus transition: opacity each structure starts from, by id
  std::map<int, double> fade_from_;
  std::chrono::steady_clock::time_point fade_start_;
  void step_transition();
  // mouse state for the arcball
  bool dragging_ = false;
  int drag_button_ = -1;
  double drag_x_ = 0, drag_y_ = 0, press_x_ = 0, press_y_ = 0;
  bool measure_mode_ = false;
  std::chrono::steady_clock::time_point last_hover_;
  double hover_x_ = -1, hover_y_ = -1;
};

}  // namespace fabrica::viewer
