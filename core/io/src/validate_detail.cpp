#include "validate_detail.hpp"

#include <algorithm>
#include <numeric>

namespace fabrica::io::detail {

namespace {

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

}  // namespace fabrica::io::detail
