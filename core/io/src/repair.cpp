#include "fabrica/io/repair.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>
#include <string>

#include "fabrica/core/error.hpp"
#include "validate_detail.hpp"

namespace fabrica::io {

namespace {

using detail::plural;

// Representative (first occurrence) of every vertex: bit-equal positions.
std::vector<std::int32_t> exact_representatives(const std::vector<Vec3>& pos) {
  std::vector<std::int32_t> order(pos.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
    const Vec3& p = pos[a];
    const Vec3& q = pos[b];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    if (p.z() != q.z()) return p.z() < q.z();
    return a < b;
  });
  std::vector<std::int32_t> rep(pos.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j < order.size() && pos[order[j]] == pos[order[i]]) rep[order[j++]] = order[i];
    i = j;
  }
  return rep;
}

// Representative within `tolerance` of an earlier kept point (lowest index).
std::vector<std::int32_t> tolerance_representatives(const std::vector<Vec3>& pos,
                                                    double tolerance) {
  const BoundingBox box = bounding_box(pos);
  const double extent = (box.max - box.min).cwiseAbs().maxCoeff();
  if (!(tolerance > 0.0) || !std::isfinite(tolerance) || extent / tolerance > 1e15)
    throw InputError("weld tolerance " + std::to_string(tolerance) +
                     " is not a positive number large enough for a mesh of extent " +
                     std::to_string(extent));
  using Cell = std::array<std::int64_t, 3>;
  auto cell_of = [&](const Vec3& p) {
    return Cell{static_cast<std::int64_t>(std::floor((p.x() - box.min.x()) / tolerance)),
                static_cast<std::int64_t>(std::floor((p.y() - box.min.y()) / tolerance)),
                static_cast<std::int64_t>(std::floor((p.z() - box.min.z()) / tolerance))};
  };
  std::map<Cell, std::vector<std::int32_t>> grid;  // ordered: deterministic, no hash tuning
  std::vector<std::int32_t> rep(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i) {
    const Cell c = cell_of(pos[i]);
    std::int32_t best = -1;
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(Cell{c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == grid.end()) continue;
          for (auto j : it->second)
            if ((pos[j] - pos[i]).norm() <= tolerance && (best < 0 || j < best)) best = j;
        }
    if (best < 0) {
      best = static_cast<std::int32_t>(i);
      grid[c].push_back(best);
    }
    rep[i] = best;
  }
  return rep;
}

// Welds coincident vertices that close cracks: only vertices on boundary
// edges are merged, into the first such vertex at that position, and a merge
// is undone when it would create a non-manifold edge or vertex (so copies
// made by splitting stay split and repair is idempotent).
std::size_t weld(TriangleMesh& mesh, const detail::ProperTopology& before, double tolerance) {
  const std::size_t nv = mesh.positions.size();
  std::vector<std::int32_t> rep(nv);
  std::iota(rep.begin(), rep.end(), 0);
  {
    std::vector<std::int32_t> candidates;
    for (std::size_t v = 0; v < nv; ++v)
      if (before.topology().is_boundary_vertex(v))
        candidates.push_back(static_cast<std::int32_t>(v));
    if (candidates.size() < 2) return 0;
    std::vector<Vec3> points(candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) points[i] = mesh.positions[candidates[i]];
    const auto local = tolerance > 0.0 ? tolerance_representatives(points, tolerance)
                                       : exact_representatives(points);
    for (std::size_t i = 0; i < candidates.size(); ++i) rep[candidates[i]] = candidates[local[i]];
  }
  std::vector<std::uint8_t> is_target(nv, 0);
  bool any = false;
  for (std::size_t v = 0; v < nv; ++v)
    if (rep[v] != static_cast<std::int32_t>(v)) is_target[rep[v]] = any = true;
  if (!any) return 0;

  // Undo merges whose result is non-manifold; undoing one merge can expose
  // another (two merges that only together made a fan), so repeat until none.
  for (bool reverted = true; reverted && any;) {
    TriangleMesh welded;
    welded.positions.resize(nv, Vec3::Zero());  // the adjacency only needs the count
    welded.faces = mesh.faces;
    for (Face& f : welded.faces)
      for (auto& v : f) v = rep[v];
    const detail::ProperTopology after(welded);
    const Topology& topo = after.topology();
    std::vector<std::uint8_t> revert(nv, 0);
    for (std::size_t e = 0; e < topo.edge_count(); ++e)
      if (topo.is_nonmanifold_edge(e)) {
        const auto& ends = topo.edge(e);
        if (is_target[ends[0]] || is_target[ends[1]]) revert[ends[0]] = revert[ends[1]] = 1;
      }
    std::vector<int> fan_of_entry;
    for (std::size_t v = 0; v < nv; ++v)
      if (is_target[v] && detail::vertex_fans(topo, v, fan_of_entry) > 1) revert[v] = 1;
    reverted = false;
    for (std::size_t v = 0; v < nv; ++v)
      if (revert[rep[v]] && rep[v] != static_cast<std::int32_t>(v)) {
        rep[v] = static_cast<std::int32_t>(v);
        reverted = true;
      }
    std::fill(is_target.begin(), is_target.end(), 0);
    any = false;
    for (std::size_t v = 0; v < nv; ++v)
      if (rep[v] != static_cast<std::int32_t>(v)) is_target[rep[v]] = any = true;
  }
  if (!any) return 0;

  std::vector<std::uint8_t> moved(nv, 0);
  for (Face& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
      if (rep[f[k]] != f[k]) {
        moved[f[k]] = 1;
        f[k] = rep[f[k]];
      }
  return static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
}

// Removes degenerate and/or duplicate faces, keeping the order of the rest.
// Returns whether any face was removed.
bool remove_faces(TriangleMesh& mesh, const detail::ProperTopology& proper, const RepairOptions& o,
                  RepairReport& report) {
  const Topology& topo = proper.topology();
  const auto& faces = proper.faces();
  const auto& pos = mesh.positions;
  const double mean = detail::mean_edge_length(topo, pos);
  const double zero_area = detail::kDegenerateAreaFraction * mean * mean;

  std::vector<std::uint8_t> remove(mesh.faces.size(), 0);
  if (o.remove_degenerate) {
    for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
      const Face& t = mesh.faces[f];
      if (detail::has_repeated_index(t) ||
          0.5 * (pos[t[1]] - pos[t[0]]).cross(pos[t[2]] - pos[t[0]]).norm() <= zero_area) {
        remove[f] = 1;
        ++report.removed_degenerate_faces;
      }
    }
  }
  if (o.remove_duplicates) {
    for (std::size_t f = 0; f < faces.size(); ++f) {
      if (remove[proper.original_face(f)]) continue;
      for (auto g : topo.edge_faces(topo.face_edge(f, 0))) {
        if (static_cast<std::size_t>(g) >= f) break;
        if (!remove[proper.original_face(g)] && detail::same_vertex_set(faces[f], faces[g])) {
          remove[proper.original_face(f)] = 1;
          ++report.removed_duplicate_faces;
          break;
        }
      }
    }
  }
  if (report.removed_degenerate_faces + report.removed_duplicate_faces == 0) return false;
  std::size_t out = 0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    if (!remove[f]) {
      mesh.faces[out] = mesh.faces[f];
      report.face_origin[out] = report.face_origin[f];
      ++out;
    }
  mesh.faces.resize(out);
  report.face_origin.resize(out);
  return true;
}

// Every fan of a vertex after the first (by lowest face) gets a new vertex.
// With cut_edges, fans are joined only through two-face edges, which also
// separates the sheets meeting at a non-manifold edge.
std::size_t split_vertices(TriangleMesh& mesh, const detail::ProperTopology& proper,
                           bool split_pinches, bool cut_edges, RepairReport& report) {
  const Topology& topo = proper.topology();
  const std::size_t nv = mesh.positions.size();
  std::vector<std::uint8_t> on_nonmanifold_edge(nv, 0);
  for (std::size_t e = 0; cut_edges && e < topo.edge_count(); ++e)
    if (topo.is_nonmanifold_edge(e)) {
      ++report.cut_nonmanifold_edges;
      on_nonmanifold_edge[topo.edge(e)[0]] = on_nonmanifold_edge[topo.edge(e)[1]] = 1;
    }
  std::vector<int> fan_of_entry;
  std::size_t split_vertices = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    const auto vf = topo.vertex_faces(v);
    if (vf.size() < 2) continue;
    const bool by_manifold_edges = cut_edges && on_nonmanifold_edge[v];
    if (!split_pinches && !by_manifold_edges) continue;
    const int fans = detail::vertex_fans(topo, v, fan_of_entry, by_manifold_edges);
    if (fans < 2) continue;
    ++split_vertices;
    const auto corners = topo.vertex_face_corners(v);
    const Vec3 p = mesh.positions[v];
    for (int fan = 1; fan < fans; ++fan) {
      const auto added = static_cast<std::int32_t>(mesh.positions.size());
      mesh.positions.push_back(p);
      for (std::size_t i = 0; i < vf.size(); ++i)
        if (fan_of_entry[i] == fan) mesh.faces[proper.original_face(vf[i])][corners[i]] = added;
    }
  }
  report.split_nonmanifold_vertices = mesh.positions.size() - nv;
  return split_vertices;
}

// Consistent orientation by breadth-first search through two-face edges;
// then each closed piece faces out of the solid (positive volume, negative
// for a cavity wall nested inside an odd number of other closed pieces), and
// every other piece keeps the orientation of the majority of its faces.
// The topology follows the faces turned (`proper` describes the mesh after).
void orient(TriangleMesh& mesh, detail::ProperTopology& proper, bool outward,
            RepairReport& report) {
  const Topology& topo = proper.topology();
  const auto& faces = proper.faces();
  const std::size_t nf = faces.size();
  const Vec3 origin = bounding_box(mesh.positions).center();

  struct PieceState {
    std::size_t begin = 0, end = 0;  // range in `order`
    bool conflict = false, open = false;
    std::size_t flipped = 0;
    double volume6 = 0.0;
  };
  std::vector<PieceState> pieces;
  std::vector<std::int32_t> piece(nf, -1);
  std::vector<std::uint8_t> flip(nf, 0);
  std::vector<std::int32_t> order;  // faces in breadth-first order, piece by piece
  order.reserve(nf);
  for (std::size_t seed = 0; seed < nf; ++seed) {
    if (piece[seed] >= 0) continue;
    const auto id = static_cast<std::int32_t>(pieces.size());
    PieceState state;
    state.begin = order.size();
    order.push_back(static_cast<std::int32_t>(seed));
    piece[seed] = id;
    for (std::size_t head = state.begin; head < order.size(); ++head) {
      const auto f = order[head];
      for (int k = 0; k < 3; ++k) {
        const auto e = topo.face_edge(f, k);
        const auto ef = topo.edge_faces(e);
        if (ef.size() != 2) {
          state.open = true;
          continue;
        }
        const auto g = ef[0] == f ? ef[1] : ef[0];
        const int kg = detail::corner_opposite(topo, g, e);
        const bool same = detail::edge_start(faces[f], k) == detail::edge_start(faces[g], kg);
        const std::uint8_t want = flip[f] ^ static_cast<std::uint8_t>(same);
        if (piece[g] < 0) {
          piece[g] = id;
          flip[g] = want;
          order.push_back(g);
        } else if (flip[g] != want) {
          state.conflict = true;
        }
      }
    }
    state.end = order.size();
    for (std::size_t i = state.begin; i < state.end; ++i) {
      const auto f = order[i];
      state.flipped += flip[f];
      const double v =
          detail::signed_volume6(mesh.positions[faces[f][0]], mesh.positions[faces[f][1]],
                                 mesh.positions[faces[f][2]], origin);
      state.volume6 += flip[f] ? -v : v;
    }
    if (state.conflict) ++report.nonorientable_pieces;
    pieces.push_back(state);
  }

  std::vector<std::uint8_t> closed(pieces.size(), 0);
  for (std::size_t p = 0; p < pieces.size(); ++p)
    closed[p] = outward && !pieces[p].open && !pieces[p].conflict && pieces[p].volume6 != 0.0;
  const std::vector<int> depth = detail::nesting_depths(mesh.positions, faces, piece, closed);
  // Open pieces: outward when their volume with the boundary loops capped is
  // positive; a (nearly) flat sheet has no side and keeps its majority.
  const bool any_open = std::any_of(pieces.begin(), pieces.end(),
                                    [](const PieceState& s) { return s.open && !s.conflict; });
  const auto capped =
      outward && any_open
          ? detail::capped_piece_volumes(topo, mesh.positions, faces, piece, pieces.size(), &flip)
          : std::vector<detail::CappedVolume>();
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    const PieceState& state = pieces[p];
    const bool majority_flipped = 2 * state.flipped > state.end - state.begin;
    bool reverse = false;
    if (closed[p]) {
      const bool want_positive = depth[p] % 2 == 0;
      reverse = (state.volume6 > 0.0) != want_positive;
      if (reverse) ++report.components_reversed;
    } else if (!capped.empty() && state.open && !state.conflict && !capped[p].ambiguous()) {
      reverse = capped[p].volume6 < 0.0;
      if (reverse != majority_flipped) {
        ++report.open_pieces_reversed;
        report.open_piece_loops += capped[p].loops;
      }
    } else {
      reverse = majority_flipped;
    }
    if (reverse)
      for (std::size_t i = state.begin; i < state.end; ++i) flip[order[i]] ^= 1;
  }
  for (std::size_t f = 0; f < nf; ++f)
    if (flip[f]) {
      const Face before = faces[f];  // (faces may be mesh.faces)
      proper.reverse_face(f, before);
      Face& t = mesh.faces[proper.original_face(f)];
      std::swap(t[1], t[2]);
      ++report.flipped_faces;
    }
}

// repair_mesh; with `topology_out`, also the Topology of the repaired mesh
// when the last one a step built still describes it (else nullopt).
RepairReport run_repair(TriangleMesh& mesh, const RepairOptions& o,
                        std::optional<Topology>* topology_out) {
  if (topology_out) topology_out->reset();
  check_mesh_indices_and_values(mesh, "mesh");
  RepairReport report;
  report.face_origin.resize(mesh.faces.size());
  std::iota(report.face_origin.begin(), report.face_origin.end(), 0);

  // Adjacency is rebuilt only after a step changed the faces: every step
  // that changes the mesh resets it, except the orientation, which updates
  // it for the faces it turns; so when set, it describes the mesh.
  std::optional<detail::ProperTopology> proper;
  auto topology = [&]() -> detail::ProperTopology& {
    if (!proper) proper.emplace(mesh);
    return *proper;
  };
  // Weld and removal alternate until nothing changes: welding reveals
  // duplicates, and removing them can unblock a weld that would have made a
  // non-manifold edge with a face that is now gone.
  for (int round = 0; round < 4; ++round) {
    const std::size_t welded = o.weld ? weld(mesh, topology(), o.weld_tolerance) : 0;
    report.welded_vertices += welded;
    if (welded > 0) proper.reset();
    bool removed = false;
    if (o.remove_degenerate || o.remove_duplicates)
      removed = remove_faces(mesh, topology(), o, report);
    if (removed) proper.reset();
    if (!removed || !o.weld) break;
  }
  if (report.welded_vertices > 0)
    report.changes.push_back(
        "welded " + plural(report.welded_vertices, "vertex", "vertices") +
        (o.weld_tolerance > 0.0 ? " within " + std::to_string(o.weld_tolerance)
                                : std::string(" at identical positions")) +
        " on boundary edges into earlier ones (closing cracks; the copies stay in place, "
        "unreferenced)");
  if (report.removed_degenerate_faces > 0)
    report.changes.push_back(
        "removed " +
        plural(report.removed_degenerate_faces, "degenerate face", "degenerate faces") +
        " (repeated vertex or zero area)");
  if (report.removed_duplicate_faces > 0)
    report.changes.push_back(
        "removed " + plural(report.removed_duplicate_faces, "duplicate face", "duplicate faces"));
  if (o.split_nonmanifold_vertices || o.split_nonmanifold_edges) {
    const std::size_t split = split_vertices(mesh, topology(), o.split_nonmanifold_vertices,
                                             o.split_nonmanifold_edges, report);
    if (split > 0) proper.reset();
    if (report.cut_nonmanifold_edges > 0)
      report.changes.push_back(
          "cut apart the sheets at " +
          plural(report.cut_nonmanifold_edges, "non-manifold edge", "non-manifold edges") +
          " (they become boundary edges)");
    if (split > 0)
      report.changes.push_back(
          "split " + plural(split, "vertex", "vertices") + " joining separate fans (appended " +
          plural(report.split_nonmanifold_vertices, "vertex", "vertices") + " at the end)");
  }
  if (o.orient) {
    orient(mesh, topology(), o.outward, report);
    if (report.flipped_faces > 0) {
      std::string line = "flipped " + plural(report.flipped_faces, "face", "faces");
      if (report.components_reversed > 0)
        line += " (" + plural(report.components_reversed, "closed piece", "closed pieces") +
                " turned outward)";
      if (report.open_pieces_reversed > 0)
        line += " (" + plural(report.open_pieces_reversed, "open piece", "open pieces") +
                " turned outward: the signed volume with its " +
                plural(report.open_piece_loops, "boundary loop", "boundary loops") +
                " capped was negative)";
      report.changes.push_back(line);
    }
    if (report.nonorientable_pieces > 0)
      report.warnings.push_back("could not orient " +
                                plural(report.nonorientable_pieces, "piece", "pieces") +
                                " consistently: the surface is not orientable (Moebius-like)");
  }
  if (topology_out && proper) *topology_out = proper->release_mesh_topology();
  return report;
}

}  // namespace

RepairReport repair_mesh(TriangleMesh& mesh, const RepairOptions& options) {
  return run_repair(mesh, options, nullptr);
}

RepairReport repair_mesh(TriangleMesh& mesh, const RepairOptions& options,
                         std::optional<Topology>& topology_out) {
  return run_repair(mesh, options, &topology_out);
}

namespace {
RepairOptions lines_repair_options(const fabrica::PrepareOptions& options) {
  RepairOptions o;
  o.weld = true;
  o.weld_tolerance = 0.0;
  o.remove_degenerate = false;
  o.remove_duplicates = false;
  o.split_nonmanifold_vertices = false;
  o.split_nonmanifold_edges = false;
  o.orient = options.orient;
  o.outward = options.orient;
  return o;
}
}  // namespace

RepairReport prepare_for_lines(TriangleMesh& mesh, const fabrica::PrepareOptions& options) {
  return run_repair(mesh, lines_repair_options(options), nullptr);
}

RepairReport prepare_for_lines(TriangleMesh& mesh, const fabrica::PrepareOptions& options,
                               std::optional<Topology>& topology_out) {
  return run_repair(mesh, lines_repair_options(options), &topology_out);
}

nlohmann::json to_json(const RepairReport& r) {
  return {{"welded_vertices", r.welded_vertices},
          {"removed_degenerate_faces", r.removed_degenerate_faces},
          {"removed_duplicate_faces", r.removed_duplicate_faces},
          {"flipped_faces", r.flipped_faces},
          {"components_reversed", r.components_reversed},
          {"open_pieces_reversed", r.open_pieces_reversed},
          {"split_nonmanifold_vertices", r.split_nonmanifold_vertices},
          {"cut_nonmanifold_edges", r.cut_nonmanifold_edges},
          {"nonorientable_pieces", r.nonorientable_pieces},
          {"changes", r.changes},
          {"warnings", r.warnings}};
}

}  // namespace fabrica::io
