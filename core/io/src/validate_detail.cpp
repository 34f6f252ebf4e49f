#include "validate_detail.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>

#include "fabrica/core/mesh.hpp"

namespace fabrica::io::detail {

std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

void unite(std::vector<std::int32_t>& parent, std::int32_t a, std::int32_t b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a == b) return;
  if (a < b) std::swap(a, b);
  parent[a] = b;  // the lower index becomes the root: deterministic labels
}

std::string plural(std::size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

namespace {

// The common case, fast: walk around v from its first face through two-face
// edges in both directions; one fan when the walk meets every face of v.
bool single_fan_by_walk(const Topology& topology, std::size_t v, std::int32_t first_face,
                        int first_corner, std::size_t face_count) {
  const auto vertex = static_cast<std::int32_t>(v);
  // The edge of face f at v other than `from`.
  auto other_edge_at_v = [&](std::int32_t f, std::int32_t from) {
    for (int k = 0; k < 3; ++k) {
      const auto e = topology.face_edge(f, k);
      if (e == from || e < 0) continue;
      const auto& ends = topology.edge(e);
      if (ends[0] == vertex || ends[1] == vertex) return e;
    }
    return std::int32_t{-1};
  };
  std::size_t seen = 1;
  const std::int32_t start_edges[2] = {topology.face_edge(first_face, (first_corner + 1) % 3),
                                       topology.face_edge(first_face, (first_corner + 2) % 3)};
  for (int side = 0; side < 2; ++side) {
    std::int32_t f = first_face, e = start_edges[side];
    while (e >= 0 && seen <= face_count) {
      const auto ef = topology.edge_faces(e);
      if (ef.size() != 2) break;
      f = ef[0] == f ? ef[1] : ef[0];
      if (f == first_face) return seen == face_count;  // closed ring
      ++seen;
      e = other_edge_at_v(f, e);
    }
  }
  return seen == face_count;
}

}  // namespace

ProperTopology::ProperTopology(const TriangleMesh& mesh) : mesh_faces_(&mesh.faces) {
  for (const Face& f : mesh.faces)
    if (has_repeated_index(f)) ++repeated_index_faces_;
  if (repeated_index_faces_ == 0) {
    topology_ = Topology(mesh);
    return;
  }
  filtered_ = true;
  TriangleMesh proper;
  proper.positions.resize(mesh.positions.size(), Vec3::Zero());  // Topology only needs the count
  proper.faces.reserve(mesh.faces.size() - repeated_index_faces_);
  original_face_.reserve(mesh.faces.size() - repeated_index_faces_);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    if (!has_repeated_index(mesh.faces[f])) {
      proper.faces.push_back(mesh.faces[f]);
      original_face_.push_back(static_cast<std::int32_t>(f));
    }
  topology_ = Topology(proper);
  filtered_faces_ = std::move(proper.faces);
}

double mean_edge_length(const Topology& topology, const std::vector<Vec3>& positions) {
  const std::size_t ne = topology.edge_count();
  if (ne == 0) return 0.0;
  double sum = 0.0;
  for (std::size_t e = 0; e < ne; ++e) {
    const auto& ed = topology.edge(e);
    sum += (positions[ed[0]] - positions[ed[1]]).norm();
  }
  return sum / static_cast<double>(ne);
}

int vertex_fans(const Topology& topology, std::size_t v, std::vector<int>& fan_of_entry,
                bool manifold_edges_only) {
  const auto faces = topology.vertex_faces(v);
  const auto corners = topology.vertex_face_corners(v);
  const auto n = static_cast<std::int32_t>(faces.size());
  fan_of_entry.assign(faces.size(), 0);
  if (n <= 1) return n;
  if (single_fan_by_walk(topology, v, faces.front(), corners.front(), faces.size())) return 1;
  thread_local std::vector<std::int32_t> parent;
  thread_local std::vector<int> label;
  parent.resize(faces.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (std::int32_t i = 0; i < n; ++i) {
    const auto f = faces[i];
    const int k = corners[i];
    for (int side : {(k + 1) % 3, (k + 2) % 3}) {  // the two edges of f at v
      const auto e = topology.face_edge(f, side);
      if (e < 0) continue;
      const auto ef = topology.edge_faces(e);
      if (manifold_edges_only && ef.size() != 2) continue;
      for (auto g : ef) {
        if (g <= f) continue;
        const auto it = std::lower_bound(faces.begin(), faces.end(), g);
        if (it != faces.end() && *it == g)
          unite(parent, i, static_cast<std::int32_t>(it - faces.begin()));
      }
    }
  }
  int fans = 0;
  label.assign(faces.size(), -1);
  for (std::int32_t i = 0; i < n; ++i) {
    const auto r = find_root(parent, i);
    if (label[r] < 0) label[r] = fans++;
    fan_of_entry[i] = label[r];
  }
  return fans;
}

bool CappedVolume::ambiguous() const {
  return !(std::abs(volume6) / 6.0 >= kFlatSheetRatio * area * std::sqrt(area)) || area <= 0.0;
}

std::vector<CappedVolume> capped_piece_volumes(const Topology& topology,
                                               const std::vector<Vec3>& positions,
                                               const std::vector<Face>& faces,
                                               const std::vector<std::int32_t>& piece,
                                               std::size_t piece_count,
                                               const std::vector<std::uint8_t>* flip) {
  std::vector<CappedVolume> out(piece_count);
  const Vec3 origin = bounding_box(positions).center();
  auto corners = [&](std::size_t f) {
    Face t = faces[f];
    if (flip != nullptr && (*flip)[f]) std::swap(t[1], t[2]);
    return t;
  };
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Face t = corners(f);
    const Vec3 &a = positions[t[0]], &b = positions[t[1]], &c = positions[t[2]];
    out[piece[f]].volume6 += signed_volume6(a, b, c, origin);
    out[piece[f]].area += 0.5 * (b - a).cross(c - a).norm();
  }
  // Boundary loops: vertices of boundary edges joined through those edges.
  std::vector<std::int32_t> parent(positions.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::int32_t> boundary;
  for (std::size_t e = 0; e < topology.edge_count(); ++e)
    if (topology.is_boundary_edge(e)) {
      boundary.push_back(static_cast<std::int32_t>(e));
      unite(parent, topology.edge(e)[0], topology.edge(e)[1]);
    }
  if (boundary.empty()) return out;
  std::vector<Vec3> sum(positions.size(), Vec3::Zero());
  std::vector<std::size_t> count(positions.size(), 0);
  std::vector<std::uint8_t> counted(positions.size(), 0);
  for (auto e : boundary)
    for (auto v : topology.edge(e))
      if (!counted[v]) {
        counted[v] = 1;
        const auto root = find_root(parent, v);
        sum[root] += positions[v];
        ++count[root];
      }
  std::vector<std::int32_t> loop_piece(positions.size(), -1);
  for (auto e : boundary) {
    const auto f = static_cast<std::size_t>(topology.edge_faces(e)[0]);
    const Face t = corners(f);
    // The directed edge of (the possibly flipped) face f along e.
    const auto ends = topology.edge(e);
    std::int32_t s = -1, u = -1;
    for (int i = 0; i < 3; ++i)
      if ((t[i] == ends[0] && t[(i + 1) % 3] == ends[1]) ||
          (t[i] == ends[1] && t[(i + 1) % 3] == ends[0])) {
        s = t[i];
        u = t[(i + 1) % 3];
      }
    if (s < 0) continue;
    const auto root = find_root(parent, s);
    const Vec3 centroid = sum[root] / static_cast<double>(count[root]);
    // The cap runs against the face's edge so that the capped piece is closed.
    out[piece[f]].volume6 += signed_volume6(positions[u], positions[s], centroid, origin);
    if (loop_piece[root] != piece[f]) {
      loop_piece[root] = piece[f];
      ++out[piece[f]].loops;
    }
  }
  return out;
}

std::vector<std::int32_t> manifold_pieces(const Topology& topology, std::size_t& piece_count) {
  const std::size_t nf = topology.face_count();
  std::vector<std::int32_t> parent(nf);
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t e = 0; e < topology.edge_count(); ++e) {
    const auto ef = topology.edge_faces(e);
    if (ef.size() == 2) unite(parent, ef[0], ef[1]);
  }
  std::vector<std::int32_t> piece(nf, -1);
  std::vector<std::int32_t> label(nf, -1);
  std::int32_t count = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const auto r = find_root(parent, static_cast<std::int32_t>(f));
    if (label[r] < 0) label[r] = count++;
    piece[f] = label[r];
  }
  piece_count = static_cast<std::size_t>(count);
  return piece;
}

namespace {

// Ray parity against one closed piece: triangles projected along a fixed
// generic direction d onto the plane (u, w) perpendicular to it and binned in
// a uniform 2D grid, so each query tests only the triangles over its cell.
class RayParity {
 public:
  RayParity(const std::vector<Vec3>& pos, const std::vector<Face>& faces,
            std::span<const std::int32_t> piece_faces)
      : pos_(pos), faces_(faces), piece_faces_(piece_faces) {
    d_ = Vec3(0.5377, 0.6391, 0.5498).normalized();
    u_ = d_.cross(Vec3(1, 0, 0)).normalized();
    w_ = d_.cross(u_);
    lo_ = Eigen::Vector2d::Constant(std::numeric_limits<double>::max());
    hi_ = -lo_;
    for (auto f : piece_faces_)
      for (int k = 0; k < 3; ++k) {
        const auto q = project(pos_[faces_[f][k]]);
        lo_ = lo_.cwiseMin(q);
        hi_ = hi_.cwiseMax(q);
      }
    n_ = std::clamp(static_cast<int>(std::sqrt(static_cast<double>(piece_faces_.size()) / 2.0)), 1,
                    1024);
    cell_ = ((hi_ - lo_) / n_).cwiseMax(Eigen::Vector2d::Constant(1e-300));
    std::vector<std::int32_t> counts(static_cast<std::size_t>(n_) * n_ + 1, 0);
    auto for_cells = [&](std::int32_t f, auto visit) {
      Eigen::Vector2d a = project(pos_[faces_[f][0]]), b = a;
      for (int k = 1; k < 3; ++k) {
        const auto q = project(pos_[faces_[f][k]]);
        a = a.cwiseMin(q);
        b = b.cwiseMax(q);
      }
      const int i0 = cell_index(a.x(), 0), i1 = cell_index(b.x(), 0);
      const int j0 = cell_index(a.y(), 1), j1 = cell_index(b.y(), 1);
      for (int i = i0; i <= i1; ++i)
        for (int j = j0; j <= j1; ++j) visit(i * n_ + j);
    };
    for (auto f : piece_faces_) for_cells(f, [&](int c) { ++counts[c + 1]; });
    std::partial_sum(counts.begin(), counts.end(), counts.begin());
    offsets_ = counts;
    cell_faces_.resize(offsets_.back());
    for (auto f : piece_faces_) for_cells(f, [&](int c) { cell_faces_[counts[c]++] = f; });
  }

  /// Whether p is inside the closed piece (odd number of crossings along d).
  bool inside(const Vec3& p) const {
    const auto q = project(p);
    if ((q.array() < lo_.array()).any() || (q.array() > hi_.array()).any()) return false;
    const int c = cell_index(q.x(), 0) * n_ + cell_index(q.y(), 1);
    int crossings = 0;
    for (auto i = offsets_[c]; i < offsets_[c + 1]; ++i) {
      const Face& f = faces_[cell_faces_[i]];
      const Vec3& a = pos_[f[0]];
      const Vec3& b = pos_[f[1]];
      const Vec3& cc = pos_[f[2]];
      // Signed volumes of the ray against the three edges (Pluecker-like
      // test): same sign = the line through p along d crosses the triangle.
      const double s0 = d_.dot((b - p).cross(cc - p));
      const double s1 = d_.dot((cc - p).cross(a - p));
      const double s2 = d_.dot((a - p).cross(b - p));
      if (!((s0 > 0 && s1 > 0 && s2 > 0) || (s0 < 0 && s1 < 0 && s2 < 0))) continue;
      const Vec3 n = (b - a).cross(cc - a);
      const double nd = n.dot(d_);
      if (nd == 0.0) continue;
      if (n.dot(a - p) / nd > 0.0) ++crossings;  // in front of p
    }
    return crossings % 2 == 1;
  }

 private:
  Eigen::Vector2d project(const Vec3& p) const { return {u_.dot(p), w_.dot(p)}; }
  int cell_index(double x, int axis) const {
    const double t = (x - lo_[axis]) / cell_[axis];
    return std::clamp(static_cast<int>(std::floor(t)), 0, n_ - 1);
  }

  const std::vector<Vec3>& pos_;
  const std::vector<Face>& faces_;
  std::span<const std::int32_t> piece_faces_;
  Vec3 d_, u_, w_;
  Eigen::Vector2d lo_, hi_, cell_;
  int n_ = 1;
  std::vector<std::int32_t> offsets_, cell_faces_;
};

}  // namespace

std::vector<int> nesting_depths(const std::vector<Vec3>& positions, const std::vector<Face>& faces,
                                const std::vector<std::int32_t>& piece,
                                const std::vector<std::uint8_t>& piece_closed) {
  const std::size_t np = piece_closed.size();
  std::vector<int> depth(np, 0);
  if (std::count(piece_closed.begin(), piece_closed.end(), 1) < 2) return depth;

  // Faces of each piece (CSR), bounding boxes and extreme vertices.
  std::vector<std::int32_t> offsets(np + 1, 0), piece_faces(faces.size());
  for (auto p : piece) ++offsets[p + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  {
    std::vector<std::int32_t> cursor(offsets.begin(), offsets.end() - 1);
    for (std::size_t f = 0; f < faces.size(); ++f)
      piece_faces[cursor[piece[f]]++] = static_cast<std::int32_t>(f);
  }
  std::vector<BoundingBox> box(np);
  std::vector<std::array<std::int32_t, 6>> extreme(np);
  for (std::size_t p = 0; p < np; ++p) {
    bool first = true;
    for (auto i = offsets[p]; i < offsets[p + 1]; ++i)
      for (auto v : faces[piece_faces[i]]) {
        const Vec3& x = positions[v];
        for (int a = 0; a < 3; ++a) {
          if (first || x[a] < positions[extreme[p][a]][a]) extreme[p][a] = v;
          if (first || x[a] > positions[extreme[p][3 + a]][a]) extreme[p][3 + a] = v;
        }
        box[p].min = first ? x : box[p].min.cwiseMin(x);
        box[p].max = first ? x : box[p].max.cwiseMax(x);
        first = false;
      }
  }

  for (std::size_t b = 0; b < np; ++b) {
    if (!piece_closed[b]) continue;
    std::vector<std::size_t> candidates;
    for (std::size_t a = 0; a < np; ++a)
      if (a != b && piece_closed[a] && (box[a].min.array() >= box[b].min.array()).all() &&
          (box[a].max.array() <= box[b].max.array()).all())
        candidates.push_back(a);
    if (candidates.empty()) continue;
    const RayParity container(positions, faces,
                              std::span<const std::int32_t>(piece_faces.data() + offsets[b],
                                                            piece_faces.data() + offsets[b + 1]));
    for (auto a : candidates) {
      bool all_inside = true;
      for (auto v : extreme[a])
        if (!container.inside(positions[v])) {
          all_inside = false;
          break;
        }
      depth[a] += all_inside;
    }
  }
  return depth;
}

}  // namespace fabrica::io::detail
