// A coarse copy of a mesh for drawing ghosted context while the camera moves
// (docs/algorithms.md §16).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "fabrica/render/render_mesh.hpp"

namespace fabrica::render {

namespace {

// One clustering at cell size `cell`: every vertex goes to the grid cell it
// lies in, a cell's vertices become one at their mean, faces whose corners
// fall into three different cells are kept (once per set of cells). Vertex
// order follows the cells' first vertices, face order the source faces:
// the same input always gives the same output.
TriangleMesh cluster(const TriangleMesh& mesh, const Vec3& origin, double cell) {
  const std::size_t n = mesh.positions.size();
  std::vector<char> used(n, 0);
  for (const Face& f : mesh.faces)
    for (int k = 0; k < 3; ++k) used[static_cast<std::size_t>(f[k])] = 1;
  // (cell key, vertex) pairs sorted by key, then by vertex.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed;
  keyed.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!used[i]) continue;
    std::uint64_t key = 0;
    for (int c = 0; c < 3; ++c) {
      const double g = std::floor((mesh.positions[i][c] - origin[c]) / cell);
      key = key << 21 | static_cast<std::uint64_t>(std::clamp(g, 0.0, 2097151.0));
    }
    keyed.emplace_back(key, static_cast<std::uint32_t>(i));
  }
  std::sort(keyed.begin(), keyed.end());
  // Clusters numbered by their smallest vertex, so the numbering does not
  // depend on where the grid's keys fall.
  std::vector<std::uint32_t> first;  // per cluster in key order: its smallest vertex
  std::vector<std::int32_t> cluster_of(n, -1);
  for (std::size_t a = 0; a < keyed.size();) {
    std::size_t b = a;
    while (b < keyed.size() && keyed[b].first == keyed[a].first) ++b;
    first.push_back(keyed[a].second);
    for (std::size_t k = a; k < b; ++k)
      cluster_of[keyed[k].second] = static_cast<std::int32_t>(first.size() - 1);
    a = b;
  }
  std::vector<std::uint32_t> order(first.size());
  for (std::size_t c = 0; c < order.size(); ++c) order[c] = static_cast<std::uint32_t>(c);
  std::sort(order.begin(), order.end(), [&](auto x, auto y) { return first[x] < first[y]; });
  std::vector<std::int32_t> rank(first.size());
  for (std::size_t r = 0; r < order.size(); ++r) rank[order[r]] = static_cast<std::int32_t>(r);
  TriangleMesh out;
  out.space = mesh.space;
  out.space_source = mesh.space_source;
  out.positions.assign(first.size(), Vec3::Zero());
  std::vector<std::uint32_t> count(first.size(), 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (cluster_of[i] < 0) continue;
    const auto r = static_cast<std::size_t>(rank[static_cast<std::size_t>(cluster_of[i])]);
    cluster_of[i] = static_cast<std::int32_t>(r);
    out.positions[r] += mesh.positions[i];
    ++count[r];
  }
  for (std::size_t r = 0; r < out.positions.size(); ++r) out.positions[r] /= double(count[r]);
  // Faces between three clusters, each set of clusters once (the first face).
  std::vector<std::pair<std::array<std::int32_t, 3>, std::uint32_t>> faces;
  faces.reserve(mesh.faces.size() / 4);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    Face c;
    for (int k = 0; k < 3; ++k) c[k] = cluster_of[static_cast<std::size_t>(mesh.faces[f][k])];
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
    std::array<std::int32_t, 3> sorted = c;
    std::sort(sorted.begin(), sorted.end());
    faces.emplace_back(sorted, static_cast<std::uint32_t>(f));
  }
  std::sort(faces.begin(), faces.end());
  std::vector<std::uint32_t> kept;
  for (std::size_t k = 0; k < faces.size(); ++k)
    if (k == 0 || faces[k].first != faces[k - 1].first) kept.push_back(faces[k].second);
  std::sort(kept.begin(), kept.end());
  out.faces.reserve(kept.size());
  for (std::uint32_t f : kept) {
    Face c;
    for (int k = 0; k < 3; ++k) c[k] = cluster_of[static_cast<std::size_t>(mesh.faces[f][k])];
    out.faces.push_back(c);
  }
  return out;
}

}  // namespace

TriangleMesh cluster_simplify(const TriangleMesh& mesh, std::size_t target_faces) {
  if (mesh.faces.size() <= target_faces || target_faces < 4 || mesh.positions.empty()) return mesh;
  Vec3 lo = mesh.positions.front(), hi = lo;
  for (const Vec3& p : mesh.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  double area = 0.0;
  for (const Face& f : mesh.faces) {
    const Vec3& a = mesh.positions[static_cast<std::size_t>(f[0])];
    area += 0.5 * (mesh.positions[static_cast<std::size_t>(f[1])] - a)
                      .cross(mesh.positions[static_cast<std::size_t>(f[2])] - a)
                      .norm();
  }
  const double extent = std::max((hi - lo).maxCoeff(), 1e-30);
  // About 3 A / h^2 faces for a surface of area A in cells of side h;
  // then corrected from the count the clustering gives (faces ~ 1 / h^2).
  double cell = std::sqrt(3.0 * std::max(area, 1e-60) / double(target_faces));
  cell = std::max(cell, extent / 2000000.0);  // 21 bits per axis
  TriangleMesh best;
  for (int iteration = 0; iteration < 4; ++iteration) {
    TriangleMesh m = cluster(mesh, lo, cell);
    const double ratio = double(m.faces.size()) / double(target_faces);
    const bool fits = m.faces.size() <= target_faces + target_faces / 4;
    if (fits && (best.faces.empty() || m.faces.size() > best.faces.size())) best = std::move(m);
    if (ratio > 0.8 && ratio < 1.25) break;
    cell *= std::sqrt(std::max(ratio, 0.01));
  }
  if (best.faces.empty()) return mesh;  // nothing fits (degenerate input): draw it whole
  return best;
}

}  // namespace fabrica::render
