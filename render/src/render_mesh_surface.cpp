// Kept apart from render_mesh.cpp: only users of Surface pull this in.
#include "fabrica/core/surface.hpp"
#include "fabrica/render/render_mesh.hpp"

namespace fabrica::render {

RenderMesh make_render_mesh(const Surface& surface, bool with_curvature) {
  RenderMesh m = make_render_mesh(surface.mesh(), surface.vertex_normals());
  if (with_curvature) {
    const PrincipalCurvatures& c = surface.curvature();
    set_curvature(m, c.k1, c.k2, c.e1, c.e2);
    m.feature_size = surface.feature_size();
  }
  return m;
}

}  // namespace fabrica::render
