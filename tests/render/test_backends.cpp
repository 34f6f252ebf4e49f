// Headless backends: selection and fallback, a PNG through EGL and OSMesa,
// transparent background, large and tiled images, shader errors.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/render/context.hpp"
#include "fabrica/render/renderer.hpp"
#include "fabrica/render/shader.hpp"
#include "render_test_util.hpp"

namespace fr = fabrica::render;
using fabrica::Camera;

namespace {

struct EnvGuard {
  EnvGuard(const char* value) {
    if (value)
      setenv("FABRICA_GL_BACKEND", value, 1);
    else
      unsetenv("FABRICA_GL_BACKEND");
  }
  ~EnvGuard() { unsetenv("FABRICA_GL_BACKEND"); }
};

fr::Scene sphere_scene() {
  fr::Scene scene;
  fr::Structure s;
  s.name = "sphere";
  s.mesh = fabrica::test::sphere_render_mesh(10.0, 4);
  s.style = fr::default_style(fr::Role::focus);
  s.style.color = {1.0f, 1.0f, 1.0f, 1.0f};
  s.style.ambient = 0.0;
  scene.structures.push_back(std::move(s));
  scene.background = {0.0f, 0.0f, 1.0f, 1.0f};
  return scene;
}

void expect_gl33(const fr::GlContext& ctx) {
  EXPECT_FALSE(ctx.renderer().empty());
  int major = 0, minor = 0;
  ASSERT_EQ(std::sscanf(ctx.version().c_str(), "%d.%d", &major, &minor), 2) << ctx.version();
  EXPECT_GE(major * 10 + minor, 33) << ctx.version();
  EXPECT_GE(ctx.max_framebuffer_size(), 4096);
}

}  // namespace

TEST(RenderBackends, EglSurfacelessCreatesCoreContext) {
  auto ctx = fr::create_egl_context();
  EXPECT_EQ(ctx->backend(), fr::Backend::egl);
  expect_gl33(*ctx);
}

TEST(RenderBackends, OsMesaCreatesCoreContext) {
  auto ctx = fr::create_osmesa_context();
  EXPECT_EQ(ctx->backend(), fr::Backend::osmesa);
  expect_gl33(*ctx);
}

TEST(RenderBackends, SelectionByOptionAndEnvironment) {
  {
    EnvGuard env(nullptr);
    EXPECT_EQ(fr::create_headless_context()->backend(), fr::Backend::egl);  // EGL preferred
    EXPECT_EQ(fr::create_headless_context({fr::Backend::osmesa})->backend(), fr::Backend::osmesa);
  }
  {
    EnvGuard env("osmesa");
    EXPECT_EQ(fr::create_headless_context()->backend(), fr::Backend::osmesa);
    // An explicit option wins over the environment.
    EXPECT_EQ(fr::create_headless_context({fr::Backend::egl})->backend(), fr::Backend::egl);
  }
  {
    EnvGuard env("EGL");
    EXPECT_EQ(fr::create_headless_context()->backend(), fr::Backend::egl);
  }
  {
    EnvGuard env("vulkan");
    EXPECT_THROW(fr::create_headless_context(), fabrica::InputError);
  }
  EXPECT_THROW(fr::create_headless_context({fr::Backend::glfw}), fabrica::InputError);
}

TEST(RenderBackends, FallbackToOsMesaWhenEglIsMissing) {
  // ctest runs this test a second time with __EGL_VENDOR_LIBRARY_FILENAMES
  // pointing nowhere (glvnd then finds no EGL driver) and
  // FABRICA_TEST_EXPECT_FALLBACK=1: forcing EGL must fail with a typed
  // "unavailable" error and automatic selection must fall back to OSMesa.
  EnvGuard env(nullptr);
  if (std::getenv("FABRICA_TEST_EXPECT_FALLBACK") == nullptr) {
    expect_gl33(*fr::create_headless_context());
    return;
  }
  try {
    fr::create_egl_context();
    FAIL() << "EGL should be unavailable in this run";
  } catch (const fabrica::Error& e) {
    EXPECT_EQ(e.kind(), fabrica::ErrorKind::unavailable);
    EXPECT_NE(std::string(e.what()).find("egl"), std::string::npos) << e.what();
  }
  auto ctx = fr::create_headless_context();
  EXPECT_EQ(ctx->backend(), fr::Backend::osmesa);
  expect_gl33(*ctx);
  fr::Renderer r(std::move(ctx));
  const fr::Image img = r.render(sphere_scene(), fabrica::test::front_camera(64, 64, 60.0));
  EXPECT_GT(img.pixel(32, 32)[0], 240);
}

TEST(RenderBackends, SameImageThroughEglAndOsMesa) {
  const Camera cam = fabrica::test::front_camera(160, 120, 60.0);
  fr::Renderer egl(fr::create_egl_context());
  fr::Renderer osmesa(fr::create_osmesa_context());
  const fr::Image a = egl.render(sphere_scene(), cam);
  const fr::Image b = osmesa.render(sphere_scene(), cam);
  ASSERT_EQ(a.width, 160);
  ASSERT_EQ(a.height, 120);
  const auto d = fr::compare_images(a, b, 2);
  EXPECT_TRUE(d.same_size);
  EXPECT_LE(d.fraction_over, 0.001) << "max " << d.max_abs;
  // Blue background at the corners, white-ish sphere in the centre.
  const auto* corner = a.pixel(0, 0);
  EXPECT_EQ(corner[0], 0);
  EXPECT_EQ(corner[2], 255);
  EXPECT_EQ(corner[3], 255);
  const auto* centre = a.pixel(80, 60);
  EXPECT_GT(centre[0], 240);
  EXPECT_GT(centre[1], 240);

  // And through a PNG file and back.
  const auto dir = fabrica::test::temp_dir("render_png");
  fr::write_png(a, dir / "sphere.png");
  const fr::Image c = fr::read_png(dir / "sphere.png");
  EXPECT_EQ(fr::compare_images(a, c, 0).max_abs, 0);
}

TEST(RenderBackends, TransparentBackgroundHasZeroAlphaAtCorners) {
  fr::Renderer r(fr::create_headless_context());
  fr::RenderOptions opt;
  opt.transparent_background = true;
  const fr::Image img = r.render(sphere_scene(), fabrica::test::front_camera(200, 100, 60.0), opt);
  for (auto [x, y] : {std::pair{0, 0}, {199, 0}, {0, 99}, {199, 99}})
    EXPECT_EQ(img.pixel(x, y)[3], 0) << x << "," << y;
  EXPECT_EQ(img.pixel(100, 50)[3], 255);
}

TEST(RenderBackends, LargeImageAndTilingAgree) {
  fr::Renderer r(fr::create_headless_context());
  fr::Scene scene = sphere_scene();
  // A visible circle on the sphere (z = 9) checks that quads are continuous across tiles.
  fabrica::Polyline pl;
  pl.family = fabrica::LineFamily::contour;
  for (int i = 0; i <= 64; ++i) {
    const double a = 2.0 * M_PI * i / 64;
    fabrica::LineVertex v;
    const double rc = std::sqrt(100.0 - 81.0);
    v.position = fabrica::Vec3(rc * std::cos(a), rc * std::sin(a), 9.0);
    pl.vertices.push_back(v);
  }
  scene.structures[0].lines.polylines.push_back(pl);
  const Camera cam = fabrica::test::front_camera(1500, 1100, 60.0);
  fr::RenderOptions tiled;
  tiled.max_tile_size = 400;  // 4 x 3 tiles
  const fr::Image a = r.render(scene, cam);
  const fr::Image b = r.render(scene, cam, tiled);
  const auto d = fr::compare_images(a, b, 1);
  if (d.fraction_over > 1e-4) {
    const auto dir = fabrica::test::temp_dir("render_tiles");
    fr::write_png(a, dir / "untiled.png");
    fr::write_png(b, dir / "tiled.png");
    ADD_FAILURE() << "images written to " << dir;
  }
  EXPECT_LE(d.fraction_over, 1e-4) << "max " << d.max_abs << " mean " << d.mean_abs;
  EXPECT_GT(fabrica::test::count_dark(a), 1000u);
}

TEST(RenderBackends, Image4096) {
  fr::Renderer r(fr::create_headless_context());
  const fr::Image img = r.render(sphere_scene(), fabrica::test::front_camera(4096, 4096, 60.0));
  ASSERT_EQ(img.width, 4096);
  ASSERT_EQ(img.height, 4096);
  EXPECT_EQ(img.pixel(0, 0)[2], 255);
  EXPECT_GT(img.pixel(2048, 2048)[0], 240);
}

TEST(RenderBackends, ShaderErrorNamesTheShaderAndHasTheDriverLog) {
  auto ctx = fr::create_headless_context();
  fr::ShaderStage bad;
  bad.type = GL_FRAGMENT_SHADER;
  bad.parts = {{"(version)", "#version 330 core\n"},
               {"broken.frag", "out vec4 c;\nvoid main() { c = vec4(undefined_name); }\n"}};
  try {
    fr::ShaderProgram p(ctx->gl(), "broken-program", {bad});
    FAIL() << "compiling a broken shader did not throw";
  } catch (const fabrica::Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(e.kind(), fabrica::ErrorKind::internal);
    EXPECT_NE(msg.find("broken.frag"), std::string::npos) << msg;
    EXPECT_NE(msg.find("broken-program"), std::string::npos) << msg;
    EXPECT_NE(msg.find("undefined_name"), std::string::npos) << msg;  // the driver's log
  }
  EXPECT_THROW(fr::shader_source("no-such.glsl"), fabrica::Error);
}

// render::write_png (zlib, Up filter; render/src/image.cpp): any size, the
// first row unfiltered and several IDAT chunks for a large noisy image, reads
// back (stb_image) to the same pixels, and writes the same bytes every time.
TEST(RenderPng, WrittenPixelsReadBackExactlyAndTheBytesAreStable) {
  const auto dir = fabrica::test::temp_dir("render_png_roundtrip");
  std::uint32_t state = 12345u;
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return static_cast<std::uint8_t>(state >> 24);
  };
  for (auto [w, h] : {std::pair{1, 1}, {37, 23}, {1500, 800}}) {
    fr::Image img(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 4; ++c)  // noise in the left half, flat on the right
          img.rgba[(static_cast<std::size_t>(y) * w + x) * 4 + c] =
              x < w / 2 ? next() : static_cast<std::uint8_t>(40 * c + y % 7);
    const auto path = dir / ("img-" + std::to_string(w) + ".png");
    fr::write_png(img, path);
    const fr::Image back = fr::read_png(path);
    ASSERT_EQ(back.width, w);
    ASSERT_EQ(back.height, h);
    EXPECT_EQ(back.rgba, img.rgba) << w << "x" << h;
    const auto again = dir / ("again-" + std::to_string(w) + ".png");
    fr::write_png(img, again);
    std::ifstream a(path, std::ios::binary), b(again, std::ios::binary);
    const std::string sa((std::istreambuf_iterator<char>(a)), {}),
        sb((std::istreambuf_iterator<char>(b)), {});
    EXPECT_EQ(sa, sb);
  }
}
