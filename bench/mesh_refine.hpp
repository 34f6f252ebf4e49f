// Refinements of a triangle mesh that keep its shape (new vertices lie on the
// old triangles), for the benchmarks that need larger meshes than the bundled
// ones: bench/scale_mesh (time and memory from 100k to 2M faces) and
// bench/make_context (the viewer orbit's context structures).
#pragma once

#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "fabrica/core/mesh.hpp"

namespace fabrica::bench {

/// Midpoint subdivision: a vertex at each edge's midpoint (shared by the
/// edge's faces), four triangles per triangle, in face order.
inline void split_midpoints(TriangleMesh& m) {
  std::unordered_map<std::uint64_t, int> mid;
  mid.reserve(m.faces.size() * 2);
  auto at = [&](int a, int b) {
    const auto lo = static_cast<std::uint64_t>(std::min(a, b));
    const auto hi = static_cast<std::uint64_t>(std::max(a, b));
    auto [it, fresh] = mid.try_emplace(lo << 32 | hi, static_cast<int>(m.positions.size()));
    if (fresh) m.positions.push_back(0.5 * (m.positions[a] + m.positions[b]));
    return it->second;
  };
  std::vector<Face> out;
  out.reserve(m.faces.size() * 4);
  for (const Face& f : m.faces) {
    const int ab = at(f[0], f[1]), bc = at(f[1], f[2]), ca = at(f[2], f[0]);
    out.push_back({f[0], ab, ca});
    out.push_back({ab, f[1], bc});
    out.push_back({ca, bc, f[2]});
    out.push_back({ab, bc, ca});
  }
  m.faces = std::move(out);
}

/// Centroid split: a vertex at each triangle's centroid, three triangles per
/// triangle.
inline void split_centroids(TriangleMesh& m) {
  std::vector<Face> out;
  out.reserve(m.faces.size() * 3);
  for (const Face& f : m.faces) {
    const int c = static_cast<int>(m.positions.size());
    m.positions.push_back((m.positions[f[0]] + m.positions[f[1]] + m.positions[f[2]]) / 3.0);
    out.push_back({f[0], f[1], c});
    out.push_back({f[1], f[2], c});
    out.push_back({f[2], f[0], c});
  }
  m.faces = std::move(out);
}

}  // namespace fabrica::bench
