// GLSL programs built from the files of shaders/ (embedded in the binary at
// build time). A stage is the concatenation of a version line, optional
// #defines and one or more named files; compile and link failures throw
// Error(ErrorKind::internal) naming the program, the stage's files and the
// driver's log.
#pragma once

#include <GL/glcorearb.h>

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "fabrica/render/gl_functions.hpp"

namespace fabrica::render {

/// Source of an embedded shader file (e.g. "mesh.vert"); Error(internal) if unknown.
std::string_view shader_source(std::string_view name);

/// One stage: a list of (name, source) parts compiled as one shader.
struct ShaderStage {
  GLenum type = GL_VERTEX_SHADER;
  std::vector<std::pair<std::string, std::string>> parts;
  /// Stage from embedded files, with `defines` ("NAME" or "NAME VALUE") prepended.
  static ShaderStage from_files(GLenum type, const std::vector<std::string>& files,
                                const std::vector<std::string>& defines = {});
};

class ShaderProgram {
 public:
  ShaderProgram() = default;
  ShaderProgram(const GlFunctions& gl, std::string name, const std::vector<ShaderStage>& stages);
  ~ShaderProgram();
  ShaderProgram(ShaderProgram&& other) noexcept;
  ShaderProgram& operator=(ShaderProgram&& other) noexcept;
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;

  GLuint id() const { return id_; }
  const std::string& name() const { return name_; }
  void use() const;
  /// Uniform location (cached); -1 when the driver optimised it away.
  GLint uniform(const char* name) const;

  void set(const char* name, int v) const;
  void set(const char* name, float v) const;
  void set(const char* name, float x, float y) const;
  void set(const char* name, float x, float y, float z) const;
  void set(const char* name, float x, float y, float z, float w) const;
  void set_mat3(const char* name, const float* column_major) const;
  void set_mat4(const char* name, const float* column_major) const;
  /// A float array uniform (`name` without [0]); nothing for an empty one.
  void set_array(const char* name, const std::vector<float>& values) const;

 private:
  void release();
  const GlFunctions* gl_ = nullptr;
  GLuint id_ = 0;
  std::string name_;
  mutable std::map<std::string, GLint, std::less<>> uniforms_;
};

}  // namespace fabrica::render
