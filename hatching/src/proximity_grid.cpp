// Hierarchical proximity grid with midpoint (√2) subdivision; see the header.
#include "fabrica/hatching/proximity_grid.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica::hatching {
namespace {

constexpr int kMarkOffset = 2;  // queries at level d look at marks of level d + 2

Vec2 lattice_of(double side, const Vec2& center, int level, const Vec2& pixel) {
  const double h = std::ldexp(side, -(level / 2));
  const Vec2 q = (pixel - center) / h;
  if (level % 2 == 0) return Vec2(q.x() + 0.5, q.y() + 0.5);
  return Vec2(q.x() + q.y() + 0.5, q.x() - q.y() + 0.5);
}

/// Frame index of the first cell and cell counts of `level` covering the image.
std::array<int, 4> level_extent(int width, int height, int level) {
  const double side = static_cast<double>(std::max(width, height));
  const Vec2 center(0.5 * width, 0.5 * height);
  double lo_x = std::numeric_limits<double>::max(), hi_x = -lo_x, lo_y = lo_x, hi_y = -lo_x;
  for (const Vec2& corner : {Vec2(0, 0), Vec2(width, 0), Vec2(0, height), Vec2(width, height)}) {
    const Vec2 u = lattice_of(side, center, level, corner);
    lo_x = std::min(lo_x, u.x());
    hi_x = std::max(hi_x, u.x());
    lo_y = std::min(lo_y, u.y());
    hi_y = std::max(hi_y, u.y());
  }
  const int i0 = static_cast<int>(std::floor(lo_x)), j0 = static_cast<int>(std::floor(lo_y));
  return {i0, j0, static_cast<int>(std::floor(hi_x)) - i0 + 1,
          static_cast<int>(std::floor(hi_y)) - j0 + 1};
}

/// Clips the segment a-b to the box [lo, hi] (Liang-Barsky); false when
/// nothing of it is inside.
bool clip_to_box(Vec2& a, Vec2& b, const Vec2& lo, const Vec2& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Vec2 d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    const double p[2] = {-d[axis], d[axis]};
    const double q[2] = {a[axis] - lo[axis], hi[axis] - a[axis]};
    for (int k = 0; k < 2; ++k) {
      if (p[k] == 0.0) {
        if (q[k] < 0.0) return false;
        continue;
      }
      const double r = q[k] / p[k];
      if (p[k] < 0.0)
        t0 = std::max(t0, r);
      else
        t1 = std::min(t1, r);
    }
  }
  if (t0 > t1) return false;
  const Vec2 start = a;
  a = start + t0 * d;
  b = start + t1 * d;
  return true;
}

}  // namespace

std::size_t ProximityGrid::cell_count(int width, int height, int max_level) {
  if (width <= 0 || height <= 0 || max_level < 0) return 0;
  std::size_t total = 0;
  for (int d = 0; d <= max_level + kMarkOffset; ++d) {
    const auto e = level_extent(width, height, d);
    total += static_cast<std::size_t>(e[2]) * static_cast<std::size_t>(e[3]);
  }
  return total;
}

ProximityGrid::ProximityGrid(int width, int height, int max_level)
    : width_(width), height_(height), max_level_(max_level) {
  if (width <= 0 || height <= 0)
    throw InputError("proximity grid: image size must be positive (got " + std::to_string(width) +
                     "x" + std::to_string(height) + ")");
  if (max_level < 0 || max_level > 40)
    throw InputError("proximity grid: grid depth must be in [0, 40] (got " +
                     std::to_string(max_level) + ")");
  if (cell_count(width, height, max_level) > kMaxCells)
    throw InputError("proximity grid: grid depth " + std::to_string(max_level) + " at " +
                     std::to_string(width) + "x" + std::to_string(height) + " needs " +
                     std::to_string(cell_count(width, height, max_level) >> 20) +
                     " MiB, more than the " + std::to_string(kMaxCells >> 20) +
                     " MiB allowed; use a smaller --grid-depth");
  side_ = static_cast<double>(std::max(width, height));
  center_ = Vec2(0.5 * width, 0.5 * height);
  const int count = max_level + kMarkOffset + 1;
  levels_.resize(static_cast<std::size_t>(count));
  for (int d = 0; d < count; ++d) {
    Level& level = levels_[static_cast<std::size_t>(d)];
    const auto e = level_extent(width, height, d);
    level.i0 = e[0];
    level.j0 = e[1];
    level.nx = e[2];
    level.ny = e[3];
    level.marks.assign(static_cast<std::size_t>(level.nx) * static_cast<std::size_t>(level.ny), 0);
  }
}

double ProximityGrid::cell_size(int level) const {
  return side_ * std::pow(2.0, -0.5 * static_cast<double>(level));
}

Vec2 ProximityGrid::to_lattice(int level, const Vec2& pixel) const {
  return lattice_of(side_, center_, level, pixel);
}

bool ProximityGrid::near_image(const Vec2& pixel) const {
  // Farther out, lattice indices would not fit an int (a camera zoomed far
  // in projects the mesh to enormous pixel coordinates): nothing is marked there.
  return pixel.allFinite() && pixel.x() > -side_ && pixel.y() > -side_ &&
         pixel.x() < width_ + side_ && pixel.y() < height_ + side_;
}

Vec2 ProximityGrid::from_lattice(int level, const Vec2& lattice) const {
  const double h = std::ldexp(side_, -(level / 2));
  const Vec2 u = lattice - Vec2(0.5, 0.5);
  const Vec2 q = level % 2 == 0 ? u : Vec2(0.5 * (u.x() + u.y()), 0.5 * (u.x() - u.y()));
  return center_ + h * q;
}

std::vector<Vec2> ProximityGrid::new_lattice_points(int level) const {
  std::vector<Vec2> points;
  if (level < 0 || level >= static_cast<int>(levels_.size())) return points;
  const Level& l = levels_[static_cast<std::size_t>(level)];
  for (int j = l.j0; j < l.j0 + l.ny; ++j) {
    for (int i = l.i0; i < l.i0 + l.nx; ++i) {
      // Level 0 has the single centre point; every later level adds the
      // points with i + j odd (the others belong to the previous level).
      if (level == 0 ? (i != 0 || j != 0) : ((i + j) & 1) == 0) continue;
      const Vec2 p = from_lattice(level, Vec2(i + 0.5, j + 0.5));
      if (p.x() >= 0.0 && p.y() >= 0.0 && p.x() < width_ && p.y() < height_) points.push_back(p);
    }
  }
  return points;
}

void ProximityGrid::mark_segment_level(int level_index, const Vec2& a_px, const Vec2& b_px) {
  Level& level = levels_[static_cast<std::size_t>(level_index)];
  const Vec2 a = to_lattice(level_index, a_px), b = to_lattice(level_index, b_px);
  int i = static_cast<int>(std::floor(a.x())), j = static_cast<int>(std::floor(a.y()));
  const int i_end = static_cast<int>(std::floor(b.x())),
            j_end = static_cast<int>(std::floor(b.y()));
  const double dx = b.x() - a.x(), dy = b.y() - a.y();
  const int step_i = i_end >= i ? 1 : -1, step_j = j_end >= j ? 1 : -1;
  int remaining_i = std::abs(i_end - i), remaining_j = std::abs(j_end - j);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double delta_i = dx != 0.0 ? 1.0 / std::abs(dx) : kInf;
  const double delta_j = dy != 0.0 ? 1.0 / std::abs(dy) : kInf;
  double t_i = dx > 0.0 ? (i + 1 - a.x()) * delta_i : dx < 0.0 ? (a.x() - i) * delta_i : kInf;
  double t_j = dy > 0.0 ? (j + 1 - a.y()) * delta_j : dy < 0.0 ? (a.y() - j) * delta_j : kInf;
  auto mark = [&](int ci, int cj) {
    const int u = ci - level.i0, v = cj - level.j0;
    if (u >= 0 && v >= 0 && u < level.nx && v < level.ny)
      level.marks[static_cast<std::size_t>(v) * level.nx + u] = 1;
  };
  mark(i, j);
  // Exactly |Δi| + |Δj| steps (Amanatides–Woo), so rounding cannot make the
  // walk overshoot or loop.
  while (remaining_i > 0 || remaining_j > 0) {
    if (remaining_j == 0 || (remaining_i > 0 && t_i <= t_j)) {
      i += step_i;
      t_i += delta_i;
      --remaining_i;
    } else {
      j += step_j;
      t_j += delta_j;
      --remaining_j;
    }
    mark(i, j);
  }
}

void ProximityGrid::mark_segment(const Vec2& a_px, const Vec2& b_px) {
  if (!a_px.allFinite() || !b_px.allFinite()) return;
  // Only the part near the image is marked (queries farther out see nothing).
  Vec2 a = a_px, b = b_px;
  if (!clip_to_box(a, b, Vec2(-0.5 * side_, -0.5 * side_),
                   Vec2(width_ + 0.5 * side_, height_ + 0.5 * side_)))
    return;
  for (int d = 0; d < static_cast<int>(levels_.size()); ++d) mark_segment_level(d, a, b);
}

void ProximityGrid::mark_polyline(const std::vector<Vec2>& points) {
  if (points.size() == 1) mark_segment(points[0], points[0]);
  for (std::size_t k = 1; k < points.size(); ++k) mark_segment(points[k - 1], points[k]);
}

bool ProximityGrid::is_marked(int level, const Vec2& pixel) const {
  if (!near_image(pixel)) return false;
  level = std::clamp(level, 0, static_cast<int>(levels_.size()) - 1);
  const Vec2 u = to_lattice(level, pixel);
  return marked_cell(levels_[static_cast<std::size_t>(level)], static_cast<int>(std::floor(u.x())),
                     static_cast<int>(std::floor(u.y())));
}

bool ProximityGrid::blocked(const Vec2& pixel, int level) const {
  if (!near_image(pixel)) return false;
  level = std::clamp(level, 0, max_level_);
  const int fine = level + kMarkOffset;
  const Level& l = levels_[static_cast<std::size_t>(fine)];
  const Vec2 u = to_lattice(fine, pixel);
  // s_d is 2 cells of level d + 2: look at every cell closer than 2 units.
  constexpr double r = 2.0;
  const int i_lo = static_cast<int>(std::floor(u.x() - r)),
            i_hi = static_cast<int>(std::floor(u.x() + r));
  const int j_lo = static_cast<int>(std::floor(u.y() - r)),
            j_hi = static_cast<int>(std::floor(u.y() + r));
  for (int j = j_lo; j <= j_hi; ++j) {
    const double gy = std::max({j - u.y(), 0.0, u.y() - (j + 1)});
    for (int i = i_lo; i <= i_hi; ++i) {
      const double gx = std::max({i - u.x(), 0.0, u.x() - (i + 1)});
      if (gx * gx + gy * gy < r * r && marked_cell(l, i, j)) return true;
    }
  }
  return false;
}

void ProximityGrid::clear() {
  for (Level& level : levels_) std::fill(level.marks.begin(), level.marks.end(), std::uint8_t{0});
}

}  // namespace fabrica::hatching
