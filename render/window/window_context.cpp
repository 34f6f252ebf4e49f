#include "fabrica/render/window_context.hpp"

#include <GLFW/glfw3.h>

#include <mutex>

#include "fabrica/core/error.hpp"

namespace fabrica::render {

namespace {

std::mutex glfw_mutex;
int glfw_users = 0;
std::string glfw_last_error;

void acquire_glfw() {
  std::lock_guard<std::mutex> lock(glfw_mutex);
  if (glfw_users++ > 0) return;
  glfwSetErrorCallback([](int, const char* message) { glfw_last_error = message ? message : ""; });
  if (glfwInit() != GLFW_TRUE) {
    glfw_users = 0;
    throw Error(ErrorKind::unavailable,
                "glfw: cannot initialise (" + glfw_last_error +
                    "); a window needs a display: run under xvfb-run -a, or render headless");
  }
}

void release_glfw() {
  std::lock_guard<std::mutex> lock(glfw_mutex);
  if (--glfw_users == 0) glfwTerminate();
}

}  // namespace

WindowContext::WindowContext(const WindowOptions& o) {
  acquire_glfw();
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, o.visible ? GLFW_TRUE : GLFW_FALSE);
  window_ = glfwCreateWindow(o.width, o.height, o.title.c_str(), nullptr, nullptr);
  if (window_ == nullptr) {
    release_glfw();
    throw Error(ErrorKind::unavailable,
                "glfw: cannot create an OpenGL 3.3 core window (" + glfw_last_error + ")");
  }
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(o.vsync ? 1 : 0);
  try {
    initialise(
        [](const char* name, void*) { return reinterpret_cast<void*>(glfwGetProcAddress(name)); },
        nullptr);
  } catch (...) {
    glfwDestroyWindow(window_);
    release_glfw();
    throw;
  }
}

WindowContext::~WindowContext() {
  if (window_ != nullptr) glfwDestroyWindow(window_);
  release_glfw();
}

void WindowContext::make_current() {
  if (glfwGetCurrentContext() != window_) glfwMakeContextCurrent(window_);
}

bool WindowContext::should_close() const {
  return glfwWindowShouldClose(window_) == GLFW_TRUE;
}
void WindowContext::swap_buffers() {
  glfwSwapBuffers(window_);
}
void WindowContext::framebuffer_size(int& width, int& height) const {
  glfwGetFramebufferSize(window_, &width, &height);
}

}  // namespace fabrica::render
