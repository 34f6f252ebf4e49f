// The CPU depth rasteriser; see the header.
#include "fabrica/core/depth_raster.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>

#include "depth_raster_internal.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/projector.hpp"

namespace fabrica {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();

}  // namespace

float DepthBuffer::min3x3(double x, double y) const {
  const int cx = static_cast<int>(std::floor(x)), cy = static_cast<int>(std::floor(y));
  float m = kInf;
  for (int yy = std::max(cy - 1, 0); yy <= std::min(cy + 1, height - 1); ++yy)
    for (int xx = std::max(cx - 1, 0); xx <= std::min(cx + 1, width - 1); ++xx)
      m = std::min(m, at(xx, yy));
  return m;
}

float DepthBuffer::max3x3(double x, double y) const {
  const int cx = static_cast<int>(std::floor(x)), cy = static_cast<int>(std::floor(y));
  float m = -kInf;
  for (int yy = cy - 1; yy <= cy + 1; ++yy)
    for (int xx = cx - 1; xx <= cx + 1; ++xx) {
      if (xx < 0 || yy < 0 || xx >= width || yy >= height) return kInf;
      m = std::max(m, at(xx, yy));
    }
  return m;
}

namespace {

using Corner = detail::RasterCorner;
using Binned = detail::RasterTriangle;

// floor(v) for v well inside the int range (std::floor is a library call
// without SSE4.1).
inline int floor_int(double v) {
  const int i = static_cast<int>(v);
  return i - (static_cast<double>(i) > v ? 1 : 0);
}

// First pixel centre (c + 0.5) at or after v and last at or before v, for
// v clamped to [-2, size + 1]. Exact: no rounding of v - 0.5.
inline void centres_around(double v, int size, std::int16_t& lo, std::int16_t& hi) {
  v = std::min(std::max(v, -2.0), static_cast<double>(size) + 1.0);
  const int f = floor_int(v);
  lo = static_cast<std::int16_t>(f + (f + 0.5 < v ? 1 : 0));
  hi = static_cast<std::int16_t>(f - (f + 0.5 > v ? 1 : 0));
}

constexpr int kBand = 32;              // rows per band
constexpr std::size_t kChunk = 16384;  // faces per binning chunk
constexpr int kMaxSide = 32000;        // pixel indices (and size + 1) fit in int16

}  // namespace

namespace detail {

namespace {

// The portable row kernel: per row, up to 64 columns at a time, the
// coverage of every pixel first (no branches), then the depth of the
// covered ones.
struct PortableRows {
  template <bool kFaces>
  static void draw(const RasterBand& band, const raster_band::Setup& s) {
    const int W = band.width;
    double num[64][3];
    for (int y = s.y0; y <= s.y1; ++y) {
      const double py = y + 0.5;
      double ry[3];
      for (int k = 0; k < 3; ++k) ry[k] = s.ex[k] * (py - s.ay[k]);
      float* const row = band.depth + static_cast<std::size_t>(y) * W;
      for (int xs = s.x0; xs <= s.x1; xs += 64) {
        const int n = std::min<int>(s.x1 - xs + 1, 64);
        std::uint64_t mask = 0;
        for (int i = 0; i < n; ++i) {
          const double px = (xs + i) + 0.5;
          double* const m = num[i];
          m[0] = ry[0] - s.ey[0] * (px - s.ax[0]);
          m[1] = ry[1] - s.ey[1] * (px - s.ax[1]);
          m[2] = ry[2] - s.ey[2] * (px - s.ax[2]);
          const bool in = s.positive ? (!(m[0] < 0.0) & !(m[1] < 0.0) & !(m[2] < 0.0))
                                     : (!(m[0] > 0.0) & !(m[1] > 0.0) & !(m[2] > 0.0));
          mask |= static_cast<std::uint64_t>(in) << i;
        }
        while (mask != 0) {
          const int i = std::countr_zero(mask);
          mask &= mask - 1;
          const double* const m = num[i];
          const double w0 = m[0] * s.inv_area, w1 = m[1] * s.inv_area, w2 = m[2] * s.inv_area;
          const double d = band.perspective ? 1.0 / (w0 / s.z[0] + w1 / s.z[1] + w2 / s.z[2])
                                            : w0 * s.z[0] + w1 * s.z[1] + w2 * s.z[2];
          float& dst = row[xs + i];
          if constexpr (kFaces) {
            const float z = static_cast<float>(d);
            std::int32_t& id = band.seen[static_cast<std::size_t>(y) * W + xs + i];
            if (z < dst || (z == dst && s.face < id)) {
              dst = z;
              id = s.face;
            }
          } else {
            dst = std::min(dst, static_cast<float>(d));
          }
        }
      }
    }
  }
};

}  // namespace

void project_corner(const Projector& project, const Vec3& position, RasterCorner& c) {
  const ProjectedPoint pp = project(position);
  c.x = pp.pixel.x();
  c.y = pp.pixel.y();
  c.z = pp.depth;
  c.valid = std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z) &&
            !(project.perspective() && c.z <= kRasterNearLimit);
  if (c.valid) {
    centres_around(c.x, project.width(), c.x_lo, c.x_hi);
    centres_around(c.y, project.height(), c.y_lo, c.y_hi);
  }
}

void draw_band_portable(const RasterBand& band) {
  raster_band::draw_band<PortableRows>(band);
}

#if !defined(FABRICA_DEPTH_RASTER_AVX2)
// Without the AVX2 file: never called (depth_raster_avx2_enabled() is false).
void draw_band_avx2(const RasterBand& band) {
  draw_band_portable(band);
}
std::size_t project_corners_avx2(const Projector&, const Vec3*, RasterCorner*, std::size_t begin,
                                 std::size_t) {
  return begin;
}
#endif

std::atomic<bool>& depth_raster_avx2_enabled() {
#if defined(FABRICA_DEPTH_RASTER_AVX2)
  static std::atomic<bool> on{__builtin_cpu_supports("avx2") != 0};
#else
  static std::atomic<bool> on{false};
#endif
  return on;
}

// render_depth's working memory, kept in the DepthBuffer between calls.
struct RasterScratch {
  // Grow-only storage left uninitialised (every element used is written
  // first, in the parallel loops), so a fresh buffer pays no serial zeroing.
  template <class T>
  struct Array {
    std::unique_ptr<T[]> data;
    std::size_t capacity = 0;
    void resize(std::size_t n) {
      if (n > capacity) {
        data.reset(new T[n]);
        capacity = n;
      }
    }
    T& operator[](std::size_t i) { return data[i]; }
  };
  static_assert(std::is_trivially_default_constructible_v<Corner> &&
                std::is_trivially_default_constructible_v<Binned>);
  // One chunk of faces' triangles, by (group, band, face): (group g, band
  // k)'s are [start[g * bands + k], start[g * bands + k + 1]).
  struct Chunk {
    Array<Binned> binned;
    std::vector<std::uint32_t> start;
  };
  Array<Corner> corners;
  std::vector<Chunk> chunks;
};

RasterScratchSlot::RasterScratchSlot() = default;
RasterScratchSlot::~RasterScratchSlot() = default;
RasterScratchSlot::RasterScratchSlot(const RasterScratchSlot&) {}
RasterScratchSlot& RasterScratchSlot::operator=(const RasterScratchSlot&) {
  return *this;
}
RasterScratchSlot::RasterScratchSlot(RasterScratchSlot&&) noexcept = default;
RasterScratchSlot& RasterScratchSlot::operator=(RasterScratchSlot&&) noexcept = default;
RasterScratch& RasterScratchSlot::get() {
  if (!scratch_) scratch_ = std::make_unique<RasterScratch>();
  return *scratch_;
}

}  // namespace detail

// Depth raster. Per pixel the coverage test and the depth are evaluated
// exactly as the original scalar rasteriser did (same double operations in
// the same order), so the buffer is bit-identical to it; what changed is
// which triangles and pixels are visited:
//  * only pixel centres inside a triangle's bounding box are tested;
//  * triangles are binned into 32-row bands per fixed chunk of faces, each
//    chunk into a list of its own (in parallel over chunks), and the bands
//    are rasterised in parallel, each band's triangles chunk after chunk;
//  * in each band the triangles facing the camera in the image (negative
//    signed area: counter-clockwise in a y-up view) are drawn first, then the
//    others, each of which is skipped when every pixel of its box already
//    holds a depth at or below a guaranteed lower bound of any depth it
//    could write. The buffer keeps the minimum, which does not depend on the
//    order (positive depths), so skipping changes nothing; on a closed or
//    nearly closed surface almost all back faces are skipped this way.
// Where the CPU has AVX2, the corners are projected and the rows drawn by
// depth_raster_avx2.cpp (four vertices or pixels per step, the same
// operations in the same order: the same bits).
void render_depth(const TriangleMesh& mesh, const Camera& camera, DepthBuffer& buf, bool faces) {
  if (camera.width <= 0 || camera.height <= 0 || camera.width > kMaxSide ||
      camera.height > kMaxSide)
    throw InputError("depth buffer: image size " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height) + " is not between 1 and " +
                     std::to_string(kMaxSide) + " pixels per side; choose a smaller size");
  buf.width = camera.width;
  buf.height = camera.height;
  buf.depth.resize(static_cast<std::size_t>(buf.width) * static_cast<std::size_t>(buf.height));
  if (faces)
    buf.face.resize(buf.depth.size());
  else
    buf.face.clear();
  detail::RasterScratch& scratch = buf.scratch.get();
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.faces.size();
  auto& proj = scratch.corners;
  proj.resize(nv);
  const Projector project(camera);
  const bool perspective = camera.projection == Projection::perspective;
  const bool avx2 = detail::depth_raster_avx2_enabled().load(std::memory_order_relaxed);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 2048), [&](const auto& r) {
    std::size_t from = r.begin();
    if (avx2)
      from = detail::project_corners_avx2(project, mesh.positions.data(), proj.data.get(), from,
                                          r.end());
    for (std::size_t i = from; i != r.end(); ++i)
      detail::project_corner(project, mesh.positions[i], proj[i]);
  });
  const int W = buf.width;
  const std::size_t nb = static_cast<std::size_t>((buf.height + kBand - 1) / kBand);
  const std::size_t chunks = (nf + kChunk - 1) / kChunk;
  // The triangle of face f when it covers a pixel centre: its entry and
  // group (0: negative area).
  auto setup = [&](std::size_t f, Binned& e, std::size_t& g) {
    const Face& t = mesh.faces[f];
    const Corner &a = proj[t[0]], &b = proj[t[1]], &c = proj[t[2]];
    if (!(a.valid && b.valid && c.valid)) return false;
    e.x0 = std::max<std::int16_t>(std::min({a.x_lo, b.x_lo, c.x_lo}), 0);
    e.x1 = std::min<std::int16_t>(std::max({a.x_hi, b.x_hi, c.x_hi}),
                                  static_cast<std::int16_t>(buf.width - 1));
    if (e.x0 > e.x1) return false;
    e.y0 = std::max<std::int16_t>(std::min({a.y_lo, b.y_lo, c.y_lo}), 0);
    e.y1 = std::min<std::int16_t>(std::max({a.y_hi, b.y_hi, c.y_hi}),
                                  static_cast<std::int16_t>(buf.height - 1));
    if (e.y0 > e.y1) return false;
    e.area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (e.area == 0.0 || e.area != e.area) return false;
    e.face = static_cast<std::int32_t>(f);
    e.bound = -kInf;
    g = e.area < 0.0 ? 0 : 1;
    if (g == 1) {
      // Any depth written is >= zmin (1 - 1e-6) when the barycentric
      // weights are accurate: their error is below about
      // 1e-14 (s + 1)^2 / |area| for a box of side s (products of
      // coordinate differences <= s (s + 1), a few roundings each), so the
      // sum of the weights is within 1e-7 of 1 where (s + 1)^2 <= 3e6 |area|.
      // Slivers and non-positive depths get no bound (never skipped).
      // Rounding to float is monotonic; one more step down keeps the bound
      // below the stored depth.
      const double zmin = std::min({a.z, b.z, c.z});
      const double side = std::max(e.x1 - e.x0, e.y1 - e.y0) + 2.0;
      if (zmin > 0.0 && (side + 1.0) * (side + 1.0) <= 3e6 * std::abs(e.area)) {
        const float z = static_cast<float>(zmin * (1.0 - 1e-6));
        if (z > 0.0f && z < kInf)  // the next float below z
          e.bound = std::bit_cast<float>(std::bit_cast<std::uint32_t>(z) - 1u);
      }
    }
    return true;
  };
  // Per chunk of faces (in parallel), its triangles binned by group and
  // band in a list of its own: the chunks' lists are small pieces (a few
  // hundred kB each on a 270k-face mesh) instead of one array of every
  // band's triangles and one of every face's. A chunk's triangles are set
  // up once into a buffer of the task's, counted, then copied to their
  // bins.
  scratch.chunks.resize(chunks);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    const std::size_t f0 = c * kChunk, f1 = std::min(nf, f0 + kChunk);
    const std::unique_ptr<Binned[]> local(new Binned[f1 - f0]);
    detail::RasterScratch::Chunk& chunk = scratch.chunks[c];
    std::vector<std::uint32_t>& start = chunk.start;
    start.assign(2 * nb + 1, 0);
    std::size_t g;
    for (std::size_t f = f0; f < f1; ++f) {
      Binned& e = local[f - f0];
      if (setup(f, e, g)) {
        for (int k = e.y0 / kBand; k <= e.y1 / kBand; ++k)
          ++start[g * nb + static_cast<std::size_t>(k) + 1];
      } else {
        e.face = -1;
      }
    }
    for (std::size_t i = 0; i < 2 * nb; ++i) start[i + 1] += start[i];
    chunk.binned.resize(start[2 * nb]);
    std::vector<std::uint32_t> cursor(start.begin(), start.end() - 1);
    for (std::size_t f = f0; f < f1; ++f) {
      const Binned& e = local[f - f0];
      if (e.face < 0) continue;
      const std::size_t h = e.area < 0.0 ? 0 : 1;
      for (int k = e.y0 / kBand; k <= e.y1 / kBand; ++k)
        chunk.binned[cursor[h * nb + static_cast<std::size_t>(k)]++] = e;
    }
  });
  tbb::parallel_for(std::size_t{0}, nb, [&](std::size_t band) {
    const int y_lo = static_cast<int>(band) * kBand;
    const int y_hi = std::min(buf.height, y_lo + kBand) - 1;
    float* const image = buf.depth.data();
    std::int32_t* const seen = buf.face.data();
    std::fill(image + static_cast<std::size_t>(y_lo) * W,
              image + static_cast<std::size_t>(y_hi + 1) * W, kInf);
    if (faces)
      std::fill(seen + static_cast<std::size_t>(y_lo) * W,
                seen + static_cast<std::size_t>(y_hi + 1) * W, -1);
    detail::RasterBand job{
        nullptr, nullptr, mesh.faces.data(), proj.data.get(), image, faces ? seen : nullptr, W,
        y_lo,    y_hi,    perspective};
    // The triangles facing the camera first (group 0), then the others;
    // each group's in face order (chunk after chunk).
    for (std::size_t g = 0; g < 2; ++g)
      for (detail::RasterScratch::Chunk& chunk : scratch.chunks) {
        const std::uint32_t* const at = chunk.start.data() + g * nb + band;
        if (at[0] == at[1]) continue;
        job.first = chunk.binned.data.get() + at[0];
        job.last = chunk.binned.data.get() + at[1];
        if (avx2)
          detail::draw_band_avx2(job);
        else
          detail::draw_band_portable(job);
      }
  });
}

DepthBuffer render_depth(const TriangleMesh& mesh, const Camera& camera, bool faces) {
  DepthBuffer buf;
  render_depth(mesh, camera, buf, faces);
  return buf;
}

}  // namespace fabrica
