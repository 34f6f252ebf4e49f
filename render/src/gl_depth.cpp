#include "fabrica/render/gl_depth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/render/shader.hpp"

namespace fabrica::render {

namespace {

// Linear eye depth -e.z of the view-space position, interpolated
// perspective-correctly; the depth test keeps the nearest, as the CPU
// raster's minimum.
constexpr const char* kVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
uniform mat4 u_model_view;
uniform mat4 u_projection;
out float v_depth;
void main() {
  vec4 e = u_model_view * vec4(a_position, 1.0);
  v_depth = -e.z;
  gl_Position = u_projection * e;
}
)";
constexpr const char* kFragment = R"(#version 330 core
in float v_depth;
layout(location = 0) out float o_depth;
void main() { o_depth = v_depth; }
)";

}  // namespace

struct GlDepthRenderer::Impl {
  GlContext* context;
  Vec3 center;
  double radius = 0.0;
  GLsizei index_count = 0;
  GLuint vao = 0, vbo = 0, ebo = 0;
  GLuint fbo = 0, color = 0, depth = 0;
  int width = 0, height = 0;
  ShaderProgram program;
  std::vector<float> rows;

  const GlFunctions& gl() const { return context->gl(); }

  void release_targets() {
    const GlFunctions& g = gl();
    if (fbo) g.DeleteFramebuffers(1, &fbo);
    if (color) g.DeleteTextures(1, &color);
    if (depth) g.DeleteRenderbuffers(1, &depth);
    fbo = color = depth = 0;
    width = height = 0;
  }

  void ensure_targets(int w, int h) {
    if (w == width && h == height && fbo) return;
    release_targets();
    const GlFunctions& g = gl();
    g.GenTextures(1, &color);
    g.BindTexture(GL_TEXTURE_2D, color);
    g.TexImage2D(GL_TEXTURE_2D, 0, GL_R32F, w, h, 0, GL_RED, GL_FLOAT, nullptr);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    g.GenRenderbuffers(1, &depth);
    g.BindRenderbuffer(GL_RENDERBUFFER, depth);
    g.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, w, h);
    g.GenFramebuffers(1, &fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color, 0);
    g.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    check_gl_error(g, "allocating the depth target");
    const GLenum status = g.CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
      throw Error(ErrorKind::unavailable,
                  "the OpenGL driver cannot create the depth framebuffer (status " +
                      std::to_string(status) + ")");
    width = w;
    height = h;
  }
};

GlDepthRenderer::GlDepthRenderer(GlContext& context, const TriangleMesh& mesh)
    : impl_(std::make_unique<Impl>()) {
  if (mesh.faces.empty() || mesh.positions.empty())
    throw InputError("GL depth buffer: the mesh has no faces; give a mesh with triangles");
  Impl& I = *impl_;
  I.context = &context;
  context.make_current();
  const GlFunctions& g = context.gl();
  const BoundingBox box = bounding_box(mesh.positions);
  I.center = box.center();
  I.radius = std::max(0.5 * box.diagonal(), 1e-9);
  // Relative to the centre: float keeps ~1e-7 of the mesh's size, not of
  // its distance from the origin.
  std::vector<float> xyz(3 * mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    for (int k = 0; k < 3; ++k)
      xyz[3 * i + k] = static_cast<float>(mesh.positions[i][k] - I.center[k]);
  static_assert(sizeof(Face) == 3 * sizeof(GLuint));
  I.index_count = static_cast<GLsizei>(3 * mesh.faces.size());
  g.GenVertexArrays(1, &I.vao);
  g.BindVertexArray(I.vao);
  g.GenBuffers(1, &I.vbo);
  g.BindBuffer(GL_ARRAY_BUFFER, I.vbo);
  g.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(xyz.size() * sizeof(float)), xyz.data(),
               GL_STATIC_DRAW);
  g.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  g.EnableVertexAttribArray(0);
  g.GenBuffers(1, &I.ebo);
  g.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, I.ebo);
  g.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.faces.size() * sizeof(Face)),
               mesh.faces.data(), GL_STATIC_DRAW);
  g.BindVertexArray(0);
  check_gl_error(g, "uploading the mesh");
  I.program = ShaderProgram(g, "gl_depth",
                            {ShaderStage{GL_VERTEX_SHADER, {{"gl_depth.vert", kVertex}}},
                             ShaderStage{GL_FRAGMENT_SHADER, {{"gl_depth.frag", kFragment}}}});
}

GlDepthRenderer::~GlDepthRenderer() {
  Impl& I = *impl_;
  I.context->make_current();
  const GlFunctions& g = I.gl();
  I.release_targets();
  if (I.ebo) g.DeleteBuffers(1, &I.ebo);
  if (I.vbo) g.DeleteBuffers(1, &I.vbo);
  if (I.vao) g.DeleteVertexArrays(1, &I.vao);
}

void GlDepthRenderer::render(const Camera& camera, DepthBuffer& out) {
  Impl& I = *impl_;
  const int w = camera.width, h = camera.height;
  const int limit = I.context->max_framebuffer_size();
  if (w < 1 || h < 1 || w > limit || h > limit)
    throw InputError("GL depth buffer: image size " + std::to_string(w) + "x" + std::to_string(h) +
                     " is not between 1 and " + std::to_string(limit) +
                     " pixels per side (this GL driver's limit); choose a smaller size");
  const GlFunctions& g = I.gl();
  I.ensure_targets(w, h);
  // The camera's matrices with the upload's centre moved back in.
  const auto [n, f] = clip_planes(camera, I.center, I.radius);
  Eigen::Matrix4d view = view_matrix(camera);
  view.col(3) += view.topLeftCorner<4, 3>() * I.center;
  const Eigen::Matrix4f mv = view.cast<float>();
  const Eigen::Matrix4f proj = projection_matrix(camera, n, f).cast<float>();
  g.BindFramebuffer(GL_FRAMEBUFFER, I.fbo);
  g.Viewport(0, 0, w, h);
  g.Disable(GL_BLEND);
  g.Disable(GL_CULL_FACE);
  g.Disable(GL_SCISSOR_TEST);
  g.Disable(GL_STENCIL_TEST);
  g.Enable(GL_DEPTH_TEST);
  g.DepthFunc(GL_LESS);
  g.DepthMask(GL_TRUE);
  g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  const float empty[4] = {-1.0f, 0.0f, 0.0f, 0.0f};
  const float far_depth = 1.0f;
  g.ClearBufferfv(GL_COLOR, 0, empty);
  g.ClearBufferfv(GL_DEPTH, 0, &far_depth);
  I.program.use();
  I.program.set_mat4("u_model_view", mv.data());
  I.program.set_mat4("u_projection", proj.data());
  g.BindVertexArray(I.vao);
  g.DrawElements(GL_TRIANGLES, I.index_count, GL_UNSIGNED_INT, nullptr);
  g.BindVertexArray(0);
  const auto count = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  I.rows.resize(count);
  g.PixelStorei(GL_PACK_ALIGNMENT, 4);
  g.ReadBuffer(GL_COLOR_ATTACHMENT0);
  g.ReadPixels(0, 0, w, h, GL_RED, GL_FLOAT, I.rows.data());
  check_gl_error(g, "drawing and reading the depth");
  out.width = w;
  out.height = h;
  out.depth.resize(count);
  out.face.clear();
  // GL's row 0 is the bottom; the buffer's is the top. Never-drawn pixels
  // hold -1 (a drawn depth is > 0: in front of the near plane).
  const float inf = std::numeric_limits<float>::infinity();
  for (int y = 0; y < h; ++y) {
    const float* src = I.rows.data() + static_cast<std::size_t>(h - 1 - y) * w;
    float* dst = out.depth.data() + static_cast<std::size_t>(y) * w;
    for (int x = 0; x < w; ++x) dst[x] = src[x] > 0.0f ? src[x] : inf;
  }
}

}  // namespace fabrica::render
