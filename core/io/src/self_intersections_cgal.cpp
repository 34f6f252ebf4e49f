// The only translation unit that includes CGAL (heavy to compile, adds
// -frounding-math): counts self-intersecting face pairs with
// CGAL::Polygon_mesh_processing::self_intersections on a Surface_mesh copy
// (exact predicates, inexact constructions). Faces that only touch at a
// split non-manifold vertex or along a cut non-manifold edge are not counted.
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
// share corner POSITIONS: copies of a split non-manifold vertex or of a cut
// non-manifold edge. Then they count only when they meet beyond what they
// share, tested as CGAL tests faces sharing a vertex or an edge.
bool intersect_beyond_shared_points(const TriangleMesh& mesh, const Face& f, const Face& g) {
  const auto& p = mesh.positions;
  int shared = 0, fi[3] = {0, 0, 0}, gj[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (p[f[i]] == p[g[j]] && shared < 3) {
        fi[shared] = i;
        gj[shared] = j;
        ++shared;
      }
  if (shared == 0 || shared >= 3) return true;  // CGAL's verdict; or the same triangle twice
  if (shared == 2 && (fi[0] == fi[1] || gj[0] == gj[1])) return true;  // a collapsed face
  if (shared == 2) {
    // Shared edge (a, b): overlap iff coplanar with both opposite corners on
    // the same side of the edge.
    const Point a = to_point(p[f[fi[0]]]), b = to_point(p[f[fi[1]]]);
    const Point r = to_point(p[f[3 - fi[0] - fi[1]]]), s = to_point(p[g[3 - gj[0] - gj[1]]]);
    return CGAL::coplanar(a, b, r, s) && CGAL::coplanar_orientation(a, b, r, s) == CGAL::POSITIVE;
  }
  // Shared point: each triangle against the other's opposite edge.
  const int i = fi[0], j = gj[0];
  const Triangle tf(to_point(p[f[0]]), to_point(p[f[1]]), to_point(p[f[2]]));
  const Triangle tg(to_point(p[g[0]]), to_point(p[g[1]]), to_point(p[g[2]]));
  const Segment sf(to_point(p[f[(i + 1) % 3]]), to_point(p[f[(i + 2) % 3]]));
  const Segment sg(to_point(p[g[(j + 1) % 3]]), to_point(p[g[(j + 2) % 3]]));
  return CGAL::do_intersect(tf, sg) || CGAL::do_intersect(tg, sf);
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
    if (intersect_beyond_shared_points(mesh, mesh.faces[static_cast<std::size_t>(a)],
                                       mesh.faces[static_cast<std::size_t>(b)]))
      ++count;
  return count;
}

}  // namespace fabrica::io::detail
