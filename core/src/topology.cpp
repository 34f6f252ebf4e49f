#include "fabrica/core/topology.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <memory>
#include <mutex>
#include <numeric>
#include <string>
#include <type_traits>
#include <utility>

#include "fabrica/core/error.hpp"
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

/// The other vertices of one face already counted for a vertex v: a face
/// counts once per edge even when it is degenerate (it then lists v, or a
/// neighbour, twice; its entries in v's list are adjacent). Faces with three
/// distinct corners skip the check, and so does every face (kCheck false)
/// when the mesh has no degenerate face.
template <bool kCheck>
class FaceNeighbors {
 public:
  /// The next entry of v's list: face f with the other corners o.
  void entry(std::int32_t f, const std::array<std::int32_t, 2>& o, std::int32_t v) {
    if constexpr (!kCheck) return;
    if (f != face_) {
      face_ = f;
      n_ = 0;
    }
    check_ = o[0] == o[1] || o[0] == v || o[1] == v;
  }
  bool first_time(std::int32_t w) {
    if (!kCheck || !check_) return true;
    for (int i = 0; i < n_; ++i)
      if (seen_[i] == w) return false;
    seen_[n_++] = w;
    return true;
  }

 private:
  std::int32_t face_ = -1;
  int n_ = 0;
  bool check_ = false;
  std::array<std::int32_t, 2> seen_{};
};

}  // namespace

// docs/algorithms.md §1, "Adjacency".
Topology::Topology(const TriangleMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.faces.size();

  // Vertex -> faces, by counting sort (faces come out in increasing order).
  std::vector<std::int32_t> counts(nv, 0);
  bool degenerate = false;
  for (const Face& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) ++counts[f[k]];
    degenerate |= (f[0] == f[1]) | (f[1] == f[2]) | (f[0] == f[2]);
  }
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
  // uninitialised: the parallel pass touches it first), with, slot by slot,
  // how many faces share the edge to that neighbour.
  OppositeLists& opposite = opposite_->value;
  opposite.resize(vertex_faces_.size());
  const std::size_t slots = 2 * vertex_faces_.size();
  // (+ kRankPad: the rank count below reads eight entries at a time; what it
  // reads past a list is masked out.)
  const std::unique_ptr<std::int32_t[]> candidates(new std::int32_t[slots + kRankPad]);
  std::fill_n(candidates.get() + slots, kRankPad, 0);
  const std::unique_ptr<std::int32_t[]> sharing(new std::int32_t[slots]);
  // Per vertex: neighbours, higher neighbours, faces on the edges to them.
  const std::unique_ptr<std::array<std::int32_t, 3>[]> sizes(new std::array<std::int32_t, 3>[nv]);
  boundary_vertex_.resize(nv);
  const auto neighbor_pass = [&](auto check) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
      for (std::size_t v = r.begin(); v < r.end(); ++v) {
        const auto begin = static_cast<std::size_t>(vertex_face_offsets_[v]);
        const auto end = static_cast<std::size_t>(vertex_face_offsets_[v + 1]);
        std::int32_t* const first = candidates.get() + 2 * begin;
        std::int32_t* const shared = sharing.get() + 2 * begin;
        const auto vi = static_cast<std::int32_t>(v);
        std::int32_t n = 0, upper = 0;
        FaceNeighbors<decltype(check)::value> seen;
        // Insertion into a sorted list without repeats: each neighbour of an
        // interior vertex comes twice (once per face of its edge), and the
        // list is a handful long.
        auto insert = [&](std::int32_t w) {
          if (w == vi || !seen.first_time(w)) return;
          std::int32_t j = n;
          while (j > 0 && first[j - 1] > w) --j;
          if (j > 0 && first[j - 1] == w) {
            ++shared[j - 1];
            return;
          }
          for (std::int32_t m = n; m > j; --m) {
            first[m] = first[m - 1];
            shared[m] = shared[m - 1];
          }
          first[j] = w;
          shared[j] = 1;
          ++n;
          upper += w > vi;
        };
        for (std::size_t i = begin; i < end; ++i) {
          const Face& f = mesh.faces[static_cast<std::size_t>(vertex_faces_[i])];
          const int c = vertex_face_corners_[i];
          const std::array<std::int32_t, 2> o = corners_after(f, c);
          opposite[i] = o;
          seen.entry(vertex_faces_[i], o, vi);
          insert(o[0]);
          insert(o[1]);
        }
        // A boundary edge has one face (seen from either end).
        std::int32_t upper_faces = 0;
        bool boundary = false;
        for (std::int32_t j = 0; j < n; ++j) {
          boundary |= shared[j] == 1;
          if (j >= n - upper) upper_faces += shared[j];
        }
        sizes[v] = {n, upper, upper_faces};
        boundary_vertex_[v] = boundary ? 1 : 0;
      }
    });
  };
  if (degenerate)
    neighbor_pass(std::true_type{});
  else
    neighbor_pass(std::false_type{});
  // (The neighbour lists themselves are kept only when asked for: built
  // from the edges, build_neighbor_lists.)
  vertex_edge_offsets_.resize(nv + 1);
  std::vector<std::int32_t> edge_face_base(nv + 1);
  vertex_edge_offsets_[0] = edge_face_base[0] = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    vertex_edge_offsets_[v + 1] = vertex_edge_offsets_[v] + sizes[v][1];
    edge_face_base[v + 1] = edge_face_base[v] + sizes[v][2];
  }
  EdgeList& edges = edges_->value;
  edges.resize(static_cast<std::size_t>(vertex_edge_offsets_.back()));
  EdgeFaceLists& edge_faces = edge_face_lists_->value;
  edge_faces.offsets.resize(edges.size() + 1);
  edge_faces.offsets.back() = edge_face_base.back();
  edge_faces.faces.resize(static_cast<std::size_t>(edge_face_base.back()));
  face_edges_.resize(nf);
  // Edge e = (a, b), a < b, is numbered vertex_edge_offsets_[a] + the rank
  // of b among a's higher neighbours, and its faces are those of a that hold
  // b (in a's increasing face order). So each vertex writes its own lists,
  // the edges it is the lower end of with their faces, and the face edges
  // it is the lower end of (or both ends: a degenerate face's edge, -1):
  // every output is written once, by one vertex.
  const auto edge_pass = [&](auto check) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
      for (std::size_t v = r.begin(); v < r.end(); ++v) {
        const auto vi = static_cast<std::int32_t>(v);
        const auto begin = static_cast<std::size_t>(vertex_face_offsets_[v]);
        const std::int32_t* const nb = candidates.get() + 2 * begin;
        const auto count = static_cast<std::size_t>(sizes[v][0]);
        const std::int32_t upper = sizes[v][1];
        const std::size_t lower = count - static_cast<std::size_t>(upper);
        const std::int32_t first_edge = vertex_edge_offsets_[v];
        // The face count of each higher neighbour's slot becomes the write
        // cursor into that edge's faces.
        std::int32_t* const cursor = sharing.get() + 2 * begin + lower;
        std::int32_t at = edge_face_base[v];
        for (std::int32_t i = 0; i < upper; ++i) {
          const auto e = static_cast<std::size_t>(first_edge + i);
          edges[e] = {vi, nb[lower + static_cast<std::size_t>(i)]};
          edge_faces.offsets[e] = at;
          at += std::exchange(cursor[i], at);
        }
        FaceNeighbors<decltype(check)::value> seen;
        auto edge_to = [&](std::int32_t w, std::array<std::int32_t, 3>& fe, int k, std::int32_t f) {
          if (w == vi) {
            fe[k] = -1;
          } else if (w > vi) {
            const std::int32_t rank = count_below(nb + lower, upper, w);
            fe[k] = first_edge + rank;
            if (seen.first_time(w)) edge_faces.faces[static_cast<std::size_t>(cursor[rank]++)] = f;
          }
        };
        const auto end = static_cast<std::size_t>(vertex_face_offsets_[v + 1]);
        for (std::size_t j = begin; j < end; ++j) {
          const std::int32_t f = vertex_faces_[j];
          const auto& o = opposite[j];
          seen.entry(f, o, vi);
          const int c = vertex_face_corners_[j];
          // The edges opposite the two other corners k touch v; their other
          // end is the corner that is neither c nor k.
          auto& fe = face_edges_[static_cast<std::size_t>(f)];
          edge_to(o[1], fe, c == 2 ? 0 : c + 1, f);
          edge_to(o[0], fe, c == 0 ? 2 : c - 1, f);
        }
      }
    });
  };
  if (degenerate)
    edge_pass(std::true_type{});
  else
    edge_pass(std::false_type{});
  edges_->ready.store(true, std::memory_order_release);
  opposite_->ready.store(true, std::memory_order_release);
  edge_face_lists_->ready.store(true, std::memory_order_release);
}

void Topology::release_derived_parts() {
  opposite_ = std::make_shared<LazyPart<OppositeLists>>();
  edge_face_lists_ = std::make_shared<LazyPart<EdgeFaceLists>>();
}

void Topology::release_edges() {
  edges_ = std::make_shared<LazyPart<EdgeList>>();
}

// Edge e joins two corners of each of its faces: each vertex w, at corner c
// of face f, is an end of f's two edges at that corner (opposite corners
// c + 1 and c + 2; -1 where the two corners are one vertex). Edges are
// numbered by their lower vertex, so e is w's own (w its lower end) when it
// lies in w's range of edge numbers, and w is its higher end otherwise: each
// half of each pair is written by one vertex only (every edge has a face,
// which lists both its ends), with the constructor's values.
void Topology::build_edges(LazyPart<EdgeList>& p) const {
  std::call_once(p.once, [&] {
    const std::size_t nv = vertex_count();
    EdgeList& edges = p.value;
    edges.resize(edge_count());
    tbb::this_task_arena::isolate([&] {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
        for (std::size_t v = r.begin(); v < r.end(); ++v) {
          const auto w = static_cast<std::int32_t>(v);
          const std::int32_t own = vertex_edge_offsets_[v], own_end = vertex_edge_offsets_[v + 1];
          for (auto i = static_cast<std::size_t>(vertex_face_offsets_[v]),
                    end = static_cast<std::size_t>(vertex_face_offsets_[v + 1]);
               i < end; ++i) {
            const auto& fe = face_edges_[static_cast<std::size_t>(vertex_faces_[i])];
            const int c = vertex_face_corners_[i];
            for (const std::int32_t e : corners_after(fe, c)) {
              if (e < 0) continue;
              edges[static_cast<std::size_t>(e)][e >= own && e < own_end ? 0 : 1] = w;
            }
          }
        }
      });
    });
    p.ready.store(true, std::memory_order_release);
  });
}

namespace {

/// The other end of edge e from vertex v, or v itself where the face's two
/// corners are one vertex (face edge -1).
inline std::int32_t other_end(const std::array<std::int32_t, 2>* edges, std::int32_t e,
                              std::int32_t v) {
  if (e < 0) return v;
  const auto& ab = edges[static_cast<std::size_t>(e)];
  return ab[0] == v ? ab[1] : ab[0];
}

}  // namespace

// The corners after v in face f at corner c: f[(c+1)%3] is the other end of
// the edge joining corners c and c+1 (the face edge opposite corner
// (c+2)%3), f[(c+2)%3] that of the edge joining c+2 and c (opposite
// (c+1)%3); a face edge of -1 joins two corners that are one vertex, v.
// The constructor's lists, bit for bit (also on degenerate faces).
void Topology::build_opposite(LazyPart<OppositeLists>& p) const {
  std::call_once(p.once, [&] {
    const std::size_t nv = vertex_count();
    OppositeLists& o = p.value;
    o.resize(vertex_faces_.size());
    const auto* const edges = edge_list().data();
    tbb::this_task_arena::isolate([&] {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& r) {
        for (std::size_t v = r.begin(); v < r.end(); ++v) {
          const auto vi = static_cast<std::int32_t>(v);
          for (auto i = static_cast<std::size_t>(vertex_face_offsets_[v]),
                    end = static_cast<std::size_t>(vertex_face_offsets_[v + 1]);
               i < end; ++i) {
            const auto& fe = face_edges_[static_cast<std::size_t>(vertex_faces_[i])];
            const int c = vertex_face_corners_[i];
            o[i] = {other_end(edges, fe[c == 0 ? 2 : c - 1], vi),
                    other_end(edges, fe[c == 2 ? 0 : c + 1], vi)};
          }
        }
      });
    });
    p.ready.store(true, std::memory_order_release);
  });
}

// Each edge's faces in increasing face order, from the face edges (a face
// whose two face edges are one edge, a degenerate face, counts once), as
// the constructor's edge pass lists them.
void Topology::build_edge_faces(LazyPart<EdgeFaceLists>& p) const {
  std::call_once(p.once, [&] {
    const std::size_t ne = edge_count(), nf = face_count();
    EdgeFaceLists& l = p.value;
    l.offsets.assign(ne + 1, 0);
    const auto once = [](const std::array<std::int32_t, 3>& fe, int k) {
      return fe[k] >= 0 && (k < 1 || fe[k] != fe[0]) && (k < 2 || fe[k] != fe[1]);
    };
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k)
        if (once(face_edges_[f], k)) ++l.offsets[static_cast<std::size_t>(face_edges_[f][k]) + 1];
    for (std::size_t e = 0; e < ne; ++e) l.offsets[e + 1] += l.offsets[e];
    l.faces.resize(static_cast<std::size_t>(l.offsets[ne]));
    std::vector<std::int32_t> cursor(l.offsets.begin(), l.offsets.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k)
        if (once(face_edges_[f], k))
          l.faces[static_cast<std::size_t>(cursor[static_cast<std::size_t>(face_edges_[f][k])]++)] =
              static_cast<std::int32_t>(f);
    p.ready.store(true, std::memory_order_release);
  });
}

// Each vertex's neighbours in increasing order, from the edges (a, b), a <
// b, in their lexicographic order: b is appended to a's list and a to b's.
// A vertex v receives first its lower neighbours (edges (a, v), a < v, come
// before v's own edges, by increasing a), then its higher ones (v's edges,
// by increasing b): the sorted list of the vertices sharing a face's edge
// with v, as the constructor's neighbour pass finds them.
void Topology::build_neighbor_lists(LazyNeighbors& n) const {
  std::call_once(n.once, [&] {
    const std::size_t nv = vertex_count();
    NeighborLists& l = n.lists;
    l.offsets.assign(nv + 1, 0);
    // Degrees: v's higher neighbours are its edges; the lower ones counted.
    const EdgeList& edges = edge_list();
    for (const auto& e : edges) ++l.offsets[static_cast<std::size_t>(e[1]) + 1];
    for (std::size_t v = 0; v < nv; ++v)
      l.offsets[v + 1] += l.offsets[v] + (vertex_edge_offsets_[v + 1] - vertex_edge_offsets_[v]);
    l.neighbors.resize(static_cast<std::size_t>(nv ? l.offsets[nv] : 0));
    std::vector<std::int32_t> cursor(l.offsets.begin(), l.offsets.end() - (nv ? 1 : 0));
    for (const auto& e : edges) {
      const auto a = static_cast<std::size_t>(e[0]), b = static_cast<std::size_t>(e[1]);
      l.neighbors[static_cast<std::size_t>(cursor[a]++)] = e[1];
      l.neighbors[static_cast<std::size_t>(cursor[b]++)] = e[0];
    }
    n.ready.store(true, std::memory_order_release);
  });
}

void Topology::reverse_face(std::size_t f, const Face& corners) {
  // The entry of f in each corner's face list, checked: f lists that
  // vertex at that corner.
  std::array<std::size_t, 3> entry{};
  bool ok = f < face_count() && corners[0] != corners[1] && corners[1] != corners[2] &&
            corners[2] != corners[0];
  for (int c = 0; ok && c < 3; ++c) {
    const auto v = static_cast<std::size_t>(corners[c]);
    if (corners[c] < 0 || v >= vertex_count()) {
      ok = false;
      break;
    }
    const auto first = vertex_faces_.begin() + vertex_face_offsets_[v];
    const auto last = vertex_faces_.begin() + vertex_face_offsets_[v + 1];
    const auto it = std::lower_bound(first, last, static_cast<std::int32_t>(f));
    entry[c] = static_cast<std::size_t>(it - vertex_faces_.begin());
    ok = it != last && *it == static_cast<std::int32_t>(f) && vertex_face_corners_[entry[c]] == c;
  }
  if (!ok)
    throw InputError("Topology::reverse_face: face " + std::to_string(f) + " is not (" +
                     std::to_string(corners[0]) + ", " + std::to_string(corners[1]) + ", " +
                     std::to_string(corners[2]) +
                     ") with three distinct vertices in this topology");
  auto& fe = face_edges_[f];
  std::swap(fe[1], fe[2]);  // (b, a) was opposite corner 2, (a, c) opposite corner 1
  // The opposite corners: swapped in place when held by this topology
  // alone; a copy's that are held are copied first; lists not held are
  // rebuilt from the new face edges when asked for (a copy's are its own).
  const bool held = opposite_->ready.load(std::memory_order_acquire);
  if (opposite_.use_count() > 1) {
    auto own = std::make_shared<LazyPart<OppositeLists>>();
    if (held) {
      own->value = opposite_->value;
      own->ready.store(true, std::memory_order_release);
    }
    opposite_ = std::move(own);
  }
  for (int c = 0; c < 3; ++c) {
    // Corner 1 becomes corner 2 and 2 becomes 1; the two other corners
    // after v change places for every corner.
    vertex_face_corners_[entry[c]] = static_cast<std::uint8_t>((3 - c) % 3);
    if (held) std::swap(opposite_->value[entry[c]][0], opposite_->value[entry[c]][1]);
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
