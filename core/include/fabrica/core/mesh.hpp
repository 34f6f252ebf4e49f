// The indexed triangle mesh every module works on: flat arrays, file order.
//
// Vertex i is vertex i of the file it came from (for STL: order of first
// appearance after welding). Faces are counter-clockwise seen from outside
// when the mesh is oriented outward. Coordinates are millimetres in the
// patient space named by `space`.
#pragma once

#include <string>
#include <vector>

#include "fabrica/core/types.hpp"

namespace fabrica {

/// The anatomical coordinate convention of a mesh's coordinates.
enum class Space { lps, ras };

/// How the coordinate convention was decided (reported to users).
enum class SpaceSource { default_assumed, file_tag, user_override };

struct TriangleMesh {
  std::vector<Vec3> positions;
  std::vector<Face> faces;

  Space space = Space::lps;
  SpaceSource space_source = SpaceSource::default_assumed;

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t face_count() const { return faces.size(); }
  bool empty() const { return positions.empty() || faces.empty(); }
};

const char* to_string(Space space);
const char* to_string(SpaceSource source);

/// Throws InputError (naming `what`, e.g. the file) when a face index is out
/// of range or a coordinate is not finite; does not judge topology.
void check_mesh_indices_and_values(const TriangleMesh& mesh, const std::string& what);

/// Axis-aligned bounding box; both corners are zero for an empty mesh.
struct BoundingBox {
  Vec3 min = Vec3::Zero();
  Vec3 max = Vec3::Zero();
  Vec3 center() const { return 0.5 * (min + max); }
  double diagonal() const { return (max - min).norm(); }
};
BoundingBox bounding_box(const std::vector<Vec3>& positions);

}  // namespace fabrica
