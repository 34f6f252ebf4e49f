// Private to fabrica::core: what depth_raster.cpp (the portable row kernel)
// and depth_raster_avx2.cpp (the AVX2 one, compiled with -mavx2 and called
// only when the CPU has AVX2) share: the projected corners, the binned
// triangles, one band's job and the band loop around a row kernel.
//
// The band loop is in an anonymous namespace: the two files compile it with
// different instruction sets, and the two copies must never be merged by
// the linker (an inline function or template with external linkage would
// be).
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/projector.hpp"

namespace fabrica::detail {

// Projected corner: pixel position, linear depth, and the pixel centres on
// either side of it: lo = the first centre at or after the coordinate, hi =
// the last centre at or before it (per axis; coordinates clamped to just
// outside the image). A triangle's box covers the centres from the minimum
// lo to the maximum hi of its corners (the maps are monotonic).
struct RasterCorner {
  double x, y, z;
  std::int16_t x_lo, x_hi, y_lo, y_hi;
  bool valid;  // finite, and in front of the near limit (perspective)
};

// A triangle in a band's list: its doubled signed area in pixels, its face,
// a lower bound of any depth it can write (-inf: none known), and the pixel
// centres of its bounding box (clipped to the image).
struct RasterTriangle {
  double area;
  std::int32_t face;
  float bound;
  std::int16_t x0, x1, y0, y1;
};

// One band of rows [y_lo, y_hi] and its triangles [first, last) to draw
// into `depth` (and `seen`, the face per pixel, unless null): the image is
// `width` pixels wide, its rows already cleared.
struct RasterBand {
  const RasterTriangle* first;
  const RasterTriangle* last;
  const Face* faces;
  const RasterCorner* corners;
  float* depth;
  std::int32_t* seen;
  int width, y_lo, y_hi;
  bool perspective;
};

// Perspective views skip triangles with a corner at a depth at or below
// this (no near clipping).
constexpr double kRasterNearLimit = 1e-9;

// A position projected into its corner (depth_raster.cpp).
void project_corner(const Projector& project, const Vec3& position, RasterCorner& corner);
// Projects positions [begin, end) into corners with AVX2, four at a time,
// with the operations of project_corner (same bits); returns where it
// stopped (a multiple of four from begin): the caller does the rest. Call
// only when depth_raster_avx2_enabled().
std::size_t project_corners_avx2(const Projector& project, const Vec3* positions,
                                 RasterCorner* corners, std::size_t begin, std::size_t end);

// The band's triangles with the portable row kernel (depth_raster.cpp).
void draw_band_portable(const RasterBand& band);
// The same with the AVX2 row kernel (depth_raster_avx2.cpp); the same bits.
// Call only when depth_raster_avx2_enabled().
void draw_band_avx2(const RasterBand& band);

}  // namespace fabrica::detail

namespace fabrica::detail {
namespace {
namespace raster_band {

// A triangle ready for the row kernels. Edge k runs from corner k+1 to
// corner k+2; its barycentric weight at (px, py) is
// ((bx - ax)(py - ay) - (by - ay)(px - ax)) / area, evaluated term by term
// as the original scalar rasteriser (same bits): row term
// ex[k] (py - ay[k]), column term ey[k] (px - ax[k]), their difference the
// numerator. The weight is negative exactly when the numerator's sign
// differs from the area's (the product cannot underflow at pixel scale), so
// a pixel is covered when no numerator has the sign opposite to the area's.
struct Setup {
  double ax[3], ay[3], ex[3], ey[3];
  double z[3];
  double inv_area;
  bool positive;
  std::int32_t face;
  int x0, x1, y0, y1;  // the box's rows clipped to the band
};

// Whether the triangle is hidden: every pixel of its box already holds a
// depth at or below its bound (the buffer never holds NaN). Boxes up to 4
// wide (almost all) take four clamped reads per row and no branches.
inline bool hidden_in_band(const RasterTriangle& e, const float* image, int W, int ya, int yb) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  if (!(e.bound > -inf)) return false;
  float far = -inf;
  if (e.x1 - e.x0 < 4) {
    const int c1 = std::min(e.x0 + 1, static_cast<int>(e.x1));
    const int c2 = std::min(e.x0 + 2, static_cast<int>(e.x1));
    const int c3 = std::min(e.x0 + 3, static_cast<int>(e.x1));
    for (int y = ya; y <= yb; ++y) {
      const float* row = image + static_cast<std::size_t>(y) * W;
      far = std::max({far, row[e.x0], row[c1], row[c2], row[c3]});
    }
  } else {
    for (int y = ya; y <= yb && far <= e.bound; ++y) {
      const float* row = image + static_cast<std::size_t>(y) * W;
      for (int x = e.x0; x <= e.x1; ++x) far = std::max(far, row[x]);
    }
  }
  return far <= e.bound;
}

// Every triangle of the band that is not hidden, through
// Rows::draw<with_faces>(band, setup).
template <class Rows>
inline void draw_band(const RasterBand& band) {
  // The triangles without a bound are drawn: their face's corner indices
  // are fetched 2 kAhead triangles ahead and their corners kAhead ahead (a
  // band's triangles are a sparse subset of the faces, in face order: the
  // loads would otherwise miss the cache).
  constexpr std::ptrdiff_t kAhead = 8;
  constexpr float inf = std::numeric_limits<float>::infinity();
  for (const RasterTriangle* e = band.first; e != band.last; ++e) {
    if (band.last - e > 2 * kAhead) {
      if (!(e[2 * kAhead].bound > -inf)) __builtin_prefetch(band.faces + e[2 * kAhead].face);
      if (!(e[kAhead].bound > -inf)) {
        const Face& t = band.faces[static_cast<std::size_t>(e[kAhead].face)];
        for (int k = 0; k < 3; ++k) __builtin_prefetch(band.corners + t[k]);
      }
    }
    const int ya = std::max<int>(band.y_lo, e->y0), yb = std::min<int>(band.y_hi, e->y1);
    if (hidden_in_band(*e, band.depth, band.width, ya, yb)) continue;
    const Face& t = band.faces[static_cast<std::size_t>(e->face)];
    Setup s;
    for (int k = 0; k < 3; ++k) {
      const RasterCorner& ca = band.corners[t[(k + 1) % 3]];
      const RasterCorner& cb = band.corners[t[(k + 2) % 3]];
      s.ax[k] = ca.x;
      s.ay[k] = ca.y;
      s.ex[k] = cb.x - ca.x;
      s.ey[k] = cb.y - ca.y;
      s.z[k] = band.corners[t[k]].z;
    }
    s.inv_area = 1.0 / e->area;
    s.positive = e->area > 0.0;
    s.face = e->face;
    s.x0 = e->x0;
    s.x1 = e->x1;
    s.y0 = ya;
    s.y1 = yb;
    if (band.seen)
      Rows::template draw<true>(band, s);
    else
      Rows::template draw<false>(band, s);
  }
}

}  // namespace raster_band
}  // namespace
}  // namespace fabrica::detail
