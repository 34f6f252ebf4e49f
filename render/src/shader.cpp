#include "fabrica/render/shader.hpp"

#include <utility>

#include "fabrica/core/error.hpp"

namespace fabrica::render {

namespace detail {
// Generated at build time from shaders/ (shaders/embed_shaders.cmake).
std::string_view embedded_shader(std::string_view name);
}  // namespace detail

std::string_view shader_source(std::string_view name) {
  std::string_view s = detail::embedded_shader(name);
  if (s.empty())
    throw Error(ErrorKind::internal, "no embedded shader named '" + std::string(name) + "'");
  return s;
}

ShaderStage ShaderStage::from_files(GLenum type, const std::vector<std::string>& files,
                                    const std::vector<std::string>& defines) {
  ShaderStage stage;
  stage.type = type;
  std::string header = "#version 330 core\n";
  for (const auto& d : defines) header += "#define " + d + "\n";
  stage.parts.emplace_back("(version and defines)", header);
  for (const auto& f : files) stage.parts.emplace_back(f, std::string(shader_source(f)));
  return stage;
}

namespace {

const char* stage_name(GLenum type) {
  switch (type) {
    case GL_VERTEX_SHADER:
      return "vertex";
    case GL_FRAGMENT_SHADER:
      return "fragment";
    case GL_GEOMETRY_SHADER:
      return "geometry";
    default:
      return "shader";
  }
}

std::string describe_parts(const ShaderStage& stage) {
  std::string s;
  for (std::size_t i = 0; i < stage.parts.size(); ++i) {
    if (i) s += ", ";
    s += std::to_string(i) + "=" + stage.parts[i].first;
  }
  return s;
}

}  // namespace

ShaderProgram::ShaderProgram(const GlFunctions& gl, std::string name,
                             const std::vector<ShaderStage>& stages)
    : gl_(&gl), name_(std::move(name)) {
  std::vector<GLuint> shaders;
  auto cleanup = [&] {
    for (GLuint s : shaders) gl.DeleteShader(s);
  };
  for (const auto& stage : stages) {
    GLuint s = gl.CreateShader(stage.type);
    if (s == 0) {
      cleanup();
      throw Error(ErrorKind::internal,
                  "program '" + name_ + "': cannot create a " + stage_name(stage.type) + " shader");
    }
    shaders.push_back(s);
    std::vector<const GLchar*> strings;
    std::vector<GLint> lengths;
    for (const auto& part : stage.parts) {
      strings.push_back(part.second.data());
      lengths.push_back(static_cast<GLint>(part.second.size()));
    }
    gl.ShaderSource(s, static_cast<GLsizei>(strings.size()), strings.data(), lengths.data());
    gl.CompileShader(s);
    GLint ok = GL_FALSE;
    gl.GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
      GLint len = 0;
      gl.GetShaderiv(s, GL_INFO_LOG_LENGTH, &len);
      std::string log(static_cast<std::size_t>(std::max(len, 1)), '\0');
      gl.GetShaderInfoLog(s, len, nullptr, log.data());
      while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
      const std::string file = stage.parts.empty() ? "?" : stage.parts.back().first;
      cleanup();
      throw Error(ErrorKind::internal, "shader '" + file + "' (" + stage_name(stage.type) +
                                           " stage of program '" + name_ +
                                           "') failed to compile; source strings " +
                                           describe_parts(stage) + "; driver log:\n" + log);
    }
  }
  id_ = gl.CreateProgram();
  for (GLuint s : shaders) gl.AttachShader(id_, s);
  gl.LinkProgram(id_);
  cleanup();  // flagged for deletion; freed with the program
  GLint ok = GL_FALSE;
  gl.GetProgramiv(id_, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint len = 0;
    gl.GetProgramiv(id_, GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<std::size_t>(std::max(len, 1)), '\0');
    gl.GetProgramInfoLog(id_, len, nullptr, log.data());
    while (!log.empty() && (log.back() == '\0' || log.back() == '\n')) log.pop_back();
    std::string files;
    for (const auto& stage : stages)
      for (std::size_t i = 1; i < stage.parts.size(); ++i) files += " " + stage.parts[i].first;
    release();
    throw Error(ErrorKind::internal, "program '" + name_ + "' (" +
                                         files.substr(files.empty() ? 0 : 1) +
                                         ") failed to link; driver log:\n" + log);
  }
}

ShaderProgram::~ShaderProgram() {
  release();
}

ShaderProgram::ShaderProgram(ShaderProgram&& other) noexcept
    : gl_(other.gl_),
      id_(std::exchange(other.id_, 0)),
      name_(std::move(other.name_)),
      uniforms_(std::move(other.uniforms_)) {}

ShaderProgram& ShaderProgram::operator=(ShaderProgram&& other) noexcept {
  if (this != &other) {
    release();
    gl_ = other.gl_;
    id_ = std::exchange(other.id_, 0);
    name_ = std::move(other.name_);
    uniforms_ = std::move(other.uniforms_);
  }
  return *this;
}

void ShaderProgram::release() {
  if (id_ != 0 && gl_ != nullptr) gl_->DeleteProgram(id_);
  id_ = 0;
}

void ShaderProgram::use() const {
  gl_->UseProgram(id_);
}

GLint ShaderProgram::uniform(const char* name) const {
  auto it = uniforms_.find(std::string_view(name));
  if (it != uniforms_.end()) return it->second;
  const GLint loc = gl_->GetUniformLocation(id_, name);
  uniforms_.emplace(name, loc);
  return loc;
}

void ShaderProgram::set(const char* name, int v) const {
  gl_->Uniform1i(uniform(name), v);
}
void ShaderProgram::set(const char* name, float v) const {
  gl_->Uniform1f(uniform(name), v);
}
void ShaderProgram::set(const char* name, float x, float y) const {
  gl_->Uniform2f(uniform(name), x, y);
}
void ShaderProgram::set(const char* name, float x, float y, float z) const {
  gl_->Uniform3f(uniform(name), x, y, z);
}
void ShaderProgram::set(const char* name, float x, float y, float z, float w) const {
  gl_->Uniform4f(uniform(name), x, y, z, w);
}
void ShaderProgram::set_mat3(const char* name, const float* m) const {
  gl_->UniformMatrix3fv(uniform(name), 1, GL_FALSE, m);
}
void ShaderProgram::set_mat4(const char* name, const float* m) const {
  gl_->UniformMatrix4fv(uniform(name), 1, GL_FALSE, m);
}
void ShaderProgram::set_array(const char* name, const std::vector<float>& values) const {
  if (!values.empty())
    gl_->Uniform1fv(uniform(name), static_cast<GLsizei>(values.size()), values.data());
}

}  // namespace fabrica::render
