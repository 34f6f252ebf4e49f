// Headless GL contexts: EGL surfaceless (Mesa's EGL_MESA_platform_surfaceless)
// and OSMesa opened with dlopen (docs/DEVELOPING.md, "GL entry points").
#include "fabrica/render/context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/osmesa.h>
#include <dlfcn.h>
#include <link.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "fabrica/core/error.hpp"

namespace fabrica::render {

const char* to_string(Backend backend) {
  switch (backend) {
    case Backend::egl:
      return "egl";
    case Backend::osmesa:
      return "osmesa";
    case Backend::glfw:
      return "glfw";
  }
  return "?";
}

std::optional<Backend> parse_backend(std::string_view name) {
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "egl") return Backend::egl;
  if (lower == "osmesa") return Backend::osmesa;
  if (lower == "glfw") return Backend::glfw;
  return std::nullopt;
}

#if defined(__SANITIZE_ADDRESS__)
#define FABRICA_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FABRICA_ASAN 1
#endif
#endif

// Under AddressSanitizer only (build-asan/, scripts/sanitize-test): marks
// every shared library loaded so far - the GL driver Mesa opened for this
// context among them - as never to be unloaded. Mesa unloads its driver
// (swrast_dri.so) when the display is terminated, before LeakSanitizer looks
// at the heap at exit; the driver's own leftovers would then be reported
// from an unnamed module, and no suppression could name them. Kept loaded,
// the driver's memory stays reachable and nothing is reported.
void keep_gl_driver_loaded() {
#ifdef FABRICA_ASAN
  std::vector<std::string> names;
  dl_iterate_phdr(
      [](dl_phdr_info* info, std::size_t, void* out) {
        if (info->dlpi_name != nullptr && info->dlpi_name[0] != '\0')
          static_cast<std::vector<std::string>*>(out)->emplace_back(info->dlpi_name);
        return 0;
      },
      &names);
  for (const auto& name : names) dlopen(name.c_str(), RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
#endif
}

void GlContext::initialise(GlProcLoader loader, void* user) {
  keep_gl_driver_loaded();
  load_gl_functions(gl_, loader, user, to_string(backend()));
  auto str = [this](GLenum e) {
    const auto* s = reinterpret_cast<const char*>(gl_.GetString(e));
    return std::string(s != nullptr ? s : "");
  };
  renderer_ = str(GL_RENDERER);
  version_ = str(GL_VERSION);
  GLint rb = 0, tex = 0, vp[2] = {0, 0};
  gl_.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &rb);
  gl_.GetIntegerv(GL_MAX_TEXTURE_SIZE, &tex);
  gl_.GetIntegerv(GL_MAX_VIEWPORT_DIMS, vp);
  max_size_ = std::min({rb, tex, vp[0], vp[1]});
  while (gl_.GetError() != GL_NO_ERROR) {
  }
  if (max_size_ < 64)
    throw Error(ErrorKind::unavailable,
                std::string(to_string(backend())) +
                    ": the OpenGL context reports no usable framebuffer size");
}

namespace {

// ---------------------------------------------------------------- EGL ----

const char* egl_error_name(EGLint e) {
  switch (e) {
    case EGL_SUCCESS:
      return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    default:
      return "EGL error";
  }
}

// One EGLDisplay per process is shared by all contexts (eglTerminate would end
// every context on it), so it is reference counted.
std::mutex egl_mutex;
EGLDisplay egl_display = EGL_NO_DISPLAY;
int egl_users = 0;

[[noreturn]] void egl_fail(const std::string& what) {
  throw Error(ErrorKind::unavailable, "egl: " + what + " (" + egl_error_name(eglGetError()) + ")");
}

EGLDisplay acquire_egl_display() {
  std::lock_guard<std::mutex> lock(egl_mutex);
  if (egl_users > 0) {
    ++egl_users;
    return egl_display;
  }
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client_ext == nullptr || std::strstr(client_ext, "EGL_MESA_platform_surfaceless") == nullptr)
    throw Error(ErrorKind::unavailable,
                "egl: the EGL library has no surfaceless platform (EGL_MESA_platform_surfaceless); "
                "install Mesa's EGL (libegl-mesa0) or use --backend osmesa");
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr) egl_fail("eglGetPlatformDisplayEXT is missing");
  EGLDisplay dpy =
      get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (dpy == EGL_NO_DISPLAY) egl_fail("cannot open the surfaceless display");
  EGLint major = 0, minor = 0;
  if (eglInitialize(dpy, &major, &minor) != EGL_TRUE) egl_fail("eglInitialize failed");
  egl_display = dpy;
  egl_users = 1;
  return dpy;
}

void release_egl_display() {
  std::lock_guard<std::mutex> lock(egl_mutex);
  if (--egl_users == 0) {
    eglTerminate(egl_display);
    egl_display = EGL_NO_DISPLAY;
  }
}

class EglContext final : public GlContext {
 public:
  EglContext() {
    display_ = acquire_egl_display();
    try {
      create();
    } catch (...) {
      release_egl_display();
      throw;
    }
  }
  ~EglContext() override {
    if (context_ != EGL_NO_CONTEXT) {
      if (eglGetCurrentContext() == context_)
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      eglDestroyContext(display_, context_);
    }
    release_egl_display();
  }
  void make_current() override {
    if (eglGetCurrentContext() == context_) return;
    if (eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_) != EGL_TRUE)
      egl_fail("eglMakeCurrent failed");
  }
  Backend backend() const override { return Backend::egl; }

 private:
  void create() {
    if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE) egl_fail("desktop OpenGL is not supported");
    const char* ext = eglQueryString(display_, EGL_EXTENSIONS);
    const bool no_config = ext != nullptr && (std::strstr(ext, "EGL_KHR_no_config_context") ||
                                              std::strstr(ext, "EGL_MESA_configless_context"));
    const bool surfaceless = ext != nullptr && std::strstr(ext, "EGL_KHR_surfaceless_context");
    if (!surfaceless) egl_fail("EGL_KHR_surfaceless_context is not supported");
    EGLConfig config = EGL_NO_CONFIG_KHR;
    if (!no_config) {
      const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
      EGLint count = 0;
      if (eglChooseConfig(display_, config_attribs, &config, 1, &count) != EGL_TRUE || count < 1)
        egl_fail("no EGL configuration supports desktop OpenGL");
    }
    const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                              3,
                              EGL_CONTEXT_MINOR_VERSION,
                              3,
                              EGL_CONTEXT_OPENGL_PROFILE_MASK,
                              EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                              EGL_NONE};
    context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, attribs);
    if (context_ == EGL_NO_CONTEXT) egl_fail("cannot create an OpenGL 3.3 core context");
    make_current();
    initialise(
        [](const char* name, void*) { return reinterpret_cast<void*>(eglGetProcAddress(name)); },
        nullptr);
  }

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
};

// ------------------------------------------------------------- OSMesa ----

struct OsMesaLibrary {
  using CreateContextAttribs = OSMesaContext (*)(const int*, OSMesaContext);
  using MakeCurrent = GLboolean (*)(OSMesaContext, void*, GLenum, GLsizei, GLsizei);
  using DestroyContext = void (*)(OSMesaContext);
  using GetProcAddress = void* (*)(const char*);
  using GetCurrentContext = OSMesaContext (*)();
  void* handle = nullptr;
  CreateContextAttribs create_context_attribs = nullptr;
  MakeCurrent make_current = nullptr;
  DestroyContext destroy_context = nullptr;
  GetProcAddress get_proc_address = nullptr;
  GetCurrentContext get_current_context = nullptr;
  std::string error;
};

// Opened once and kept for the life of the process (unloading a GL driver
// while other contexts might exist is not safe).
const OsMesaLibrary& osmesa_library() {
  static const OsMesaLibrary lib = [] {
    OsMesaLibrary l;
    for (const char* name : {"libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"}) {
      l.handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
      if (l.handle != nullptr) break;
    }
    if (l.handle == nullptr) {
      const char* e = dlerror();
      l.error = std::string("cannot load libOSMesa.so.8 (") + (e ? e : "not found") +
                "); install libosmesa6";
      return l;
    }
    l.create_context_attribs = reinterpret_cast<OsMesaLibrary::CreateContextAttribs>(
        dlsym(l.handle, "OSMesaCreateContextAttribs"));
    l.make_current =
        reinterpret_cast<OsMesaLibrary::MakeCurrent>(dlsym(l.handle, "OSMesaMakeCurrent"));
    l.destroy_context =
        reinterpret_cast<OsMesaLibrary::DestroyContext>(dlsym(l.handle, "OSMesaDestroyContext"));
    l.get_proc_address =
        reinterpret_cast<OsMesaLibrary::GetProcAddress>(dlsym(l.handle, "OSMesaGetProcAddress"));
    l.get_current_context = reinterpret_cast<OsMesaLibrary::GetCurrentContext>(
        dlsym(l.handle, "OSMesaGetCurrentContext"));
    if (!l.create_context_attribs || !l.make_current || !l.destroy_context || !l.get_proc_address ||
        !l.get_current_context)
      l.error = "libOSMesa lacks OSMesaCreateContextAttribs (Mesa 10.5 or newer is needed)";
    return l;
  }();
  return lib;
}

class OsMesaContextImpl final : public GlContext {
 public:
  OsMesaContextImpl() : lib_(osmesa_library()) {
    if (!lib_.error.empty()) throw Error(ErrorKind::unavailable, "osmesa: " + lib_.error);
    const int attribs[] = {OSMESA_FORMAT,
                           OSMESA_RGBA,
                           OSMESA_DEPTH_BITS,
                           0,
                           OSMESA_PROFILE,
                           OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION,
                           3,
                           OSMESA_CONTEXT_MINOR_VERSION,
                           3,
                           0};
    context_ = lib_.create_context_attribs(attribs, nullptr);
    if (context_ == nullptr)
      throw Error(ErrorKind::unavailable, "osmesa: cannot create an OpenGL 3.3 core context");
    make_current();
    initialise(
        [](const char* name, void* user) {
          return static_cast<const OsMesaLibrary*>(user)->get_proc_address(name);
        },
        const_cast<OsMesaLibrary*>(&lib_));
  }
  ~OsMesaContextImpl() override {
    if (context_ != nullptr) lib_.destroy_context(context_);
  }
  void make_current() override {
    if (lib_.get_current_context() == context_) return;
    // The default framebuffer is a 1x1 dummy: fabrica renders into FBOs.
    if (lib_.make_current(context_, buffer_, GL_UNSIGNED_BYTE, 1, 1) != GL_TRUE)
      throw Error(ErrorKind::unavailable, "osmesa: OSMesaMakeCurrent failed");
  }
  Backend backend() const override { return Backend::osmesa; }

 private:
  const OsMesaLibrary& lib_;
  OSMesaContext context_ = nullptr;
  unsigned char buffer_[16] = {};
};

}  // namespace

std::unique_ptr<GlContext> create_egl_context() {
  return std::make_unique<EglContext>();
}
std::unique_ptr<GlContext> create_osmesa_context() {
  return std::make_unique<OsMesaContextImpl>();
}

std::unique_ptr<GlContext> create_headless_context(const HeadlessOptions& options) {
  std::optional<Backend> choice = options.backend;
  if (!choice) {
    const char* env = std::getenv("FABRICA_GL_BACKEND");
    if (env != nullptr && *env != '\0') {
      choice = parse_backend(env);
      if (!choice || *choice == Backend::glfw)
        throw InputError(std::string("FABRICA_GL_BACKEND=") + env +
                         " is not a headless backend: use egl or osmesa");
    }
  }
  if (choice) {
    if (*choice == Backend::egl) return create_egl_context();
    if (*choice == Backend::osmesa) return create_osmesa_context();
    throw InputError("the glfw backend needs a window: use egl or osmesa for headless rendering");
  }
  std::string egl_reason;
  try {
    return create_egl_context();
  } catch (const Error& e) {
    egl_reason = e.what();
  }
  try {
    return create_osmesa_context();
  } catch (const Error& e) {
    throw Error(ErrorKind::unavailable,
                std::string("no headless OpenGL 3.3 backend is available: ") + egl_reason + "; " +
                    e.what());
  }
}

}  // namespace fabrica::render
