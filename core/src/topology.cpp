#include "fabrica/core/topology.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <memory>
#include <numeric>

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

// How many entries count_below may read past a list (readable, ignored).
constexpr std::size_t kRankPad = 8;

// Set bits of each byte (the baseline x86-64 has no popcnt instruction).
constexpr auto kBitCount = [] {
  std::array<std::uint8_t, 256> t{};
  for (unsigned i = 0; i < 256; ++i) t[i] = static_cast<std::uint8_t>((i & 1) + t[i / 2]);
  return t;
}();

/// How many of the n values at p are < b. Lists of up to eight (nearly all
/// of them: a vertex's higher neighbours) are compared eight at a time (two
/// SSE2 compares; entries past n are read, never counted).
inline std::int32_t count_below(const std::int32_t* p, std::int32_t n, std::int32_t b) {
#if defined(__SSE2__)
  if (n <= 8) {
    const __m128i vb = _mm_set1_epi32(b);
    const __m128i lo = _mm_cmplt_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)), vb);
    const __m128i hi =
        _mm_cmplt_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 4)), vb);
    const unsigned bits = static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(lo))) |
                          (static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(hi))) << 4);
    return kBitCount[bits & ((1u << n) - 1u)];
  }
#endif
  std::int32_t rank = 0;
  for (std::int32_t i = 0; i < n; ++i) rank += p[i] < b;
  return rank;
}

}  // namespace

// docs/algorithms.md §1, "Adjacency".
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

  // Vertex -> the two other corners of each incident face (read once here,
  // streamed afterwards), and sorted unique neighbours, each vertex's list
  // in a scratch segment of two slots per incident face (left
  // uninitialised: the parallel pass touches it first).
  vertex_face_opposite_.resize(vertex_faces_.size());
  // (+ kRankPad: the rank count below reads eight entries at a time; what it
  // reads past a list is masked out.)
  const std::unique_ptr<std::int32_t[]> candidates(
      new std::int32_t[2 * vertex_faces_.size() + kRankPad]);
  std::fill_n(candidates.get() + 2 * vertex_faces_.size(), kRankPad, 0);
  std::vector<std::int32_t> neighbor_counts(nv), upper_counts(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      const auto begin = static_cast<std::size_t>(vertex_face_offsets_[v]);
      const auto end = static_cast<std::size_t>(vertex_face_offsets_[v + 1]);
      std::int32_t* const first = candidates.get() + 2 * begin;
      const auto vi = static_cast<std::int32_t>(v);
      std::int32_t n = 0, upper = 0;
      // Insertion into a sorted list without repeats: each neighbour of an
      // interior vertex comes twice, and the list is a handful long.
      auto insert = [&](std::int32_t w) {
        if (w == vi) return;
        std::int32_t j = n;
        while (j > 0 && first[j - 1] > w) --j;
        if (j > 0 && first[j - 1] == w) return;
        for (std::int32_t m = n; m > j; --m) first[m] = first[m - 1];
        first[j] = w;
        ++n;
        upper += w > vi;
      };
      for (std::size_t i = begin; i < end; ++i) {
        const Face& f = mesh.faces[static_cast<std::size_t>(vertex_faces_[i])];
        const int c = vertex_face_corners_[i];
        const std::array<std::int32_t, 2> o{f[c == 2 ? 0 : c + 1], f[c == 0 ? 2 : c - 1]};
        vertex_face_opposite_[i] = o;
        insert(o[0]);
        insert(o[1]);
      }
      neighbor_counts[v] = n;
      upper_counts[v] = upper;
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
    return candidates.get() + 2 * static_cast<std::size_t>(vertex_face_offsets_[v]);
  };
  // Rank of b among a's upper neighbours (a handful: a branch-free count).
  auto upper_rank = [&](std::size_t a, std::int32_t b) {
    const std::int32_t* const last = sorted_neighbors(a) + neighbor_counts[a];
    return count_below(last - upper_counts[a], upper_counts[a], b);
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      const auto vi = static_cast<std::int32_t>(v);
      const std::int32_t* const nb = sorted_neighbors(v);
      const auto count = static_cast<std::size_t>(neighbor_counts[v]);
      const auto out = static_cast<std::size_t>(vertex_neighbor_offsets_[v]);
      std::copy(nb, nb + count, vertex_neighbors_.data() + out);
      const std::size_t lower = count - static_cast<std::size_t>(upper_counts[v]);
      for (std::size_t i = 0; i < lower; ++i)
        vertex_edges_[out + i] = edge_offsets[static_cast<std::size_t>(nb[i])] +
                                 upper_rank(static_cast<std::size_t>(nb[i]), vi);
      const std::int32_t first_edge = edge_offsets[v];
      for (std::size_t i = lower; i < count; ++i) {
        const auto e = first_edge + static_cast<std::int32_t>(i - lower);
        vertex_edges_[out + i] = e;
        edges_[static_cast<std::size_t>(e)] = {vi, nb[i]};
      }
      const auto fs = vertex_faces(v);
      const auto cs = vertex_face_corners(v);
      const auto os = vertex_face_opposite(v);
      for (std::size_t j = 0; j < fs.size(); ++j) {
        const auto f = static_cast<std::size_t>(fs[j]);
        const int c = cs[j];
        // The edges opposite the two other corners k touch v; their other
        // end is the corner that is neither c nor k.
        const int k1 = c == 2 ? 0 : c + 1, k2 = c == 0 ? 2 : c - 1;
        const auto w1 = os[j][1], w2 = os[j][0];
        auto& fe = face_edges_[f];
        if (w1 == vi)
          fe[k1] = -1;
        else if (w1 > vi)
          fe[k1] = first_edge + upper_rank(v, w1);
        if (w2 == vi)
          fe[k2] = -1;
        else if (w2 > vi)
          fe[k2] = first_edge + upper_rank(v, w2);
      }
    }
  });
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
