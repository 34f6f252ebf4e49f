#include "fabrica/lines/chain.hpp"

#include <algorithm>
#include <cstdint>

namespace fabrica {

namespace {

std::uint64_t end_key(const LineSegment& s, int e, std::size_t index) {
  const SegmentEnd& end = s.end[e];
  if (end.kind == EndKind::interior || end.element < 0)
    return (std::uint64_t{3} << 61) | (static_cast<std::uint64_t>(index) * 2 + e);
  return (static_cast<std::uint64_t>(end.kind) << 61) | static_cast<std::uint64_t>(end.element);
}

LineVertex to_vertex(const SegmentEnd& e) {
  LineVertex v;
  v.anchor = e.anchor;
  v.position = e.position;
  v.strength = e.strength;
  v.visible = true;
  return v;
}

}  // namespace

double projected_length(const Polyline& pl, const Camera& camera) {
  double sum = 0.0;
  const std::size_t n = pl.vertices.size();
  if (n < 2) return 0.0;
  Vec2 prev = project(camera, pl.vertices[0].position).pixel;
  const Vec2 first = prev;
  for (std::size_t i = 1; i < n; ++i) {
    const Vec2 p = project(camera, pl.vertices[i].position).pixel;
    sum += (p - prev).norm();
    prev = p;
  }
  if (pl.closed) sum += (first - prev).norm();
  return sum;
}

std::vector<Polyline> chain_segments(const SegmentSoup& soup, const ChainOptions& options) {
  const auto& segs = soup.segments;
  const std::size_t n = segs.size();
  std::vector<Polyline> out;
  if (n == 0) return out;
  // Sort endpoint keys; partner[end] = the other end with the same key when
  // exactly two ends share it.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(2 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int e = 0; e < 2; ++e)
      keys[2 * i + e] = {end_key(segs[i], e, i), static_cast<std::uint32_t>(2 * i + e)};
  std::sort(keys.begin(), keys.end());
  std::vector<std::int64_t> partner(2 * n, -1);
  for (std::size_t a = 0; a < keys.size();) {
    std::size_t b = a + 1;
    while (b < keys.size() && keys[b].first == keys[a].first) ++b;
    if (b - a == 2 && keys[a].second / 2 != keys[a + 1].second / 2) {
      partner[keys[a].second] = keys[a + 1].second;
      partner[keys[a + 1].second] = keys[a].second;
    }
    a = b;
  }
  std::vector<std::uint8_t> used(n, 0);
  auto walk = [&](std::size_t start, int start_end) {
    Polyline pl;
    pl.family = soup.family;
    std::size_t s = start;
    int e = start_end;
    pl.vertices.push_back(to_vertex(segs[s].end[e]));
    while (true) {
      used[s] = 1;
      pl.vertices.push_back(to_vertex(segs[s].end[1 - e]));
      pl.edge_faces.push_back(segs[s].face);
      const std::int64_t p = partner[2 * s + (1 - e)];
      if (p < 0) break;
      const auto ns = static_cast<std::size_t>(p / 2);
      if (ns == start) {  // back at the start: a loop
        pl.closed = true;
        pl.vertices.pop_back();
        break;
      }
      if (used[ns]) break;
      s = ns;
      e = static_cast<int>(p % 2);
    }
    return pl;
  };
  auto keep = [&](const Polyline& pl) {
    if (pl.vertices.size() < 2) return false;
    if (options.min_length > 0.0 && pl.length() < options.min_length) return false;
    if (options.min_length_px > 0.0 && options.camera &&
        projected_length(pl, *options.camera) < options.min_length_px)
      return false;
    return true;
  };
  // Open chains first: start at free ends.
  for (std::size_t i = 0; i < n; ++i) {
    if (used[i]) continue;
    for (int e = 0; e < 2; ++e)
      if (!used[i] && partner[2 * i + e] < 0) {
        Polyline pl = walk(i, e);
        if (keep(pl)) out.push_back(std::move(pl));
      }
  }
  // What remains are loops.
  for (std::size_t i = 0; i < n; ++i) {
    if (used[i]) continue;
    Polyline pl = walk(i, 0);
    if (keep(pl)) out.push_back(std::move(pl));
  }
  return out;
}

LineSet chain_segments(const std::vector<SegmentSoup>& soups, const ChainOptions& options) {
  LineSet set;
  for (const auto& soup : soups) {
    auto pls = chain_segments(soup, options);
    for (auto& p : pls) set.polylines.push_back(std::move(p));
  }
  return set;
}

}  // namespace fabrica
