// The only translation unit that includes CGAL (heavy to compile, adds
// -frounding-math): counts self-intersecting face pairs with
// CGAL::Polygon_mesh_processing::self_intersections on a Surface_mesh copy
// (exact predicates, inexact constructions). Faces that only touch at a
// split non-manifold vertex are not counted.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/intersections.h>

#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "validate_detail.hpp"

namespace fabrica::io::detail {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

using Triangle = Kernel::Triangle_3;
using Segment = Kernel::Segment_3;

Point to_point(const Vec3& p) {
  return Point(p.x(), p.y(), p.z());
}

// Faces f and g have no vertex index in common (CGAL reported them), but may
// share a corner POSITION: copies of a split non-manifold vertex. Then they
// only count when they meet beyond that point, tested as CGAL tests faces
// sharing a vertex: each triangle against the other's opposite edge.
bool intersect_beyond_shared_point(const TriangleMesh& mesh, const Face& f, const Face& g) {
  const auto& p = mesh.positions;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      if (p[f[i]] != p[g[j]]) continue;
      const Triangle tf(to_point(p[f[0]]), to_point(p[f[1]]), to_point(p[f[2]]));
      const Triangle tg(to_point(p[g[0]]), to_point(p[g[1]]), to_point(p[g[2]]));
      const Segment sf(to_point(p[f[(i + 1) % 3]]), to_point(p[f[(i + 2) % 3]]));
      const Segment sg(to_point(p[g[(j + 1) % 3]]), to_point(p[g[(j + 2) % 3]]));
      return CGAL::do_intersect(tf, sg) || CGAL::do_intersect(tg, sf);
    }
  return true;  // no shared point: CGAL's verdict stands
}

}  // namespace

std::optional<std::size_t> count_self_intersecting_face_pairs(const TriangleMesh& mesh,
                                                              std::string& why_not) {
  SurfaceMesh sm;
  sm.reserve(static_cast<SurfaceMesh::size_type>(mesh.positions.size()),
             static_cast<SurfaceMesh::size_type>(3 * mesh.faces.size() / 2),
             static_cast<SurfaceMesh::size_type>(mesh.faces.size()));
  std::vector<SurfaceMesh::Vertex_index> vertex(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    vertex[i] = sm.add_vertex(Point(p.x(), p.y(), p.z()));
  }
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& t = mesh.faces[f];
    const auto added = sm.add_face(vertex[t[0]], vertex[t[1]], vertex[t[2]]);
    if (added == SurfaceMesh::null_face()) {
      why_not = "self-intersections not checked: CGAL's surface mesh rejected face " +
                std::to_string(f) + " (non-manifold or inconsistently oriented there)";
      return std::nullopt;
    }
  }
  std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
  CGAL::Polygon_mesh_processing::self_intersections<CGAL::Sequential_tag>(
      sm, std::back_inserter(pairs));
  // Faces were added in order, so face index i is mesh face i.
  std::size_t count = 0;
  for (const auto& [a, b] : pairs)
    if (intersect_beyond_shared_point(mesh, mesh.faces[static_cast<std::size_t>(a)],
                                      mesh.faces[static_cast<std::size_t>(b)]))
      ++count;
  return count;
}

}  // namespace fabrica::io::detail
