#include "fabrica/core/topology.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <numeric>
#include <span>

#include "fabrica/core/mesh.hpp"

namespace fabrica {

namespace {

// Exclusive prefix sum of counts into offsets (size n+1).
std::vector<std::int32_t> offsets_from_counts(const std::vector<std::int32_t>& counts) {
  std::vector<std::int32_t> offsets(counts.size() + 1, 0);
  std::partial_sum(counts.begin(), counts.end(), offsets.begin() + 1);
  return offsets;
}

constexpr std::size_t kGrain = 4096;

}  // namespace

Topology::Topology(const TriangleMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.faces.size();

  // Vertex -> faces, by counting sort (faces come out in increasing order).
  std::vector<std::int32_t> counts(nv, 0);
  for (const Face& f : mesh.faces)
    for (int k = 0; k < 3; ++k) ++counts[f[k]];
  vertex_face_offsets_ = offsets_from_counts(counts);
  vertex_faces_.resize(vertex_face_offsets_.back());
  vertex_face_corners_.resize(vertex_face_offsets_.back());
  {
    std::vector<std::int32_t> cursor(vertex_face_offsets_.begin(), vertex_face_offsets_.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const auto v = mesh.faces[f][k];
        vertex_faces_[cursor[v]] = static_cast<std::int32_t>(f);
        vertex_face_corners_[cursor[v]] = static_cast<std::uint8_t>(k);
        ++cursor[v];
      }
  }

  // Vertex -> sorted unique neighbours. Each vertex's candidates (two per
  // incident face) are sorted once in a scratch segment, then compacted.
  std::vector<std::int32_t> candidates(2 * vertex_faces_.size());
  std::vector<std::int32_t> neighbor_counts(nv), upper_counts(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      auto* const first = candidates.data() + 2 * vertex_face_offsets_[v];
      auto* last = first;
      for (auto f : vertex_faces(v))
        for (int k = 0; k < 3; ++k) {
          const auto w = mesh.faces[f][k];
          if (static_cast<std::size_t>(w) != v) *last++ = w;
        }
      std::sort(first, last);
      last = std::unique(first, last);
      neighbor_counts[v] = static_cast<std::int32_t>(last - first);
      upper_counts[v] = static_cast<std::int32_t>(
          last - std::upper_bound(first, last, static_cast<std::int32_t>(v)));
    }
  });
  vertex_neighbor_offsets_ = offsets_from_counts(neighbor_counts);
  const std::vector<std::int32_t> edge_offsets = offsets_from_counts(upper_counts);
  vertex_neighbors_.resize(vertex_neighbor_offsets_.back());
  vertex_edges_.resize(vertex_neighbor_offsets_.back());
  edges_.resize(edge_offsets.back());
  face_edges_.resize(nf);
  // Edge e = (a, b), a < b, is numbered edge_offsets[a] + the rank of b among
  // a's upper neighbours: the lower vertex numbers its edges without a search.
  // Each vertex writes its own lists, the edge ids of its lower neighbours
  // (one search in the lower neighbour's sorted list, still in `candidates`),
  // and the face edges it is the lower end of (or both ends: a degenerate
  // face's edge, -1), so every output is written once, by one vertex.
  auto sorted_neighbors = [&](std::size_t v) {
    const auto* const first = candidates.data() + 2 * vertex_face_offsets_[v];
    return std::span<const std::int32_t>(first, static_cast<std::size_t>(neighbor_counts[v]));
  };
  auto upper_rank = [&](std::size_t a, std::int32_t b) {
    const auto nb = sorted_neighbors(a);
    const auto first_upper = nb.end() - upper_counts[a];
    return static_cast<std::int32_t>(std::lower_bound(first_upper, nb.end(), b) - first_upper);
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      const auto vi = static_cast<std::int32_t>(v);
      const auto nb = sorted_neighbors(v);
      const auto out = static_cast<std::size_t>(vertex_neighbor_offsets_[v]);
      std::copy(nb.begin(), nb.end(), vertex_neighbors_.begin() + static_cast<std::ptrdiff_t>(out));
      const std::size_t lower = nb.size() - static_cast<std::size_t>(upper_counts[v]);
      for (std::size_t i = 0; i < lower; ++i)
        vertex_edges_[out + i] = edge_offsets[nb[i]] + upper_rank(nb[i], vi);
      std::int32_t e = edge_offsets[v];
      for (std::size_t i = lower; i < nb.size(); ++i, ++e) {
        vertex_edges_[out + i] = e;
        edges_[e] = {vi, nb[i]};
      }
      const auto fs = vertex_faces(v);
      const auto cs = vertex_face_corners(v);
      for (std::size_t j = 0; j < fs.size(); ++j) {
        const auto f = static_cast<std::size_t>(fs[j]);
        const int c = cs[j];
        // The other corner k' of the edge opposite corner k touches v.
        for (const int k : {(c + 2) % 3, (c + 1) % 3}) {
          const auto w = mesh.faces[f][3 - k - c];
          if (w == vi)
            face_edges_[f][k] = -1;
          else if (w > vi)
            face_edges_[f][k] = edge_offsets[v] + upper_rank(v, w);
        }
      }
    }
  });
  candidates = {};
  std::vector<std::int32_t> edge_counts(edges_.size(), 0);
  for (const auto& fe : face_edges_)
    for (int k = 0; k < 3; ++k)
      if (fe[k] >= 0 && (k == 0 || fe[k] != fe[0]) && (k < 2 || fe[k] != fe[1]))
        ++edge_counts[fe[k]];
  edge_face_offsets_ = offsets_from_counts(edge_counts);
  edge_faces_.resize(edge_face_offsets_.back());
  {
    std::vector<std::int32_t> cursor(edge_face_offsets_.begin(), edge_face_offsets_.end() - 1);
    for (std::size_t f = 0; f < nf; ++f) {
      const auto& fe = face_edges_[f];
      for (int k = 0; k < 3; ++k)
        if (fe[k] >= 0 && (k == 0 || fe[k] != fe[0]) && (k < 2 || fe[k] != fe[1]))
          edge_faces_[cursor[fe[k]]++] = static_cast<std::int32_t>(f);
    }
  }

  boundary_vertex_.assign(nv, 0);
  for (std::size_t e = 0; e < edges_.size(); ++e)
    if (edge_counts[e] == 1) {
      boundary_vertex_[edges_[e][0]] = 1;
      boundary_vertex_[edges_[e][1]] = 1;
    }
}

std::int32_t Topology::face_neighbor(std::size_t f, int k) const {
  const auto e = face_edges_[f][k];
  if (e < 0) return -1;
  const auto faces = edge_faces(e);
  if (faces.size() != 2) return -1;
  return faces[0] == static_cast<std::int32_t>(f) ? faces[1] : faces[0];
}

}  // namespace fabrica
