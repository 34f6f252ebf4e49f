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

SurfacePoint SegmentGeometry::anchor(const LineSegment& s, int i) const {
  const SegmentEnd& e = s.end[i];
  const Face& f = faces_[static_cast<std::size_t>(s.face)];
  SurfacePoint p{s.face, Vec3::Zero()};
  switch (s.kind[i]) {
    case EndKind::edge: {
      const auto& ev = topo_->edge(static_cast<std::size_t>(e.element));
      for (int k = 0; k < 3; ++k) {
        if (f[k] == ev[0]) p.bary[k] = 1.0 - e.t;
        if (f[k] == ev[1]) p.bary[k] = e.t;
      }
      break;
    }
    case EndKind::vertex:
      for (int k = 0; k < 3; ++k)
        if (f[k] == e.element) p.bary[k] = 1.0;
      break;
    case EndKind::centroid:
      p.bary = Vec3::Constant(1.0 / 3.0);
      break;
    case EndKind::interior: {
      const double b0 = e.bary[0], b1 = e.bary[1];
      p.bary = Vec3(b0, b1, 1.0 - b0 - b1);
      break;
    }
  }
  return p;
}

Vec3 SegmentGeometry::position(const LineSegment& s, int i) const {
  const SegmentEnd& e = s.end[i];
  switch (s.kind[i]) {
    case EndKind::edge: {
      const auto& ev = topo_->edge(static_cast<std::size_t>(e.element));
      const Vec3 &a = pos_[ev[0]], &b = pos_[ev[1]];
      const double u = 1.0 - e.t;
      return Vec3(u * a[0] + e.t * b[0], u * a[1] + e.t * b[1], u * a[2] + e.t * b[2]);
    }
    case EndKind::vertex:
      return pos_[static_cast<std::size_t>(e.element)];
    case EndKind::centroid: {
      const Face& f = faces_[static_cast<std::size_t>(s.face)];
      const Vec3 &a = pos_[f[0]], &b = pos_[f[1]], &c = pos_[f[2]];
      return Vec3((a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0,
                  (a[2] + b[2] + c[2]) / 3.0);
    }
    case EndKind::interior:
      break;
  }
  const Face& f = faces_[static_cast<std::size_t>(s.face)];
  const Vec3 b = anchor(s, i).bary;
  return b[0] * pos_[f[0]] + b[1] * pos_[f[1]] + b[2] * pos_[f[2]];
}

ResolvedEnd SegmentGeometry::resolve(const LineSegment& s, int i) const {
  return {anchor(s, i), position(s, i), s.end[i].element, s.kind[i], s.end[i].strength};
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
