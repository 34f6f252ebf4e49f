// CPU z-buffer rasteriser; see the header.
#include "fabrica/hatching/depth_buffer.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace fabrica::hatching {
namespace {
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
constexpr int kBandRows = 16;
/// Faces per binning chunk (fixed, so the binning does not depend on threads).
constexpr std::size_t kBinChunk = 16384;
}  // namespace

ImageProjector::ImageProjector(const Camera& camera)
    : camera_(camera),
      forward_(camera.forward()),
      right_(camera.right()),
      up_(camera.true_up()),
      half_h_(std::tan(0.5 * camera.fov_deg * kDegToRad)),
      ortho_h_((camera.center - camera.eye).norm() * half_h_),
      aspect_(camera.aspect()),
      perspective_(camera.projection == Projection::perspective) {}

ProjectedPoint ImageProjector::project(const Vec3& p) const {
  // Same operations, in the same order, as fabrica::project().
  const Vec3 d = p - camera_.eye;
  const double depth = d.dot(forward_);
  double x, y;
  if (perspective_) {
    x = d.dot(right_) / (depth * half_h_);
    y = d.dot(up_) / (depth * half_h_);
  } else {
    x = d.dot(right_) / ortho_h_;
    y = d.dot(up_) / ortho_h_;
  }
  x /= aspect_;
  return {Vec2(0.5 * (x + 1.0) * camera_.width, 0.5 * (1.0 - y) * camera_.height), depth};
}

void ImageProjector::ray(const Vec2& pixel, Vec3& origin, Vec3& direction) const {
  const double x = (2.0 * pixel.x() / camera_.width - 1.0) * aspect_;
  const double y = 1.0 - 2.0 * pixel.y() / camera_.height;
  if (perspective_) {
    origin = camera_.eye;
    direction = (forward_ + x * half_h_ * right_ + y * half_h_ * up_).normalized();
  } else {
    origin = camera_.eye + x * ortho_h_ * right_ + y * ortho_h_ * up_;
    direction = forward_;
  }
}

double ImageProjector::pixel_size(double depth) const {
  const double h = perspective_ ? depth * half_h_ : ortho_h_;
  return 2.0 * h / camera_.height;
}

DepthBuffer rasterize_depth(const TriangleMesh& mesh, const Camera& camera) {
  DepthBuffer buffer;
  buffer.width = camera.width;
  buffer.height = camera.height;
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * camera.height;
  buffer.depth.assign(pixels, std::numeric_limits<float>::infinity());
  buffer.face.assign(pixels, -1);

  const ImageProjector projector(camera);
  const bool perspective = camera.projection == Projection::perspective;
  const std::size_t nv = mesh.positions.size(), nf = mesh.faces.size();
  std::vector<ProjectedPoint> projected(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v)
      projected[v] = projector.project(mesh.positions[v]);
  });

  // Bin faces into bands of rows (in face order, so every band sees its
  // faces in increasing index), then rasterise the bands in parallel. The
  // binning runs on fixed chunks of faces in parallel, each chunk with its
  // own band lists, joined in chunk order: the same lists at any thread count.
  const int bands = (camera.height + kBandRows - 1) / kBandRows;
  std::vector<std::array<int, 4>> boxes(nf);
  const std::size_t chunks = (nf + kBinChunk - 1) / kBinChunk;
  std::vector<std::vector<std::vector<std::int32_t>>> chunk_bands(
      chunks, std::vector<std::vector<std::int32_t>>(static_cast<std::size_t>(bands)));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& r) {
    for (std::size_t chunk = r.begin(); chunk != r.end(); ++chunk) {
      auto& band_faces = chunk_bands[chunk];
      const std::size_t f_end = std::min(nf, (chunk + 1) * kBinChunk);
      for (std::size_t f = chunk * kBinChunk; f < f_end; ++f) {
        const Face& t = mesh.faces[f];
        const ProjectedPoint& a = projected[static_cast<std::size_t>(t[0])];
        const ProjectedPoint& b = projected[static_cast<std::size_t>(t[1])];
        const ProjectedPoint& c = projected[static_cast<std::size_t>(t[2])];
        if (a.depth <= 0.0 || b.depth <= 0.0 || c.depth <= 0.0) continue;
        const double lo_x = std::min({a.pixel.x(), b.pixel.x(), c.pixel.x()});
        const double hi_x = std::max({a.pixel.x(), b.pixel.x(), c.pixel.x()});
        const double lo_y = std::min({a.pixel.y(), b.pixel.y(), c.pixel.y()});
        const double hi_y = std::max({a.pixel.y(), b.pixel.y(), c.pixel.y()});
        if (!(hi_x >= 0.0 && hi_y >= 0.0 && lo_x < camera.width && lo_y < camera.height)) continue;
        // Pixel centres i + 0.5 inside [lo, hi].
        const int i0 = std::max(0, static_cast<int>(std::ceil(lo_x - 0.5)));
        const int i1 = std::min(camera.width - 1, static_cast<int>(std::floor(hi_x - 0.5)));
        const int j0 = std::max(0, static_cast<int>(std::ceil(lo_y - 0.5)));
        const int j1 = std::min(camera.height - 1, static_cast<int>(std::floor(hi_y - 0.5)));
        if (i0 > i1 || j0 > j1) continue;
        boxes[f] = {i0, i1, j0, j1};
        for (int band = j0 / kBandRows; band <= j1 / kBandRows; ++band)
          band_faces[static_cast<std::size_t>(band)].push_back(static_cast<std::int32_t>(f));
      }
    }
  });
  std::vector<std::vector<std::int32_t>> band_faces(static_cast<std::size_t>(bands));
  tbb::parallel_for(tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& r) {
    for (int band = r.begin(); band != r.end(); ++band) {
      auto& out = band_faces[static_cast<std::size_t>(band)];
      std::size_t total = 0;
      for (const auto& lists : chunk_bands) total += lists[static_cast<std::size_t>(band)].size();
      out.reserve(total);
      for (const auto& lists : chunk_bands) {
        const auto& in = lists[static_cast<std::size_t>(band)];
        out.insert(out.end(), in.begin(), in.end());
      }
    }
  });

  tbb::parallel_for(tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& r) {
    for (int band = r.begin(); band != r.end(); ++band) {
      const int row_lo = band * kBandRows, row_hi = std::min(camera.height, row_lo + kBandRows) - 1;
      for (const std::int32_t f : band_faces[static_cast<std::size_t>(band)]) {
        const Face& t = mesh.faces[static_cast<std::size_t>(f)];
        const ProjectedPoint& a = projected[static_cast<std::size_t>(t[0])];
        const ProjectedPoint& b = projected[static_cast<std::size_t>(t[1])];
        const ProjectedPoint& c = projected[static_cast<std::size_t>(t[2])];
        const double area = (b.pixel.x() - a.pixel.x()) * (c.pixel.y() - a.pixel.y()) -
                            (b.pixel.y() - a.pixel.y()) * (c.pixel.x() - a.pixel.x());
        if (!(std::abs(area) > 1e-12)) continue;
        const double inv_area = 1.0 / area;
        const auto& box = boxes[static_cast<std::size_t>(f)];
        const int j0 = std::max(box[2], row_lo), j1 = std::min(box[3], row_hi);
        // Per-vertex depth terms: 1/z for perspective (linear in screen space), z otherwise.
        const double za = perspective ? 1.0 / a.depth : a.depth;
        const double zb = perspective ? 1.0 / b.depth : b.depth;
        const double zc = perspective ? 1.0 / c.depth : c.depth;
        for (int j = j0; j <= j1; ++j) {
          const double py = j + 0.5;
          for (int i = box[0]; i <= box[1]; ++i) {
            const double px = i + 0.5;
            // Barycentric coordinates in screen space (signed areas).
            const double wa = ((b.pixel.x() - px) * (c.pixel.y() - py) -
                               (b.pixel.y() - py) * (c.pixel.x() - px)) *
                              inv_area;
            const double wb = ((c.pixel.x() - px) * (a.pixel.y() - py) -
                               (c.pixel.y() - py) * (a.pixel.x() - px)) *
                              inv_area;
            const double wc = 1.0 - wa - wb;
            if (wa < 0.0 || wb < 0.0 || wc < 0.0) continue;
            const double zi = wa * za + wb * zb + wc * zc;
            const float z = static_cast<float>(perspective ? 1.0 / zi : zi);
            const std::size_t at = static_cast<std::size_t>(j) * camera.width + i;
            if (z < buffer.depth[at] || (z == buffer.depth[at] && f < buffer.face[at])) {
              buffer.depth[at] = z;
              buffer.face[at] = f;
            }
          }
        }
      }
    }
  });
  return buffer;
}

}  // namespace fabrica::hatching
