// Hierarchical proximity grid in image space (Singh & Schaefer 2010, §3.3;
// docs/algorithms.md §9) with midpoint (√2) subdivision.
//
// Level d has cell size s_d = S / √2^d pixels, S = max(width, height), on a
// square of side S centred on the image. Even levels 2k are square lattices
// of spacing S/2^k; odd levels 2k+1 add the corners of the level-2k cells,
// giving a quincunx lattice whose Voronoi cells are 45° diamonds of side
// s_d. Each level therefore contains every earlier lattice point, and its
// cells are the Voronoi cells of all seeds of the levels so far.
//
// A stroke's image polyline is marked into the cells it crosses at every
// level (exact grid traversal). Queries give a spacing GUARANTEE: a point is
// `blocked` at level d when a marked cell of level d + 2 (cells half as
// large, same lattice kind) lies closer than s_d. An unblocked point is
// therefore at least s_d from every marked stroke; a blocked one is within
// s_d (1 + √2/2) of one. (The paper tests only the point's own cell, which
// lets strokes in neighbouring cells touch.)
//
// Coordinates are pixels: x right, y down, origin at the image's top-left.
#pragma once

#include <cstdint>
#include <vector>

#include "fabrica/core/types.hpp"

namespace fabrica::hatching {

class ProximityGrid {
 public:
  /// `max_level`: the deepest level that is queried (the paper's grid depth,
  /// 20 at 800 px). Marks are kept down to max_level + 2. Throws InputError
  /// for a non-positive size or a level outside [0, 40].
  ProximityGrid(int width, int height, int max_level);

  /// Most cells (bytes of marks) a grid may hold: 256 MiB. The constructor
  /// throws InputError for a depth needing more (about depth 25 at any size).
  static constexpr std::size_t kMaxCells = std::size_t{1} << 28;
  /// Cells a grid of this size and depth holds, without allocating them.
  static std::size_t cell_count(int width, int height, int max_level);

  int width() const { return width_; }
  int height() const { return height_; }
  int max_level() const { return max_level_; }
  /// S: the side of the level-0 cell (pixels).
  double side() const { return side_; }
  /// s_d = S / √2^d (pixels).
  double cell_size(int level) const;

  /// Lattice (cell) frame of `level`: cells are unit squares [i,i+1)×[j,j+1),
  /// lattice points at their centres; one frame unit is cell_size(level) px.
  Vec2 to_lattice(int level, const Vec2& pixel) const;
  Vec2 from_lattice(int level, const Vec2& lattice) const;

  /// The lattice points that are new at `level` (level 0: the centre of the
  /// square), inside the image [0,width)×[0,height), in a fixed order.
  std::vector<Vec2> new_lattice_points(int level) const;

  /// Marks the segment a–b (pixels) into every level.
  void mark_segment(const Vec2& a, const Vec2& b);
  /// Marks a polyline (consecutive segments).
  void mark_polyline(const std::vector<Vec2>& points);
  /// True when the cell of `level` containing `pixel` is marked (the paper's test).
  bool is_marked(int level, const Vec2& pixel) const;
  /// True when a marked cell of level + 2 lies closer than cell_size(level)
  /// to `pixel` (the spacing test used for truncation and seeding).
  /// Levels above max_level() are clamped to it; negative ones to 0.
  bool blocked(const Vec2& pixel, int level) const;
  /// Removes every mark.
  void clear();

 private:
  struct Level {
    int i0 = 0, j0 = 0;  ///< frame index of the first stored cell
    int nx = 0, ny = 0;
    std::vector<std::uint8_t> marks;
  };
  bool marked_cell(const Level& level, int i, int j) const {
    const int a = i - level.i0, b = j - level.j0;
    if (a < 0 || b < 0 || a >= level.nx || b >= level.ny) return false;
    return level.marks[static_cast<std::size_t>(b) * level.nx + a] != 0;
  }
  void mark_segment_level(int level, const Vec2& a, const Vec2& b);
  /// Within one image side of the image (where lattice indices fit an int).
  bool near_image(const Vec2& pixel) const;

  int width_, height_, max_level_;
  double side_;
  Vec2 center_;
  std::vector<Level> levels_;
};

}  // namespace fabrica::hatching
