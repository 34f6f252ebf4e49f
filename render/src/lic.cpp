// Surface LIC: options, the shared noise and kernel, the field per triangle
// and the CPU reference (docs/algorithms.md §14). The GPU pass is in
// renderer.cpp and shaders/lic_*.
#include "fabrica/render/lic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
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
  LicField field = compute_lic_field(surface);
  mesh.lic_field = std::move(field.direction);
  mesh.lic_level = std::move(field.level);
}

void set_lic_field(RenderMesh& mesh, const std::shared_ptr<const Surface>& surface) {
  if (!surface) throw InputError("LIC: no surface");
  if (mesh.vertex_count() != surface->vertex_count() ||
      mesh.triangle_count() != surface->face_count())
    throw InputError("LIC: the render mesh was not made from this surface");
  const std::shared_ptr<const LicField> field = cached_lic_field(surface);
  mesh.lic_field = field->direction;
  mesh.lic_level = field->level;
}

std::shared_ptr<const LicField> cached_lic_field(const std::shared_ptr<const Surface>& surface) {
  struct Entry {
    std::weak_ptr<const Surface> surface;
    std::shared_ptr<const LicField> field;
  };
  static std::mutex mutex;
  static std::vector<Entry> cache;
  auto find = [&]() -> std::shared_ptr<const LicField> {
    // An expired entry's address may be reused by a new surface: dropped.
    std::erase_if(cache, [](const Entry& e) { return e.surface.expired(); });
    for (const Entry& e : cache)
      if (e.surface.lock() == surface) return e.field;
    return nullptr;
  };
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (auto hit = find()) return hit;
  }
  // Computed outside the lock (parallel inside); a concurrent twin computes
  // the same bytes, the first one stored wins.
  auto field = std::make_shared<const LicField>(compute_lic_field(*surface));
  const std::lock_guard<std::mutex> lock(mutex);
  if (auto hit = find()) return hit;
  cache.push_back({surface, field});
  return field;
}

LicField compute_lic_field(const Surface& surface) {
  const hatching::CurvatureField field = hatching::compute_curvature_field(surface);
  const hatching::FeatureRegions regions = hatching::compute_feature_regions(surface);
  const std::size_t nv = surface.vertex_count();
  // Per vertex, the line average (doubled angles, area weighted) of its
  // faces' directions in a tangent frame (t, b) of the vertex normal.
  const auto& normals = surface.vertex_normals();
  std::vector<Vec3> t(nv), b(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const Vec3& n = normals[v];
    const Vec3 axis = std::abs(n.x()) < 0.6 ? Vec3::UnitX() : Vec3::UnitY();
    t[v] = n.cross(axis);
    const double len = t[v].norm();
    t[v] = len > 0.0 ? Vec3(t[v] / len) : Vec3::Zero();
    b[v] = n.cross(t[v]);
  }
  std::vector<Vec2> sum(nv, Vec2::Zero());
  const auto& faces = surface.faces();
  const auto& areas = surface.face_areas();
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Vec3& d = field.face_direction[f];
    if (!(d.squaredNorm() > 0.0) || !(areas[f] > 0.0)) continue;
    for (int c = 0; c < 3; ++c) {
      const auto v = static_cast<std::size_t>(faces[f][c]);
      const double x = d.dot(t[v]), y = d.dot(b[v]), r2 = x * x + y * y;
      if (r2 > 0.0) sum[v] += areas[f] * Vec2((x * x - y * y) / r2, 2.0 * x * y / r2);
    }
  }
  LicField out;
  out.direction.assign(3 * nv, 0.0f);
  out.level.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    out.level[v] = static_cast<float>(regions.level[v]);
    if (!(sum[v].squaredNorm() > 0.0)) continue;
    const double half = 0.5 * std::atan2(sum[v].y(), sum[v].x());
    const Vec3 d = std::cos(half) * t[v] + std::sin(half) * b[v];
    for (int c = 0; c < 3; ++c) out.direction[3 * v + c] = static_cast<float>(d[c]);
  }
  return out;
}

// ------------------------------------------------------------ reference

namespace {

// Stage 1 data of one pixel as the RGBA8 target holds it (lic_stage1.frag):
// screen direction (decoded 2 x - 1), noise, mask.
struct Texel {
  float dx = 0.0f, dy = 0.0f, noise = 0.0f, mask = 0.0f;
};

// A value in [0, 1] through an 8-bit normalised channel.
float unorm8(float x) {
  return std::round(std::clamp(x, 0.0f, 1.0f) * 255.0f) / 255.0f;
}

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
  std::vector<std::uint8_t> front(pixels, 0);
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
        front[i] = area > 0.0 ? 1 : 0;  // counter-clockwise on the screen (y up)
        Vec3 b(l[0] / clip[0].w(), l[1] / clip[1].w(), l[2] / clip[2].w());
        bary[i] = b / b.sum();
      }
    }
  }

  // Per vertex (lic_stage1.vert): the direction's screen projection as a
  // doubled-angle vector.
  std::vector<Vec2> doubled(mesh.vertex_count(), Vec2::Zero());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const float* fd = &mesh.lic_field[3 * v];
    const Vec3 p = vertex(static_cast<std::uint32_t>(v));
    const Eigen::Vector4d c = mvp * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
    const Eigen::Vector4d dc = mvp * Eigen::Vector4d(fd[0], fd[1], fd[2], 0.0);
    const double sx = (dc.x() * c.w() - c.x() * dc.w()) * W,
                 sy = (dc.y() * c.w() - c.y() * dc.w()) * H;
    const double l2 = sx * sx + sy * sy;
    if (l2 > 0.0) doubled[v] = Vec2((sx * sx - sy * sy) / l2, 2.0 * sx * sy / l2);
  }

  // Stage 1 per pixel: the visible front faces (lic_stage1.frag).
  std::vector<Texel> data(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (tri[i] < 0 || !front[i]) continue;
    const auto t = static_cast<std::size_t>(tri[i]);
    Vec3 p = Vec3::Zero();
    Vec2 q = Vec2::Zero();
    double level = 0.0;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * t + k];
      p += bary[i][k] * vertex(v);
      q += bary[i][k] * doubled[v];
      level += bary[i][k] * mesh.lic_level[v];
    }
    const float mask = std::clamp(static_cast<float>(level), 0.0f, 1.0f);
    Texel& d = data[i];
    const Vec3 pf = p.cast<float>().cast<double>();
    d.noise = unorm8(lic_noise(static_cast<float>(pf.x()) * inv_cell,
                               static_cast<float>(pf.y()) * inv_cell,
                               static_cast<float>(pf.z()) * inv_cell));
    const double len = q.norm();
    if (!(len > 1e-4) || !(mask > 0.0f)) continue;  // (0.5, 0.5, noise, 0)
    const double c = std::clamp(q.x() / len, -1.0, 1.0);
    double dx = std::sqrt(0.5 * (1.0 + c)), dy = std::sqrt(0.5 * (1.0 - c));
    if (q.y() < 0.0) dy = -dy;
    d.dx = 2.0f * unorm8(static_cast<float>(dx * 0.5 + 0.5)) - 1.0f;
    d.dy = 2.0f * unorm8(static_cast<float>(dy * 0.5 + 0.5)) - 1.0f;
    d.mask = unorm8(mask);
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
