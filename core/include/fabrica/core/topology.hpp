// Adjacency of an indexed triangle mesh, built once per Surface.
//
// Works on any triangle soup: open, multi-component, non-manifold. Every
// list is in a deterministic order (by vertex index, then face index), so
// results never depend on thread count.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <new>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include "fabrica/core/types.hpp"

namespace fabrica {

struct TriangleMesh;

namespace detail {
/// An allocator whose resize() leaves new elements default-initialised
/// (trivial types: not zeroed), for arrays a parallel pass fills anyway:
/// no serial zeroing pass over fresh memory.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T, class U>
bool operator==(const DefaultInitAllocator<T>&, const DefaultInitAllocator<U>&) noexcept {
  return true;
}
/// A vector whose resize() does not zero (see DefaultInitAllocator).
template <class T>
using FilledVector = std::vector<T, DefaultInitAllocator<T>>;
}  // namespace detail

class Topology {
 public:
  Topology() = default;
  explicit Topology(const TriangleMesh& mesh);

  std::size_t vertex_count() const {
    return vertex_face_offsets_.empty() ? 0 : vertex_face_offsets_.size() - 1;
  }
  std::size_t face_count() const { return face_edges_.size(); }
  std::size_t edge_count() const {
    return vertex_edge_offsets_.empty() ? 0 : static_cast<std::size_t>(vertex_edge_offsets_.back());
  }

  /// Faces incident to vertex v, increasing face index.
  std::span<const std::int32_t> vertex_faces(std::size_t v) const {
    return {vertex_faces_.data() + vertex_face_offsets_[v],
            vertex_faces_.data() + vertex_face_offsets_[v + 1]};
  }
  /// Corner index (0..2) of v in each face of vertex_faces(v), same order.
  std::span<const std::uint8_t> vertex_face_corners(std::size_t v) const {
    return {vertex_face_corners_.data() + vertex_face_offsets_[v],
            vertex_face_corners_.data() + vertex_face_offsets_[v + 1]};
  }
  /// The two other corners (i1, i2) of each face of vertex_faces(v), same
  /// order, in the face's corner order after v: i1 = f[(c+1)%3],
  /// i2 = f[(c+2)%3] where c is v's corner. (After release_derived_parts,
  /// rebuilt from the face edges on the first call, once, thread-safe.)
  /// The two corners after corner c of face f, in its corner order:
  /// {f[(c+1)%3], f[(c+2)%3]} (one entry of vertex_face_opposite).
  static std::array<std::int32_t, 2> corners_after(const Face& f, int c) {
    return {f[c == 2 ? 0 : c + 1], f[c == 0 ? 2 : c - 1]};
  }
  std::span<const std::array<std::int32_t, 2>> vertex_face_opposite(std::size_t v) const {
    const auto& o = opposite_lists();
    return {o.data() + vertex_face_offsets_[v], o.data() + vertex_face_offsets_[v + 1]};
  }
  /// Vertices joined to v by an edge, increasing index. (Built from the
  /// edges on the first call of this, vertex_edge or upper_neighbors on
  /// this topology or a copy of it, once, thread-safe: most paths never
  /// read them.)
  std::span<const std::int32_t> vertex_neighbors(std::size_t v) const {
    const NeighborLists& n = neighbor_lists();
    return {n.neighbors.data() + n.offsets[v], n.neighbors.data() + n.offsets[v + 1]};
  }
  /// Edge index of entry i of vertex_neighbors(v). The edges to v's higher
  /// neighbours are numbered consecutively from v's first edge; the edge to
  /// a lower neighbour a is found among a's higher neighbours.
  std::int32_t vertex_edge(std::size_t v, std::size_t i) const {
    const NeighborLists& n = neighbor_lists();
    const auto begin = static_cast<std::size_t>(n.offsets[v]);
    const auto upper =
        static_cast<std::size_t>(vertex_edge_offsets_[v + 1] - vertex_edge_offsets_[v]);
    const std::size_t lower = static_cast<std::size_t>(n.offsets[v + 1]) - begin - upper;
    if (i >= lower) return vertex_edge_offsets_[v] + static_cast<std::int32_t>(i - lower);
    const auto a = static_cast<std::size_t>(n.neighbors[begin + i]);
    return vertex_edge_offsets_[a] + upper_rank(a, static_cast<std::int32_t>(v));
  }
  /// The edge joining vertices a and b, or -1 when there is none (or a == b).
  std::int32_t find_edge(std::int32_t a, std::int32_t b) const {
    if (a == b) return -1;
    const auto lo = static_cast<std::size_t>(a < b ? a : b);
    const std::int32_t hi = a < b ? b : a;
    const std::int32_t r = upper_rank(lo, hi);
    const std::int32_t e = vertex_edge_offsets_[lo] + r;
    if (e == vertex_edge_offsets_[lo + 1] || edge_list()[static_cast<std::size_t>(e)][1] != hi)
      return -1;
    return e;
  }
  /// The edges whose lower vertex is v: vertex_edge_begin(v) + i joins v and
  /// the i-th of v's neighbours above v.
  std::int32_t vertex_edge_begin(std::size_t v) const { return vertex_edge_offsets_[v]; }
  /// v's neighbours above v (the tail of vertex_neighbors(v)), increasing.
  std::span<const std::int32_t> upper_neighbors(std::size_t v) const {
    const NeighborLists& n = neighbor_lists();
    const auto end = static_cast<std::size_t>(n.offsets[v + 1]);
    const auto upper =
        static_cast<std::size_t>(vertex_edge_offsets_[v + 1] - vertex_edge_offsets_[v]);
    return {n.neighbors.data() + (end - upper), n.neighbors.data() + end};
  }
  /// Whether vertex_neighbors' lists have been built (tests, memory probes).
  bool has_vertex_neighbors() const {
    return neighbors_ && neighbors_->ready.load(std::memory_order_acquire);
  }

  /// Undirected edge e as (lower vertex, higher vertex). Edges are numbered in
  /// lexicographic order of that pair. (After release_edges, rebuilt from
  /// the vertex faces and face edges on the first call, once, thread-safe.)
  const std::array<std::int32_t, 2>& edge(std::size_t e) const { return edge_list()[e]; }
  /// Faces using edge e, increasing face index: 1 = boundary, 2 = interior,
  /// more = non-manifold edge. (After release_derived_parts, rebuilt from
  /// the face edges on the first call, once, thread-safe.)
  std::span<const std::int32_t> edge_faces(std::size_t e) const {
    const EdgeFaceLists& l = edge_face_lists();
    return {l.faces.data() + l.offsets[e], l.faces.data() + l.offsets[e + 1]};
  }
  /// The edge of face f opposite corner k, i.e. joining corners (k+1)%3 and (k+2)%3.
  std::int32_t face_edge(std::size_t f, int k) const { return face_edges_[f][k]; }
  /// The three edges of face f in one row (for prefetching).
  const std::int32_t* face_edge_row(std::size_t f) const { return face_edges_[f].data(); }
  /// The face across the edge opposite corner k of f, or -1 at a boundary or
  /// non-manifold edge.
  std::int32_t face_neighbor(std::size_t f, int k) const;

  bool is_boundary_edge(std::size_t e) const { return edge_faces(e).size() == 1; }
  bool is_nonmanifold_edge(std::size_t e) const { return edge_faces(e).size() > 2; }
  /// A vertex on a boundary edge.
  bool is_boundary_vertex(std::size_t v) const { return boundary_vertex_[v] != 0; }
  /// A vertex referenced by no face.
  bool is_isolated_vertex(std::size_t v) const { return vertex_faces(v).empty(); }

  /// Frees the parts that are derived from the face edges and edges:
  /// vertex_face_opposite (8 bytes per corner) and edge_faces (4 bytes per
  /// corner and per edge). Each is rebuilt, bit for bit, on the first call
  /// of its accessor afterwards (once, thread-safe; copies made before keep
  /// theirs). For a topology whose readers mostly never ask for them (a
  /// Surface's: the curvature fits and the one-shot line extraction read
  /// neither), so that they do not hold memory through every later phase.
  /// Not to be called while another thread reads this topology.
  void release_derived_parts();
  /// Frees the edges' vertex pairs (8 bytes per edge; edge_count() and the
  /// face edges stay), which edge(), find_edge(), vertex_edge(), the
  /// neighbour lists and the derived parts read: derived from the vertex
  /// faces, their corners and the face edges, they are rebuilt, bit for
  /// bit, on the first call of such an accessor afterwards (once,
  /// thread-safe; copies made before keep theirs). For a topology whose
  /// readers never ask for them (the one-shot line drawing of `fabrica
  /// lines`: its zero crossings read the face edges only). Not to be called
  /// while another thread reads this topology.
  void release_edges();
  /// Whether edge()'s pairs are held (tests, memory probes).
  bool has_edges() const { return edges_ && edges_->ready.load(std::memory_order_acquire); }
  /// Whether vertex_face_opposite's and edge_faces' lists are held (tests,
  /// memory probes).
  bool has_vertex_face_opposite() const {
    return opposite_ && opposite_->ready.load(std::memory_order_acquire);
  }
  bool has_edge_faces() const {
    return edge_face_lists_ && edge_face_lists_->ready.load(std::memory_order_acquire);
  }

  /// Follows face f turned over from `corners` (a, b, c) to (a, c, b), as
  /// io::repair_mesh orients faces (corner 0 keeps its vertex): afterwards
  /// this is Topology(mesh) of the mesh with that face turned, bit for bit
  /// (only the corner order of f changes: its face edges, and its corner and
  /// opposite entries at its three vertices; O(log degree)). `corners` must
  /// be face f as this topology has it, three distinct vertices; otherwise
  /// throws InputError and changes nothing.
  void reverse_face(std::size_t f, const Face& corners);

 private:
  /// How many of v's higher neighbours are below b (a handful: a plain
  /// count over the second ends of v's edges).
  std::int32_t upper_rank(std::size_t v, std::int32_t b) const {
    std::int32_t r = 0;
    const auto* const edges = edge_list().data();
    for (auto e = static_cast<std::size_t>(vertex_edge_offsets_[v]),
              end = static_cast<std::size_t>(vertex_edge_offsets_[v + 1]);
         e < end; ++e)
      r += edges[e][1] < b;
    return r;
  }

  /// The vertex neighbour lists (CSR), built on first use from the edges.
  struct NeighborLists {
    std::vector<std::int32_t> offsets;
    detail::FilledVector<std::int32_t> neighbors;
  };
  /// Shared by copies (the lists depend on the edges only, which
  /// reverse_face keeps); `ready` is the fast path's check.
  struct LazyNeighbors {
    std::once_flag once;
    std::atomic<bool> ready{false};
    NeighborLists lists;
  };
  const NeighborLists& neighbor_lists() const {
    LazyNeighbors& n = *neighbors_;
    if (!n.ready.load(std::memory_order_acquire)) build_neighbor_lists(n);
    return n.lists;
  }
  void build_neighbor_lists(LazyNeighbors& n) const;

  /// A part built by the constructor, or after release_derived_parts on
  /// first use (`ready` is the fast path's check); shared by copies until
  /// one of them changes it (reverse_face).
  template <class T>
  struct LazyPart {
    std::once_flag once;
    std::atomic<bool> ready{false};
    T value;
  };
  using OppositeLists = detail::FilledVector<std::array<std::int32_t, 2>>;
  struct EdgeFaceLists {
    detail::FilledVector<std::int32_t> offsets;  ///< edge_count() + 1
    detail::FilledVector<std::int32_t> faces;
  };
  const OppositeLists& opposite_lists() const {
    LazyPart<OppositeLists>& p = *opposite_;
    if (!p.ready.load(std::memory_order_acquire)) build_opposite(p);
    return p.value;
  }
  const EdgeFaceLists& edge_face_lists() const {
    LazyPart<EdgeFaceLists>& p = *edge_face_lists_;
    if (!p.ready.load(std::memory_order_acquire)) build_edge_faces(p);
    return p.value;
  }
  using EdgeList = detail::FilledVector<std::array<std::int32_t, 2>>;
  const EdgeList& edge_list() const {
    LazyPart<EdgeList>& p = *edges_;
    if (!p.ready.load(std::memory_order_acquire)) build_edges(p);
    return p.value;
  }
  void build_edges(LazyPart<EdgeList>& p) const;
  void build_opposite(LazyPart<OppositeLists>& p) const;
  void build_edge_faces(LazyPart<EdgeFaceLists>& p) const;

  // Arrays that the constructor fills completely are not zeroed first.
  std::vector<std::int32_t> vertex_face_offsets_;
  detail::FilledVector<std::int32_t> vertex_faces_;
  detail::FilledVector<std::uint8_t> vertex_face_corners_;
  std::shared_ptr<LazyPart<OppositeLists>> opposite_ = std::make_shared<LazyPart<OppositeLists>>();
  std::shared_ptr<LazyNeighbors> neighbors_ = std::make_shared<LazyNeighbors>();
  // First edge of each vertex (edges numbered by lower vertex), size nv + 1.
  std::vector<std::int32_t> vertex_edge_offsets_;
  std::shared_ptr<LazyPart<EdgeList>> edges_ = std::make_shared<LazyPart<EdgeList>>();
  std::shared_ptr<LazyPart<EdgeFaceLists>> edge_face_lists_ =
      std::make_shared<LazyPart<EdgeFaceLists>>();
  detail::FilledVector<std::array<std::int32_t, 3>> face_edges_;
  detail::FilledVector<std::uint8_t> boundary_vertex_;
};

}  // namespace fabrica
