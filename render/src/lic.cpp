// Surface LIC: options, the shared noise and kernel, the field per triangle
// and the CPU reference (docs/algorithms.md §14). The GPU pass is in
// renderer.cpp and shaders/lic_*.
#include "fabrica/render/lic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/curvature_field.hpp"

namespace fabrica::render {

void validate(const LicOptions& o, const std::string& what) {
  auto bad = [&](const std::string& name, double v, const std::string& range) {
    throw InputError(what + ": " + name + " must be " + range + " (got " + std::to_string(v) + ")");
  };
  if (!(o.kernel_length > 0.0 && o.kernel_length <= 64.0))
    bad("kernel length", o.kernel_length, "in (0, 64] noise cells");
  if (!(o.noise_scale >= 0.0 && std::isfinite(o.noise_scale)))
    bad("noise scale", o.noise_scale, "a size in mm >= 0 (0 = automatic)");
  if (!(o.strength >= 0.0 && o.strength <= 1.0)) bad("strength", o.strength, "in [0, 1]");
}

double lic_noise_cell(const RenderMesh& mesh, const LicOptions& o) {
  if (o.noise_scale > 0.0) return o.noise_scale;
  const double r = mesh.radius > 0.0 ? mesh.radius : 1.0;
  return r / 200.0;
}

double camera_px_per_mm(const Camera& camera) {
  const double half_h = (camera.center - camera.eye).norm() *
                        std::tan(0.5 * camera.fov_deg * std::numbers::pi / 180.0);
  return camera.height / (2.0 * half_h);
}

LicKernel lic_kernel(const LicOptions& o, double cell_mm, double px_per_mm) {
  LicKernel k;
  const double length_px = o.kernel_length * cell_mm * px_per_mm;
  if (!(length_px >= 1.0) || !std::isfinite(length_px)) {
    k.steps = 0;
    k.step_px = 1.0f;
  } else {
    k.steps = std::min(kLicMaxSteps, static_cast<int>(std::ceil(length_px)));
    k.step_px = static_cast<float>(length_px / k.steps);
  }
  // Averaging about 2 L independent cells shrinks the noise's spread by
  // sqrt(2 L); the stretch restores most of it (docs/algorithms.md §14).
  k.gain = static_cast<float>(std::max(1.0, 0.8 * std::sqrt(2.0 * o.kernel_length)));
  for (int i = 1; i <= k.steps; ++i)
    k.weights.push_back(
        static_cast<float>(0.5 + 0.5 * std::cos(std::numbers::pi * i / (k.steps + 1.0))));
  return k;
}

namespace {

// The same integer hash as shaders/lic_noise.glsl (wrapping 32-bit products).
std::uint32_t lattice_hash(std::int32_t x, std::int32_t y, std::int32_t z) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 0x8da6b343u ^
                    static_cast<std::uint32_t>(y) * 0xd8163841u ^
                    static_cast<std::uint32_t>(z) * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

float lattice_value(std::int32_t x, std::int32_t y, std::int32_t z) {
  return static_cast<float>(lattice_hash(x, y, z) >> 8) * (1.0f / 16777216.0f);
}

}  // namespace

float lic_noise(float x, float y, float z) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const auto ix = static_cast<std::int32_t>(fx), iy = static_cast<std::int32_t>(fy),
             iz = static_cast<std::int32_t>(fz);
  auto smooth = [](float t) { return t * t * (3.0f - 2.0f * t); };
  const float tx = smooth(x - fx), ty = smooth(y - fy), tz = smooth(z - fz);
  auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
  float c[2][2];
  for (int j = 0; j < 2; ++j)
    for (int k = 0; k < 2; ++k)
      c[j][k] = lerp(lattice_value(ix, iy + j, iz + k), lattice_value(ix + 1, iy + j, iz + k), tx);
  return lerp(lerp(c[0][0], c[1][0], ty), lerp(c[0][1], c[1][1], ty), tz);
}

void set_lic_field(RenderMesh& mesh, const Surface& surface) {
  if (mesh.vertex_count() != surface.vertex_count() ||
      mesh.triangle_count() != surface.face_count())
    throw InputError("LIC: the render mesh was not made from this surface");
  const hatching::CurvatureField field = hatching::compute_curvature_field(surface);
  const hatching::FeatureRegions regions = hatching::compute_feature_regions(surface);
  mesh.lic_field.assign(4 * surface.face_count(), 0.0f);
  for (std::size_t f = 0; f < surface.face_count(); ++f) {
    const Vec3& d = field.face_direction[f];
    if (!(d.squaredNorm() > 0.0)) continue;  // degenerate face
    for (int c = 0; c < 3; ++c) mesh.lic_field[4 * f + c] = static_cast<float>(d[c]);
    mesh.lic_field[4 * f + 3] = 1.0f;
  }
  mesh.lic_level.resize(surface.vertex_count());
  for (std::size_t v = 0; v < surface.vertex_count(); ++v)
    mesh.lic_level[v] = static_cast<float>(regions.level[v]);
}

// ------------------------------------------------------------ reference

namespace {

// Stage 1 data of one pixel: screen direction, noise, mask (lic_stage1.frag).
struct Texel {
  float dx = 0.0f, dy = 0.0f, noise = 0.0f, mask = 0.0f;
};

}  // namespace

LicBuffer lic_reference(const RenderMesh& mesh, const Camera& camera, const LicOptions& options) {
  validate(options);
  validate_camera(camera, "camera");
  if (!mesh.has_lic_field())
    throw InputError("LIC needs the mesh's direction field and feature level (set_lic_field)");
  const int W = camera.width, H = camera.height;
  const auto [n, f] = clip_planes(camera, mesh.center, std::max(mesh.radius, 1e-9));
  const Eigen::Matrix4d mvp = projection_matrix(camera, n, f) * view_matrix(camera);
  const double cell = lic_noise_cell(mesh, options);
  const LicKernel kernel = lic_kernel(options, cell, camera_px_per_mm(camera));
  const auto inv_cell = static_cast<float>(1.0 / cell);

  // Rasterise at pixel centres (GL convention, y up): nearest triangle and
  // its perspective-correct barycentric coordinates.
  const std::size_t pixels = static_cast<std::size_t>(W) * H;
  std::vector<double> depth(pixels, std::numeric_limits<double>::infinity());
  std::vector<std::int64_t> tri(pixels, -1);
  std::vector<Vec3> bary(pixels);
  auto vertex = [&](std::uint32_t v) {
    return Vec3(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
  };
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    Eigen::Vector4d clip[3];
    double sx[3], sy[3], sz[3];
    bool behind = false;
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = vertex(mesh.indices[3 * t + k]);
      clip[k] = mvp * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
      if (!(clip[k].w() > 1e-12)) behind = true;
      sx[k] = (0.5 * clip[k].x() / clip[k].w() + 0.5) * W;
      sy[k] = (0.5 * clip[k].y() / clip[k].w() + 0.5) * H;
      sz[k] = clip[k].z() / clip[k].w();
    }
    if (behind) continue;
    const double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
    if (std::abs(area) < 1e-12) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({sx[0], sx[1], sx[2]}))));
    const int x1 = std::min(W - 1, static_cast<int>(std::ceil(std::max({sx[0], sx[1], sx[2]}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({sy[0], sy[1], sy[2]}))));
    const int y1 = std::min(H - 1, static_cast<int>(std::ceil(std::max({sy[0], sy[1], sy[2]}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        double l[3];
        for (int k = 0; k < 3; ++k) {
          const int a = (k + 1) % 3, b = (k + 2) % 3;
          l[k] = ((sx[b] - sx[a]) * (py - sy[a]) - (sy[b] - sy[a]) * (px - sx[a])) / area;
        }
        if (l[0] < 0.0 || l[1] < 0.0 || l[2] < 0.0) continue;
        const double z = l[0] * sz[0] + l[1] * sz[1] + l[2] * sz[2];
        const std::size_t i = static_cast<std::size_t>(y) * W + x;
        if (!(z < depth[i]) || z < -1.0 || z > 1.0) continue;
        depth[i] = z;
        tri[i] = static_cast<std::int64_t>(t);
        Vec3 b(l[0] / clip[0].w(), l[1] / clip[1].w(), l[2] / clip[2].w());
        bary[i] = b / b.sum();
      }
    }
  }

  // Stage 1 per pixel.
  std::vector<Texel> data(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (tri[i] < 0) continue;
    const auto t = static_cast<std::size_t>(tri[i]);
    Vec3 p = Vec3::Zero();
    double level = 0.0;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * t + k];
      p += bary[i][k] * vertex(v);
      level += bary[i][k] * mesh.lic_level[v];
    }
    const float mask = std::clamp(static_cast<float>(level), 0.0f, 1.0f);
    const float* fd = &mesh.lic_field[4 * t];
    Texel& d = data[i];
    const Vec3 pf = p.cast<float>().cast<double>();
    d.noise =
        lic_noise(static_cast<float>(pf.x()) * inv_cell, static_cast<float>(pf.y()) * inv_cell,
                  static_cast<float>(pf.z()) * inv_cell);
    const Eigen::Vector4d c = mvp * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
    const Eigen::Vector4d dc = mvp * Eigen::Vector4d(fd[0], fd[1], fd[2], 0.0);
    const double sx = (dc.x() * c.w() - c.x() * dc.w()) * W,
                 sy = (dc.y() * c.w() - c.y() * dc.w()) * H;
    const double len = std::hypot(sx, sy);
    if (!(len > 0.0) || !(fd[3] > 0.0f) || !(mask > 0.0f)) continue;
    d.dx = static_cast<float>(sx / len);
    d.dy = static_cast<float>(sy / len);
    d.mask = mask;
  }

  // Stage 2: the convolution (lic_stage2.frag).
  LicBuffer out;
  out.width = W;
  out.height = H;
  out.value.assign(pixels, 0.0f);
  out.mask.assign(pixels, 0.0f);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const Texel& c = data[static_cast<std::size_t>(y) * W + x];
      if (!(c.mask > 0.0f)) continue;
      float sum = c.noise, wsum = 1.0f;
      for (float sign : {1.0f, -1.0f}) {
        float px = x + 0.5f, py = y + 0.5f, dx = sign * c.dx, dy = sign * c.dy;
        for (int i = 1; i <= kernel.steps; ++i) {
          px += kernel.step_px * dx;
          py += kernel.step_px * dy;
          const int qx = static_cast<int>(std::floor(px)), qy = static_cast<int>(std::floor(py));
          if (qx < 0 || qy < 0 || qx >= W || qy >= H) break;
          const Texel& s = data[static_cast<std::size_t>(qy) * W + qx];
          if (!(s.mask > 0.0f)) break;
          float nx = s.dx, ny = s.dy;
          if (nx * dx + ny * dy < 0.0f) nx = -nx, ny = -ny;
          dx = nx, dy = ny;
          const float w = kernel.weights[static_cast<std::size_t>(i - 1)];
          sum += w * s.noise;
          wsum += w;
        }
      }
      const float mean = sum / wsum;
      const std::size_t row = static_cast<std::size_t>(H - 1 - y) * W + x;  // Image rows top down
      out.value[row] = std::clamp(0.5f + (mean - 0.5f) * kernel.gain, 0.0f, 1.0f);
      out.mask[row] = c.mask;
    }
  }
  return out;
}

}  // namespace fabrica::render
