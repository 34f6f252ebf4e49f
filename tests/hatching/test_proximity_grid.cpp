// The hierarchical proximity grid: midpoint (√2) lattices, seeds new per
// level, and the spacing guarantee of `blocked`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/hatching/proximity_grid.hpp"

using fabrica::Vec2;
using fabrica::hatching::ProximityGrid;

namespace {

double point_segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

bool is_lattice_point(const ProximityGrid& grid, int level, const Vec2& p) {
  const Vec2 u = grid.to_lattice(level, p);
  return std::abs(u.x() - std::floor(u.x()) - 0.5) < 1e-9 &&
         std::abs(u.y() - std::floor(u.y()) - 0.5) < 1e-9;
}

}  // namespace

TEST(ProximityGrid, CellSizesHalveAreaPerLevel) {
  const ProximityGrid grid(800, 800, 20);
  EXPECT_DOUBLE_EQ(grid.cell_size(0), 800.0);
  for (int d = 1; d <= 20; ++d)
    EXPECT_NEAR(grid.cell_size(d - 1) / grid.cell_size(d), std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(grid.cell_size(20), 800.0 / 1024.0, 1e-12);
}

TEST(ProximityGrid, LatticeRoundTripAndScale) {
  const ProximityGrid grid(640, 480, 12);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(0, 640), uy(0, 480);
  for (int d = 0; d <= 14; ++d) {
    for (int k = 0; k < 50; ++k) {
      const Vec2 p(ux(rng), uy(rng)), q(ux(rng), uy(rng));
      EXPECT_LT((grid.from_lattice(d, grid.to_lattice(d, p)) - p).norm(), 1e-9);
      // One lattice unit is one cell: distances scale by the cell size.
      const double frame = (grid.to_lattice(d, p) - grid.to_lattice(d, q)).norm();
      EXPECT_NEAR(frame * grid.cell_size(d), (p - q).norm(), 1e-9 * (1 + (p - q).norm()));
    }
  }
}

TEST(ProximityGrid, LevelsAreNestedMidpointLattices) {
  const int size = 256;
  const ProximityGrid grid(size, size, 12);
  const auto level0 = grid.new_lattice_points(0);
  ASSERT_EQ(level0.size(), 1u);
  EXPECT_NEAR((level0[0] - Vec2(128, 128)).norm(), 0.0, 1e-12);
  std::vector<Vec2> all = level0;
  for (int d = 1; d <= 10; ++d) {
    const auto fresh = grid.new_lattice_points(d);
    for (const Vec2& p : fresh) {
      EXPECT_TRUE(is_lattice_point(grid, d, p));
      EXPECT_FALSE(is_lattice_point(grid, d - 1, p)) << "level " << d;
    }
    // Every earlier point is a lattice point of this level (nesting).
    for (const Vec2& p : all) {
      EXPECT_TRUE(is_lattice_point(grid, d, p)) << "level " << d;
    }
    all.insert(all.end(), fresh.begin(), fresh.end());
    // The union is the whole lattice of level d inside the image: nearest
    // neighbours exactly one cell apart, and about S²/s_d² points.
    const double s = grid.cell_size(d);
    if (d >= 4) {
      const double expected = size * size / (s * s);
      EXPECT_NEAR(static_cast<double>(all.size()), expected, 0.1 * expected + 4 * size / s)
          << "level " << d;
    }
    if (d <= 8) {
      double nearest = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < all.size(); ++i)
        for (std::size_t j = i + 1; j < all.size(); ++j)
          nearest = std::min(nearest, (all[i] - all[j]).norm());
      if (all.size() > 1) {
        EXPECT_NEAR(nearest, s, 1e-9) << "level " << d;
      }
    }
  }
}

TEST(ProximityGrid, OddLevelsAreDiamonds) {
  // The cell of a level-1 point is a 45° diamond: moving s/2 along a
  // diagonal from the centre reaches its border, along an axis s/√2.
  const ProximityGrid grid(512, 512, 8);
  const double s = grid.cell_size(3);
  const Vec2 c = grid.from_lattice(3, Vec2(0.5, 0.5));
  const Vec2 diag = Vec2(1, 1).normalized(), axis(1, 0);
  auto same_cell = [&](const Vec2& a, const Vec2& b) {
    const Vec2 ua = grid.to_lattice(3, a), ub = grid.to_lattice(3, b);
    return std::floor(ua.x()) == std::floor(ub.x()) && std::floor(ua.y()) == std::floor(ub.y());
  };
  EXPECT_TRUE(same_cell(c, c + 0.49 * s * diag));
  EXPECT_FALSE(same_cell(c, c + 0.51 * s * diag));
  EXPECT_TRUE(same_cell(c, c + 0.70 * s * axis));
  EXPECT_FALSE(same_cell(c, c + 0.72 * s * axis));
}

TEST(ProximityGrid, MarkedSegmentsBlockWithinOneCellSize) {
  const ProximityGrid empty(400, 300, 16);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(0, 400), uy(0, 300), len(-30, 30);
  ProximityGrid grid = empty;
  std::vector<std::pair<Vec2, Vec2>> segments;
  for (int k = 0; k < 40; ++k) {
    const Vec2 a(ux(rng), uy(rng));
    Vec2 b = a + Vec2(len(rng), len(rng));
    b = Vec2(std::clamp(b.x(), 0.0, 399.9),
             std::clamp(b.y(), 0.0, 299.9));  // strokes stay in the image
    grid.mark_segment(a, b);
    segments.push_back({a, b});
  }
  for (int d = 0; d <= 16; ++d) {
    const double s = grid.cell_size(d);
    int blocked = 0;
    for (int k = 0; k < 400; ++k) {
      const Vec2 p(ux(rng), uy(rng));
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& [a, b] : segments)
        nearest = std::min(nearest, point_segment_distance(p, a, b));
      if (grid.blocked(p, d)) {
        ++blocked;
        EXPECT_LT(nearest, s * (1.0 + std::sqrt(0.5)) + 1e-9) << "level " << d;
      } else {
        EXPECT_GE(nearest, s - 1e-9) << "level " << d;  // the spacing guarantee
      }
    }
    if (d >= 8) {
      EXPECT_LT(blocked, 400) << "level " << d;
    }
    if (d <= 2) {
      EXPECT_EQ(blocked, 400) << "level " << d;
    }
  }
  // The paper's own-cell test: every point of a marked segment is in a marked cell.
  for (const auto& [a, b] : segments) {
    for (int d = 0; d <= 18; ++d) {
      for (double t = 0; t <= 1.0; t += 0.01) {
        EXPECT_TRUE(grid.is_marked(d, a + t * (b - a)));
      }
    }
  }
  EXPECT_FALSE(empty.is_marked(10, Vec2(100, 100)));
  EXPECT_FALSE(empty.blocked(Vec2(100, 100), 0));
  grid.clear();
  EXPECT_FALSE(grid.blocked(segments[0].first, 10));
}

TEST(ProximityGrid, RejectsBadSizes) {
  EXPECT_THROW(ProximityGrid(0, 10, 4), fabrica::InputError);
  EXPECT_THROW(ProximityGrid(10, 10, -1), fabrica::InputError);
  EXPECT_THROW(ProximityGrid(10, 10, 41), fabrica::InputError);
}

TEST(ProximityGrid, MemoryIsBoundedAndDeepGridsAreRefusedBeforeAllocating) {
  EXPECT_LE(ProximityGrid::cell_count(800, 800, 20), std::size_t{1} << 24);
  EXPECT_GT(ProximityGrid::cell_count(800, 800, 30), ProximityGrid::kMaxCells);
  EXPECT_THROW(ProximityGrid(800, 800, 30), fabrica::InputError);
  EXPECT_GT(ProximityGrid::cell_count(16384, 16384, 29), ProximityGrid::kMaxCells);
}

TEST(ProximityGrid, SegmentsFarOutsideTheImageAreClippedNotWalked) {
  // A camera zoomed far in projects the mesh to pixel coordinates near 1e12;
  // walking such a segment cell by cell took a minute, then overflowed.
  ProximityGrid grid(64, 64, 12);
  grid.mark_segment(Vec2(-1e12, 32.0), Vec2(1e12, 32.5));
  EXPECT_TRUE(grid.is_marked(12, Vec2(32.0, 32.25)));
  grid.mark_segment(Vec2(1e12, 1e12), Vec2(2e12, -3e12));  // never crosses the image
  EXPECT_FALSE(grid.is_marked(12, Vec2(60.0, 60.0)));
  EXPECT_FALSE(grid.blocked(Vec2(1e15, -1e15), 5));
  EXPECT_FALSE(grid.is_marked(3, Vec2(std::numeric_limits<double>::quiet_NaN(), 1.0)));
}
