#include "fabrica/lines/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "parallel.hpp"

namespace fabrica {

namespace {

double point_segment_distance2(const Vec3& p, const Segment3& s) {
  const Vec3 d = s[1] - s[0];
  const double l2 = d.squaredNorm();
  double t = l2 > 0.0 ? (p - s[0]).dot(d) / l2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (s[0] + t * d - p).squaredNorm();
}

// Uniform grid over segments (cell = tolerance), each segment registered in
// every cell its tolerance-expanded box overlaps.
class SegmentGrid {
 public:
  SegmentGrid(const std::vector<Segment3>& segs, double cell) : segs_(segs), cell_(cell) {
    for (std::size_t i = 0; i < segs.size(); ++i) {
      const Vec3 lo = segs[i][0].cwiseMin(segs[i][1]).array() - cell;
      const Vec3 hi = segs[i][0].cwiseMax(segs[i][1]).array() + cell;
      const auto a = key3(lo), b = key3(hi);
      for (auto x = a[0]; x <= b[0]; ++x)
        for (auto y = a[1]; y <= b[1]; ++y)
          for (auto z = a[2]; z <= b[2]; ++z) cells_[pack(x, y, z)].push_back(static_cast<int>(i));
    }
  }
  bool near(const Vec3& p, double tol2) const {
    const auto k = key3(p);
    const auto it = cells_.find(pack(k[0], k[1], k[2]));
    if (it == cells_.end()) return false;
    for (int i : it->second)
      if (point_segment_distance2(p, segs_[static_cast<std::size_t>(i)]) <= tol2) return true;
    return false;
  }

 private:
  std::array<std::int64_t, 3> key3(const Vec3& p) const {
    return {static_cast<std::int64_t>(std::floor(p.x() / cell_)),
            static_cast<std::int64_t>(std::floor(p.y() / cell_)),
            static_cast<std::int64_t>(std::floor(p.z() / cell_))};
  }
  static std::uint64_t pack(std::int64_t x, std::int64_t y, std::int64_t z) {
    const auto m = [](std::int64_t v) {
      return static_cast<std::uint64_t>(v + (1 << 20)) & 0x1FFFFF;
    };
    return (m(x) << 42) | (m(y) << 21) | m(z);
  }
  const std::vector<Segment3>& segs_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

// Matched length and total length of `a` against `b`.
std::pair<double, double> matched_length(const std::vector<Segment3>& a, const SegmentGrid& grid,
                                         double tol, double spacing) {
  std::vector<double> matched(a.size(), 0.0), total(a.size(), 0.0);
  const double tol2 = tol * tol;
  detail::parallel_range(
      a.size(),
      [&](std::size_t i) {
        const Vec3 d = a[i][1] - a[i][0];
        const double len = d.norm();
        if (!(len > 0.0)) return;
        const int n = std::max(1, static_cast<int>(std::ceil(len / spacing)));
        const double piece = len / n;
        double m = 0.0;
        for (int k = 0; k < n; ++k) {
          const Vec3 p = a[i][0] + ((k + 0.5) / n) * d;
          if (grid.near(p, tol2)) m += piece;
        }
        matched[i] = m;
        total[i] = len;
      },
      256);
  double ms = 0.0, ts = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) ms += matched[i], ts += total[i];
  return {ms, ts};
}

}  // namespace

LineMatchScore compare_segments(const std::vector<Segment3>& test,
                                const std::vector<Segment3>& reference, double tolerance,
                                double spacing) {
  LineMatchScore s;
  const double cell = std::max(tolerance, 1e-300);
  const SegmentGrid ref_grid(reference, cell), test_grid(test, cell);
  const auto [tm, tt] = matched_length(test, ref_grid, tolerance, spacing);
  const auto [rm, rt] = matched_length(reference, test_grid, tolerance, spacing);
  s.test_length = tt;
  s.reference_length = rt;
  s.precision = tt > 0.0 ? tm / tt : 1.0;
  s.recall = rt > 0.0 ? rm / rt : 1.0;
  s.f =
      s.precision + s.recall > 0.0 ? 2.0 * s.precision * s.recall / (s.precision + s.recall) : 0.0;
  return s;
}

double segments_diagonal(const std::vector<const std::vector<Segment3>*>& sets) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  bool any = false;
  for (const auto* set : sets)
    for (const auto& s : *set)
      for (const auto& p : s) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
        any = true;
      }
  return any ? (hi - lo).norm() : 0.0;
}

}  // namespace fabrica
