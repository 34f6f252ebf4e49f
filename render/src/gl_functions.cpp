#include "fabrica/render/gl_functions.hpp"

#include "fabrica/core/error.hpp"

namespace fabrica::render {

void load_gl_functions(GlFunctions& table, GlProcLoader loader, void* user,
                       const std::string& backend) {
#define FABRICA_GL_LOAD(type, name)                                                               \
  table.name = reinterpret_cast<type>(loader("gl" #name, user));                                  \
  if (table.name == nullptr)                                                                      \
    throw Error(ErrorKind::unavailable, backend + ": the OpenGL driver does not provide gl" #name \
                                                  " (OpenGL 3.3 core is required)");
  FABRICA_GL_FUNCTIONS(FABRICA_GL_LOAD)
#undef FABRICA_GL_LOAD
  // A driver may hand out entry points its context's version lacks.
  GLint major = 0;
  table.GetIntegerv(GL_MAJOR_VERSION, &major);
  while (table.GetError() != GL_NO_ERROR) {
  }
  const bool gl4 = major >= 4;
#define FABRICA_GL_LOAD_OPTIONAL(type, name) \
  table.name = gl4 ? reinterpret_cast<type>(loader("gl" #name, user)) : nullptr;
  FABRICA_GL_OPTIONAL_FUNCTIONS(FABRICA_GL_LOAD_OPTIONAL)
#undef FABRICA_GL_LOAD_OPTIONAL
}

void check_gl_error(const GlFunctions& gl, const char* what) {
  const GLenum err = gl.GetError();
  if (err == GL_NO_ERROR) return;
  while (gl.GetError() != GL_NO_ERROR) {
  }
  const char* name = "unknown";
  switch (err) {
    case GL_INVALID_ENUM:
      name = "GL_INVALID_ENUM";
      break;
    case GL_INVALID_VALUE:
      name = "GL_INVALID_VALUE";
      break;
    case GL_INVALID_OPERATION:
      name = "GL_INVALID_OPERATION";
      break;
    case GL_INVALID_FRAMEBUFFER_OPERATION:
      name = "GL_INVALID_FRAMEBUFFER_OPERATION";
      break;
    case GL_OUT_OF_MEMORY:
      throw Error(ErrorKind::unavailable, std::string("OpenGL ran out of memory while ") + what +
                                              " (try a smaller --size or a smaller tile size)");
    default:
      break;
  }
  throw Error(ErrorKind::internal, std::string("OpenGL error ") + name + " while " + what);
}

}  // namespace fabrica::render
