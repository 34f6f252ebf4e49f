// GL contexts behind one interface: EGL surfaceless (headless; uses a real
// GPU when there is one), OSMesa (headless, CPU; opened with dlopen at run
// time) and a GLFW window (separate target fabrica_render_window, so the
// headless exporter links neither GLFW nor a display). Every context is
// OpenGL 3.3 core or newer and carries its own function table.
//
// Headless selection: the explicit choice, else the environment variable
// FABRICA_GL_BACKEND=egl|osmesa, else EGL then OSMesa. A forced backend
// that fails is an error (no silent fallback); in automatic mode the error
// lists why each backend failed.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "fabrica/render/gl_functions.hpp"

namespace fabrica::render {

enum class Backend { egl, osmesa, glfw };

const char* to_string(Backend backend);
/// "egl", "osmesa", "glfw" (case-insensitive); nullopt otherwise.
std::optional<Backend> parse_backend(std::string_view name);

/// In AddressSanitizer builds, keeps every library loaded so far (the GL
/// driver of the current context among them) loaded until exit, so
/// LeakSanitizer can name the driver's allocations (docs/reliability.md,
/// "Sanitizers"); does nothing in other builds. Every context made here calls
/// it; a program that makes its own GL context (the study) calls it too.
void keep_gl_driver_loaded();

class GlContext {
 public:
  virtual ~GlContext() = default;
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  /// Makes this context current on the calling thread.
  virtual void make_current() = 0;
  virtual Backend backend() const = 0;

  const GlFunctions& gl() const { return gl_; }
  /// GL_RENDERER / GL_VERSION strings (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  const std::string& renderer() const { return renderer_; }
  const std::string& version() const { return version_; }
  /// min(GL_MAX_RENDERBUFFER_SIZE, GL_MAX_TEXTURE_SIZE, GL_MAX_VIEWPORT_DIMS).
  int max_framebuffer_size() const { return max_size_; }

 protected:
  GlContext() = default;
  /// Loads the table and queries strings and limits; call once current.
  void initialise(GlProcLoader loader, void* user);

  GlFunctions gl_;
  std::string renderer_, version_;
  int max_size_ = 0;
};

struct HeadlessOptions {
  /// egl or osmesa; empty = FABRICA_GL_BACKEND, else automatic.
  std::optional<Backend> backend;
};

/// Creates a headless context (current on return). Throws
/// Error(ErrorKind::unavailable) when no backend can be created.
std::unique_ptr<GlContext> create_headless_context(const HeadlessOptions& options = {});

/// The individual backends (current on return; Error(unavailable) on failure).
std::unique_ptr<GlContext> create_egl_context();
std::unique_ptr<GlContext> create_osmesa_context();

}  // namespace fabrica::render
