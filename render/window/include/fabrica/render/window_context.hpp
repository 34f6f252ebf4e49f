// GLFW window context (OpenGL 3.3 core) for the viewer: a separate target,
// fabrica_render_window, so the headless exporter links neither GLFW nor
// anything that needs a display. GLFW needs an X display (run tests under
// `xvfb-run -a`); without one, creation throws Error(unavailable).
#pragma once

#include <memory>
#include <string>

#include "fabrica/render/context.hpp"

struct GLFWwindow;

namespace fabrica::render {

struct WindowOptions {
  int width = 1024;
  int height = 768;
  std::string title = "fabrica";
  bool visible = true;
  bool vsync = true;
};

class WindowContext final : public GlContext {
 public:
  /// Creates the window and makes its context current.
  explicit WindowContext(const WindowOptions& options);
  ~WindowContext() override;
  void make_current() override;
  Backend backend() const override { return Backend::glfw; }

  GLFWwindow* window() const { return window_; }
  bool should_close() const;
  void swap_buffers();
  /// Framebuffer size in pixels (may differ from the window size on HiDPI).
  void framebuffer_size(int& width, int& height) const;

 private:
  GLFWwindow* window_ = nullptr;
};

}  // namespace fabrica::render
