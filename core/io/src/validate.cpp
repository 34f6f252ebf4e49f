#include "fabrica/io/validate.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "fabrica/core/error.hpp"
#include "fabrica/io/repair.hpp"
#include "validate_detail.hpp"

namespace fabrica::io {

namespace {

constexpr std::size_t kGrain = 4096;

using detail::find_root;
using detail::plural;
using detail::unite;

std::string edge_name(const Topology& topology, std::size_t e) {
  const auto& ed = topology.edge(e);
  return "the edge between vertices " + std::to_string(ed[0]) + " and " + std::to_string(ed[1]);
}

void add_self_intersections(const TriangleMesh& mesh, const detail::ProperTopology& proper,
                            ValidationReport& r) {
  if (r.nonmanifold_edges > 0) {
    r.self_intersections_skipped =
        "self-intersections not checked: CGAL's surface mesh cannot hold the " +
        plural(r.nonmanifold_edges, "non-manifold edge", "non-manifold edges");
    return;
  }
  if (proper.repeated_index_faces() > 0) {
    r.self_intersections_skipped =
        "self-intersections not checked: " +
        plural(proper.repeated_index_faces(), "face has", "faces have") +
        " a repeated vertex; repair the mesh first (fabrica info --repair)";
    return;
  }
  // CGAL needs a consistently oriented halfedge mesh: orient and split
  // pinch vertices on a copy (faces keep their order; pinch points touching
  // then count as intersections, which they geometrically are).
  TriangleMesh copy = mesh;
  RepairOptions ro;
  ro.weld = false;
  ro.remove_degenerate = false;
  ro.remove_duplicates = false;
  ro.outward = false;
  ro.split_nonmanifold_edges = false;
  const RepairReport rr = repair_mesh(copy, ro);
  if (rr.nonorientable_pieces > 0) {
    r.self_intersections_skipped =
        "self-intersections not checked: the surface is not orientable (" +
        plural(rr.nonorientable_pieces, "piece", "pieces") +
        "), which CGAL's surface mesh cannot hold";
    return;
  }
  std::string why_not;
  r.self_intersecting_face_pairs = detail::count_self_intersecting_face_pairs(copy, why_not);
  if (!r.self_intersecting_face_pairs) r.self_intersections_skipped = why_not;
}

}  // namespace

ValidationReport validate_mesh(const TriangleMesh& mesh, const ValidateOptions& options) {
  check_mesh_indices_and_values(mesh, "mesh");
  ValidationReport r;
  r.vertices = mesh.vertex_count();
  r.faces = mesh.face_count();
  r.bbox = bounding_box(mesh.positions);

  const detail::ProperTopology proper(mesh);
  const Topology& topo = proper.topology();
  const std::vector<Face>& faces = proper.faces();
  const std::vector<Vec3>& pos = mesh.positions;
  const std::size_t nv = pos.size();
  const std::size_t nf = faces.size();
  const std::size_t ne = topo.edge_count();

  // Edges: boundary, non-manifold, orientation consistency (classified in
  // parallel, counted in order).
  enum : std::uint8_t { kInterior, kBoundary, kNonmanifold, kInconsistent, kIsolated };
  r.edges = ne;
  std::vector<std::uint8_t> edge_class(ne);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ne, kGrain), [&](const auto& range) {
    for (std::size_t e = range.begin(); e < range.end(); ++e) {
      const auto ef = topo.edge_faces(e);
      std::uint8_t c = kIsolated;
      if (ef.size() == 1) {
        c = kBoundary;
      } else if (ef.size() > 2) {
        c = kNonmanifold;
      } else if (ef.size() == 2) {
        const auto ei = static_cast<std::int32_t>(e);
        const int k0 = detail::corner_opposite(topo, ef[0], ei);
        const int k1 = detail::corner_opposite(topo, ef[1], ei);
        c = detail::edge_start(faces[ef[0]], k0) == detail::edge_start(faces[ef[1]], k1)
                ? kInconsistent
                : kInterior;
      }
      edge_class[e] = c;
    }
  });
  std::int64_t first_nonmanifold_edge = -1, first_inconsistent_edge = -1;
  for (std::size_t e = 0; e < ne; ++e) {
    if (edge_class[e] == kBoundary) {
      ++r.boundary_edges;
    } else if (edge_class[e] == kNonmanifold) {
      if (r.nonmanifold_edges++ == 0) first_nonmanifold_edge = static_cast<std::int64_t>(e);
    } else if (edge_class[e] == kInconsistent) {
      if (r.inconsistent_edges++ == 0) first_inconsistent_edge = static_cast<std::int64_t>(e);
    }
  }
  r.consistently_oriented = r.inconsistent_edges == 0;
  r.mean_edge_length = detail::mean_edge_length(topo, pos);

  // Areas, volume, degenerate faces: partial sums over fixed chunks, added
  // in chunk order, so the bits do not depend on the thread count.
  const double zero_area =
      detail::kDegenerateAreaFraction * r.mean_edge_length * r.mean_edge_length;
  const Vec3 origin = r.bbox.center();
  std::int64_t first_degenerate = -1;
  for (std::size_t f = 0; f < mesh.faces.size() && first_degenerate < 0; ++f)
    if (detail::has_repeated_index(mesh.faces[f])) first_degenerate = static_cast<std::int64_t>(f);
  r.degenerate_faces = proper.repeated_index_faces();
  const std::size_t chunks = (nf + kGrain - 1) / kGrain;
  std::vector<double> chunk_area(chunks, 0.0), chunk_volume6(chunks, 0.0);
  std::vector<std::uint8_t> zero_area_face(nf, 0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t chunk) {
    double area = 0.0, volume6 = 0.0;
    for (std::size_t f = chunk * kGrain; f < std::min(nf, (chunk + 1) * kGrain); ++f) {
      const Vec3& a = pos[faces[f][0]];
      const Vec3& b = pos[faces[f][1]];
      const Vec3& c = pos[faces[f][2]];
      const double face_area = 0.5 * (b - a).cross(c - a).norm();
      area += face_area;
      volume6 += detail::signed_volume6(a, b, c, origin);
      zero_area_face[f] = face_area <= zero_area;
    }
    chunk_area[chunk] = area;
    chunk_volume6[chunk] = volume6;
  });
  double area = 0.0, volume6 = 0.0;
  for (std::size_t c = 0; c < chunks; ++c) {
    area += chunk_area[c];
    volume6 += chunk_volume6[c];
  }
  for (std::size_t f = 0; f < nf; ++f)
    if (zero_area_face[f]) {
      ++r.degenerate_faces;
      const std::int64_t of = proper.original_face(f);
      if (first_degenerate < 0 || of < first_degenerate) first_degenerate = of;
    }
  r.area = area;
  r.signed_volume = volume6 / 6.0;

  // Duplicates: a duplicate shares its first edge with the earlier face.
  std::int64_t first_duplicate = -1, duplicated_face = -1;
  for (std::size_t f = 0; f < nf; ++f) {
    for (auto g : topo.edge_faces(topo.face_edge(f, 0))) {
      if (static_cast<std::size_t>(g) >= f) break;
      if (detail::same_vertex_set(faces[f], faces[g])) {
        if (r.duplicate_faces++ == 0) {
          first_duplicate = proper.original_face(f);
          duplicated_face = proper.original_face(g);
        }
        break;
      }
    }
  }

  // Unreferenced vertices and vertex-connected components (all faces count).
  std::vector<std::uint8_t> referenced(nv, 0), properly_referenced(nv, 0);
  std::vector<std::int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  for (const Face& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) referenced[f[k]] = 1;
    unite(parent, f[0], f[1]);
    unite(parent, f[0], f[2]);
  }
  for (const Face& f : faces)
    for (int k = 0; k < 3; ++k) properly_referenced[f[k]] = 1;
  std::size_t proper_vertices = 0;
  std::int64_t first_unreferenced = -1;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!referenced[v]) {
      if (r.unreferenced_vertices++ == 0) first_unreferenced = static_cast<std::int64_t>(v);
    } else if (find_root(parent, static_cast<std::int32_t>(v)) == static_cast<std::int32_t>(v)) {
      ++r.components;
    }
    proper_vertices += properly_referenced[v];
  }
  r.euler_characteristic = static_cast<long long>(proper_vertices) - static_cast<long long>(ne) +
                           static_cast<long long>(nf);

  // Fans: non-manifold vertices (in parallel); then boundary edges paired
  // through their fan at each boundary vertex.
  std::vector<std::uint8_t> several_fans(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, kGrain), [&](const auto& range) {
    std::vector<int> fan_of_entry;
    for (std::size_t v = range.begin(); v < range.end(); ++v)
      several_fans[v] = detail::vertex_fans(topo, v, fan_of_entry) > 1;
  });
  std::int64_t first_nonmanifold_vertex = -1;
  for (std::size_t v = 0; v < nv; ++v)
    if (several_fans[v])
      if (r.nonmanifold_vertices++ == 0) first_nonmanifold_vertex = static_cast<std::int64_t>(v);
  std::vector<std::int32_t> loop_parent;
  if (r.boundary_edges > 0) {
    loop_parent.resize(ne);
    std::iota(loop_parent.begin(), loop_parent.end(), 0);
  }
  std::vector<int> fan_of_entry;
  std::vector<std::pair<int, std::int32_t>> boundary_at_v;  // (fan, edge)
  for (std::size_t v = 0; v < nv && r.boundary_edges > 0; ++v) {
    if (!topo.is_boundary_vertex(v)) continue;
    const auto vf = topo.vertex_faces(v);
    detail::vertex_fans(topo, v, fan_of_entry);
    boundary_at_v.clear();
    for (std::size_t i = 0; i < topo.vertex_neighbors(v).size(); ++i) {
      const std::int32_t e = topo.vertex_edge(v, i);
      const auto ef = topo.edge_faces(static_cast<std::size_t>(e));
      if (ef.size() != 1) continue;
      const auto it = std::lower_bound(vf.begin(), vf.end(), ef[0]);
      boundary_at_v.emplace_back(fan_of_entry[it - vf.begin()], e);
    }
    std::sort(boundary_at_v.begin(), boundary_at_v.end());
    for (std::size_t i = 0; i < boundary_at_v.size();) {
      std::size_t j = i;
      while (j < boundary_at_v.size() && boundary_at_v[j].first == boundary_at_v[i].first) ++j;
      if (j - i == 2) unite(loop_parent, boundary_at_v[i].second, boundary_at_v[i + 1].second);
      i = j;
    }
  }
  for (std::size_t e = 0; e < ne; ++e)
    if (topo.is_boundary_edge(e) &&
        find_root(loop_parent, static_cast<std::int32_t>(e)) == static_cast<std::int32_t>(e))
      ++r.boundary_loops;

  // Closed and outward.
  r.closed = nf > 0 && r.boundary_edges == 0;
  if (r.closed && r.consistently_oriented && r.nonmanifold_edges == 0) {
    std::size_t pieces = 0;
    const auto piece = detail::manifold_pieces(topo, pieces);
    std::vector<double> piece_volume6(pieces, 0.0);
    for (std::size_t f = 0; f < nf; ++f)
      piece_volume6[piece[f]] +=
          detail::signed_volume6(pos[faces[f][0]], pos[faces[f][1]], pos[faces[f][2]], origin);
    std::vector<std::uint8_t> closed_piece(pieces, 1);  // as in repair: flat pieces have no side
    for (std::size_t p = 0; p < pieces; ++p) closed_piece[p] = piece_volume6[p] != 0.0;
    const auto depth = detail::nesting_depths(pos, faces, piece, closed_piece);
    for (std::size_t p = 0; p < pieces; ++p)
      if (piece_volume6[p] != 0.0 && (piece_volume6[p] > 0.0) != (depth[p] % 2 == 0))
        ++r.inward_pieces;
    r.outward = r.inward_pieces == 0;
  } else if (!r.closed && nf > 0 && r.consistently_oriented && r.nonmanifold_edges == 0) {
    // Open pieces face outward when their volume with the boundary loops
    // capped is positive (as repair and prepare_for_lines orient them).
    std::size_t pieces = 0;
    const auto piece = detail::manifold_pieces(topo, pieces);
    for (const auto& c : detail::capped_piece_volumes(topo, pos, faces, piece, pieces))
      if (c.loops > 0 && !c.ambiguous() && c.volume6 < 0.0) ++r.inward_open_pieces;
  }

  if (options.self_intersections) add_self_intersections(mesh, proper, r);

  // One line per kind of defect, naming the first example.
  if (r.degenerate_faces > 0)
    r.problems.push_back(plural(r.degenerate_faces, "degenerate face", "degenerate faces") +
                         " (repeated vertex or zero area), e.g. face " +
                         std::to_string(first_degenerate));
  if (r.duplicate_faces > 0)
    r.problems.push_back(plural(r.duplicate_faces, "duplicate face", "duplicate faces") +
                         " (same vertices as an earlier face), e.g. face " +
                         std::to_string(first_duplicate) + " repeats face " +
                         std::to_string(duplicated_face));
  if (r.nonmanifold_edges > 0)
    r.problems.push_back(plural(r.nonmanifold_edges, "non-manifold edge", "non-manifold edges") +
                         " (three or more faces), e.g. " +
                         edge_name(topo, static_cast<std::size_t>(first_nonmanifold_edge)));
  if (r.nonmanifold_vertices > 0)
    r.problems.push_back(
        plural(r.nonmanifold_vertices, "non-manifold vertex", "non-manifold vertices") +
        " (faces around it form several fans: bow-tie or pinch), e.g. vertex " +
        std::to_string(first_nonmanifold_vertex));
  if (r.inconsistent_edges > 0)
    r.problems.push_back(
        "inconsistent orientation: " + plural(r.inconsistent_edges, "edge is", "edges are") +
        " used in the same direction by both faces, e.g. " +
        edge_name(topo, static_cast<std::size_t>(first_inconsistent_edge)));
  if (r.outward && !*r.outward)
    r.problems.push_back("normals point inward: " +
                         plural(r.inward_pieces, "closed piece faces", "closed pieces face") +
                         " into the solid (lines and shading expect outward normals)");
  if (r.inward_open_pieces > 0)
    r.problems.push_back(
        "normals point inward: " +
        plural(r.inward_open_pieces, "open piece faces", "open pieces face") +
        " inward (its signed volume with the boundary loops capped is negative; lines and "
        "shading expect outward normals: fabrica info --repair turns it)");
  if (r.self_intersecting_face_pairs && *r.self_intersecting_face_pairs > 0)
    r.problems.push_back(plural(*r.self_intersecting_face_pairs, "pair", "pairs") +
                         " of faces intersect each other");

  if (nf == 0) r.notes.push_back("no faces with three distinct vertices");
  if (r.boundary_edges > 0)
    r.notes.push_back(
        "open surface: " + plural(r.boundary_edges, "boundary edge", "boundary edges") + " in " +
        plural(r.boundary_loops, "loop", "loops"));
  if (r.components > 1) r.notes.push_back(std::to_string(r.components) + " separate components");
  if (r.unreferenced_vertices > 0)
    r.notes.push_back(
        plural(r.unreferenced_vertices, "unreferenced vertex", "unreferenced vertices") +
        " (used by no face; kept so vertex numbers match the file), e.g. vertex " +
        std::to_string(first_unreferenced));
  if (!r.self_intersections_skipped.empty()) r.notes.push_back(r.self_intersections_skipped);
  return r;
}

nlohmann::json to_json(const ValidationReport& r) {
  nlohmann::json j;
  j["vertices"] = r.vertices;
  j["faces"] = r.faces;
  j["edges"] = r.edges;
  j["components"] = r.components;
  j["boundary_loops"] = r.boundary_loops;
  j["boundary_edges"] = r.boundary_edges;
  j["nonmanifold_edges"] = r.nonmanifold_edges;
  j["nonmanifold_vertices"] = r.nonmanifold_vertices;
  j["degenerate_faces"] = r.degenerate_faces;
  j["duplicate_faces"] = r.duplicate_faces;
  j["unreferenced_vertices"] = r.unreferenced_vertices;
  j["inconsistent_edges"] = r.inconsistent_edges;
  j["euler_characteristic"] = r.euler_characteristic;
  j["consistently_oriented"] = r.consistently_oriented;
  j["closed"] = r.closed;
  j["outward"] = r.outward ? nlohmann::json(*r.outward) : nlohmann::json(nullptr);
  j["inward_pieces"] = r.inward_pieces;
  j["inward_open_pieces"] = r.inward_open_pieces;
  j["signed_volume"] = r.signed_volume;
  j["area"] = r.area;
  j["mean_edge_length"] = r.mean_edge_length;
  j["bbox"] = {{"min", {r.bbox.min.x(), r.bbox.min.y(), r.bbox.min.z()}},
               {"max", {r.bbox.max.x(), r.bbox.max.y(), r.bbox.max.z()}}};
  j["self_intersecting_face_pairs"] = r.self_intersecting_face_pairs
                                          ? nlohmann::json(*r.self_intersecting_face_pairs)
                                          : nlohmann::json(nullptr);
  if (!r.self_intersections_skipped.empty())
    j["self_intersections_skipped"] = r.self_intersections_skipped;
  j["clean"] = r.clean();
  j["problems"] = r.problems;
  j["notes"] = r.notes;
  return j;
}

}  // namespace fabrica::io
