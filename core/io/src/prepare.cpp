#include "fabrica/io/prepare.hpp"

#include <utility>

#include "fabrica/core/error.hpp"

namespace fabrica {

std::vector<std::string> PreparedMesh::messages() const {
  std::vector<std::string> out = repair.changes;
  if (info.welded_vertices > 0)
    out.push_back("welded " + std::to_string(info.welded_vertices) + " coincident STL vertices");
  return out;
}

namespace {
// Welds exact duplicates always; orients only when options.orient (docs/validation.md).
void prepare(PreparedMesh& prepared, const PrepareOptions& options) {
  prepared.repair = io::prepare_for_lines(prepared.mesh, options, prepared.topology);
}
}  // namespace

Surface to_surface(PreparedMesh&& prepared, const SurfaceOptions& options) {
  std::optional<Topology> topology = std::move(prepared.topology);
  prepared.topology.reset();
  if (topology) return Surface(std::move(prepared.mesh), std::move(*topology), options);
  return Surface(std::move(prepared.mesh), options);
}

PreparedMesh prepare_mesh(const std::filesystem::path& path, const PrepareOptions& options) {
  io::ReadOptions read_options;
  read_options.space = options.space;
  io::LoadedMesh loaded = io::read_mesh(path, read_options);
  PreparedMesh prepared;
  prepared.mesh = std::move(loaded.mesh);
  prepared.info = std::move(loaded.info);
  prepare(prepared, options);
  return prepared;
}

PreparedMesh prepare_mesh(TriangleMesh mesh, const PrepareOptions& options,
                          const std::string& what) {
  check_mesh_indices_and_values(mesh, what);
  if (mesh.empty()) throw InputError(what + ": the mesh has no vertices or no faces");
  PreparedMesh prepared;
  prepared.mesh = std::move(mesh);
  if (options.space) {
    prepared.mesh.space = *options.space;
    prepared.mesh.space_source = SpaceSource::user_override;
  }
  prepared.info.path = what;
  prepare(prepared, options);
  return prepared;
}

}  // namespace fabrica
