#include "cutaway_field.hpp"

#include <cmath>
#include <limits>

namespace fabrica::render::detail {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One dimension of the squared Euclidean distance transform of a sampled
// function (Felzenszwalb & Huttenlocher 2012, the lower envelope of the
// parabolas (q - p)^2 + f(p)): d[q] = min_p (q - p)^2 + f[p] and the p
// reaching it (-1 where every f is infinite). Ties go to the lower p.
void distance_1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& arg) {
  const int n = static_cast<int>(f.size());
  std::vector<int> v;     // parabolas of the envelope, by position
  std::vector<double> z;  // where each starts (z[k] .. z[k+1])
  for (int p = 0; p < n; ++p) {
    if (!std::isfinite(f[p])) continue;
    while (!v.empty()) {
      const int r = v.back();
      const double s = ((f[p] + double(p) * p) - (f[r] + double(r) * r)) / (2.0 * (p - r));
      if (s <= z.back()) {
        v.pop_back();
        z.pop_back();
      } else {
        z.push_back(s);
        break;
      }
    }
    if (v.empty()) z = {-kInf};
    v.push_back(p);
  }
  d.assign(n, kInf);
  arg.assign(n, -1);
  if (v.empty()) return;
  z.push_back(kInf);
  std::size_t k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const int p = v[k];
    d[q] = double(q - p) * (q - p) + f[p];
    arg[q] = p;
  }
}

}  // namespace

CutawayField::CutawayField(const DepthBuffer& focus, const Camera& camera, const Cutaway& cutaway,
                           double scale)
    : width_(focus.width),
      height_(focus.height),
      projector_(camera),
      cutaway_(cutaway),
      scale_(scale) {
  const int W = width_, H = height_;
  const std::size_t N = static_cast<std::size_t>(W) * H;
  // Columns: the nearest focus row per pixel; then rows over those.
  std::vector<double> column_d(N, kInf);
  std::vector<int> column_arg(N, -1);
  std::vector<double> f, d;
  std::vector<int> arg;
  for (int x = 0; x < W; ++x) {
    f.assign(H, kInf);
    for (int y = 0; y < H; ++y)
      if (std::isfinite(focus.at(x, y))) f[y] = 0.0;
    distance_1d(f, d, arg);
    for (int y = 0; y < H; ++y) {
      column_d[static_cast<std::size_t>(y) * W + x] = d[y];
      column_arg[static_cast<std::size_t>(y) * W + x] = arg[y];
    }
  }
  distance_.assign(N, std::numeric_limits<float>::infinity());
  depth_.assign(N, std::numeric_limits<float>::infinity());
  for (int y = 0; y < H; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * W;
    f.assign(column_d.begin() + static_cast<std::ptrdiff_t>(row),
             column_d.begin() + static_cast<std::ptrdiff_t>(row + W));
    distance_1d(f, d, arg);
    for (int x = 0; x < W; ++x) {
      if (arg[x] < 0) continue;
      const int sx = arg[x], sy = column_arg[row + sx];
      distance_[row + x] = static_cast<float>(std::sqrt(d[x]));
      depth_[row + x] = focus.at(sx, sy);
    }
  }
}

double CutawayField::keep(const Vec3& p) const {
  const ProjectedPoint q = projector_(p);
  const double x = std::floor(q.pixel.x()), y = std::floor(q.pixel.y());
  if (!(x >= 0.0 && y >= 0.0 && x < width_ && y < height_)) return 1.0;
  const std::size_t i = static_cast<std::size_t>(y) * width_ + static_cast<std::size_t>(x);
  if (!(q.depth < depth_[i])) return 1.0;  // behind the focus's front (or no focus near)
  return cutaway_keep(cutaway_, distance_[i], scale_);
}

}  // namespace fabrica::render::detail
