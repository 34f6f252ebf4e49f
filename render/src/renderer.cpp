#include "fabrica/render/renderer.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/render/shader.hpp"

namespace fabrica::render {

double default_tau(double feature_size) {
  if (!(feature_size > 0.0) || !std::isfinite(feature_size)) return 0.0;
  return std::log2(0.25 * feature_size * feature_size);
}

namespace {

constexpr int kTileMargin = 2;  // pixels rendered around each tile (3x3 filters, AA)
constexpr int kMaxImageSide = 32768;
constexpr std::size_t kLineVertexFloats = 13;  // one line quad corner (lines.vert)
const std::string kLicMaxStepsDefine = "LIC_MAX_STEPS " + std::to_string(kLicMaxSteps);

struct GpuMesh {
  std::weak_ptr<const RenderMesh> source;
  GLuint vao = 0, vbo = 0, ebo = 0;
  GLsizei index_count = 0;
  bool curvature = false;
  bool lic = false;  // attributes 5 (feature level) and 6 (direction) present
};

struct Matrices {
  std::array<float, 16> model_view{}, projection{};
  std::array<float, 9> normal{};
  float near_plane = 0.0f, far_plane = 1.0f;
  bool orthographic = false;
  double px_per_mm = 1.0;
};

Matrices camera_matrices(const Camera& camera, const Vec3& center, double radius) {
  Matrices m;
  const auto [n, f] = clip_planes(camera, center, std::max(radius, 1e-9));
  const Eigen::Matrix4f view = view_matrix(camera).cast<float>();
  const Eigen::Matrix4f proj = projection_matrix(camera, n, f).cast<float>();
  std::copy(view.data(), view.data() + 16, m.model_view.begin());
  std::copy(proj.data(), proj.data() + 16, m.projection.begin());
  const Eigen::Matrix3f normal = view.topLeftCorner<3, 3>();
  std::copy(normal.data(), normal.data() + 9, m.normal.begin());
  m.near_plane = static_cast<float>(n);
  m.far_plane = static_cast<float>(f);
  m.orthographic = camera.projection == Projection::orthographic;
  m.px_per_mm = camera_px_per_mm(camera);
  return m;
}

// Tile geometry: the region of the image (GL pixel coordinates, origin at
// the bottom left) and the uniform mapping whole-image clip space to it.
struct Tile {
  int x = 0, y = 0, w = 0, h = 0;  // inner region
  int margin = kTileMargin;        // pixels rendered around it
  int render_w = 0, render_h = 0;  // with margins
  std::array<float, 4> transform{};
};

// A rectangle of whole-image pixels [x0, x1) x [y0, y1), GL coordinates.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// Pixels the meshes can cover: their vertices' boxes (or their bounding
// spheres' enclosing cubes) projected, 2 px wider for rounding; the whole
// image when a corner is not in front of the eye. projected_boxes: the
// same for boxes.
PixelRect projected_boxes(const Matrices& m, const std::vector<BoundingBox>& boxes, int width,
                          int height) {
  const PixelRect whole{0, 0, width, height};
  const Eigen::Matrix4d mvp =
      Eigen::Map<const Eigen::Matrix4f>(m.projection.data()).cast<double>() *
      Eigen::Map<const Eigen::Matrix4f>(m.model_view.data()).cast<double>();
  double lo_x = 1e300, lo_y = 1e300, hi_x = -1e300, hi_y = -1e300;
  for (const BoundingBox& box : boxes) {
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 p(corner & 1 ? box.max.x() : box.min.x(), corner & 2 ? box.max.y() : box.min.y(),
                   corner & 4 ? box.max.z() : box.min.z());
      const Eigen::Vector4d clip = mvp * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
      if (!(clip.w() > 1e-9)) return whole;
      const double x = (0.5 * clip.x() / clip.w() + 0.5) * width;
      const double y = (0.5 * clip.y() / clip.w() + 0.5) * height;
      if (!std::isfinite(x) || !std::isfinite(y)) return whole;
      lo_x = std::min(lo_x, x), hi_x = std::max(hi_x, x);
      lo_y = std::min(lo_y, y), hi_y = std::max(hi_y, y);
    }
  }
  if (boxes.empty()) return {};
  auto to_int = [](double v, int lo, int hi) {
    return static_cast<int>(std::clamp(v, static_cast<double>(lo), static_cast<double>(hi)));
  };
  return {to_int(std::floor(lo_x) - 2.0, 0, width), to_int(std::floor(lo_y) - 2.0, 0, height),
          to_int(std::ceil(hi_x) + 2.0, 0, width), to_int(std::ceil(hi_y) + 2.0, 0, height)};
}

PixelRect projected_rect(const Matrices& m, const std::vector<const RenderMesh*>& meshes, int width,
                         int height) {
  std::vector<BoundingBox> boxes;
  for (const RenderMesh* mesh : meshes) {
    // The vertices' box where known (up to sqrt(3) times tighter across
    // than the sphere's enclosing cube: fewer pixels for the passes that
    // are scissored to it), else the sphere's cube.
    if ((mesh->box_min.array() <= mesh->box_max.array()).all())
      boxes.push_back({mesh->box_min, mesh->box_max});
    else
      boxes.push_back({mesh->center - Vec3::Constant(mesh->radius),
                       mesh->center + Vec3::Constant(mesh->radius)});
  }
  return projected_boxes(m, boxes, width, height);
}

// `region` in the pixels of tile `t` (render region, margins included),
// one pixel inside it; empty (x1 <= x0 or y1 <= y0) when the tile misses it.
PixelRect tile_region(const Tile& t, const PixelRect& region) {
  const int ox = t.x - t.margin, oy = t.y - t.margin;  // tile origin in the image
  return {std::max(1, region.x0 - ox), std::max(1, region.y0 - oy),
          std::min(t.render_w - 1, region.x1 - ox), std::min(t.render_h - 1, region.y1 - oy)};
}

bool is_empty(const PixelRect& r) {
  return r.x1 <= r.x0 || r.y1 <= r.y0;
}

// Tiles of at most `inner` pixels a side, each rendered with `margin`
// pixels around it (kTileMargin, or the LIC kernel's reach: a filter
// reading up to `margin` pixels away sees what it would see untiled).
std::vector<Tile> make_tiles(int width, int height, int inner, int margin = kTileMargin) {
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += inner) {
    for (int x = 0; x < width; x += inner) {
      Tile t;
      t.x = x;
      t.y = y;
      t.w = std::min(inner, width - x);
      t.h = std::min(inner, height - y);
      t.margin = margin;
      t.render_w = t.w + 2 * margin;
      t.render_h = t.h + 2 * margin;
      const double ox = x - margin, oy = y - margin;
      t.transform = {float(double(width) / t.render_w), float(double(height) / t.render_h),
                     float((width - 2.0 * ox) / t.render_w - 1.0),
                     float((height - 2.0 * oy) / t.render_h - 1.0)};
      tiles.push_back(t);
    }
  }
  return tiles;
}

struct LineBatch {
  std::size_t structure = 0;
  bool wide = false;
  int layer = -1;                // index into Structure::polyline_layers; -1: the feature lines
  GLsizei first = 0, count = 0;  // in indices
};

bool is_wide_family(LineFamily f) {
  return f == LineFamily::contour || f == LineFamily::boundary;
}

// What the passes of one Renderer::render frame share (prepared once).
struct FrameState {
  FrameState(const Scene& s, const Camera& c, const RenderOptions& o)
      : scene(s), camera(c), options(o) {}
  const Scene& scene;
  const Camera& camera;
  const RenderOptions& options;
  Matrices M;
  std::vector<const GpuMesh*> gpu;
  bool any_transparent = false, any_hybrid = false, any_lic = false;
  double tolerance = 0.0, line_scale = 1.0;
  float bg_alpha = 1.0f;
  std::vector<LineBatch> batches;
  bool lines_need_depth_b = false;
  PixelRect hybrid_region, lic_region;
  PixelRect ghost_region;  // what the ghosted (transparent) structures can cover
  LicKernel lic_kernel;
  float lic_inv_cell = 1.0f;
  bool cut = false;            // a cutaway with focus and context (pass_cutaway)
  PixelRect cut_region;        // the focus's pixels widened by the cutaway's reach
  bool cut_fade_only = false;  // the transparency pass draws only the cut's fade
  bool ghost_half = false;     // the transparency pass at half resolution (pass_transparent)
  // With ghost_half: the ghosts' nearest depth drawn by the transparency
  // pass itself (ghost_depth_in_one_pass), not by a depth pass of its own.
  bool ghost_depth_merged = false;
};

void check_size(const Camera& camera) {
  validate_camera(camera, "camera");
  if (camera.width > kMaxImageSide || camera.height > kMaxImageSide)
    throw InputError("image size " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height) + " is too large (at most " +
                     std::to_string(kMaxImageSide) + " pixels a side)");
}

float hybrid_scale(const RenderMesh& mesh, const HybridOptions& o) {
  double tau = 0.0;
  if (o.tau) {
    tau = *o.tau;
  } else {
    const double fs = mesh.feature_size > 0.0 ? mesh.feature_size : mesh.mean_edge_length;
    tau = default_tau(fs);
  }
  if (!std::isfinite(tau)) throw InputError("hybrid apparent ridges: tau must be finite");
  return static_cast<float>(std::exp2(tau));
}

// The cutaway (docs/algorithms.md §15): on when enabled and the scene has
// both focus and context structures.
bool cutaway_applies(const Scene& scene) {
  if (!scene.cutaway.enabled) return false;
  bool focus = false, context = false;
  for (const auto& s : scene.structures) (s.role == Role::focus ? focus : context) = true;
  return focus && context;
}

// How far (pixels of the picture) the cutaway reaches from the focus's
// footprint: margin + fade (+ rim), `scale` the line scale.
double cutaway_reach(const Cutaway& c, double scale) {
  return (c.margin_px + c.fade_px + (c.rim ? kCutawayRimPx : 0.0)) * scale;
}

// Tiles' margin with a cutaway: every pixel of a tile sees the focus
// pixels within reach (the distance field is computed per tile).
int cutaway_margin(const Cutaway& c, double scale) {
  return static_cast<int>(std::ceil(cutaway_reach(c, scale))) + 2;
}

// Texture units the cutaway's textures stay bound to while a tile is drawn.
constexpr int kCutSeedUnit = 5, kCutDepthUnit = 6;

}  // namespace

struct Renderer::Impl {
  std::unique_ptr<GlContext> ctx;
  std::map<const RenderMesh*, GpuMesh> meshes;
  std::map<std::string, ShaderProgram, std::less<>> programs;
  GLuint empty_vao = 0;
  GLuint line_vao = 0, line_vbo = 0, line_ebo = 0;
  // Capacity of line_vbo / line_ebo in bytes, and the CPU-side arrays of
  // upload_lines: kept between draws, so a viewer's frames reuse them.
  std::size_t line_vbo_bytes = 0, line_ebo_bytes = 0;
  std::vector<float> line_vertex_scratch;
  std::vector<std::uint32_t> line_index_scratch;
  std::vector<double> arc_scratch;

  // Render targets, (re)allocated for the largest tile.
  int target_w = 0, target_h = 0;
  GLuint main_fbo = 0, main_color = 0, depth_a = 0;
  GLuint overlay_fbo = 0;  // main_color without depth: overlays may sample depth A
  GLuint oit_fbo = 0, accum = 0, reveal = 0;
  // The transparency pass at half resolution (RenderOptions::
  // ghosts_half_resolution): its own accumulation targets (filtered
  // linearly by the composite) and a copy of depth A, half_w x half_h.
  GLuint half_fbo = 0, half_accum = 0, half_reveal = 0, half_depth = 0;
  // Where the driver blends buffers with their own equations: the ghosts'
  // nearest depth (R32F, blended by GL_MIN) as half_fbo's third target.
  GLuint half_ghost_depth = 0;
  // True while half_depth holds depth A copied down by this tile's
  // transparency pass (which tests it without writing): the ghosts' depth
  // pass then draws into it without copying it again.
  bool half_depth_is_a = false;
  int half_w = 0, half_h = 0;
  GLuint depthb_fbo = 0, depth_b = 0;
  // Hybrid apparent ridges: stage 1 draws (q, t1) into ar_color with the
  // depth-stencil ar_depth (stencil 1 where a hybrid mesh is visible); stage 2
  // draws into main_color through ar_out_fbo, which shares ar_depth so that
  // the filter runs only where it can ink (hybrid_stage2).
  GLuint ar_fbo = 0, ar_color = 0, ar_depth = 0, ar_out_fbo = 0;
  bool ar_float = false;
  // Surface LIC: stage 1 draws (direction, noise, mask) into lic_color with
  // the depth-stencil lic_depth (stencil 1 where a LIC mesh is visible);
  // stage 2 multiplies into main_color through lic_out_fbo (lic_stage2).
  GLuint lic_fbo = 0, lic_color = 0, lic_depth = 0, lic_out_fbo = 0;
  // Cutaway (pass_cutaway): the focus's front depth (cut_depth, drawn
  // through cut_fbo) and the jump-flooding ping-pong of nearest focus
  // pixels (cut_seeds, RG32F); cut_params = (margin, fade, rim width) in
  // pixels of the picture, as cutaway.glsl takes them.
  GLuint cut_fbo = 0, cut_depth = 0;
  GLuint cut_seeds[2] = {0, 0}, cut_seed_fbos[2] = {0, 0};
  std::array<float, 3> cut_params{};
  Color cut_rim_color;
  PixelRect cut_rect;  // F.cut_region in the tile's pixels: where anything can be cut

  // Scissor to cut_rect (the passes that only draw the cut), or off.
  void cut_scissor(bool on) {
    if (!on) {
      gl().Disable(GL_SCISSOR_TEST);
      return;
    }
    gl().Enable(GL_SCISSOR_TEST);
    gl().Scissor(cut_rect.x0, cut_rect.y0, std::max(0, cut_rect.x1 - cut_rect.x0),
                 std::max(0, cut_rect.y1 - cut_rect.y0));
  }

  explicit Impl(std::unique_ptr<GlContext> c) : ctx(std::move(c)) {
    ctx->make_current();
    const GlFunctions& gl = ctx->gl();
    gl.GenVertexArrays(1, &empty_vao);
    gl.GenVertexArrays(1, &line_vao);
    gl.GenBuffers(1, &line_vbo);
    gl.GenBuffers(1, &line_ebo);
  }

  ~Impl() {
    try {
      ctx->make_current();
    } catch (...) {
      return;  // no context: the driver frees everything with it
    }
    const GlFunctions& gl = ctx->gl();
    for (auto& [key, m] : meshes) release_mesh(m);
    programs.clear();
    release_targets();
    gl.DeleteVertexArrays(1, &empty_vao);
    gl.DeleteVertexArrays(1, &line_vao);
    gl.DeleteBuffers(1, &line_vbo);
    gl.DeleteBuffers(1, &line_ebo);
  }

  const GlFunctions& gl() const { return ctx->gl(); }

  // ------------------------------------------------------------ programs
  const ShaderProgram& program(const std::string& key) {
    auto it = programs.find(key);
    if (it != programs.end()) return it->second;
    auto vs = [](std::vector<std::string> files, std::vector<std::string> defines = {}) {
      files.insert(files.begin(), "common.glsl");
      return ShaderStage::from_files(GL_VERTEX_SHADER, files, defines);
    };
    auto fs = [](std::vector<std::string> files, std::vector<std::string> defines = {}) {
      return ShaderStage::from_files(GL_FRAGMENT_SHADER, files, defines);
    };
    std::vector<ShaderStage> stages;
    if (key == "mesh")
      stages = {vs({"mesh.vert"}), fs({"shading.glsl", "cutaway.glsl", "mesh.frag"})};
    else if (key == "mesh_uncut")
      stages = {vs({"mesh.vert"}), fs({"shading.glsl", "cutaway.glsl", "mesh.frag"}, {"NO_CUT"})};
    else if (key == "mesh_oit")
      stages = {vs({"mesh.vert"}), fs({"shading.glsl", "cutaway.glsl", "mesh_oit.frag"})};
    else if (key == "mesh_oit_uncut")
      stages = {vs({"mesh.vert"}),
                fs({"shading.glsl", "cutaway.glsl", "mesh_oit.frag"}, {"NO_CUT"})};
    else if (key == "depth")
      stages = {vs({"mesh.vert"}), fs({"cutaway.glsl", "depth.frag"})};
    else if (key == "depth_uncut")
      stages = {vs({"mesh.vert"}), fs({"cutaway.glsl", "depth.frag"}, {"NO_CUT"})};
    else if (key == "oit_composite")
      stages = {vs({"fullscreen.vert"}), fs({"oit_composite.frag"})};
    else if (key == "oit_composite_half")
      stages = {vs({"fullscreen.vert"}), fs({"oit_composite.frag"}, {"HALF_RESOLUTION"})};
    else if (key == "lines")
      stages = {vs({"lines.vert"}), fs({"cutaway.glsl", "lines.frag"})};
    else if (key == "ar1")
      stages = {vs({"apparent_ridges.glsl", "ar_stage1.vert"}),
                fs({"apparent_ridges.glsl", "cutaway.glsl", "ar_stage1.frag"})};
    else if (key == "ar1_per_fragment")
      stages = {vs({"apparent_ridges.glsl", "ar_stage1.vert"}, {"PER_FRAGMENT"}),
                fs({"apparent_ridges.glsl", "cutaway.glsl", "ar_stage1.frag"}, {"PER_FRAGMENT"})};
    else if (key == "ar2")
      stages = {vs({"fullscreen.vert"}), fs({"ar_stage2.frag"})};
    else if (key == "ar_occluder")
      stages = {vs({"mesh.vert"}), fs({"cutaway.glsl", "ar_occluder.frag"})};
    else if (key == "ar_mask")
      stages = {vs({"fullscreen.vert"}), fs({"ar_mask.frag"})};
    else if (key == "ar_bare1")
      stages = {vs({"ar_bare.vert"}), fs({"ar_bare_stage1.frag"})};
    else if (key == "ar_bare2")
      stages = {vs({"fullscreen.vert"}), fs({"ar_bare_stage2.frag"})};
    else if (key == "lic1")
      stages = {vs({"lic_stage1.vert"}), fs({"lic_noise.glsl", "cutaway.glsl", "lic_stage1.frag"})};
    else if (key == "lic_mask")
      stages = {vs({"fullscreen.vert"}), fs({"lic_mask.frag"})};
    else if (key == "lic2")
      stages = {vs({"fullscreen.vert"}), fs({"lic_stage2.frag"}, {kLicMaxStepsDefine})};
    else if (key == "lic2_value")
      stages = {vs({"fullscreen.vert"}),
                fs({"lic_stage2.frag"}, {kLicMaxStepsDefine, "LIC_VALUE"})};
    else if (key == "cut_seed")
      stages = {vs({"mesh.vert"}), fs({"cutaway_seed.frag"})};
    else if (key == "cut_jfa")
      stages = {vs({"cutaway_far.vert"}), fs({"cutaway_jfa.frag"})};
    else
      throw Error(ErrorKind::internal, "unknown program " + key);
    return programs.emplace(key, ShaderProgram(gl(), key, stages)).first->second;
  }

  // -------------------------------------------------------------- meshes
  void release_mesh(GpuMesh& m) {
    gl().DeleteVertexArrays(1, &m.vao);
    gl().DeleteBuffers(1, &m.vbo);
    gl().DeleteBuffers(1, &m.ebo);
    m = GpuMesh{};
  }

  const GpuMesh& gpu_mesh(const std::shared_ptr<const RenderMesh>& mesh) {
    for (auto it = meshes.begin(); it != meshes.end();) {
      if (it->second.source.expired()) {
        release_mesh(it->second);
        it = meshes.erase(it);
      } else {
        ++it;
      }
    }
    auto it = meshes.find(mesh.get());
    if (it != meshes.end() && !it->second.source.owner_before(mesh) &&
        !mesh.owner_before(it->second.source))
      return it->second;
    if (it != meshes.end()) {
      release_mesh(it->second);
      meshes.erase(it);
    }
    const RenderMesh& m = *mesh;
    const GlFunctions& g = gl();
    GpuMesh gm;
    gm.source = mesh;
    gm.curvature = m.has_curvature();
    const std::size_t n = m.vertex_count();
    const bool lic = m.has_lic_field();
    const std::size_t lic_offset = gm.curvature ? 14 * n : 6 * n;
    const std::size_t floats = lic_offset + (lic ? 4 * n : 0);
    gm.lic = lic;
    g.GenVertexArrays(1, &gm.vao);
    g.GenBuffers(1, &gm.vbo);
    g.GenBuffers(1, &gm.ebo);
    g.BindVertexArray(gm.vao);
    g.BindBuffer(GL_ARRAY_BUFFER, gm.vbo);
    std::vector<float> data;
    data.reserve(floats);
    data.insert(data.end(), m.positions.begin(), m.positions.end());
    data.insert(data.end(), m.normals.begin(), m.normals.end());
    if (gm.curvature) {
      for (std::size_t i = 0; i < n; ++i) {
        data.push_back(m.k1[i]);
        data.push_back(m.k2[i]);
      }
      data.insert(data.end(), m.e1.begin(), m.e1.end());
      data.insert(data.end(), m.e2.begin(), m.e2.end());
    }
    if (lic) {
      data.insert(data.end(), m.lic_level.begin(), m.lic_level.end());
      data.insert(data.end(), m.lic_field.begin(), m.lic_field.end());
    }
    g.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(),
                 GL_STATIC_DRAW);
    auto attrib = [&](GLuint loc, int size, std::size_t offset_floats) {
      g.EnableVertexAttribArray(loc);
      g.VertexAttribPointer(loc, size, GL_FLOAT, GL_FALSE, 0,
                            reinterpret_cast<const void*>(offset_floats * sizeof(float)));
    };
    attrib(0, 3, 0);
    attrib(1, 3, 3 * n);
    if (gm.curvature) {
      attrib(2, 2, 6 * n);
      attrib(3, 3, 8 * n);
      attrib(4, 3, 11 * n);
    }
    if (lic) {
      attrib(5, 1, lic_offset);
      attrib(6, 3, lic_offset + n);
    }
    g.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, gm.ebo);
    g.BufferData(GL_ELEMENT_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(m.indices.size() * sizeof(std::uint32_t)),
                 m.indices.data(), GL_STATIC_DRAW);
    gm.index_count = static_cast<GLsizei>(m.indices.size());
    g.BindVertexArray(0);
    check_gl_error(g, "uploading a mesh");
    return meshes.emplace(mesh.get(), gm).first->second;
  }

  void draw_mesh(const GpuMesh& m) {
    gl().BindVertexArray(m.vao);
    gl().DrawElements(GL_TRIANGLES, m.index_count, GL_UNSIGNED_INT, nullptr);
  }

  // ------------------------------------------------------------- targets
  GLuint make_texture(GLint internal, GLenum format, GLenum type, int w, int h) {
    const GlFunctions& g = gl();
    GLuint t = 0;
    g.GenTextures(1, &t);
    g.BindTexture(GL_TEXTURE_2D, t);
    g.TexImage2D(GL_TEXTURE_2D, 0, internal, w, h, 0, format, type, nullptr);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return t;
  }

  void check_fbo(const char* what) {
    const GLenum status = gl().CheckFramebufferStatus(GL_FRAMEBUFFER);
    check_gl_error(gl(), what);
    if (status != GL_FRAMEBUFFER_COMPLETE)
      throw Error(ErrorKind::unavailable, std::string("the OpenGL driver cannot create the ") +
                                              what + " (framebuffer status " +
                                              std::to_string(status) + ")");
  }

  void release_targets() {
    const GlFunctions& g = gl();
    GLuint fbos[] = {main_fbo,   overlay_fbo, oit_fbo,     depthb_fbo, ar_fbo,
                     ar_out_fbo, lic_fbo,     lic_out_fbo, half_fbo};
    g.DeleteFramebuffers(9, fbos);
    GLuint textures[] = {main_color, depth_a,    accum,       reveal,     depth_b,         ar_color,
                         lic_color,  half_accum, half_reveal, half_depth, half_ghost_depth};
    g.DeleteTextures(11, textures);
    GLuint renderbuffers[] = {ar_depth, lic_depth};
    g.DeleteRenderbuffers(2, renderbuffers);
    main_fbo = overlay_fbo = oit_fbo = depthb_fbo = ar_fbo = ar_out_fbo = 0;
    main_color = depth_a = accum = reveal = depth_b = ar_color = ar_depth = 0;
    lic_fbo = lic_out_fbo = lic_color = lic_depth = 0;
    half_fbo = half_accum = half_reveal = half_depth = half_ghost_depth = 0;
    half_w = half_h = 0;
    release_cutaway();
    target_w = target_h = 0;
  }

  void ensure_main(int w, int h) {
    if (w <= target_w && h <= target_h && main_fbo != 0) return;
    release_targets();
    const GlFunctions& g = gl();
    target_w = w;
    target_h = h;
    main_color = make_texture(GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE, w, h);
    depth_a = make_texture(GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, w, h);
    check_gl_error(g, "allocating the colour and depth targets");
    g.GenFramebuffers(1, &main_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, main_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, main_color, 0);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_a, 0);
    check_fbo("colour/depth framebuffer");
    g.GenFramebuffers(1, &overlay_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, overlay_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, main_color, 0);
    check_fbo("overlay framebuffer");
  }

  // Weighted blended OIT targets of w x h: accumulation (RGBA16F) and
  // revealage (R16F) textures, with `depth` attached, drawn into together.
  void make_oit_targets(int w, int h, GLuint depth, GLuint& fbo, GLuint& acc, GLuint& rev,
                        const char* name) {
    const GlFunctions& g = gl();
    acc = make_texture(GL_RGBA16F, GL_RGBA, GL_FLOAT, w, h);
    rev = make_texture(GL_R16F, GL_RED, GL_FLOAT, w, h);
    g.GenFramebuffers(1, &fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, acc, 0);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, rev, 0);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
    const GLenum bufs[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    g.DrawBuffers(2, bufs);
    check_fbo(name);
  }

  void ensure_oit() {
    if (oit_fbo != 0) return;
    make_oit_targets(target_w, target_h, depth_a, oit_fbo, accum, reveal,
                     "transparency framebuffer");
  }

  // Half-resolution transparency targets for render targets of target_w x
  // target_h: every half pixel covers 2x2 pixels (the last row and column
  // may cover one); the composite filters them linearly.
  void ensure_oit_half() {
    if (half_fbo != 0) return;
    const GlFunctions& g = gl();
    half_w = (target_w + 1) / 2;
    half_h = (target_h + 1) / 2;
    half_depth =
        make_texture(GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, half_w, half_h);
    make_oit_targets(half_w, half_h, half_depth, half_fbo, half_accum, half_reveal,
                     "half-resolution transparency framebuffer");
    for (GLuint t : {half_accum, half_reveal}) {
      g.BindTexture(GL_TEXTURE_2D, t);
      g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    }
    if (ghost_depth_in_one_pass()) {
      half_ghost_depth = make_texture(GL_R32F, GL_RED, GL_FLOAT, half_w, half_h);
      g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT2, GL_TEXTURE_2D, half_ghost_depth,
                             0);
      check_fbo("half-resolution transparency framebuffer");
    }
  }

  // Whether the transparency pass at half resolution draws the ghosts'
  // nearest depth as a third target blended by GL_MIN (per-buffer blend
  // equations, OpenGL 4.0), saving the ghosts' depth pass: one pass over
  // their triangles instead of two.
  bool ghost_depth_in_one_pass() const { return gl().BlendEquationi != nullptr; }

  void ensure_depth_b() {
    if (depthb_fbo != 0) return;
    const GlFunctions& g = gl();
    depth_b =
        make_texture(GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, target_w, target_h);
    g.GenFramebuffers(1, &depthb_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, depthb_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_b, 0);
    const GLenum none = GL_NONE;
    g.DrawBuffers(1, &none);
    g.ReadBuffer(GL_NONE);
    check_fbo("depth framebuffer");
  }

  void ensure_ar(bool float_target) {
    if (ar_fbo != 0 && ar_float == float_target) return;
    const GlFunctions& g = gl();
    if (ar_fbo != 0) {
      g.DeleteFramebuffers(1, &ar_fbo);
      g.DeleteFramebuffers(1, &ar_out_fbo);
      g.DeleteTextures(1, &ar_color);
      g.DeleteRenderbuffers(1, &ar_depth);
    }
    ar_float = float_target;
    ar_color = float_target ? make_texture(GL_RGBA32F, GL_RGBA, GL_FLOAT, target_w, target_h)
                            : make_texture(GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE, target_w, target_h);
    make_two_stage_targets(ar_color, ar_depth, ar_fbo, ar_out_fbo, "apparent-ridge");
  }

  // A two-stage image method's targets (hybrid ridges, LIC): `fbo` draws
  // into `color` with a new depth-stencil renderbuffer `depth`; `out_fbo`
  // draws into main_color with the same depth-stencil.
  void make_two_stage_targets(GLuint color, GLuint& depth, GLuint& fbo, GLuint& out_fbo,
                              const std::string& name) {
    const GlFunctions& g = gl();
    g.GenRenderbuffers(1, &depth);
    g.BindRenderbuffer(GL_RENDERBUFFER, depth);
    g.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, target_w, target_h);
    g.GenFramebuffers(1, &fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color, 0);
    g.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth);
    check_fbo((name + " framebuffer").c_str());
    g.GenFramebuffers(1, &out_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, out_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, main_color, 0);
    g.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth);
    check_fbo((name + " output framebuffer").c_str());
  }

  // Tiles' largest render size: the targets are (re)made for it.
  void ensure_main_for(const std::vector<Tile>& tiles) {
    int max_w = 0, max_h = 0;
    for (const auto& t : tiles) {
      max_w = std::max(max_w, t.render_w);
      max_h = std::max(max_h, t.render_h);
    }
    ensure_main(max_w, max_h);
  }

  // Stage 1 of a two-stage method: `fbo` bound and cleared (colour `clear`,
  // depth 1, stencil 0) for tile `t`, opaque state, stencil test on with
  // REPLACE (each draw sets its reference value).
  void begin_stage1(GLuint fbo, const Tile& t, const std::array<float, 4>& clear) {
    const GlFunctions& g = gl();
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.Viewport(0, 0, t.render_w, t.render_h);
    set_state_opaque();  // depth writes on, or Clear leaves the depth alone
    g.ClearColor(clear[0], clear[1], clear[2], clear[3]);
    g.ClearDepth(1.0);
    g.ClearStencil(0);
    g.StencilMask(0xFF);
    g.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    g.Enable(GL_STENCIL_TEST);
    g.StencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
  }

  // Stage 2 of a two-stage method: `out_fbo` bound for tile `t`, scissored
  // to `r`, stage 1's `data` on unit 0, stencil test EQUAL 1 (read only).
  void begin_stage2(GLuint out_fbo, GLuint data, const Tile& t, const PixelRect& r) {
    const GlFunctions& g = gl();
    g.BindFramebuffer(GL_FRAMEBUFFER, out_fbo);
    const GLenum color0 = GL_COLOR_ATTACHMENT0;
    g.DrawBuffers(1, &color0);
    g.Viewport(0, 0, t.render_w, t.render_h);
    g.Enable(GL_SCISSOR_TEST);
    g.Scissor(r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0);
    g.ActiveTexture(GL_TEXTURE0);
    g.BindTexture(GL_TEXTURE_2D, data);
    g.Enable(GL_STENCIL_TEST);
    g.StencilMask(0x00);
    g.StencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
    g.StencilFunc(GL_EQUAL, 1, 0xFF);
  }

  // The mark pass: the fullscreen triangle by the program in use (which
  // discards the pixels to skip) writes window depth 0.5, no colour.
  void mark_pixels() {
    const GlFunctions& g = gl();
    g.ColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    g.Disable(GL_BLEND);
    g.Enable(GL_DEPTH_TEST);
    g.DepthFunc(GL_ALWAYS);
    g.DepthMask(GL_TRUE);
    draw_fullscreen();  // z = 0: window depth 0.5 on the marked pixels
    g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  }

  // The LIC targets: lic_fbo draws stage 1 into lic_color (RGBA8) with the
  // opaque pass's depth depth_a (tested, not written); lic_out_fbo draws into
  // main_color with its own depth lic_depth (the mark pass's).
  void ensure_lic() {
    if (lic_fbo != 0) return;
    const GlFunctions& g = gl();
    lic_color = make_texture(GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE, target_w, target_h);
    g.GenFramebuffers(1, &lic_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, lic_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, lic_color, 0);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_a, 0);
    check_fbo("LIC framebuffer");
    g.GenRenderbuffers(1, &lic_depth);
    g.BindRenderbuffer(GL_RENDERBUFFER, lic_depth);
    g.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, target_w, target_h);
    g.GenFramebuffers(1, &lic_out_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, lic_out_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, main_color, 0);
    g.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, lic_depth);
    check_fbo("LIC output framebuffer");
  }

  void ensure_cutaway() {
    if (cut_fbo != 0) return;
    const GlFunctions& g = gl();
    cut_depth =
        make_texture(GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, target_w, target_h);
    for (GLuint& seeds : cut_seeds)
      seeds = make_texture(GL_RG32F, GL_RG, GL_FLOAT, target_w, target_h);
    // The focus pass: its depth and its seeds in both targets.
    g.GenFramebuffers(1, &cut_fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, cut_fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, cut_depth, 0);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, cut_seeds[0], 0);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, cut_seeds[1], 0);
    const GLenum both[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    g.DrawBuffers(2, both);
    check_fbo("cutaway focus framebuffer");
    // The flood passes: one target each, depth-tested against the focus.
    g.GenFramebuffers(2, cut_seed_fbos);
    for (int k = 0; k < 2; ++k) {
      g.BindFramebuffer(GL_FRAMEBUFFER, cut_seed_fbos[k]);
      g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, cut_seeds[k], 0);
      g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, cut_depth, 0);
      check_fbo("cutaway distance framebuffer");
    }
  }

  void release_cutaway() {
    const GlFunctions& g = gl();
    g.DeleteFramebuffers(1, &cut_fbo);
    g.DeleteFramebuffers(2, cut_seed_fbos);
    g.DeleteTextures(1, &cut_depth);
    g.DeleteTextures(2, cut_seeds);
    cut_fbo = cut_depth = 0;
    cut_seeds[0] = cut_seeds[1] = cut_seed_fbos[0] = cut_seed_fbos[1] = 0;
  }

  // The cutaway's uniforms (cutaway.glsl) on every program set_common sets
  // up; u_cutaway itself is set per draw (set_clip).
  void set_cut_uniforms(const ShaderProgram& p) {
    p.set("u_cut_seeds", kCutSeedUnit);
    p.set("u_cut_depth", kCutDepthUnit);
    p.set("u_cut", cut_params[0], cut_params[1], cut_params[2]);
    p.set("u_cut_rim_color", cut_rim_color.r, cut_rim_color.g, cut_rim_color.b, cut_rim_color.a);
  }

  // ------------------------------------------------------------- helpers
  int tile_inner_size(int requested, int margin = kTileMargin) const {
    int limit = std::min(ctx->max_framebuffer_size(), 4096);
    if (requested > 0) limit = std::min(limit, requested);
    return std::max(16, limit - 2 * margin);
  }

  void set_common(const ShaderProgram& p, const Matrices& m, const Tile& t) {
    p.set_mat4("u_model_view", m.model_view.data());
    p.set_mat4("u_projection", m.projection.data());
    p.set_mat3("u_normal_matrix", m.normal.data());
    p.set("u_tile", t.transform[0], t.transform[1], t.transform[2], t.transform[3]);
    p.set("u_orthographic", m.orthographic ? 1 : 0);
    set_cut_uniforms(p);
  }

  void draw_fullscreen() {
    gl().BindVertexArray(empty_vao);
    gl().DrawArrays(GL_TRIANGLES, 0, 3);
  }

  void read_tile(GLuint fbo, const Tile& t, int image_h, Image& image, bool unpremultiply) {
    const GlFunctions& g = gl();
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.ReadBuffer(GL_COLOR_ATTACHMENT0);
    g.PixelStorei(GL_PACK_ALIGNMENT, 1);
    std::vector<std::uint8_t> buffer(static_cast<std::size_t>(t.w) * t.h * 4);
    g.ReadPixels(t.margin, t.margin, t.w, t.h, GL_RGBA, GL_UNSIGNED_BYTE, buffer.data());
    check_gl_error(g, "reading the image back");
    for (int j = 0; j < t.h; ++j) {
      const int row = image_h - 1 - (t.y + j);
      std::uint8_t* dst = image.pixel(t.x, row);
      const std::uint8_t* src = buffer.data() + static_cast<std::size_t>(j) * t.w * 4;
      std::copy(src, src + static_cast<std::size_t>(t.w) * 4, dst);
      if (!unpremultiply) continue;
      for (int i = 0; i < t.w; ++i) {
        std::uint8_t* p = dst + 4 * i;
        const int a = p[3];
        if (a == 0 || a == 255) continue;
        for (int c = 0; c < 3; ++c)
          p[c] = static_cast<std::uint8_t>(std::min(255, (p[c] * 255 + a / 2) / a));
      }
    }
  }

  void set_state_opaque() {
    const GlFunctions& g = gl();
    g.Enable(GL_DEPTH_TEST);
    g.DepthFunc(GL_LESS);
    g.DepthMask(GL_TRUE);
    g.Disable(GL_BLEND);
    g.Disable(GL_CULL_FACE);
    g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  }

  void set_state_overlay() {
    const GlFunctions& g = gl();
    g.Disable(GL_DEPTH_TEST);
    g.DepthMask(GL_FALSE);
    g.Enable(GL_BLEND);
    g.BlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  }

  // Hybrid stage 1 into ar_fbo: hybrid meshes with their scale, occluders with q = 0.
  struct HybridDraw {
    const GpuMesh* mesh;
    float scale;
    bool occluder;
    bool clipped = false;  // a context structure of a scene with a clip
    bool cull = false;     // back faces culled (cullable)
    bool cut = false;      // a context structure of a frame with a cutaway
  };
  // The clipping plane as the shaders take it (common.glsl, clip_at).
  std::array<float, 4> clip{0.0f, 0.0f, 0.0f, 1.0f};
  // An unclipped draw also gets the plane 0 x + 1 >= 0 (keeps everything):
  // Mesa's llvmpipe kept clipping a draw after glDisable(GL_CLIP_DISTANCE0)
  // when the previous draw of the same program had it enabled (a focus
  // structure after a clipped context one lost its clipped half).
  // `cut`: a context structure of a frame with a cutaway (cutaway.glsl).
  void set_clip(const ShaderProgram& p, bool clipped, bool cut = false) {
    p.set("u_cutaway", cut ? 1 : 0);
    if (clipped) {
      gl().Enable(GL_CLIP_DISTANCE0);
      p.set("u_clip", clip[0], clip[1], clip[2], clip[3]);
    } else {
      gl().Disable(GL_CLIP_DISTANCE0);
      p.set("u_clip", 0.0f, 0.0f, 0.0f, 1.0f);
    }
  }
  void hybrid_stage1(const std::vector<HybridDraw>& draws, const HybridOptions& o,
                     const Matrices& m, const Tile& t, bool bare) {
    const GlFunctions& g = gl();
    ensure_ar(o.float_target);
    // Stencil: 1 where a hybrid mesh is the visible surface, 0 elsewhere.
    begin_stage1(ar_fbo, t, {0.0f, 0.5f, 0.5f, 0.0f});
    // Occluders (q = 0, coverage 0) by their own program, so the hybrid
    // program has no per-fragment branch; the draw order is kept.
    const ShaderProgram& p =
        program(bare ? "ar_bare1" : (o.per_fragment ? "ar1_per_fragment" : "ar1"));
    const ShaderProgram* current = nullptr;
    for (const auto& d : draws) {
      const ShaderProgram& q = d.occluder ? program("ar_occluder") : p;
      if (&q != current) {
        current = &q;
        q.use();
        set_common(q, m, t);
        if (&q == &p) {
          p.set("u_q_max", static_cast<float>(o.saturation));
          p.set("u_sign_free", o.sign_free ? 1 : 0);
        }
      }
      if (!d.occluder) p.set("u_scale", d.scale);
      set_clip(q, d.clipped, d.cut);
      set_cull(d.cull);
      g.StencilFunc(GL_ALWAYS, d.occluder ? 0 : 1, 0xFF);
      draw_mesh(*d.mesh);
    }
    g.Disable(GL_CLIP_DISTANCE0);
    g.Disable(GL_CULL_FACE);
    g.Disable(GL_STENCIL_TEST);
  }

  // Hybrid stage 2 into main_color (bound through ar_out_fbo). A pixel can
  // only be inked where stage 1 drew a hybrid mesh (stencil 1) and
  // (8 + 8 lambda) q > threshold (ar_stage2.frag's exact bound). A software
  // rasteriser runs a fragment shader's every instruction on every pixel of a
  // block that is alive (discard does not skip the rest; branches are masks),
  // but skips blocks that fail the early depth/stencil tests. So the method
  // first marks the pixels that pass the bound (ar_mask.frag: depth written
  // as 0.5, a cheap pass over the hybrid pixels only) and then runs
  // the filter with depth test EQUAL: on the marked pixels only. The bare
  // pass gets the same stencil test. Output identical to the unmasked filter:
  // the mask is conservative and the filter repeats the exact tests.
  // `region`: the whole-image pixels the hybrid meshes can cover; the
  // passes are scissored to it (and to one pixel inside the target, so the
  // filter's neighbours all exist; the outer pixels are margin, never read
  // back), and skipped in tiles it misses.
  void hybrid_stage2(const HybridOptions& o, const Tile& t, const PixelRect& region, bool bare) {
    const GlFunctions& g = gl();
    const PixelRect r = tile_region(t, region);
    if (is_empty(r)) return;
    begin_stage2(ar_out_fbo, ar_color, t, r);
    if (!bare) {
      const ShaderProgram& m = program("ar_mask");
      m.use();
      m.set("u_data", 0);
      // Conservative by a relative 1e-4: stage 2 repeats the exact test.
      const double gain = 8.0 + 8.0 * o.lambda;
      const double min_q =
          o.lambda >= -0.5 ? o.threshold / gain - 1e-4 * std::abs(o.threshold / gain) - 1e-7 : -1.0;
      m.set("u_min_q", static_cast<float>(min_q));
      mark_pixels();
    }
    set_state_overlay();
    if (!bare) {
      // Only the marked pixels: stage 1 leaves no hybrid or background pixel
      // at depth 0.5 unless by chance, and those are filtered exactly anyway.
      g.Disable(GL_STENCIL_TEST);
      g.Enable(GL_DEPTH_TEST);
      g.DepthFunc(GL_EQUAL);
    }
    const ShaderProgram& p = program(bare ? "ar_bare2" : "ar2");
    p.use();
    p.set("u_data", 0);
    p.set("u_lambda", static_cast<float>(o.lambda));
    p.set("u_threshold", static_cast<float>(o.threshold));
    p.set("u_fade", o.fade ? 1 : 0);
    p.set("u_sign_free", o.sign_free ? 1 : 0);
    p.set("u_line_color", o.color.r, o.color.g, o.color.b, o.color.a);
    draw_fullscreen();
    g.Disable(GL_SCISSOR_TEST);
    g.Disable(GL_STENCIL_TEST);
    g.StencilMask(0xFF);
    g.DepthFunc(GL_LESS);
    g.Disable(GL_DEPTH_TEST);
  }

  // LIC stage 1 into lic_fbo (docs/algorithms.md §14): the LIC meshes'
  // front faces by lic_stage1 with depth test LEQUAL against depth_a, as the
  // opaque pass left it (the same vertex transform: only the visible
  // fragments pass, and every other opaque mesh occludes as it does there),
  // no depth writes. A pixel whose visible surface is another mesh or a back
  // face keeps the cleared (0, 0, 0, 0): mask 0.
  struct LicDraw {
    const GpuMesh* mesh;
    bool clipped = false;  // a context structure of a scene with a clip
    bool cut = false;      // a context structure of a frame with a cutaway
  };
  void lic_stage1(const std::vector<LicDraw>& draws, const Matrices& m, const Tile& t,
                  float inv_cell, int image_w, int image_h) {
    const GlFunctions& g = gl();
    ensure_lic();
    g.BindFramebuffer(GL_FRAMEBUFFER, lic_fbo);
    const GLenum color0 = GL_COLOR_ATTACHMENT0;
    g.DrawBuffers(1, &color0);
    g.Viewport(0, 0, t.render_w, t.render_h);
    set_state_opaque();
    g.ClearColor(0.0f, 0.0f, 0.0f, 0.0f);
    g.Clear(GL_COLOR_BUFFER_BIT);
    g.DepthFunc(GL_LEQUAL);
    g.DepthMask(GL_FALSE);
    g.Enable(GL_CULL_FACE);
    const Eigen::Matrix4f mvp = Eigen::Map<const Eigen::Matrix4f>(m.projection.data()) *
                                Eigen::Map<const Eigen::Matrix4f>(m.model_view.data());
    const ShaderProgram& p = program("lic1");
    p.use();
    set_common(p, m, t);
    p.set_mat4("u_mvp", mvp.data());
    p.set("u_image_size", static_cast<float>(image_w), static_cast<float>(image_h));
    p.set("u_inv_cell", inv_cell);
    for (const auto& d : draws) {
      set_clip(p, d.clipped, d.cut);
      draw_mesh(*d.mesh);
    }
    g.Disable(GL_CLIP_DISTANCE0);
    g.Disable(GL_CULL_FACE);
    g.DepthMask(GL_TRUE);
    g.DepthFunc(GL_LESS);
  }

  // LIC stage 2 into main_color (through lic_out_fbo), scissored to
  // `region`: as hybrid_stage2, a cheap pass first marks the pixels with a
  // mask > 0 by a depth write into lic_depth, then the
  // convolution runs with depth test EQUAL on those only. Multiplied into
  // the colour (blend DST_COLOR, ZERO), or with `value` written as is
  // ((v, mask, 0, 1), render_lic_buffer).
  void lic_stage2(const LicKernel& k, float strength, const Tile& t, const PixelRect& region,
                  bool value) {
    const GlFunctions& g = gl();
    const PixelRect r = tile_region(t, region);
    if (is_empty(r)) return;
    g.BindFramebuffer(GL_FRAMEBUFFER, lic_out_fbo);
    const GLenum color0 = GL_COLOR_ATTACHMENT0;
    g.DrawBuffers(1, &color0);
    g.Viewport(0, 0, t.render_w, t.render_h);
    g.Enable(GL_SCISSOR_TEST);
    g.Scissor(r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0);
    g.DepthMask(GL_TRUE);
    g.ClearDepth(1.0);
    g.Clear(GL_DEPTH_BUFFER_BIT);
    g.ActiveTexture(GL_TEXTURE0);
    g.BindTexture(GL_TEXTURE_2D, lic_color);
    const ShaderProgram& m = program("lic_mask");
    m.use();
    m.set("u_data", 0);
    mark_pixels();
    g.DepthFunc(GL_EQUAL);
    g.DepthMask(GL_FALSE);
    if (!value) {
      g.Enable(GL_BLEND);
      g.BlendFunc(GL_DST_COLOR, GL_ZERO);
    }
    const ShaderProgram& p = program(value ? "lic2_value" : "lic2");
    p.use();
    p.set("u_data", 0);
    p.set("u_steps", k.steps);
    p.set("u_step", k.step_px);
    p.set("u_gain", k.gain);
    p.set("u_strength", strength);
    p.set_array("u_weights", k.weights);
    draw_fullscreen();
    g.Disable(GL_SCISSOR_TEST);
    g.Disable(GL_BLEND);
    g.DepthMask(GL_TRUE);
    g.DepthFunc(GL_LESS);
    g.Disable(GL_DEPTH_TEST);
  }
  // The program a pass draws a structure with, switched (and given the
  // frame's common uniforms) only when it changes from one draw to the next.
  class ProgramSwitch {
   public:
    ProgramSwitch(Impl& impl, const FrameState& F, const Tile& t) : impl_(impl), F_(F), t_(t) {}
    const ShaderProgram& use(const char* key) {
      const ShaderProgram& p = impl_.program(key);
      if (&p != current_) {
        current_ = &p;
        p.use();
        impl_.set_common(p, F_.M, t_);
      }
      return p;
    }

   private:
    Impl& impl_;
    const FrameState& F_;
    const Tile& t_;
    const ShaderProgram* current_ = nullptr;
  };

  // ------------------------------------------------- Renderer::render passes
  // One frame of a scene: what the passes share, prepared once by
  // prepare_frame; then per tile one function per pass (render()).
  void pass_opaque(const FrameState& F, const Tile& t) {
    const GlFunctions& g = gl();
    const Scene& scene = F.scene;
    g.BindFramebuffer(GL_FRAMEBUFFER, main_fbo);
    const GLenum color0 = GL_COLOR_ATTACHMENT0;
    g.DrawBuffers(1, &color0);
    g.Viewport(0, 0, t.render_w, t.render_h);
    g.ClearColor(scene.background.r * F.bg_alpha, scene.background.g * F.bg_alpha,
                 scene.background.b * F.bg_alpha, F.bg_alpha);
    set_state_opaque();  // depth writes on, or Clear leaves the depth alone
    g.ClearDepth(1.0);
    g.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    ProgramSwitch programs(*this, F, t);
    for (std::size_t i = 0; i < scene.structures.size(); ++i) {
      const Structure& s = scene.structures[i];
      if (!opaque(s)) continue;
      const bool fill = s.style.shading != Shading::none;
      g.ColorMask(fill, fill, fill, fill);
      const ShaderProgram& p = programs.use(cut(F, s) ? "mesh" : "mesh_uncut");
      set_shading(p, s.style, 1.0f);
      set_clip(p, clipped(F, s), cut(F, s));
      set_cull(cullable(F, s));
      draw_mesh(*F.gpu[i]);
    }
    g.Disable(GL_CLIP_DISTANCE0);
    g.Disable(GL_CULL_FACE);
    g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  }

  // Surface LIC of the opaque structures with style.lic, multiplied into
  // their shading (before the ghosted structures are composited over it).
  void pass_lic(const FrameState& F, const Tile& t) {
    if (!F.any_lic || is_empty(tile_region(t, F.lic_region))) return;
    std::vector<LicDraw> draws;
    for (std::size_t i = 0; i < F.scene.structures.size(); ++i) {
      const Structure& s = F.scene.structures[i];
      if (opaque(s) && s.style.lic) draws.push_back({F.gpu[i], clipped(F, s), cut(F, s)});
    }
    lic_stage1(draws, F.M, t, F.lic_inv_cell, F.camera.width, F.camera.height);
    lic_stage2(F.lic_kernel, static_cast<float>(F.options.lic.strength), t, F.lic_region, false);
  }

  // A line batch's style (its structure's lines or a polyline layer's) and
  // full width in pixels of the picture.
  static const LineStyle& batch_style(const FrameState& F, const LineBatch& b) {
    const Structure& s = F.scene.structures[b.structure];
    return b.layer < 0 ? s.style.lines : s.polyline_layers[static_cast<std::size_t>(b.layer)].style;
  }
  static double batch_width(const FrameState& F, const LineBatch& b) {
    const LineStyle& ls = batch_style(F, b);
    return ls.width * (b.wide ? ls.contour_width_factor : 1.0) * F.line_scale;
  }
  // How far (pixels) the lines of structures that are not opaque reach from
  // their centre lines: the widest one's half width plus a pixel of
  // anti-aliasing (lines.vert).
  static double ghost_line_reach(const FrameState& F) {
    double reach = 0.0;
    for (const auto& b : F.batches)
      if (!opaque(F.scene.structures[b.structure]))
        reach = std::max(reach, 0.5 * batch_width(F, b) + 1.0);
    return std::isfinite(reach) ? reach : 0.0;
  }

  // Ghosted structures: weighted blended OIT, then composite.
  void pass_transparent(const FrameState& F, const Tile& t) {
    half_depth_is_a = false;
    if (!F.any_transparent) return;
    // Only where a ghosted structure can be: clear, accumulate and composite
    // scissored to that rectangle (outside it the composite would discard).
    const PixelRect r = tile_region(t, F.ghost_region);
    if (is_empty(r)) return;
    const GlFunctions& g = gl();
    // At half resolution: depth A copied down (nearest: one of each 2x2
    // pixels' depths), the accumulation drawn into half_w x half_h over the
    // same clip space, the scissor widened by a half pixel around r so
    // that the composite's bilinear taps read only cleared pixels.
    const bool half = F.ghost_half;
    PixelRect area = r;
    if (half) {
      ensure_oit_half();
      g.BindFramebuffer(GL_READ_FRAMEBUFFER, main_fbo);
      g.BindFramebuffer(GL_DRAW_FRAMEBUFFER, half_fbo);
      // Only what the ghosts and their lines can read: r widened by their
      // lines' reach (half width, anti-aliasing, the 5-tap cross at half
      // resolution), on even pixels (an exact 2:1 copy; a tile of odd size
      // is copied whole, as its last half pixel covers one).
      const int reach = static_cast<int>(std::ceil(ghost_line_reach(F))) + 4;
      if (t.render_w % 2 == 0 && t.render_h % 2 == 0) {
        const int x0 = std::max(0, (r.x0 - reach) & ~1), y0 = std::max(0, (r.y0 - reach) & ~1);
        const int x1 = std::min(t.render_w, (r.x1 + reach + 1) & ~1);
        const int y1 = std::min(t.render_h, (r.y1 + reach + 1) & ~1);
        g.BlitFramebuffer(x0, y0, x1, y1, x0 / 2, y0 / 2, x1 / 2, y1 / 2, GL_DEPTH_BUFFER_BIT,
                          GL_NEAREST);
      } else {
        g.BlitFramebuffer(0, 0, t.render_w, t.render_h, 0, 0, (t.render_w + 1) / 2,
                          (t.render_h + 1) / 2, GL_DEPTH_BUFFER_BIT, GL_NEAREST);
      }
      half_depth_is_a = true;
      g.BindFramebuffer(GL_FRAMEBUFFER, half_fbo);
      g.Viewport(0, 0, (t.render_w + 1) / 2, (t.render_h + 1) / 2);
      area = {std::max(0, r.x0 / 2 - 1), std::max(0, r.y0 / 2 - 1),
              std::min(half_w, (r.x1 + 1) / 2 + 1), std::min(half_h, (r.y1 + 1) / 2 + 1)};
    } else {
      ensure_oit();
      g.BindFramebuffer(GL_FRAMEBUFFER, oit_fbo);
    }
    // Scissored to where what it draws can be (ghosted structures, the fade
    // of cut opaque context), and to the cut's reach where only that is drawn.
    auto scissor = [&](bool cut_only) {
      PixelRect q = area;
      if (cut_only)
        q = {std::max(q.x0, cut_rect.x0), std::max(q.y0, cut_rect.y0), std::min(q.x1, cut_rect.x1),
             std::min(q.y1, cut_rect.y1)};
      g.Scissor(q.x0, q.y0, std::max(0, q.x1 - q.x0), std::max(0, q.y1 - q.y0));
    };
    if (F.ghost_depth_merged) {
      // The ghosts' nearest depth: cleared to the far plane everywhere
      // (their lines' taps may reach past the scissor), then blended by
      // GL_MIN (the depth test keeps only what is in front of depth A).
      const GLenum three[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
      g.DrawBuffers(3, three);
      const float far[4] = {1, 1, 1, 1};
      g.ClearBufferfv(GL_COLOR, 2, far);
    }
    // Cleared whole, not scissored (nothing outside the scissor is read):
    // a driver can then clear without drawing (llvmpipe marks its tiles).
    const float zero[4] = {0, 0, 0, 0};
    g.ClearBufferfv(GL_COLOR, 0, zero);
    g.ClearBufferfv(GL_COLOR, 1, zero);
    g.Enable(GL_SCISSOR_TEST);
    scissor(F.cut_fade_only);
    g.Enable(GL_DEPTH_TEST);
    g.DepthMask(GL_FALSE);
    g.Enable(GL_BLEND);
    g.BlendFunc(GL_ONE, GL_ONE);
    if (F.ghost_depth_merged) g.BlendEquationi(2, GL_MIN);
    ProgramSwitch programs(*this, F, t);
    for (std::size_t i = 0; i < F.scene.structures.size(); ++i) {
      const Structure& s = F.scene.structures[i];
      if (!in_transparency_pass(F, s)) continue;
      // Uncut, only ghosted structures (0 < opacity < 0.999) come here.
      const ShaderProgram& p = programs.use(cut(F, s) ? "mesh_oit" : "mesh_oit_uncut");
      if (!cut(F, s))
        p.set("u_reveal",
              -std::log(1.0f - std::clamp(static_cast<float>(s.style.opacity), 0.0f, 0.999f)));
      set_shading(p, s.style, static_cast<float>(s.style.opacity));
      set_clip(p, clipped(F, s), cut(F, s));
      scissor(F.cut_fade_only || opaque(s));
      draw_mesh(*F.gpu[i]);
    }
    g.Disable(GL_CLIP_DISTANCE0);
    if (F.ghost_depth_merged) {
      g.BlendEquation(GL_FUNC_ADD);  // every buffer's
      const GLenum two[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
      g.DrawBuffers(2, two);
    }
    g.BindFramebuffer(GL_FRAMEBUFFER, overlay_fbo);
    if (half) {
      g.Viewport(0, 0, t.render_w, t.render_h);
      area = r;
    }
    scissor(F.cut_fade_only);
    set_state_overlay();
    const ShaderProgram& c = program(half ? "oit_composite_half" : "oit_composite");
    c.use();
    g.ActiveTexture(GL_TEXTURE0);
    g.BindTexture(GL_TEXTURE_2D, half ? half_accum : accum);
    g.ActiveTexture(GL_TEXTURE1);
    g.BindTexture(GL_TEXTURE_2D, half ? half_reveal : reveal);
    c.set("u_accum", 0);
    c.set("u_reveal", 1);
    draw_fullscreen();
    g.ActiveTexture(GL_TEXTURE0);
    g.Disable(GL_SCISSOR_TEST);
  }

  // The cutaway (docs/algorithms.md §15), before anything context is drawn:
  // the focus structures' front depth, then the nearest focus pixel of
  // every pixel within reach by jump flooding (log2 of the reach passes and
  // one more of step 1), left bound to kCutSeedUnit and kCutDepthUnit for
  // the tile's passes (cutaway.glsl).
  void pass_cutaway(const FrameState& F, const Tile& t) {
    if (!F.cut) return;
    const GlFunctions& g = gl();
    ensure_cutaway();
    const Cutaway& c = F.scene.cutaway;
    const double scale = F.line_scale;
    cut_params = {static_cast<float>(c.margin_px * scale), static_cast<float>(c.fade_px * scale),
                  static_cast<float>(c.rim ? kCutawayRimPx * scale : 0.0)};
    cut_rim_color = c.rim_color;
    const int ox = t.x - t.margin, oy = t.y - t.margin;
    cut_rect = {std::max(0, F.cut_region.x0 - ox), std::max(0, F.cut_region.y0 - oy),
                std::min(t.render_w, F.cut_region.x1 - ox),
                std::min(t.render_h, F.cut_region.y1 - oy)};
    for (int unit : {kCutSeedUnit, kCutDepthUnit}) {  // drawn into below
      g.ActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + unit));
      g.BindTexture(GL_TEXTURE_2D, 0);
    }
    g.ActiveTexture(GL_TEXTURE0);
    // The focus's depth, and its pixels as seeds in both targets (no seed
    // elsewhere).
    g.BindFramebuffer(GL_FRAMEBUFFER, cut_fbo);
    g.Viewport(0, 0, t.render_w, t.render_h);
    set_state_opaque();
    g.ClearDepth(1.0);
    g.Clear(GL_DEPTH_BUFFER_BIT);
    const float none[4] = {-1.0f, -1.0f, 0.0f, 0.0f};
    g.ClearBufferfv(GL_COLOR, 0, none);
    g.ClearBufferfv(GL_COLOR, 1, none);
    const ShaderProgram& d = program("cut_seed");
    d.use();
    set_common(d, F.M, t);
    set_clip(d, false, false);
    // The picture's pixels in the tile: only they seed (tiling changes nothing).
    d.set("u_picture", static_cast<float>(-ox), static_cast<float>(-oy),
          static_cast<float>(F.camera.width - ox), static_cast<float>(F.camera.height - oy));
    for (std::size_t i = 0; i < F.scene.structures.size(); ++i)
      if (F.scene.structures[i].role == Role::focus) draw_mesh(*F.gpu[i]);
    // The flood: inside cut_rect, where no focus is drawn (depth 1).
    g.DepthFunc(GL_EQUAL);
    g.DepthMask(GL_FALSE);
    cut_scissor(true);
    const ShaderProgram& j = program("cut_jfa");
    j.use();
    j.set("u_input", 0);
    j.set("u_size", static_cast<float>(t.render_w), static_cast<float>(t.render_h));
    int current = 0;
    auto flood = [&](int step, GLuint input, int into) {
      g.BindFramebuffer(GL_FRAMEBUFFER, cut_seed_fbos[into]);
      g.BindTexture(GL_TEXTURE_2D, input);
      j.set("u_step", step);
      draw_fullscreen();
      current = into;
    };
    int step = 1;
    while (2.0 * step <= cutaway_reach(c, scale)) step *= 2;
    for (; step >= 1; step /= 2) flood(step, cut_seeds[current], 1 - current);
    flood(1, cut_seeds[current], 1 - current);
    cut_scissor(false);
    g.DepthFunc(GL_LESS);
    g.Disable(GL_DEPTH_TEST);
    g.BindTexture(GL_TEXTURE_2D, 0);
    g.ActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + kCutSeedUnit));
    g.BindTexture(GL_TEXTURE_2D, cut_seeds[current]);
    g.ActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + kCutDepthUnit));
    g.BindTexture(GL_TEXTURE_2D, cut_depth);
    g.ActiveTexture(GL_TEXTURE0);
    g.DepthMask(GL_TRUE);
    check_gl_error(g, "drawing the cutaway");
  }

  // Depth of every surface, for lines of ghosted structures.
  // With F.ghost_half at half resolution, into half_depth (depth A copied
  // down, unless the transparency pass left it there: the lines of ghosted
  // structures sample it at half their pixel coordinates, pass_lines).
  void pass_depth_b(const FrameState& F, const Tile& t) {
    if (!F.lines_need_depth_b) return;
    if (F.ghost_depth_merged) {  // drawn by the transparency pass; half_depth stays depth A
      half_depth_is_a = false;
      return;
    }
    const GlFunctions& g = gl();
    const int w = F.ghost_half ? (t.render_w + 1) / 2 : t.render_w;
    const int h = F.ghost_half ? (t.render_h + 1) / 2 : t.render_h;
    if (F.ghost_half)
      ensure_oit_half();
    else
      ensure_depth_b();
    const GLuint fbo = F.ghost_half ? half_fbo : depthb_fbo;
    if (!(F.ghost_half && half_depth_is_a)) {
      g.BindFramebuffer(GL_READ_FRAMEBUFFER, main_fbo);
      g.BindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo);
      g.BlitFramebuffer(0, 0, t.render_w, t.render_h, 0, 0, w, h, GL_DEPTH_BUFFER_BIT, GL_NEAREST);
    }
    half_depth_is_a = false;
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.Viewport(0, 0, w, h);
    set_state_opaque();
    g.ColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);  // half_fbo has colour targets
    ProgramSwitch programs(*this, F, t);
    for (std::size_t i = 0; i < F.scene.structures.size(); ++i) {
      const Structure& s = F.scene.structures[i];
      if (opaque(s)) continue;
      const ShaderProgram& p = programs.use(cut(F, s) ? "depth" : "depth_uncut");
      set_clip(p, clipped(F, s), cut(F, s));
      draw_mesh(*F.gpu[i]);
    }
    g.Disable(GL_CLIP_DISTANCE0);
    g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    g.Viewport(0, 0, t.render_w, t.render_h);
  }

  // Hybrid apparent ridges (where the tile meets the hybrid meshes).
  void pass_hybrid(const FrameState& F, const Tile& t) {
    if (!F.any_hybrid || is_empty(tile_region(t, F.hybrid_region))) return;
    std::vector<HybridDraw> draws;
    for (std::size_t i = 0; i < F.scene.structures.size(); ++i) {
      const Structure& s = F.scene.structures[i];
      if (s.style.hybrid_apparent_ridges)
        draws.push_back({F.gpu[i], hybrid_scale(*s.mesh, F.options.hybrid), false, clipped(F, s),
                         opaque(s) && cullable(F, s), cut(F, s)});
      else if (opaque(s))
        draws.push_back({F.gpu[i], 1.0f, true, clipped(F, s), cullable(F, s), cut(F, s)});
    }
    hybrid_stage1(draws, F.options.hybrid, F.M, t, false);
    hybrid_stage2(F.options.hybrid, t, F.hybrid_region, false);
  }

  // Lines as quads, depth-tested against depth A (opaque) or B (ghosted).
  void pass_lines(const FrameState& F, const Tile& t) {
    if (F.batches.empty()) return;
    const GlFunctions& g = gl();
    g.BindFramebuffer(GL_FRAMEBUFFER, overlay_fbo);  // depth A is sampled, not attached
    g.Viewport(0, 0, t.render_w, t.render_h);
    set_state_overlay();
    const ShaderProgram& p = program("lines");
    p.use();
    set_common(p, F.M, t);
    p.set("u_image_size", static_cast<float>(F.camera.width), static_cast<float>(F.camera.height));
    p.set("u_px_per_mm", static_cast<float>(F.M.px_per_mm));
    p.set("u_near_far", F.M.near_plane, F.M.far_plane);
    p.set("u_depth_tolerance", static_cast<float>(F.tolerance));
    p.set("u_aa_margin", F.options.tight_line_quads ? 0.5f : 1.0f);
    p.set("u_depth", 0);
    p.set("u_depth2", 1);
    g.ActiveTexture(GL_TEXTURE0);
    g.BindVertexArray(line_vao);
    for (const auto& b : F.batches) {
      const Structure& s = F.scene.structures[b.structure];
      const LineStyle& ls = batch_style(F, b);
      const bool half = F.ghost_half && !opaque(s);
      g.BindTexture(GL_TEXTURE_2D, opaque(s) ? depth_a : half ? half_depth : depth_b);
      p.set("u_depth_shift", half ? 1 : 0);
      // Merged: depth B is the nearer of depth A (half_depth) and the ghosts'.
      const bool two = half && F.ghost_depth_merged;
      p.set("u_two_depths", two ? 1 : 0);
      if (two) {
        g.ActiveTexture(GL_TEXTURE1);
        g.BindTexture(GL_TEXTURE_2D, half_ghost_depth);
        g.ActiveTexture(GL_TEXTURE0);
      }
      p.set("u_width", static_cast<float>(batch_width(F, b)));
      p.set("u_taper", static_cast<float>(ls.taper));
      p.set("u_width_by_strength", ls.width_by_strength ? 1 : 0);
      p.set("u_line_color", ls.color.r, ls.color.g, ls.color.b, ls.color.a);
      p.set("u_fade_by_strength", ls.fade_by_strength ? 1 : 0);
      p.set("u_hidden_mode", static_cast<int>(ls.hidden));
      p.set("u_hidden_opacity", static_cast<float>(ls.hidden_opacity));
      p.set("u_dash_px", static_cast<float>(ls.dash * F.line_scale));
      set_clip(p, clipped(F, s), cut(F, s));
      g.DrawElements(GL_TRIANGLES, b.count, GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(std::size_t(b.first) * sizeof(std::uint32_t)));
    }
    g.Disable(GL_CLIP_DISTANCE0);
  }

  static bool opaque(const Structure& s) { return s.style.opacity >= 0.999; }
  // Drawn by the transparency pass.
  static bool ghosted(const Structure& s) {
    return !opaque(s) && s.style.shading != Shading::none && s.style.opacity > 0.0;
  }
  // Back faces of an opaque focus structure can be culled when its mesh is
  // closed and outward (RenderMesh::closed_outward) and the near plane does
  // not reach its bounding sphere: every pixel then sees a front face first,
  // so the picture is the same with half the triangles rasterised
  // (docs/algorithms.md §16). Context structures are never culled: the
  // clipping plane (and any cutaway) opens them.
  static bool cullable(const FrameState& F, const Structure& s) {
    if (!s.mesh->closed_outward || s.role != Role::focus) return false;
    const double depth = F.camera.forward().dot(s.mesh->center - F.camera.eye);
    return depth - s.mesh->radius > F.M.near_plane;
  }
  void set_cull(bool cull) {
    if (cull)
      gl().Enable(GL_CULL_FACE);  // GL_BACK of counter-clockwise front faces: the defaults
    else
      gl().Disable(GL_CULL_FACE);
  }
  // Context structures lose the far side of the scene's clipping plane.
  static bool clipped(const FrameState& F, const Structure& s) {
    return F.scene.clip && s.role == Role::context;
  }
  // Context structures lose what is in front of the focus (pass_cutaway).
  static bool cut(const FrameState& F, const Structure& s) {
    return F.cut && s.role == Role::context;
  }
  // What the transparency pass draws: ghosted structures, and the fade of
  // the cut of opaque context with a cutaway (mesh_oit.frag).
  static bool in_transparency_pass(const FrameState& F, const Structure& s) {
    return ghosted(s) || (opaque(s) && cut(F, s) && s.style.shading != Shading::none);
  }

  void set_shading(const ShaderProgram& p, const StructureStyle& st, float alpha) {
    p.set("u_shading", st.shading == Shading::lambert ? 1 : st.shading == Shading::toon ? 2 : 0);
    p.set("u_color", st.color.r, st.color.g, st.color.b, alpha);
    p.set("u_ambient", static_cast<float>(st.ambient));
    p.set("u_toon_levels", st.toon_levels);
  }

  // The line geometry: one strip per polyline, batched per structure and
  // style: the polyline layers first (under), then the feature lines per
  // width class; uploaded into line_vbo/line_ebo.
  // Writes `bytes` into the buffer bound to `target`, whose store has
  // `capacity` bytes: a new store (half as large again) only when it does
  // not fit, else into the one it has, so a viewer's every frame does not
  // allocate (and the driver fault in) a fresh one.
  void upload_growing(GLenum target, const void* data, std::size_t bytes, std::size_t& capacity) {
    const GlFunctions& g = gl();
    if (bytes > capacity) {
      capacity = bytes + bytes / 2;
      g.BufferData(target, static_cast<GLsizeiptr>(capacity), nullptr, GL_DYNAMIC_DRAW);
    }
    g.BufferSubData(target, 0, static_cast<GLsizeiptr>(bytes), data);
  }

  std::vector<LineBatch> upload_lines(const Scene& scene) {
    const GlFunctions& g = gl();
    // Kept between frames (a viewer uploads every frame): cleared, not freed.
    std::vector<float>& line_vertices = line_vertex_scratch;
    std::vector<std::uint32_t>& line_indices = line_index_scratch;
    std::vector<double>& arc = arc_scratch;
    line_vertices.clear();
    line_indices.clear();
    std::vector<LineBatch> batches;
    // Appends polyline `n` vertices long; position(i) and strength(i) give its vertices.
    // Written in place (the arrays grow once per polyline, not per value):
    // per polyline vertex two quad corners (sides -1 and 1) of kLineVertexFloats
    // each: position, previous, next, then side, strength, arc length, total.
    auto append_polyline = [&](std::size_t n, bool closed, auto position, auto strength) {
      if (n < 2) return;
      closed = closed && n >= 3;
      arc.assign(n, 0.0);
      for (std::size_t i = 1; i < n; ++i)
        arc[i] = arc[i - 1] + (position(i) - position(i - 1)).norm();
      const auto total = static_cast<float>(closed ? 0.0 : arc.back());
      const auto base = static_cast<std::uint32_t>(line_vertices.size() / kLineVertexFloats);
      const std::size_t v0 = line_vertices.size();
      line_vertices.resize(v0 + 2 * kLineVertexFloats * n);
      float* out = line_vertices.data() + v0;
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3 p = position(i);
        const Vec3 prev = i > 0 ? position(i - 1) : (closed ? position(n - 1) : p);
        const Vec3 next = i + 1 < n ? position(i + 1) : (closed ? position(0) : p);
        const float s = strength(i), a = static_cast<float>(arc[i]);
        for (float side : {-1.0f, 1.0f}) {
          for (const Vec3* v : {&p, &prev, &next})
            for (int c = 0; c < 3; ++c) *out++ = static_cast<float>((*v)[c]);
          *out++ = side;
          *out++ = s;
          *out++ = a;
          *out++ = total;
        }
      }
      const std::size_t segments = n - 1 + (closed ? 1 : 0);
      const std::size_t i0 = line_indices.size();
      line_indices.resize(i0 + 6 * segments);
      std::uint32_t* idx = line_indices.data() + i0;
      auto segment = [&](std::uint32_t a, std::uint32_t b) {
        const std::uint32_t a0 = base + 2 * a, a1 = a0 + 1, b0 = base + 2 * b, b1 = b0 + 1;
        for (std::uint32_t v : {a0, a1, b0, a1, b1, b0}) *idx++ = v;
      };
      for (std::size_t i = 0; i + 1 < n; ++i)
        segment(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(i + 1));
      if (closed) segment(static_cast<std::uint32_t>(n - 1), 0);
    };
    auto close_batch = [&](LineBatch batch) {
      batch.count = static_cast<GLsizei>(line_indices.size()) - batch.first;
      if (batch.count > 0) batches.push_back(batch);
    };
    for (std::size_t si = 0; si < scene.structures.size(); ++si) {
      const Structure& s = scene.structures[si];
      for (std::size_t li = 0; li < s.polyline_layers.size(); ++li) {
        const LineBatch batch{si, false, static_cast<int>(li),
                              static_cast<GLsizei>(line_indices.size()), 0};
        for (const std::vector<Vec3>& pl : s.polyline_layers[li].polylines)
          append_polyline(
              pl.size(), false, [&](std::size_t i) { return pl[i]; },
              [](std::size_t) { return 1.0f; });
        close_batch(batch);
      }
      for (int wide = 0; wide < 2; ++wide) {
        const LineBatch batch{si, wide == 1, -1, static_cast<GLsizei>(line_indices.size()), 0};
        for (const Polyline& pl : s.drawn_lines().polylines) {
          if (is_wide_family(pl.family) != (wide == 1)) continue;
          if (!s.style.families.empty() &&
              std::find(s.style.families.begin(), s.style.families.end(), pl.family) ==
                  s.style.families.end())
            continue;
          append_polyline(
              pl.vertices.size(), pl.closed, [&](std::size_t i) { return pl.vertices[i].position; },
              [&](std::size_t i) { return pl.vertices[i].strength; });
        }
        close_batch(batch);
      }
    }
    if (!batches.empty()) {
      g.BindVertexArray(line_vao);
      g.BindBuffer(GL_ARRAY_BUFFER, line_vbo);
      upload_growing(GL_ARRAY_BUFFER, line_vertices.data(), line_vertices.size() * sizeof(float),
                     line_vbo_bytes);
      const auto stride = static_cast<GLsizei>(kLineVertexFloats * sizeof(float));
      for (GLuint loc = 0; loc < 4; ++loc) {
        g.EnableVertexAttribArray(loc);
        g.VertexAttribPointer(loc, loc == 3 ? 4 : 3, GL_FLOAT, GL_FALSE, stride,
                              reinterpret_cast<const void*>(std::size_t(loc) * 3 * sizeof(float)));
      }
      g.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, line_ebo);
      upload_growing(GL_ELEMENT_ARRAY_BUFFER, line_indices.data(),
                     line_indices.size() * sizeof(std::uint32_t), line_ebo_bytes);
      g.BindVertexArray(0);
    }
    return batches;
  }
};

Renderer::Renderer(std::unique_ptr<GlContext> context) {
  if (!context) throw Error(ErrorKind::internal, "Renderer needs a GL context");
  impl_ = std::make_unique<Impl>(std::move(context));
}

Renderer::~Renderer() = default;

GlContext& Renderer::context() {
  return *impl_->ctx;
}

Image Renderer::render(const Scene& scene, const Camera& camera, const RenderOptions& options) {
  Image image(camera.width, camera.height);
  draw(scene, camera, options, &image, nullptr);
  return image;
}

void Renderer::render_to_framebuffer(const Scene& scene, const Camera& camera,
                                     const RenderOptions& options, unsigned int framebuffer,
                                     int width, int height) {
  if (width <= 0 || height <= 0)
    throw InputError("render_to_framebuffer: the target size must be positive");
  const BlitTarget target{framebuffer, width, height};
  draw(scene, camera, options, nullptr, &target);
}

void Renderer::draw(const Scene& scene, const Camera& camera, const RenderOptions& options,
                    Image* out, const BlitTarget* blit) {
  check_size(camera);
  if (scene.structures.empty()) throw InputError("the scene has no structures to draw");
  for (const auto& s : scene.structures)
    if (!s.mesh || s.mesh->vertex_count() == 0 || s.mesh->triangle_count() == 0)
      throw InputError("structure '" + s.name + "' has no mesh to draw");
  Impl& I = *impl_;
  I.ctx->make_current();

  // Scene bounding sphere (enclosing every structure's sphere).
  Vec3 center = scene.structures.front().mesh->center;
  double radius = scene.structures.front().mesh->radius;
  for (const auto& s : scene.structures) {
    const Vec3 d = s.mesh->center - center;
    const double dist = d.norm();
    if (dist + s.mesh->radius <= radius) continue;
    if (dist + radius <= s.mesh->radius) {
      center = s.mesh->center;
      radius = s.mesh->radius;
      continue;
    }
    const double new_r = 0.5 * (dist + radius + s.mesh->radius);
    center += d / dist * (new_r - radius);
    radius = new_r;
  }
  // Lines may leave the meshes' spheres (e.g. offset strokes): include them.
  auto enclose = [&](const Vec3& p) {
    const double d = (p - center).norm();
    if (d > radius) {
      const double new_r = 0.5 * (d + radius);
      center += (p - center) / d * (new_r - radius);
      radius = new_r;
    }
  };
  for (const auto& s : scene.structures) {
    for (const auto& pl : s.drawn_lines().polylines)
      for (const auto& v : pl.vertices) enclose(v.position);
    for (const auto& layer : s.polyline_layers)
      for (const auto& pl : layer.polylines)
        for (const Vec3& p : pl) enclose(p);
  }
  FrameState F(scene, camera, options);
  F.M = camera_matrices(camera, center, radius);

  F.tolerance = options.depth_tolerance;
  if (!(F.tolerance > 0.0)) {
    double edge = 0.0;
    for (const auto& s : scene.structures) edge = std::max(edge, s.mesh->mean_edge_length);
    F.tolerance = edge + 0.002 * radius;
  }
  F.line_scale = options.scale_lines_with_image ? std::min(camera.width, camera.height) /
                                                      std::max(1.0, options.line_reference_size)
                                                : 1.0;

  // Upload meshes; classify structures.
  validate(options.lic, "render options: lic");
  double lic_radius = 0.0;
  for (const auto& s : scene.structures) {
    F.gpu.push_back(&I.gpu_mesh(s.mesh));
    if (s.style.opacity < 0.999) F.any_transparent = true;
    if (s.style.hybrid_apparent_ridges) {
      if (!s.mesh->has_curvature())
        throw InputError("structure '" + s.name +
                         "': hybrid apparent ridges need per-vertex curvature");
      F.any_hybrid = true;
    }
    if (s.style.lic && Impl::opaque(s)) {
      if (!s.mesh->has_lic_field())
        throw InputError("structure '" + s.name +
                         "': LIC needs the mesh's direction field (RenderMesh::lic_field)");
      F.any_lic = true;
      lic_radius = std::max(lic_radius, s.mesh->radius);
    }
  }
  F.cut = cutaway_applies(scene);
  if (F.cut) {  // the fade of a cut is blended (pass_transparent)
    F.cut_fade_only = !F.any_transparent;
    F.any_transparent = true;
  }
  F.batches = I.upload_lines(scene);
  for (const auto& b : F.batches)
    if (!Impl::opaque(scene.structures[b.structure])) F.lines_need_depth_b = true;

  // Tiles: with LIC, margins as wide as the kernel reaches.
  int margin = kTileMargin;
  if (F.any_lic) {
    RenderMesh probe;
    probe.radius = lic_radius;
    const double cell = lic_noise_cell(probe, options.lic);
    F.lic_inv_cell = static_cast<float>(1.0 / cell);
    F.lic_kernel = lic_kernel(options.lic, cell, F.M.px_per_mm);
    margin = std::max(
        margin, static_cast<int>(std::ceil(F.lic_kernel.steps * double(F.lic_kernel.step_px))) + 2);
  }
  // With a cutaway and several tiles, margins as wide as it reaches (one
  // tile sees the whole picture: the cut seeds only on the picture's pixels).
  if (F.cut) {
    const int one = I.tile_inner_size(options.max_tile_size, margin);
    if (camera.width > one || camera.height > one)
      margin = std::max(margin, cutaway_margin(scene.cutaway, F.line_scale));
  }
  const int inner = I.tile_inner_size(options.max_tile_size, margin);
  const auto tiles = make_tiles(camera.width, camera.height, inner, margin);

  I.ensure_main_for(tiles);

  auto region_of = [&](auto&& selected) {
    std::vector<const RenderMesh*> meshes;
    for (const auto& s : scene.structures)
      if (selected(s)) meshes.push_back(s.mesh.get());
    return projected_rect(F.M, meshes, camera.width, camera.height);
  };
  if (F.any_transparent)
    F.ghost_region =
        region_of([&F](const Structure& s) { return Impl::in_transparency_pass(F, s); });
  if (F.any_hybrid)
    F.hybrid_region = region_of([](const Structure& s) { return s.style.hybrid_apparent_ridges; });
  if (F.any_lic)
    F.lic_region = region_of([](const Structure& s) { return s.style.lic && Impl::opaque(s); });
  if (F.cut) {  // the focus's vertices' box: tighter than its sphere
    std::vector<BoundingBox> boxes;
    for (const auto& s : scene.structures) {
      if (s.role != Role::focus) continue;
      const std::vector<float>& p = s.mesh->positions;
      BoundingBox b{Vec3::Constant(1e300), Vec3::Constant(-1e300)};
      for (std::size_t i = 0; i + 2 < p.size(); i += 3) {
        const Vec3 v(p[i], p[i + 1], p[i + 2]);
        b.min = b.min.cwiseMin(v);
        b.max = b.max.cwiseMax(v);
      }
      boxes.push_back(b);
    }
    const PixelRect r = projected_boxes(F.M, boxes, camera.width, camera.height);
    const int reach = static_cast<int>(std::ceil(cutaway_reach(scene.cutaway, F.line_scale))) + 2;
    F.cut_region = {r.x0 - reach, r.y0 - reach, r.x1 + reach, r.y1 + reach};
  }

  if (blit != nullptr && tiles.size() != 1)
    throw InputError("render_to_framebuffer: the picture must fit one tile (" +
                     std::to_string(inner) + " pixels a side)");
  if (scene.clip) {
    const Vec3 n = -scene.clip->normal;  // kept: -n . (p - point) >= 0
    I.clip = {static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()),
              static_cast<float>(-n.dot(scene.clip->point))};
  }
  F.bg_alpha = options.transparent_background ? 0.0f : scene.background.a;
  // Half-resolution ghosts: one tile, no cutaway (its fade is per pixel).
  F.ghost_half = options.ghosts_half_resolution && tiles.size() == 1 && !F.cut;
  // The ghosts' depth with their transparency: when every structure the
  // depth pass would draw (all not opaque) is one the transparency pass
  // draws, and that pass runs (the ghosts reach into the picture).
  F.ghost_depth_merged =
      F.ghost_half && F.lines_need_depth_b && I.ghost_depth_in_one_pass() && F.any_transparent &&
      !is_empty(F.ghost_region) &&
      std::all_of(scene.structures.begin(), scene.structures.end(),
                  [](const Structure& s) { return Impl::opaque(s) || Impl::ghosted(s); });
  const GlFunctions& g = I.gl();
  for (const Tile& t : tiles) {
    I.pass_cutaway(F, t);
    I.pass_opaque(F, t);
    I.pass_lic(F, t);
    I.pass_transparent(F, t);
    I.pass_depth_b(F, t);
    I.pass_hybrid(F, t);
    I.pass_lines(F, t);
    check_gl_error(g, "drawing the scene");
    if (out != nullptr) I.read_tile(I.main_fbo, t, camera.height, *out, true);
  }
  if (blit != nullptr) {
    // On the GPU: no read back, no upload (the viewer's window).
    const Tile& t = tiles.front();
    g.BindFramebuffer(GL_READ_FRAMEBUFFER, I.main_fbo);
    g.ReadBuffer(GL_COLOR_ATTACHMENT0);
    g.BindFramebuffer(GL_DRAW_FRAMEBUFFER, blit->framebuffer);
    const bool same = blit->width == t.w && blit->height == t.h;
    g.BlitFramebuffer(t.margin, t.margin, t.margin + t.w, t.margin + t.h, 0, 0, blit->width,
                      blit->height, GL_COLOR_BUFFER_BIT, same ? GL_NEAREST : GL_LINEAR);
    check_gl_error(g, "copying the picture");
  }
  g.BindVertexArray(0);
  g.BindFramebuffer(GL_FRAMEBUFFER, 0);
}

Image Renderer::render_hybrid(const std::shared_ptr<const RenderMesh>& mesh, const Camera& camera,
                              const HybridOptions& options, bool transparent, bool bare,
                              HybridFrameProfile* profile) {
  check_size(camera);
  if (!mesh || !mesh->has_curvature())
    throw InputError("hybrid apparent ridges need a mesh with per-vertex curvature");
  Impl& I = *impl_;
  I.ctx->make_current();
  const GlFunctions& g = I.gl();
  const Matrices M = camera_matrices(camera, mesh->center, mesh->radius);
  const GpuMesh& gm = I.gpu_mesh(mesh);
  const float scale = hybrid_scale(*mesh, options);
  const PixelRect region = projected_rect(M, {mesh.get()}, camera.width, camera.height);
  const auto tiles = make_tiles(camera.width, camera.height, I.tile_inner_size(0));
  I.ensure_main_for(tiles);
  Image image(camera.width, camera.height);
  GLuint queries[2] = {0, 0};
  if (profile) g.GenQueries(2, queries);
  using clock = std::chrono::steady_clock;
  auto lap = [&](clock::time_point& since, double& into) {
    g.Finish();
    const auto now = clock::now();
    into += std::chrono::duration<double, std::milli>(now - since).count();
    since = now;
  };
  for (const Tile& t : tiles) {
    auto since = clock::now();
    if (profile) g.BeginQuery(GL_TIME_ELAPSED, queries[0]);
    I.hybrid_stage1({{&gm, scale, false}}, options, M, t, bare);
    if (profile) {
      g.EndQuery(GL_TIME_ELAPSED);
      lap(since, profile->stage1_ms);
      g.BeginQuery(GL_TIME_ELAPSED, queries[1]);
    }
    g.BindFramebuffer(GL_FRAMEBUFFER, I.main_fbo);
    const GLenum color0 = GL_COLOR_ATTACHMENT0;
    g.DrawBuffers(1, &color0);
    g.Viewport(0, 0, t.render_w, t.render_h);
    const float a = transparent ? 0.0f : 1.0f;
    g.ClearColor(a, a, a, a);
    g.Clear(GL_COLOR_BUFFER_BIT);
    I.hybrid_stage2(options, t, region, bare);
    if (profile) {
      g.EndQuery(GL_TIME_ELAPSED);
      lap(since, profile->stage2_ms);
    }
    I.read_tile(I.main_fbo, t, camera.height, image, true);
    if (profile) {
      lap(since, profile->readback_ms);
      GLuint64 ns[2] = {0, 0};
      g.GetQueryObjectui64v(queries[0], GL_QUERY_RESULT, &ns[0]);
      g.GetQueryObjectui64v(queries[1], GL_QUERY_RESULT, &ns[1]);
      profile->stage1_gpu_ms += 1e-6 * static_cast<double>(ns[0]);
      profile->stage2_gpu_ms += 1e-6 * static_cast<double>(ns[1]);
    }
  }
  if (profile) {
    g.DeleteQueries(2, queries);
    check_gl_error(g, "timing the hybrid stages");
  }
  g.BindVertexArray(0);
  g.BindFramebuffer(GL_FRAMEBUFFER, 0);
  return image;
}

Image Renderer::render_hybrid_buffer(const std::shared_ptr<const RenderMesh>& mesh,
                                     const Camera& camera, const HybridOptions& options) {
  check_size(camera);
  if (!mesh || !mesh->has_curvature())
    throw InputError("hybrid apparent ridges need a mesh with per-vertex curvature");
  Impl& I = *impl_;
  I.ctx->make_current();
  const Matrices M = camera_matrices(camera, mesh->center, mesh->radius);
  const GpuMesh& gm = I.gpu_mesh(mesh);
  const auto tiles = make_tiles(camera.width, camera.height, I.tile_inner_size(0));
  I.ensure_main_for(tiles);
  Image image(camera.width, camera.height);
  for (const Tile& t : tiles) {
    I.hybrid_stage1({{&gm, hybrid_scale(*mesh, options), false}}, options, M, t, false);
    I.read_tile(I.ar_fbo, t, camera.height, image, false);
  }
  I.gl().BindFramebuffer(GL_FRAMEBUFFER, 0);
  return image;
}

Image Renderer::render_lic_buffer(const std::shared_ptr<const RenderMesh>& mesh,
                                  const Camera& camera, const LicOptions& options) {
  check_size(camera);
  validate(options);
  if (!mesh || !mesh->has_lic_field())
    throw InputError("LIC needs a mesh with its direction field (RenderMesh::lic_field)");
  Impl& I = *impl_;
  I.ctx->make_current();
  const GlFunctions& g = I.gl();
  const Matrices M = camera_matrices(camera, mesh->center, mesh->radius);
  const GpuMesh& gm = I.gpu_mesh(mesh);
  const double cell = lic_noise_cell(*mesh, options);
  const LicKernel kernel = lic_kernel(options, cell, M.px_per_mm);
  const int margin =
      std::max(kTileMargin, static_cast<int>(std::ceil(kernel.steps * double(kernel.step_px))) + 2);
  const auto tiles = make_tiles(camera.width, camera.height, I.tile_inner_size(0, margin), margin);
  I.ensure_main_for(tiles);
  const PixelRect region = projected_rect(M, {mesh.get()}, camera.width, camera.height);
  Image image(camera.width, camera.height);
  for (const Tile& t : tiles) {
    // The depth the opaque pass would leave (mesh.vert), then stage 1 on it.
    g.BindFramebuffer(GL_FRAMEBUFFER, I.main_fbo);
    const GLenum color0 = GL_COLOR_ATTACHMENT0;
    g.DrawBuffers(1, &color0);
    g.Viewport(0, 0, t.render_w, t.render_h);
    I.set_state_opaque();
    g.ClearColor(0.0f, 0.0f, 0.0f, 0.0f);
    g.ClearDepth(1.0);
    g.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    g.ColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    const ShaderProgram& depth = I.program("mesh");
    depth.use();
    I.set_common(depth, M, t);
    I.set_clip(depth, false);
    I.draw_mesh(gm);
    g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    I.lic_stage1({{&gm, false}}, M, t, static_cast<float>(1.0 / cell), camera.width, camera.height);
    g.BindFramebuffer(GL_FRAMEBUFFER, I.main_fbo);
    g.Viewport(0, 0, t.render_w, t.render_h);
    I.lic_stage2(kernel, static_cast<float>(options.strength), t, region, true);
    check_gl_error(g, "drawing the LIC buffer");
    I.read_tile(I.main_fbo, t, camera.height, image, false);
  }
  g.BindVertexArray(0);
  g.BindFramebuffer(GL_FRAMEBUFFER, 0);
  return image;
}

}  // namespace fabrica::render
