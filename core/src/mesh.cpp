#include "fabrica/core/mesh.hpp"

#include <cmath>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica {

const char* to_string(Space space) { return space == Space::ras ? "RAS" : "LPS"; }

const char* to_string(SpaceSource source) {
  switch (source) {
    case SpaceSource::file_tag: return "file tag";
    case SpaceSource::user_override: return "user override";
    case SpaceSource::default_assumed: break;
  }
  return "default (no tag in file)";
}

void check_mesh_indices_and_values(const TriangleMesh& mesh, const std::string& what) {
  const auto nv = static_cast<std::int64_t>(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    if (!mesh.positions[i].allFinite())
      throw InputError(what + ": vertex " + std::to_string(i) +
                       " has a coordinate that is not a finite number (NaN or infinity); fix or remove it");
    else if (mesh.positions[i].cwiseAbs().maxCoeff() > 1e15)  // areas, normals would overflow
      throw InputError(what + ": vertex " + std::to_string(i) +
                       " has a coordinate beyond 1e15 (mm); rescale the mesh");
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (mesh.faces[f][k] < 0 || mesh.faces[f][k] >= nv)
        throw InputError(what + ": face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(mesh.faces[f][k]) + ", but the mesh has only " +
                         std::to_string(nv) + " vertices");
}

BoundingBox bounding_box(const std::vector<Vec3>& positions) {
  BoundingBox box;
  if (positions.empty()) return box;
  box.min = box.max = positions.front();
  for (const Vec3& p : positions) {
    box.min = box.min.cwiseMin(p);
    box.max = box.max.cwiseMax(p);
  }
  return box;
}

}  // namespace fabrica
