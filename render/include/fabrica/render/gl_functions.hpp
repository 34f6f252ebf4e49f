// GlFunctions: the OpenGL 3.3 core entry points fabrica uses, as a table of
// function pointers filled from the backend's GetProcAddress (eglGetProcAddress,
// OSMesaGetProcAddress, glfwGetProcAddress). fabrica never calls gl* symbols
// directly: with libGL/libOpenGL and libOSMesa in one process, direct calls
// reach whichever library the dynamic linker saw first (docs/DEVELOPING.md,
// "GL entry points"), while pointers from the context's own loader always reach
// the right driver. One table per context.
#pragma once

#include <GL/glcorearb.h>

#include <string>

namespace fabrica::render {

// X(type, name): name without the "gl" prefix.
#define FABRICA_GL_FUNCTIONS(X)                                  \
  X(PFNGLGETERRORPROC, GetError)                                 \
  X(PFNGLGETSTRINGPROC, GetString)                               \
  X(PFNGLGETINTEGERVPROC, GetIntegerv)                           \
  X(PFNGLGETFLOATVPROC, GetFloatv)                               \
  X(PFNGLVIEWPORTPROC, Viewport)                                 \
  X(PFNGLSCISSORPROC, Scissor)                                   \
  X(PFNGLCLEARCOLORPROC, ClearColor)                             \
  X(PFNGLCLEARDEPTHPROC, ClearDepth)                             \
  X(PFNGLCLEARPROC, Clear)                                       \
  X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                       \
  X(PFNGLENABLEPROC, Enable)                                     \
  X(PFNGLDISABLEPROC, Disable)                                   \
  X(PFNGLBLENDFUNCPROC, BlendFunc)                               \
  X(PFNGLBLENDFUNCSEPARATEPROC, BlendFuncSeparate)               \
  X(PFNGLBLENDEQUATIONPROC, BlendEquation)                       \
  X(PFNGLDEPTHFUNCPROC, DepthFunc)                               \
  X(PFNGLDEPTHMASKPROC, DepthMask)                               \
  X(PFNGLSTENCILFUNCPROC, StencilFunc)                           \
  X(PFNGLSTENCILOPPROC, StencilOp)                               \
  X(PFNGLSTENCILMASKPROC, StencilMask)                           \
  X(PFNGLCLEARSTENCILPROC, ClearStencil)                         \
  X(PFNGLCOLORMASKPROC, ColorMask)                               \
  X(PFNGLPOLYGONOFFSETPROC, PolygonOffset)                       \
  X(PFNGLFINISHPROC, Finish)                                     \
  X(PFNGLFLUSHPROC, Flush)                                       \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                           \
  X(PFNGLREADPIXELSPROC, ReadPixels)                             \
  X(PFNGLREADBUFFERPROC, ReadBuffer)                             \
  X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                           \
  X(PFNGLGENTEXTURESPROC, GenTextures)                           \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures)                     \
  X(PFNGLBINDTEXTUREPROC, BindTexture)                           \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D)                             \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri)                       \
  X(PFNGLTEXBUFFERPROC, TexBuffer)                               \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                       \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                   \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)             \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                   \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)         \
  X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)   \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)     \
  X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                 \
  X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)           \
  X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                 \
  X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)           \
  X(PFNGLBLITFRAMEBUFFERPROC, BlitFramebuffer)                   \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                   \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)             \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                   \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                             \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                       \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                             \
  X(PFNGLBUFFERDATAPROC, BufferData)                             \
  X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                       \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)           \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)   \
  X(PFNGLDISABLEVERTEXATTRIBARRAYPROC, DisableVertexAttribArray) \
  X(PFNGLVERTEXATTRIB1FPROC, VertexAttrib1f)                     \
  X(PFNGLVERTEXATTRIB2FPROC, VertexAttrib2f)                     \
  X(PFNGLVERTEXATTRIB3FPROC, VertexAttrib3f)                     \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                             \
  X(PFNGLDRAWELEMENTSPROC, DrawElements)                         \
  X(PFNGLCREATESHADERPROC, CreateShader)                         \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                         \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                       \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                           \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                 \
  X(PFNGLDELETESHADERPROC, DeleteShader)                         \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                       \
  X(PFNGLATTACHSHADERPROC, AttachShader)                         \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                           \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                         \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)               \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                       \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                             \
  X(PFNGLBINDATTRIBLOCATIONPROC, BindAttribLocation)             \
  X(PFNGLBINDFRAGDATALOCATIONPROC, BindFragDataLocation)         \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)             \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                               \
  X(PFNGLUNIFORM1FPROC, Uniform1f)                               \
  X(PFNGLUNIFORM2FPROC, Uniform2f)                               \
  X(PFNGLUNIFORM3FPROC, Uniform3f)                               \
  X(PFNGLUNIFORM4FPROC, Uniform4f)                               \
  X(PFNGLUNIFORM1FVPROC, Uniform1fv)                             \
  X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv)                 \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                 \
  X(PFNGLGENQUERIESPROC, GenQueries)                             \
  X(PFNGLDELETEQUERIESPROC, DeleteQueries)                       \
  X(PFNGLBEGINQUERYPROC, BeginQuery)                             \
  X(PFNGLENDQUERYPROC, EndQuery)                                 \
  X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)

// Entry points of later versions, used for faster paths where the context
// has them (null otherwise; never required): per-buffer blend equations
// (OpenGL 4.0; the ghosts' depth drawn with their transparency, renderer).
#define FABRICA_GL_OPTIONAL_FUNCTIONS(X) X(PFNGLBLENDEQUATIONIPROC, BlendEquationi)

struct GlFunctions {
#define FABRICA_GL_DECLARE(type, name) type name = nullptr;
  FABRICA_GL_FUNCTIONS(FABRICA_GL_DECLARE)
  FABRICA_GL_OPTIONAL_FUNCTIONS(FABRICA_GL_DECLARE)
#undef FABRICA_GL_DECLARE
};

/// Resolves a GL entry point by name ("glClear"); returns null when absent.
using GlProcLoader = void* (*)(const char* name, void* user);

/// Fills `table` from `loader`. Throws Error(unavailable) naming the first
/// required entry point the driver does not provide, prefixed with `backend`.
/// The optional ones are left null where the driver lacks them or the
/// context's version is older than theirs (4.0); the context must be current.
void load_gl_functions(GlFunctions& table, GlProcLoader loader, void* user,
                       const std::string& backend);

/// Throws Error(internal) naming `what` if glGetError reports an error.
void check_gl_error(const GlFunctions& gl, const char* what);

}  // namespace fabrica::render
