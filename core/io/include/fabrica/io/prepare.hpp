// One entry for the mesh preparation every drawing command needs (issue 16):
// read the file (STL welding happens in the reader), then make the mesh fit
// for lines with io::prepare_for_lines (weld exact duplicates, orient
// consistently and outward). `fabrica lines`, `render`, `hatch` and
// `geometry`, the viewer, the batch runner and the Python module all prepare
// meshes through this, so they see the same mesh.
//
// Vertex order promise: as io::read_mesh and io::prepare_for_lines (vertex i
// of the file is vertex i of the prepared mesh; no face is removed).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/topology.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"

namespace fabrica {

// PrepareOptions (space, orient) is declared in fabrica/io/repair.hpp.

struct PreparedMesh {
  TriangleMesh mesh;
  io::MeshFileInfo info;    ///< what the reader found
  io::RepairReport repair;  ///< what the preparation changed (empty without `orient`)
  /// Topology(mesh) of `mesh` as prepared, the one the preparation built
  /// (io::prepare_for_lines with a topology_out: nullopt for a mesh with a
  /// face with a repeated vertex, or welded with `orient` off). to_surface
  /// hands it to the Surface, which then does not build it again. Reset it
  /// if you change `mesh`.
  std::optional<Topology> topology;
  /// One-line notes for the user, in the order the CLI prints them: the
  /// preparation's changes, then STL welding.
  std::vector<std::string> messages() const;
};

/// Reads `path` and prepares it. Throws InputError naming the file.
PreparedMesh prepare_mesh(const std::filesystem::path& path, const PrepareOptions& options = {});

/// Prepares a mesh already in memory (from arrays, another library...).
/// Throws InputError (naming `what`) for bad indices or non-finite values.
PreparedMesh prepare_mesh(TriangleMesh mesh, const PrepareOptions& options = {},
                          const std::string& what = "mesh");

/// The prepared mesh as a Surface: Surface(mesh, topology, options) when the
/// preparation kept its topology, else Surface(mesh, options); the same
/// Surface either way (bit-identical results). Takes the mesh and the
/// topology out of `prepared` (its info and repair report stay).
Surface to_surface(PreparedMesh&& prepared, const SurfaceOptions& options = {});

}  // namespace fabrica
