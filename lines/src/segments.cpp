// The lean segment record's geometry (segments.hpp, docs/algorithms.md §11
// "lean segment record"): barycentrics and positions of segment ends from
// the mesh, with the operations the zero-crossing kernels use for them.
#include "fabrica/lines/segments.hpp"

#include "fabrica/core/error.hpp"

namespace fabrica {

SegmentGeometry::SegmentGeometry(const Surface& surface)
    : faces_(surface.faces().data()),
      pos_(surface.positions().data()),
      topo_(&surface.topology()) {}

// Both from locate() (inline in the header, shared with chaining); each
// call leaves out what it does not return.
SurfacePoint SegmentGeometry::anchor(const LineSegment& s, int i) const {
  SurfacePoint a;
  Vec3 p;
  locate(s, i, a, p);
  return a;
}

Vec3 SegmentGeometry::position(const LineSegment& s, int i) const {
  SurfacePoint a;
  Vec3 p;
  locate(s, i, a, p);
  return p;
}

ResolvedEnd SegmentGeometry::resolve(const LineSegment& s, int i) const {
  ResolvedEnd r;
  locate(s, i, r.anchor, r.position);
  r.element = s.end[i].element;
  r.kind = s.kind[i];
  r.strength = s.end[i].strength;
  return r;
}
void SegmentGeometry::set_interior(LineSegment& s, int i, const double bary[3]) {
  s.kind[i] = EndKind::interior;
  s.end[i].element = -1;
  s.end[i].bary[0] = static_cast<float>(bary[0]);
  s.end[i].bary[1] = static_cast<float>(bary[1]);
}

SegmentGeometry SegmentSoup::geometry() const {
  if (!surface)
    throw Error(ErrorKind::internal,
                "segment soup: no surface (SegmentSoup::surface must name the mesh of its ends)");
  return SegmentGeometry(*surface);
}

std::vector<ResolvedSegment> SegmentSoup::resolved() const {
  std::vector<ResolvedSegment> out;
  if (segments.empty()) return out;
  const SegmentGeometry g = geometry();
  out.reserve(segments.size());
  for (const auto& s : segments) out.push_back({s.face, {g.resolve(s, 0), g.resolve(s, 1)}});
  return out;
}

double SegmentSoup::total_length() const {
  if (segments.empty()) return 0.0;
  const SegmentGeometry g = geometry();
  double sum = 0.0;
  for (const auto& s : segments) sum += (g.position(s, 1) - g.position(s, 0)).norm();
  return sum;
}

}  // namespace fabrica
