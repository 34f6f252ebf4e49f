#include "viewer.hpp"

#define GLFW_INCLUDE_NONE  // GL types come from glcorearb.h (gl_functions.hpp)
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>

#include "fabrica/core/error.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/render/draw.hpp"
#include "structure_lines.hpp"
#include "ui.hpp"

namespace fabrica::viewer {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

/// While the camera moves the lines are drawn with their near-collinear
/// vertices merged (merge_collinear): within a pixel of the lines as
/// extracted, strengths within 0.1; the still picture has every vertex.
constexpr double kMovingMergePx = 1.0;
constexpr double kMovingMergeStrength = 0.1;

Viewer* g_viewer = nullptr;  // for the GLFW drop callback

void on_drop(GLFWwindow*, int count, const char** paths) {
  if (g_viewer == nullptr) return;
  for (int i = 0; i < count; ++i) g_viewer->open(paths[i]);
}

/// The unit ray through the centre of pixel (x, y) (y down).
std::pair<Vec3, Vec3> pixel_ray(const Camera& c, double x, double y) {
  const double ndc_x = 2.0 * (x + 0.5) / c.width - 1.0;
  const double ndc_y = 1.0 - 2.0 * (y + 0.5) / c.height;
  const double t = std::tan(c.fov_deg * M_PI / 360.0);
  if (c.projection == Projection::orthographic) {
    const double half_h = (c.center - c.eye).norm() * t;
    const Vec3 origin =
        c.eye + ndc_x * half_h * c.aspect() * c.right() + ndc_y * half_h * c.true_up();
    return {origin, c.forward()};
  }
  const Vec3 d = c.forward() + ndc_x * t * c.aspect() * c.right() + ndc_y * t * c.true_up();
  return {c.eye, d.normalized()};
}

/// The mesh structure `id` is drawn with when its lines came from a level
/// of detail (LinesResult::lod), else null.
std::shared_ptr<const render::RenderMesh> lod_mesh(const LinesResult* lines, int id) {
  if (lines == nullptr) return nullptr;
  const auto it = lines->lod.find(id);
  return it == lines->lod.end() ? nullptr : it->second;
}

}  // namespace

Viewer::Viewer(const ViewerOptions& options) : options_(options) {
  render::WindowOptions wo;
  wo.width = options.width;
  wo.height = options.height;
  wo.title = "fabrica-viewer";
  wo.visible = options.visible;
  wo.vsync = false;
  auto window = std::make_unique<render::WindowContext>(wo);
  window_ = window.get();
  renderer_ = std::make_unique<render::Renderer>(std::move(window));
  camera_.width = options.width;
  camera_.height = options.height;
  if (!options.frame_log.empty()) {
    frame_log_.open(options.frame_log, std::ios::trunc);
    if (!frame_log_)
      throw OutputError(options.frame_log.string() +
                        ": cannot write the frame log; check the folder");
    frame_log_ << "frame,ms_frame,ms_gpu_submit,ms_lines,lines_age_frames\n";
  }
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsLight();
  ImGui_ImplGlfw_InitForOpenGL(window_->window(), true);
  ImGui_ImplOpenGL3_Init("#version 330");
  g_viewer = this;
  glfwSetDropCallback(window_->window(), on_drop);
  last_hover_ = Clock::now();
}

Viewer::~Viewer() {
  g_viewer = nullptr;
  window_->make_current();
  if (picture_fbo_ != 0) {
    window_->gl().DeleteFramebuffers(1, &picture_fbo_);
    window_->gl().DeleteTextures(1, &picture_);
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
}

void Viewer::report_error(const std::string& message) {
  std::fprintf(stderr, "fabrica-viewer: %s\n", message.c_str());
  errors_.push_back(message);
}

void Viewer::open(const std::filesystem::path& path) {
  loader_.open(path);
  recent_.erase(std::remove(recent_.begin(), recent_.end(), path), recent_.end());
  recent_.insert(recent_.begin(), path);
  if (recent_.size() > 10) recent_.resize(10);
}

bool Viewer::should_close() const {
  return close_requested_ || window_->should_close();
}

void Viewer::adopt_loaded() {
  for (LoadedFile& f : loader_.take_finished()) {
    if (!f.error.empty()) {
      report_error(f.error);
      continue;
    }
    bool has_focus = std::any_of(structures_.begin(), structures_.end(),
                                 [](const auto& s) { return s.role == render::Role::focus; });
    for (LoadedStructure& l : f.structures) {
      ViewerStructure s;
      s.id = next_id_++;
      s.name = l.name;
      // Names stay unique: a second "liver" becomes "liver_2".
      for (int k = 2; std::any_of(structures_.begin(), structures_.end(),
                                  [&](const auto& o) { return o.name == s.name; });
           ++k)
        s.name = l.name + "_" + std::to_string(k);
      s.mesh_file = l.mesh_file;
      s.space = l.space;
      s.role = l.role;
      s.style = l.style;
      if (!l.role_from_file && s.role == render::Role::focus && has_focus) {
        s.role = render::Role::context;
        s.style = render::default_style(render::Role::context);
      }
      has_focus = has_focus || s.role == render::Role::focus;
      s.surface = l.surface;
      s.mesh = l.mesh;
      s.lines = l.lines;
      s.mesh_lod = l.mesh_lod;
      s.lines_lod = l.lines_lod;
      s.moving_levels = l.moving_levels;
      structures_.push_back(std::move(s));
    }
    if (f.scene) {
      background_ = f.scene->background;
      transparent_ = f.scene->transparent;
      if (f.scene->clip) {
        clip_.mode = ClipSettings::Mode::fixed;
        clip_.fixed = *f.scene->clip;
      }
      cutaway_ = f.scene->cutaway;
      if (f.scene->camera) {
        const int w = camera_.width, h = camera_.height;
        camera_ = *f.scene->camera;
        camera_.width = w;
        camera_.height = h;
        camera_set_ = true;
      } else if (f.scene->view) {
        view(*f.scene->view);
      }
    }
    if (!camera_set_) view(AnatomicalView::anterior);
    lines_dirty_ = true;
    camera_changed();
  }
}

bool Viewer::lines_pending() const {
  const bool any =
      std::any_of(structures_.begin(), structures_.end(), [](const auto& s) { return s.visible; });
  return any && camera_set_ &&
         (lines_dirty_ || posted_revision_ != camera_revision_ || posted_lod_);
}

void Viewer::wait() {
  do {
    frame();
  } while (!should_close() && (loader_.busy() || lines_worker_.busy() || lines_pending()));
  frame();  // the lines of the current camera, drawn
}

std::size_t Viewer::find(const std::string& name) const {
  std::string names;
  for (std::size_t i = 0; i < structures_.size(); ++i) {
    if (structures_[i].name == name) return i;
    names += (i ? ", " : "") + structures_[i].name;
  }
  throw InputError("no structure named \"" + name +
                   "\" (there are: " + (names.empty() ? std::string("none") : names) + ")");
}

void Viewer::set_role(std::size_t i, render::Role role) {
  ViewerStructure& s = structures_.at(i);
  if (s.role == role) return;
  if (options_.interactive) {  // the window fades to the new role's opacity
    fade_from_[s.id] = s.style.opacity;
    fade_start_ = Clock::now();
  }
  const render::Color color = s.style.color;
  s.role = role;
  s.style = render::default_style(role);
  s.style.color = color;  // a structure keeps its colour in either role
  lines_dirty_ = true;
}

void Viewer::focus(std::size_t i) {
  for (std::size_t k = 0; k < structures_.size(); ++k)
    if (k != i) set_role(k, render::Role::context);
  set_role(i, render::Role::focus);
  structures_[i].visible = true;
}

void Viewer::set_keys(std::size_t i, const nlohmann::json& all_keys) {
  ViewerStructure& s = structures_.at(i);
  // The viewer's own keys (not in scene JSON): hatching, hatching_width.
  nlohmann::json keys = all_keys;
  if (keys.contains("hatching")) {
    if (!keys["hatching"].is_boolean()) throw InputError("set: hatching must be true or false");
    s.hatching = keys["hatching"].get<bool>();
    keys.erase("hatching");
  }
  if (keys.contains("hatching_width")) {
    const auto& w = keys["hatching_width"];
    if (!w.is_number() || !(w.get<double>() > 0.0 && w.get<double>() <= 20.0))
      throw InputError("set: hatching_width must be a number in (0, 20] (pixels)");
    s.hatching_width = w.get<double>();
    keys.erase("hatching_width");
  }
  lines_dirty_ = true;
  if (keys.empty()) return;
  // The structure as a one-structure scene, the keys applied, read back by
  // the scene reader: the same names, ranges and messages as scene JSON.
  render::SceneSpec one;
  render::StructureSpec spec;
  spec.name = s.name;
  spec.mesh = s.mesh_file.empty() ? std::filesystem::path(s.name) : s.mesh_file;
  spec.role = s.role;
  spec.style = s.style;
  one.structures.push_back(spec);
  nlohmann::json j = render::scene_spec_to_json(one);
  for (const auto& [key, value] : keys.items()) {
    if (key == "mesh" || key == "name" || key == "space")
      throw InputError("set: key \"" + key + "\" cannot be changed in a session");
    if (!j["structures"][0].contains(key) && key != "smooth")
      throw InputError("set: unknown key \"" + key +
                       "\" (role, shading, color, opacity, ambient, toon_levels, lines, "
                       "line_color, line_width, taper, fade, hidden, hybrid, smooth, hatching, "
                       "hatching_width)");
    j["structures"][0][key] = value;
  }
  const bool role_changes = keys.contains("role");
  if (role_changes) {
    // A new role starts from that role's defaults, then the other keys apply.
    const auto r =
        render::parse_role(keys["role"].is_string() ? keys["role"].get<std::string>() : "");
    if (!r) throw InputError("set: role must be \"focus\" or \"context\"");
    render::StructureSpec fresh = spec;
    fresh.role = *r;
    fresh.style = render::default_style(*r);
    fresh.style.color = s.style.color;
    render::SceneSpec tmp;
    tmp.structures.push_back(fresh);
    nlohmann::json base = render::scene_spec_to_json(tmp);
    for (const auto& [key, value] : keys.items()) base["structures"][0][key] = value;
    j = base;
  }
  const render::SceneSpec parsed = render::scene_spec_from_json(j, {}, "set " + s.name);
  s.role = parsed.structures[0].role;
  s.style = parsed.structures[0].style;
  lines_dirty_ = true;
}

BoundingBox Viewer::scene_box(bool focus_only) const {
  BoundingBox box;
  bool first = true;
  for (const auto& s : structures_) {
    if (!s.visible || (focus_only && s.role != render::Role::focus)) continue;
    const BoundingBox b = bounding_box(s.surface->mesh().positions);
    if (first) {
      box = b;
      first = false;
    } else {
      box.min = box.min.cwiseMin(b.min);
      box.max = box.max.cwiseMax(b.max);
    }
  }
  if (first && focus_only) return scene_box(false);
  if (first) throw InputError("nothing to look at: open a mesh, a label volume or a scene first");
  return box;
}

Space Viewer::scene_space() const {
  return structures_.empty() ? Space::lps : structures_.front().surface->mesh().space;
}

void Viewer::set_camera(const Camera& camera) {
  const int w = camera_.width, h = camera_.height;
  camera_ = camera;
  camera_.width = w;
  camera_.height = h;
  camera_set_ = true;
  camera_changed();
}

void Viewer::view(AnatomicalView v, bool animate) {
  const Camera target =
      anatomical_camera(v, scene_box(false), scene_space(), camera_.width, camera_.height);
  if (animate && camera_set_) return start_transition(target);
  camera_ = target;
  camera_set_ = true;
  camera_changed();
}

void Viewer::start_transition(const Camera& target) {
  from_ = camera_;
  to_ = target;
  transition_start_ = Clock::now();
}

void Viewer::step_transition() {
  if (!to_) return;
  const double t = std::min(1.0, ms_since(transition_start_) / 400.0);
  const double s = t * t * (3.0 - 2.0 * t);  // smoothstep
  auto basis = [](const Camera& c) {
    Eigen::Matrix3d m;
    m.col(0) = c.right();
    m.col(1) = c.true_up();
    m.col(2) = -c.forward();
    return Eigen::Quaterniond(m);
  };
  const Eigen::Quaterniond q = basis(*from_).slerp(s, basis(*to_));
  const double d0 = (from_->eye - from_->center).norm(), d1 = (to_->eye - to_->center).norm();
  const Eigen::Matrix3d r = q.toRotationMatrix();
  camera_.center = (1.0 - s) * from_->center + s * to_->center;
  camera_.eye = camera_.center + ((1.0 - s) * d0 + s * d1) * r.col(2);
  camera_.up = r.col(1);
  camera_changed();
  if (t >= 1.0) {
    const int w = camera_.width, h = camera_.height;
    camera_ = *to_;
    camera_.width = w;
    camera_.height = h;
    from_.reset();
    to_.reset();
  }
}

void Viewer::fit_to_selection(bool animate) {
  const BoundingBox box = scene_box(true);
  const Vec3 c = 0.5 * (box.min + box.max);
  const double r = 0.5 * (box.max - box.min).norm();
  const double half = std::min(camera_.fov_deg, camera_.fov_deg * camera_.aspect()) * M_PI / 360.0;
  const double distance = 1.05 * r / std::sin(half);
  Camera target = camera_;
  target.center = c;
  target.eye = c - distance * camera_.forward();
  if (animate) return start_transition(target);
  camera_ = target;
  camera_changed();
}

void Viewer::orbit(double degrees) {
  const Vec3 axis = camera_.true_up();
  const Eigen::AngleAxisd turn(degrees * M_PI / 180.0, axis);
  camera_.eye = camera_.center + turn * (camera_.eye - camera_.center);
  camera_.up = axis;
  camera_changed();
}

std::optional<render::ClipPlane> Viewer::clip_plane() const {
  if (clip_.mode == ClipSettings::Mode::off || structures_.empty()) return std::nullopt;
  if (clip_.mode == ClipSettings::Mode::fixed) return clip_.fixed;
  const BoundingBox box = scene_box(true);
  const Vec3 centre = 0.5 * (box.min + box.max);
  Vec3 normal = -camera_.forward();  // towards the eye
  if (clip_.mode == ClipSettings::Mode::side) {
    const Camera side = anatomical_camera(clip_.side, box, scene_space());
    normal = (side.eye - side.center).normalized();
  }
  render::ClipPlane plane;
  plane.normal = normal;
  plane.point = centre + clip_.offset * normal;
  return plane;
}

void Viewer::set_clip(ClipSettings::Mode mode, AnatomicalView side, double offset) {
  if (!std::isfinite(offset)) throw InputError("clip: the offset must be a finite number of mm");
  clip_.mode = mode;
  clip_.side = side;
  clip_.offset = offset;
  redraw_ = true;
  lines_dirty_ = true;
}

void Viewer::set_cutaway(const render::Cutaway& cutaway) {
  // The scene key's checks (ranges), one place for both.
  cutaway_ = render::cutaway_from_json(render::cutaway_to_json(cutaway), "cutaway");
  redraw_ = true;
}

std::uint64_t Viewer::post_lines(const Camera& camera, bool force, bool lod) {
  if (!force && !lines_dirty_ && posted_revision_ == camera_revision_ && posted_lod_ == lod)
    return lines_version_;
  LinesJob job;
  job.version = ++lines_version_;
  job.camera = camera;
  for (const auto& s : structures_) {
    if (!s.visible) continue;
    // Only structures without hybrid ridges (which need the full mesh's
    // curvature) are drawn coarse: ghosted ones from their level of detail
    // (their lines too), opaque ones from the level that fits the camera
    // (their lines from the full mesh unless coarse_lines_while_moving).
    LinesJob::Item item{s.id,         s.lines,    nullptr,          nullptr,     s.style,
                        s.thresholds, s.hatching, s.hatching_width, std::nullopt};
    if (lod && !s.style.hybrid_apparent_ridges) {
      if (s.style.opacity < 0.999) {
        if (s.lines_lod && s.mesh_lod) {
          item.lod = s.lines_lod;
          item.lod_mesh = s.mesh_lod;
        }
      } else if (const int level = moving_level(*s.mesh, s.moving_levels, camera); level >= 0) {
        const MovingLevel& m = s.moving_levels[static_cast<std::size_t>(level)];
        item.lod_mesh = m.mesh;
        if (coarse_lines_while_moving_) item.lod = m.lines;
      }
      // Not while its opacity fades after a role change (drawn see-through).
      if (!fade_from_.count(s.id))
        item.apparent_min_ndotv = moving_apparent_min_ndotv(*s.mesh, s.role, s.style, camera);
    }
    job.items.push_back(std::move(item));
  }
  if (lod) {  // while the camera moves: fewer line quads, the same picture to half a pixel
    job.merge_px = kMovingMergePx;
    job.merge_strength = kMovingMergeStrength;
  }
  lines_worker_.post(std::move(job));
  lines_dirty_ = false;
  posted_lod_ = lod;
  posted_revision_ = camera_revision_;
  return lines_version_;
}

render::Scene Viewer::build_scene(const std::shared_ptr<const LinesResult>& lines, bool fading,
                                  bool share_lines) {
  const double t = fade_from_.empty() ? 1.0 : std::min(1.0, ms_since(fade_start_) / 300.0);
  render::Scene scene;
  scene.background = background_;
  scene.clip = clip_plane();
  scene.cutaway = cutaway_;
  for (auto& s : structures_) {
    if (!s.visible) continue;
    render::Structure st;
    st.name = s.name;
    st.role = s.role;
    st.style = s.style;
    st.style.families = render::object_space_families(s.style);
    if (const auto f = fade_from_.find(s.id); fading && f != fade_from_.end())
      st.style.opacity = f->second + t * (s.style.opacity - f->second);
    if (s.style.hybrid_apparent_ridges) {
      if (!s.mesh_curvature)
        s.mesh_curvature =
            std::make_shared<render::RenderMesh>(render::make_render_mesh(*s.surface, true));
      st.mesh = s.mesh_curvature;
    } else if (const auto lod = lod_mesh(lines.get(), s.id)) {
      st.mesh = lod;  // its lines come from the same coarse mesh
    } else {
      st.mesh = s.mesh;
    }
    if (lines != nullptr) {
      const auto it = lines->lines.find(s.id);
      // A frame draws the worker's lines where they are (they live as long
      // as the result); a scene kept or exported gets its own copy.
      if (it != lines->lines.end()) {
        if (share_lines)
          st.shared_lines = std::shared_ptr<const LineSet>(lines, &it->second);
        else
          st.lines = it->second;
      }
      const auto h = lines->hatching.find(s.id);
      if (h != lines->hatching.end()) st.polyline_layers.push_back(h->second);
    }
    scene.structures.push_back(std::move(st));
  }
  if (fading && t >= 1.0) fade_from_.clear();
  return scene;
}

render::RenderOptions Viewer::render_options(bool transparent) const {
  render::RenderOptions ro;
  ro.transparent_background = transparent;
  ro.hybrid = hybrid_;
  return ro;
}

void Viewer::ensure_picture(int width, int height) {
  if (picture_fbo_ != 0 && picture_w_ == width && picture_h_ == height) return;
  const auto& g = window_->gl();
  if (picture_fbo_ == 0) {
    g.GenFramebuffers(1, &picture_fbo_);
    g.GenTextures(1, &picture_);
  }
  g.BindTexture(GL_TEXTURE_2D, picture_);
  g.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  g.BindTexture(GL_TEXTURE_2D, 0);
  g.BindFramebuffer(GL_FRAMEBUFFER, picture_fbo_);
  g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, picture_, 0);
  if (g.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error(ErrorKind::unavailable, "the OpenGL driver cannot create the window's picture");
  g.BindFramebuffer(GL_FRAMEBUFFER, 0);
  picture_w_ = width;
  picture_h_ = height;
}

void Viewer::frame() {
  const auto t0 = Clock::now();
  window_->make_current();
  glfwPollEvents();
  adopt_loaded();
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  if (options_.interactive) handle_input();
  step_transition();

  int fw = 0, fh = 0;
  window_->framebuffer_size(fw, fh);
  if (fw > 0 && fh > 0 && (fw != camera_.width || fh != camera_.height)) {
    camera_.width = fw;
    camera_.height = fh;
    camera_changed();
  }

  // Lines: this frame's camera goes to the worker; the frame draws lines at
  // most one frame old (waits for the previous frame's job if need be).
  std::shared_ptr<const LinesResult> lines;
  // While the camera moves the picture is drawn straight into the window
  // after the panels are laid out (no copy through the window's picture,
  // which is drawn again once the camera stops).
  struct DirectDraw {
    render::Scene scene;
    Camera camera;
    render::RenderOptions options;
  };
  std::optional<DirectDraw> direct;
  const bool any =
      std::any_of(structures_.begin(), structures_.end(), [](const auto& s) { return s.visible; });
  stats_.ms_gpu_submit = 0.0;
  // While the camera moves ghosted structures may be drawn coarse (their
  // lines too); once it stops, the full meshes and their lines come back.
  // `screenshot-window` right after the camera stopped shows what the
  // window shows, the moving picture, with the lines of its camera (waited
  // for, so that the capture does not race the lines worker).
  const bool capturing = !capture_.empty();
  const bool moving = camera_revision_ != last_frame_revision_ || dragging_ || to_.has_value() ||
                      (capturing && last_frame_moving_);
  last_frame_revision_ = camera_revision_;
  last_frame_moving_ = moving;
  if (any && camera_set_) {
    const std::uint64_t version = post_lines(camera_, false, moving && simplify_while_moving_);
    lines = lines_worker_.wait_for(version > 1 && !capturing ? version - 1 : version);
    if (!lines->error.empty() && (errors_.empty() || errors_.back() != lines->error))
      report_error(lines->error);
    const auto t1 = Clock::now();
    // Nothing changed since the last picture (same lines, camera and
    // styles): the window's texture still shows it.
    const std::pair<std::uint64_t, std::uint64_t> key{lines->version, camera_revision_};
    // While the camera moves the window may draw fewer pixels (View menu).
    const bool scaled = options_.interactive && moving && moving_scale_ < 0.999f;
    if (redraw_ || key != drawn_ || !has_picture_ || !fade_from_.empty() ||
        scaled != drawn_scaled_) {
      Camera c = camera_;
      if (scaled) {
        c.width = std::max(16, static_cast<int>(camera_.width * moving_scale_));
        c.height = std::max(16, static_cast<int>(camera_.height * moving_scale_));
      }
      drawn_scaled_ = scaled;
      try {
        // Simplified while moving: the ghosts' transparency at half resolution too.
        render::RenderOptions ro = render_options(false);
        ro.ghosts_half_resolution = moving && simplify_while_moving_;
        ro.tight_line_quads = moving && simplify_while_moving_;
        if (moving) {
          direct = DirectDraw{build_scene(lines, true, true), c, ro};
          has_picture_ = false;
        } else {
          // Drawn on the GPU into the window's picture (no read back): the
          // window shows the background colour even for transparent exports.
          ensure_picture(camera_.width, camera_.height);
          renderer_->render_to_framebuffer(build_scene(lines, true, true), c, ro, picture_fbo_,
                                           picture_w_, picture_h_);
          has_picture_ = true;
        }
      } catch (const Error& e) {
        report_error(e.what());
      }
      drawn_ = key;
      redraw_ = false;
    }
    stats_.ms_gpu_submit = ms_since(t1);
    stats_.ms_lines = lines->ms;
    stats_.lines_age = lines_version_ - lines->version;
  } else {
    stats_.ms_lines = 0.0;
    stats_.lines_age = 0;
  }

  draw_ui(*this);
  ImGui::Render();
  const auto t2 = Clock::now();
  const auto& g = window_->gl();
  bool drawn_direct = false;
  if (direct) {
    try {
      renderer_->render_to_framebuffer(direct->scene, direct->camera, direct->options, 0, fw, fh);
      drawn_direct = true;
    } catch (const Error& e) {
      report_error(e.what());
    }
  }
  g.BindFramebuffer(GL_FRAMEBUFFER, 0);
  g.Viewport(0, 0, fw, fh);
  g.ClearColor(background_.r, background_.g, background_.b, 1.0f);
  if (!drawn_direct) g.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (!drawn_direct && has_picture_ && any && picture_w_ == fw && picture_h_ == fh) {
    g.BindFramebuffer(GL_READ_FRAMEBUFFER, picture_fbo_);
    g.BlitFramebuffer(0, 0, fw, fh, 0, 0, fw, fh, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    g.BindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  if (!capture_.empty()) {
    // The window as shown, panels included (documentation pictures).
    render::Image shot(fw, fh), row_up(fw, fh);
    g.PixelStorei(GL_PACK_ALIGNMENT, 1);
    g.ReadPixels(0, 0, fw, fh, GL_RGBA, GL_UNSIGNED_BYTE, row_up.rgba.data());
    for (int y = 0; y < fh; ++y)
      std::copy_n(row_up.pixel(0, fh - 1 - y), static_cast<std::size_t>(fw) * 4, shot.pixel(0, y));
    for (std::size_t i = 3; i < shot.rgba.size(); i += 4) shot.rgba[i] = 255;
    const std::filesystem::path path = capture_;
    capture_.clear();
    render::write_png(shot, path);
  }
  window_->swap_buffers();
  stats_.ms_gpu_submit += ms_since(t2);
  stats_.ms_frame = ms_since(t0);
  ++stats_.frame;
  write_frame_log();
}

void Viewer::capture_window(const std::filesystem::path& path) {
  capture_ = path;
  frame();
}

void Viewer::write_frame_log() {
  if (!frame_log_.is_open()) return;
  char row[160];
  std::snprintf(row, sizeof row, "%llu,%.3f,%.3f,%.3f,%llu\n",
                static_cast<unsigned long long>(stats_.frame), stats_.ms_frame,
                stats_.ms_gpu_submit, stats_.ms_lines,
                static_cast<unsigned long long>(stats_.lines_age));
  frame_log_ << row;
  frame_log_.flush();
}

render::Image Viewer::screenshot(int width, int height, bool transparent) {
  window_->make_current();
  Camera c = camera_;
  c.width = width;
  c.height = height;
  validate_camera(c, "screenshot");
  const std::uint64_t version = post_lines(c, true);
  const auto lines = lines_worker_.wait_for(version);
  const render::Image image =
      renderer_->render(build_scene(lines), c, render_options(transparent || transparent_));
  lines_dirty_ = true;  // the next frame goes back to the window's camera
  return image;
}

void Viewer::export_svg(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".svg" && ext != ".pdf")
    throw InputError(path.string() + ": the lines are written as .svg or .pdf");
  const std::uint64_t version = post_lines(camera_, true);
  const auto lines = lines_worker_.wait_for(version);
  // The shown structures as `fabrica render` holds a scene, drawn as it
  // draws it: the same layers, styles and CPU visibility (render/draw.hpp).
  render::SceneSurfaces scene;
  for (const auto& s : structures_) {
    if (!s.visible) continue;
    render::StructureSpec spec;
    spec.name = s.name;
    spec.role = s.role;
    spec.style = s.style;
    scene.add(std::move(spec), s.surface);
  }
  if (scene.surfaces.empty()) throw InputError("export-svg: nothing is shown");
  const render::Scene drawn = build_scene(lines);
  const double reference = render_options(false).line_reference_size;
  if (ext == ".pdf")
    render::write_scene_pdf(path, scene, drawn, camera_, reference);
  else
    render::write_scene_svg(path, scene, drawn, camera_, reference);
}

void Viewer::save_scene(const std::filesystem::path& path) {
  render::SceneSpec spec;
  spec.background = background_;
  spec.transparent = transparent_;
  spec.camera = camera_;
  spec.clip = clip_plane();
  spec.cutaway = cutaway_;
  const std::filesystem::path dir = path.parent_path();
  const std::string mesh_dir = structure_name_from_file(path) + ".meshes";
  for (const auto& s : structures_) {
    if (!s.visible) continue;
    render::StructureSpec st;
    st.name = s.name;
    st.role = s.role;
    st.style = s.style;
    st.space = s.space;
    if (!s.mesh_file.empty()) {
      st.mesh = std::filesystem::absolute(s.mesh_file);
    } else {
      // A label of a volume: its surface is written beside the scene
      // (binary PLY keeps the coordinates exactly).
      const std::filesystem::path rel = std::filesystem::path(mesh_dir) / (s.name + ".ply");
      std::filesystem::create_directories(dir / mesh_dir);
      io::write_mesh(s.surface->mesh(), dir / rel);
      st.mesh = rel;
    }
    spec.structures.push_back(std::move(st));
  }
  if (spec.structures.empty()) throw InputError("save-scene: nothing is shown");
  render::write_scene_spec(spec, path);
}

std::optional<SurfacePick> Viewer::pick(int x, int y) {
  window_->make_current();
  if (x < 0 || y < 0 || x >= camera_.width || y >= camera_.height) return std::nullopt;
  // The id buffer: every shown structure flat and opaque in the colour of
  // its index, through the same renderer (one draw, read back one pixel).
  render::Scene ids;
  ids.background = {0.0f, 0.0f, 0.0f, 1.0f};
  // The focus is picked through the cutaway (a hard cut: no blended ids).
  ids.cutaway = cutaway_;
  ids.cutaway.fade_px = 0.0;
  ids.cutaway.rim = false;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < structures_.size(); ++i) {
    const auto& s = structures_[i];
    if (!s.visible) continue;
    render::Structure st;
    st.name = s.name;
    st.role = s.role;  // the renderer only cuts the context by it
    st.style.shading = render::Shading::flat;
    st.style.opacity = 1.0;
    st.style.ambient = 1.0;
    st.style.families.clear();
    const std::size_t k = index.size() + 1;
    st.style.color = {static_cast<float>(k % 256) / 255.0f,
                      static_cast<float>((k / 256) % 256) / 255.0f, 0.0f, 1.0f};
    st.mesh = s.mesh;
    index.push_back(i);
    ids.structures.push_back(std::move(st));
  }
  if (ids.structures.empty()) return std::nullopt;
  const render::Image image = renderer_->render(ids, camera_, render_options(false));
  const std::uint8_t* p = image.pixel(x, y);
  const std::size_t k = p[0] + 256u * p[1];
  if (k == 0 || k > index.size()) return std::nullopt;
  SurfacePick pick;
  pick.structure = static_cast<int>(index[k - 1]);
  // The point: the nearest hit of the pixel's ray on that structure.
  const Surface& surface = *structures_[index[k - 1]].surface;
  const auto [origin, dir] = pixel_ray(camera_, x, y);
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_face = 0;
  double bu = 0, bv = 0;
  const auto& P = surface.positions();
  const auto& F = surface.faces();
  for (std::size_t f = 0; f < F.size(); ++f) {
    const Vec3 &a = P[F[f][0]], &b = P[F[f][1]], &c = P[F[f][2]];
    const Vec3 e1 = b - a, e2 = c - a, q = dir.cross(e2);
    const double det = e1.dot(q);
    if (std::fabs(det) < 1e-15) continue;
    const Vec3 s = origin - a;
    const double u = s.dot(q) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Vec3 r = s.cross(e1);
    const double v = dir.dot(r) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(r) / det;
    if (t > 0.0 && t < best) {
      best = t;
      best_face = f;
      bu = u;
      bv = v;
    }
  }
  if (!std::isfinite(best)) return std::nullopt;
  pick.point = origin + best * dir;
  const auto& k1 = surface.curvature().k1;
  const auto& k2 = surface.curvature().k2;
  const Face& f = F[best_face];
  const double w0 = 1.0 - bu - bv;
  pick.k1 = w0 * k1[f[0]] + bu * k1[f[1]] + bv * k1[f[2]];
  pick.k2 = w0 * k2[f[0]] + bu * k2[f[1]] + bv * k2[f[2]];
  return pick;
}

void Viewer::handle_input() {
  const ImGuiIO& io = ImGui::GetIO();
  GLFWwindow* w = window_->window();
  double mx = 0, my = 0;
  glfwGetCursorPos(w, &mx, &my);
  const bool left = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  const bool right = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS ||
                     glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  if (!dragging_ && !io.WantCaptureMouse && (left || right) && camera_set_) {
    dragging_ = true;
    from_.reset();  // a drag ends an animated transition where it is
    to_.reset();
    drag_button_ = left && !io.KeyShift ? 0 : 1;
    drag_x_ = mx;
    drag_y_ = my;
    press_x_ = mx;
    press_y_ = my;
  } else if (dragging_ && (left || right)) {
    const double dx = mx - drag_x_, dy = my - drag_y_;
    if (dx != 0.0 || dy != 0.0) {
      if (drag_button_ == 0) {
        // Arcball: yaw about the view's up axis, pitch about its right axis.
        const double k = 0.4 * M_PI / 180.0;
        const Eigen::AngleAxisd yaw(-dx * k, camera_.true_up());
        const Eigen::AngleAxisd pitch(-dy * k, camera_.right());
        const Eigen::Matrix3d r = (yaw * pitch).toRotationMatrix();
        camera_.up = r * camera_.true_up();
        camera_.eye = camera_.center + r * (camera_.eye - camera_.center);
      } else {
        const double scale = 2.0 * (camera_.eye - camera_.center).norm() *
                             std::tan(camera_.fov_deg * M_PI / 360.0) / camera_.height;
        const Vec3 move = (-dx * camera_.right() + dy * camera_.true_up()) * scale;
        camera_.eye += move;
        camera_.center += move;
      }
      camera_changed();
      drag_x_ = mx;
      drag_y_ = my;
    }
  } else if (dragging_) {
    dragging_ = false;
    const bool click = std::hypot(mx - press_x_, my - press_y_) < 3.0 && drag_button_ == 0;
    if (click) click_at(static_cast<int>(mx), static_cast<int>(my));
  }
  if (!io.WantCaptureMouse && io.MouseWheel != 0.0f && camera_set_) {
    const double factor = std::pow(0.9, io.MouseWheel);
    camera_.eye = camera_.center + factor * (camera_.eye - camera_.center);
    camera_changed();
  }
  // Hover: name and curvature under the cursor, at most every 150 ms.
  if (!dragging_ && !io.WantCaptureMouse && (mx != hover_x_ || my != hover_y_) &&
      ms_since(last_hover_) > 150.0 && !structures_.empty()) {
    hover_x_ = mx;
    hover_y_ = my;
    last_hover_ = Clock::now();
    hover_ = pick(static_cast<int>(mx), static_cast<int>(my));
  }
}

void Viewer::click_at(int x, int y) {
  const auto p = pick(x, y);
  if (!p) {
    if (!options_.interactive) std::printf("click %d %d: nothing\n", x, y);
    return;
  }
  const std::string& name = structures_[static_cast<std::size_t>(p->structure)].name;
  if (!options_.interactive)  // script mode reports what the HUD shows
    std::printf("click %d %d: %s at %.3f %.3f %.3f mm, k1 %.5f k2 %.5f H %.5f /mm\n", x, y,
                name.c_str(), p->point.x(), p->point.y(), p->point.z(), p->k1, p->k2,
                0.5 * (p->k1 + p->k2));
  if (measure_mode_) {
    if (measure_.size() >= 2) measure_.clear();
    measure_.push_back(*p);
    if (measure_.size() == 2 && !options_.interactive)
      std::printf("distance %.3f mm\n", (measure_[0].point - measure_[1].point).norm());
  } else {
    focus(static_cast<std::size_t>(p->structure));
  }
  std::fflush(stdout);
}

}  // namespace fabrica::viewer
