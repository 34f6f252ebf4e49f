// Mesh repair: the hygiene steps of docs/algorithms.md §1 that keep the file's
// vertex numbering.
//
// Vertex order promise: vertex i before repair is vertex i after repair.
// Welding maps a vertex to its first occurrence and leaves the later copy in
// place, unreferenced; splitting a non-manifold vertex APPENDS one vertex per
// extra fan. Faces keep their relative order; removed faces are dropped
// (RepairReport::face_origin maps new face -> old face), flipped faces become
// (a, c, b) so corner 0 keeps its vertex.
//
// Steps, in order (each can be switched off in RepairOptions):
//  1. weld vertices at identical positions (or within weld_tolerance) to close
//     cracks: only vertices on boundary edges, and never where the merge would
//     create a non-manifold edge or vertex (so a repaired mesh stays repaired,
//     and repair is idempotent);
//  2. remove degenerate faces (repeated vertex, or zero area relative to the
//     mean edge length^2, as in validate.hpp);
//  3. remove duplicate faces (same vertex set as an earlier face);
//  4. split non-manifold vertices: each fan after the first gets a new vertex;
//     cutting non-manifold edges does the same with fans joined only through
//     two-face edges, so every sheet meeting at such an edge gets its own copy
//     of the edge (it becomes boundary);
//  5. orient consistently: breadth-first over faces through edges with exactly
//     two faces, flipping neighbours that disagree; an open piece keeps the
//     orientation of the majority of its faces;
//  6. outward: every closed edge-connected piece whose normals point into the
//     solid is reversed: a piece should enclose positive signed volume, except
//     a cavity wall (nested inside an odd number of other closed pieces, by
//     ray parity of its extreme vertices), which should enclose negative.
//     Every open piece is reversed when its signed volume with each boundary
//     loop capped virtually (a fan to the loop's centroid) is negative; a
//     (nearly) flat sheet, whose capped volume is below 1e-3 area^1.5, has no
//     inside and keeps the orientation of the majority of its faces.
// With split_nonmanifold_edges off, non-manifold edges stay (the orientation
// walk does not cross them) and validate_mesh keeps reporting them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/topology.hpp"

namespace fabrica {

/// How a mesh is prepared for drawing: by prepare_mesh (fabrica/io/prepare.hpp),
/// which every drawing command, the viewer, the batch runner and the Python
/// module use, and by io::prepare_for_lines below.
struct PrepareOptions {
  /// Coordinate space overriding the file's tag (`--space lps|ras`); used
  /// when reading (prepare_mesh), not by io::prepare_for_lines.
  std::optional<Space> space;
  /// Orient consistently and outward (`--keep-orientation` turns it off).
  /// With `orient` off, prepare_mesh and io::prepare_for_lines only weld
  /// exact duplicates (docs/validation.md); `fabrica geometry`, which reports
  /// the file as stored, reads with io::read_mesh instead.
  bool orient = true;
};

}  // namespace fabrica

namespace fabrica::io {

struct RepairOptions {
  bool weld = true;
  /// 0: weld only bit-identical positions. > 0: weld points closer than this
  /// (mesh units) to an earlier kept point.
  double weld_tolerance = 0.0;
  bool remove_degenerate = true;
  bool remove_duplicates = true;
  bool orient = true;
  bool outward = true;  ///< only with orient
  bool split_nonmanifold_vertices = true;
  /// Cut the sheets meeting at an edge with three or more faces apart
  /// (appends vertices; the cut edges become boundary edges).
  bool split_nonmanifold_edges = true;
};

struct RepairReport {
  std::size_t welded_vertices = 0;  ///< referenced vertices merged into an earlier one
  std::size_t removed_degenerate_faces = 0;
  std::size_t removed_duplicate_faces = 0;
  std::size_t flipped_faces = 0;        ///< faces whose orientation changed (net)
  std::size_t components_reversed = 0;  ///< closed pieces turned outward
  /// Open pieces turned outward (their file orientation, the majority of
  /// their faces, pointed inward by the capped-volume rule of step 6).
  std::size_t open_pieces_reversed = 0;
  std::size_t open_piece_loops = 0;  ///< boundary loops capped on those pieces
  std::size_t split_nonmanifold_vertices =
      0;                                  ///< vertices appended by splitting (vertices and edges)
  std::size_t cut_nonmanifold_edges = 0;  ///< non-manifold edges that were cut apart
  std::size_t nonorientable_pieces = 0;   ///< pieces where no consistent orientation exists
  /// For each face of the repaired mesh, the index of the face it came from.
  std::vector<std::int32_t> face_origin;
  /// Human-readable one-liners; empty when nothing changed.
  std::vector<std::string> changes;
  /// What could not be repaired (a non-orientable piece keeps one seam).
  std::vector<std::string> warnings;

  bool changed() const { return !changes.empty(); }
};

/// Repairs `mesh` in place (see the steps above). Deterministic, O(V + F log F).
/// Throws InputError when a face index is out of range or a coordinate is not
/// finite.
RepairReport repair_mesh(TriangleMesh& mesh, const RepairOptions& options = {});
/// repair_mesh, also handing over the adjacency its steps built when it
/// still describes the repaired mesh: `topology_out` is then Topology(mesh)
/// of the mesh as returned, bit for bit (for Surface(mesh, topology), which
/// then does not build it again). The orientation step turns faces in the
/// topology too (Topology::reverse_face); the other steps that change the
/// faces (weld, removal, split) build it again for the next step, and when
/// none follows, or the mesh has a face with a repeated vertex (the steps'
/// topology leaves those out), `topology_out` is nullopt. Set on return in
/// every case; reset when this throws.
RepairReport repair_mesh(TriangleMesh& mesh, const RepairOptions& options,
                         std::optional<Topology>& topology_out);

/// The former io::PrepareOptions (`keep_orientation = true` is now
/// `orient = false`); the one options type is fabrica::PrepareOptions below.
using PrepareOptions = fabrica::PrepareOptions;

/// What the line engine needs by default: weld exact duplicates, orient
/// consistently and outward per piece, closed or open (step 6); with
/// `options.orient` false it only welds (the file's orientation is kept).
/// `options.space` is not used here (it is a reading option). Removes no
/// face and adds no vertex, so face f stays face f and vertex i stays vertex
/// i. The report's `changes` say what was flipped and why.
RepairReport prepare_for_lines(TriangleMesh& mesh, const fabrica::PrepareOptions& options = {});
/// prepare_for_lines, handing over the Topology it built, as repair_mesh
/// above: Topology(mesh) of the prepared mesh, kept through the faces the
/// orientation turns (and built again after a weld); nullopt when the mesh
/// has a face with a repeated vertex, or when a weld changed it with
/// `orient` off. Then `Surface(std::move(mesh), std::move(*topology_out))`
/// does not build it a second time.
RepairReport prepare_for_lines(TriangleMesh& mesh, const fabrica::PrepareOptions& options,
                               std::optional<Topology>& topology_out);

/// The report as a JSON object (without face_origin).
nlohmann::json to_json(const RepairReport& report);

}  // namespace fabrica::io
