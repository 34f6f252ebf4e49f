#include "fabrica/lines/chain.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <limits>

#include "chain_internal.hpp"
#include "fabrica/core/projector.hpp"

namespace fabrica {

namespace {

// Endpoints that can be joined: kind edge, vertex or centroid with an
// element id >= 0. Interior ends and ends without an element never join.
bool joinable(const LineSegment& s, int side) {
  return s.kind[side] != EndKind::interior && s.end[side].element >= 0;
}
bool joinable_end(const std::vector<LineSegment>& segs, std::size_t j) {
  return joinable(segs[j / 2], static_cast<int>(j % 2));
}
// The key of end j (= 2 * segment + side): its kind and element.
EndKind kind_of(const std::vector<LineSegment>& segs, std::size_t j) {
  return segs[j / 2].kind[j % 2];
}
std::int32_t element_of(const std::vector<LineSegment>& segs, std::size_t j) {
  return segs[j / 2].end[j % 2].element;
}

constexpr std::int32_t kEmpty = -1;
constexpr std::int32_t kMany = std::numeric_limits<std::int32_t>::min();

// partner[end] (end = 2 * segment + side) = the other end with the same key
// when exactly two ends of different segments share it, else -1. Keys are
// (kind, element); a flat table indexed by (kind offset + element) replaces a
// sort of all keys. slot: kEmpty, the first end seen (>= 0), -2 - first end
// when two were seen, kMany when three or more. The table is kept per thread
// between calls (its size is bounded by the mesh's element counts) and only
// the touched entries are reset, so a call costs O(segments), not O(mesh).
// An element at or past its kind's `bound` makes it give up (false, the
// table reset) before pairing anything. No TBB call inside: the thread's
// buffers are not shared with another call meanwhile.
bool pair_ends_flat(const std::vector<LineSegment>& segs, const std::int64_t offset[3],
                    const std::int64_t bound[3], std::size_t table_size,
                    std::vector<std::int32_t>& partner) {
  const std::size_t n = segs.size();
  partner.assign(2 * n, -1);
  thread_local std::vector<std::int32_t> table;
  thread_local std::vector<std::int32_t> slots;  // each end's table index, -1: not joinable
  if (table.size() < table_size) table.resize(table_size, kEmpty);
  slots.resize(2 * n);
  auto reset = [&](std::size_t ends) {
    for (std::size_t j = 0; j < ends; ++j)
      if (slots[j] >= 0) table[static_cast<std::size_t>(slots[j])] = kEmpty;
  };
  for (std::size_t j = 0; j < 2 * n; ++j) {
    const LineSegment& seg = segs[j / 2];
    const int side = static_cast<int>(j % 2);
    const auto kind = static_cast<unsigned>(seg.kind[side]);
    const std::int32_t element = seg.end[side].element;
    slots[j] = -1;
    if (kind >= 3 || element < 0) continue;  // interior, or no element: never joined
    if (element >= bound[kind]) {
      reset(j);
      return false;
    }
    const auto index = static_cast<std::int32_t>(offset[kind] + element);
    slots[j] = index;
    std::int32_t& s = table[static_cast<std::size_t>(index)];
    const auto jj = static_cast<std::int32_t>(j);
    if (s == kEmpty) {
      s = jj;
    } else if (s >= 0) {
      if (s / 2 != jj / 2) {  // two ends of one segment are never joined
        partner[static_cast<std::size_t>(s)] = jj;
        partner[j] = s;
      }
      s = -2 - s;
    } else if (s != kMany) {  // a third end: a branch point, nothing joins here
      const std::int32_t first = -2 - s;
      const std::int32_t second = partner[static_cast<std::size_t>(first)];
      if (second >= 0) {
        partner[static_cast<std::size_t>(second)] = -1;
        partner[static_cast<std::size_t>(first)] = -1;
      }
      s = kMany;
    }
  }
  reset(2 * n);
  return true;
}

// A flat table of more entries than this (32 MB) is not kept per thread:
// the pairing sorts instead (meshes with millions of edges).
constexpr std::int64_t kMaxTable = std::int64_t{1} << 23;

// The same pairing by sorting the keys: used when element ids are too large
// for a flat table (not produced by the extractors, but possible for a soup
// built by hand).
std::vector<std::int32_t> pair_ends_sorted(const std::vector<LineSegment>& segs) {
  const std::size_t n = segs.size();
  std::vector<std::pair<std::uint64_t, std::uint64_t>> keys;
  keys.reserve(2 * n);
  for (std::size_t j = 0; j < 2 * n; ++j) {
    if (!joinable_end(segs, j)) continue;
    keys.push_back({(static_cast<std::uint64_t>(kind_of(segs, j)) << 32) |
                        static_cast<std::uint64_t>(element_of(segs, j)),
                    j});
  }
  std::sort(keys.begin(), keys.end());
  std::vector<std::int32_t> partner(2 * n, -1);
  for (std::size_t a = 0; a < keys.size();) {
    std::size_t b = a + 1;
    while (b < keys.size() && keys[b].first == keys[a].first) ++b;
    if (b - a == 2 && keys[a].second / 2 != keys[a + 1].second / 2) {
      partner[keys[a].second] = static_cast<std::int32_t>(keys[a + 1].second);
      partner[keys[a + 1].second] = static_cast<std::int32_t>(keys[a].second);
    }
    a = b;
  }
  return partner;
}

// The flat table's pairing with bound[kind] entries for each end kind (its
// ids 0 .. bound - 1). False, nothing paired, when the table would be large
// in bytes (over kMaxTable entries: meshes with millions of edges), the end
// indices overflow 31 bits, or an id is at or past its bound.
bool pair_ends_table(const std::vector<LineSegment>& segs, const std::int64_t bound[3],
                     std::vector<std::int32_t>& partner) {
  std::int64_t offset[3];
  std::int64_t size = 0;
  for (int k = 0; k < 3; ++k) {
    offset[k] = size;
    size += std::max<std::int64_t>(bound[k], 0);
  }
  return size <= kMaxTable && segs.size() < (std::size_t{1} << 29) &&
         pair_ends_flat(segs, offset, bound, static_cast<std::size_t>(size), partner);
}

}  // namespace

namespace detail {

std::vector<std::int32_t> pair_ends(const std::vector<LineSegment>& segs, bool force_sorted) {
  std::int64_t bound[3] = {0, 0, 0};  // the largest id of each kind, plus one
  for (std::size_t j = 0; j < 2 * segs.size(); ++j)
    if (joinable_end(segs, j)) {
      auto& b = bound[static_cast<int>(kind_of(segs, j))];
      b = std::max(b, static_cast<std::int64_t>(element_of(segs, j)) + 1);
    }
  std::vector<std::int32_t> partner;
  if (force_sorted || !pair_ends_table(segs, bound, partner)) return pair_ends_sorted(segs);
  return partner;
}

std::vector<std::int32_t> pair_ends(const std::vector<LineSegment>& segs,
                                    const std::int64_t bound[3]) {
  std::vector<std::int32_t> partner;
  if (!pair_ends_table(segs, bound, partner)) return pair_ends(segs);
  return partner;
}

}  // namespace detail

namespace {

// One chain as the segments it walks through and the side each is entered by.
struct Step {
  std::uint32_t segment;
  std::uint8_t entry;
};

}  // namespace

double projected_length(const Polyline& pl, const Camera& camera) {
  double sum = 0.0;
  const std::size_t n = pl.vertices.size();
  if (n < 2) return 0.0;
  const Projector project(camera);
  Vec2 prev = project(pl.vertices[0].position).pixel;
  const Vec2 first = prev;
  for (std::size_t i = 1; i < n; ++i) {
    const Vec2 p = project(pl.vertices[i].position).pixel;
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
  const SegmentGeometry geo = soup.geometry();
  // The table's bounds: the mesh's edge, vertex and face counts (the ids of
  // each end kind), so no pass over the ends looks for the largest ids.
  const std::int64_t bound[3] = {static_cast<std::int64_t>(soup.surface->topology().edge_count()),
                                 static_cast<std::int64_t>(soup.surface->vertex_count()),
                                 static_cast<std::int64_t>(soup.surface->face_count())};
  const std::vector<std::int32_t> partner = detail::pair_ends(segs, bound);

  // 1. Walk every chain (serial, indices only). Chain c is steps[first[c] ..
  //    first[c + 1]); closed[c] says whether it is a loop. Vertices of a
  //    chain: the entry end of its first step, then the exit end of every
  //    step (the last one dropped for a loop).
  std::vector<std::uint8_t> used(n, 0);
  std::vector<Step> steps;
  steps.reserve(n);
  std::vector<std::uint32_t> first;
  std::vector<std::uint8_t> closed;
  auto walk = [&](std::size_t start, int start_end) {
    first.push_back(static_cast<std::uint32_t>(steps.size()));
    std::size_t s = start;
    int e = start_end;
    while (true) {
      used[s] = 1;
      steps.push_back({static_cast<std::uint32_t>(s), static_cast<std::uint8_t>(e)});
      const std::int32_t p = partner[2 * s + static_cast<std::size_t>(1 - e)];
      if (p < 0) break;
      const auto ns = static_cast<std::size_t>(p / 2);
      if (ns == start) {  // back at the start: a loop
        closed.push_back(1);
        return;
      }
      if (used[ns]) break;
      s = ns;
      e = static_cast<int>(p % 2);
    }
    closed.push_back(0);
  };
  // Open chains first: start at free ends.
  for (std::size_t i = 0; i < n; ++i) {
    if (used[i]) continue;
    for (int e = 0; e < 2; ++e)
      if (!used[i] && partner[2 * i + static_cast<std::size_t>(e)] < 0) walk(i, e);
  }
  // What remains are loops.
  for (std::size_t i = 0; i < n; ++i)
    if (!used[i]) walk(i, 0);
  const std::size_t chains = first.size();
  first.push_back(static_cast<std::uint32_t>(steps.size()));

  // 2. Filter and build the polylines (parallel over chains; each chain's
  //    result depends only on itself), then keep them in chain order.
  std::optional<Projector> projector;
  if (options.min_length_px > 0.0 && options.camera) projector.emplace(*options.camera);
  std::vector<Polyline> built(chains);
  std::vector<std::uint8_t> keep(chains, 0);
  auto build = [&](std::size_t c) {
    const Step* st = steps.data() + first[c];
    const std::size_t m = first[c + 1] - first[c];
    const bool loop = closed[c] != 0;
    const std::size_t nv = loop ? m : m + 1;
    if (nv < 2) return;
    // The chain's vertices (entry end of the first step, then the exit end
    // of every step), each resolved once from the lean record, into this
    // thread's scratch: a chain the filters drop costs no allocation. No
    // TBB call below, so no other chain runs on this thread meanwhile.
    thread_local std::vector<LineVertex> scratch;
    if (scratch.size() < nv) scratch.resize(nv);
    LineVertex* vertices = scratch.data();
    auto resolve = [&](std::size_t k, const LineSegment& s, int side) {
      LineVertex& v = vertices[k];
      geo.locate(s, side, v.anchor, v.position);
      v.strength = s.end[side].strength;
      v.visible = true;
    };
    resolve(0, segs[st[0].segment], st[0].entry);
    for (std::size_t k = 1; k < nv; ++k) resolve(k, segs[st[k - 1].segment], 1 - st[k - 1].entry);
    auto position = [&](std::size_t k) -> const Vec3& { return vertices[k].position; };
    // The filters add the same terms in the same order as Polyline::length()
    // and projected_length(), and stop once the sum reaches the bound: the
    // terms are >= 0 (or NaN, which keeps the chain either way), so a
    // partial sum at the bound means the whole one is.
    if (options.min_length > 0.0) {
      double len = 0.0;
      for (std::size_t i = 0; i + 1 < nv && !(len >= options.min_length); ++i)
        len += (position(i + 1) - position(i)).norm();
      if (loop && nv > 2 && !(len >= options.min_length))
        len += (position(0) - position(nv - 1)).norm();
      if (len < options.min_length) return;
    }
    if (projector) {
      double len = 0.0;
      Vec2 prev = (*projector)(position(0)).pixel;
      const Vec2 start = prev;
      std::size_t i = 1;
      for (; i < nv && !(len >= options.min_length_px); ++i) {
        const Vec2 p = (*projector)(position(i)).pixel;
        len += (p - prev).norm();
        prev = p;
      }
      if (loop && i == nv && !(len >= options.min_length_px)) len += (start - prev).norm();
      if (len < options.min_length_px) return;
    }
    Polyline& pl = built[c];
    pl.family = soup.family;
    pl.closed = loop;
    pl.vertices.assign(vertices, vertices + nv);
    pl.edge_faces.resize(m);
    for (std::size_t i = 0; i < m; ++i) pl.edge_faces[i] = segs[st[i].segment].face;
    keep[c] = 1;
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chains, 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) build(c);
                    });
  std::size_t kept = 0;
  for (std::size_t c = 0; c < chains; ++c) kept += keep[c];
  out.reserve(kept);
  for (std::size_t c = 0; c < chains; ++c)
    if (keep[c]) out.push_back(std::move(built[c]));
  return out;
}

LineSet chain_segments(const std::vector<SegmentSoup>& soups, const ChainOptions& options) {
  // Each soup is chained on its own (in parallel); the results are
  // concatenated in soup order, so the output does not depend on threads.
  std::vector<std::vector<Polyline>> parts(soups.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, soups.size(), 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        parts[i] = chain_segments(soups[i], options);
                    });
  LineSet set;
  std::size_t total = 0;
  for (const auto& p : parts) total += p.size();
  set.polylines.reserve(total);
  for (auto& p : parts)
    for (auto& pl : p) set.polylines.push_back(std::move(pl));
  return set;
}

}  // namespace fabrica
