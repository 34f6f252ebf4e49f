// Intensity-ridge detection (Singh & Schaefer 2010, §4); see the header.
#include "fabrica/hatching/intensity_ridges.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace fabrica::hatching {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// |cos| of the angle between a test direction and an edge above which the
/// direction counts as running along the edge (about 0.8°).
constexpr double kAlongEdge = 0.9999;

/// Unit tangent basis (t1, t2) of the plane with unit normal n.
void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  const Vec3 a = std::abs(n.x()) < 0.6 ? Vec3::UnitX() : Vec3::UnitY();
  t1 = (a - a.dot(n) * n).normalized();
  t2 = n.cross(t1);
}

/// Dominant eigenvector (not normalised) of the symmetric 2×2 matrix
/// [a b; b c], in closed form: (λ − c, b) or (b, λ − a), whichever is
/// longer, λ the larger eigenvalue; (1, 0) when the matrix is isotropic.
Vec2 dominant_eigenvector(double a, double b, double c) {
  const double half = 0.5 * (a - c);
  const double lambda = 0.5 * (a + c) + std::sqrt(half * half + b * b);
  const Vec2 v1(lambda - c, b), v2(b, lambda - a);
  const Vec2 v = v1.squaredNorm() >= v2.squaredNorm() ? v1 : v2;
  return v.squaredNorm() > 0.0 ? v : Vec2(1.0, 0.0);
}

/// Dominant eigenvector of u uᵀ + w wᵀ (3×3) through the 2×2 Gram matrix;
/// zero when both vectors vanish.
Vec3 dominant_direction(const Vec3& u, const Vec3& w) {
  const Vec2 c = dominant_eigenvector(u.dot(u), u.dot(w), w.dot(w));
  const Vec3 e = c.x() * u + c.y() * w;
  const double len = e.norm();
  return len > 0.0 ? Vec3(e / len) : Vec3::Zero();
}

/// atan2(y, x) for y ≥ 0 to about 1e-5 rad (a minimax polynomial for atan on
/// [0, 1]); enough for angle weights and much cheaper than std::atan2.
double angle_from(double y, double x) {
  const double ax = std::abs(x);
  const double hi = std::max(ax, y), lo = std::min(ax, y);
  if (!(hi > 0.0)) return 0.0;
  const double z = lo / hi, z2 = z * z;
  double r =
      z * (0.99997726 +
           z2 * (-0.33262347 +
                 z2 * (0.19354346 + z2 * (-0.11643287 + z2 * (0.05265332 - z2 * 0.01172120)))));
  if (y > ax) r = 0.5 * kPi - r;
  if (x < 0.0) r = kPi - r;
  return r;
}

struct EdgeHit {
  Vec3 point, gradient;
};

}  // namespace

std::vector<Vec3> intensity_vertex_gradients(const Surface& surface, const IntensityField& field) {
  const auto& positions = surface.positions();
  const auto& faces = surface.faces();
  const auto& normals = surface.vertex_normals();
  const Topology& topology = surface.topology();
  const std::size_t nv = positions.size();
  std::vector<Vec3> result(nv, Vec3::Zero());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const Vec3& n = normals[v];
      if (!(n.squaredNorm() > 0.0)) continue;
      Vec3 t1, t2;
      tangent_basis(n, t1, t2);
      const auto vf = topology.vertex_faces(v);
      const auto vc = topology.vertex_face_corners(v);
      Vec3 mean = Vec3::Zero();
      double weight_sum = 0.0, cxx = 0.0, cxy = 0.0, cyy = 0.0;
      for (std::size_t k = 0; k < vf.size(); ++k) {
        const std::size_t f = static_cast<std::size_t>(vf[k]);
        const int c = vc[k];
        const Face& t = faces[f];
        const Vec3 a = positions[static_cast<std::size_t>(t[(c + 1) % 3])] - positions[v];
        const Vec3 b = positions[static_cast<std::size_t>(t[(c + 2) % 3])] - positions[v];
        const double w = angle_from(a.cross(b).norm(), a.dot(b));  // angle at the vertex
        if (!(w > 0.0)) continue;
        const Vec3& g = field.face_gradient[f];
        mean += w * g;
        weight_sum += w;
        const double gx = g.dot(t1), gy = g.dot(t2);
        cxx += w * gx * gx;
        cxy += w * gx * gy;
        cyy += w * gy * gy;
      }
      if (!(weight_sum > 0.0)) continue;
      mean /= weight_sum;
      const Vec2 c = dominant_eigenvector(cxx, cxy, cyy).normalized();
      const Vec3 e = c.x() * t1 + c.y() * t2;
      result[v] = mean.dot(e) * e;
    }
  });
  return result;
}

IntensityRidges detect_intensity_ridges(const Surface& surface, const IntensityField& field,
                                        const RidgeOptions& options) {
  IntensityRidges ridges;
  ridges.vertex_gradient = intensity_vertex_gradients(surface, field);
  const auto& grad = ridges.vertex_gradient;
  const auto& positions = surface.positions();
  const auto& faces = surface.faces();
  const auto& normals = surface.vertex_normals();
  const auto& face_normals = surface.face_normals();
  const auto& face_areas = surface.face_areas();
  const Topology& topology = surface.topology();
  const std::size_t ne = topology.edge_count();
  const double cos_min = std::cos(options.min_angle_deg * kPi / 180.0);

  // Per edge: the parameter t of the ridge point from edge(e)[0], or -1.
  std::vector<double> edge_t(ne, -1.0);

  // From p_r (parameter t on edge (v1, v2)) step along `dir` projected into
  // `face`, away from the edge, to the face's opposite side.
  auto step_into = [&](std::size_t face, std::int32_t v1, std::int32_t v2, double t,
                       const Vec3& dir, EdgeHit& hit) -> bool {
    const Face& tri = faces[face];
    int c1 = -1, c2 = -1;
    for (int k = 0; k < 3; ++k) {
      if (tri[k] == v1) c1 = k;
      if (tri[k] == v2) c2 = k;
    }
    if (c1 < 0 || c2 < 0 || c1 == c2) return false;
    const int c0 = 3 - c1 - c2;
    if (c0 < 0 || c0 > 2) return false;  // a repeated vertex
    // Rates of the barycentric coordinates along dir: (n × e_k)·d / (2A) =
    // e_k · (d × n) / (2A), e_k the edge opposite corner k (the normal part
    // of dir drops out).
    const double area = face_areas[face];
    if (!(area > 0.0)) return false;
    const Vec3 m = dir.cross(face_normals[face]) / (2.0 * area);
    Vec3 db;
    for (int k = 0; k < 3; ++k)
      db[k] = (positions[static_cast<std::size_t>(tri[(k + 2) % 3])] -
               positions[static_cast<std::size_t>(tri[(k + 1) % 3])])
                  .dot(m);
    // Parallel to the edge (or degenerate face): no step into this face.
    if (!(std::abs(db[c0]) > 1e-9 * (std::abs(db[c1]) + std::abs(db[c2])))) return false;
    if (db[c0] < 0.0) db = -db;
    Vec3 b = Vec3::Zero();
    b[c1] = 1.0 - t;
    b[c2] = t;
    double step = std::numeric_limits<double>::infinity();
    int exit = -1;
    for (int k : {c1, c2}) {
      if (db[k] < 0.0) {
        const double s = -b[k] / db[k];
        if (s < step) {
          step = s;
          exit = k;
        }
      }
    }
    if (exit < 0 || !std::isfinite(step)) return false;
    Vec3 bh = b + step * db;
    bh[exit] = 0.0;
    for (int k = 0; k < 3; ++k) bh[k] = std::max(bh[k], 0.0);
    const double sum = bh.sum();
    if (!(sum > 0.0)) return false;
    bh /= sum;
    hit.point = Vec3::Zero();
    hit.gradient = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      hit.point += bh[k] * positions[static_cast<std::size_t>(tri[k])];
      hit.gradient += bh[k] * grad[static_cast<std::size_t>(tri[k])];
    }
    return true;
  };

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ne), [&](const auto& r) {
    for (std::size_t e = r.begin(); e != r.end(); ++e) {
      const auto ef = topology.edge_faces(e);
      if (ef.size() != 2) continue;
      const std::int32_t v1 = topology.edge(e)[0], v2 = topology.edge(e)[1];
      const Vec3& g1 = grad[static_cast<std::size_t>(v1)];
      const Vec3& g2 = grad[static_cast<std::size_t>(v2)];
      const double m1 = g1.norm(), m2 = g2.norm();
      if (!(m1 + m2 > 0.0)) continue;
      // Nearly parallel gradients: a weak point. A vanishing gradient (the
      // vertex sits on the ridge) has no direction and is not excluded.
      const double tiny = 1e-9 * (m1 + m2);
      if (m1 > tiny && m2 > tiny && g1.dot(g2) > cos_min * m1 * m2) continue;
      const double t = m1 / (m1 + m2);
      const Vec3& p1 = positions[static_cast<std::size_t>(v1)];
      const Vec3& p2 = positions[static_cast<std::size_t>(v2)];
      const Vec3 pr = (1.0 - t) * p1 + t * p2;
      const Vec3 directions[2] = {
          dominant_direction(g1, g2),
          dominant_direction(normals[static_cast<std::size_t>(v1)].cross(g1),
                             normals[static_cast<std::size_t>(v2)].cross(g2))};
      bool ridge = false;
      for (const Vec3& dir : directions) {
        if (!(dir.squaredNorm() > 0.0)) continue;
        EdgeHit f, b;
        if (!step_into(static_cast<std::size_t>(ef[0]), v1, v2, t, dir, f) ||
            !step_into(static_cast<std::size_t>(ef[1]), v1, v2, t, dir, b)) {
          // A direction along the edge cannot step into a face; as it turns
          // towards the edge the exit points tend to the edge's end points,
          // so those are used (an edge crossing the ridge at right angles).
          if (!(std::abs(dir.dot(p2 - p1)) > kAlongEdge * (p2 - p1).norm())) continue;
          f = {p2, g2};
          b = {p1, g1};
        }
        const double df = f.gradient.dot(f.point - pr);
        const double dback = b.gradient.dot(pr - b.point);
        const double span = (f.point - pr).norm() + (pr - b.point).norm();
        if (!(span > 0.0)) continue;
        if ((df - dback) / span < 0.0 && df * dback < 0.0) {
          ridge = true;
          break;
        }
      }
      if (ridge) edge_t[e] = t;
    }
  });

  // Join the ridge points of each face.
  const std::size_t nf = faces.size();
  for (std::size_t f = 0; f < nf; ++f) {
    std::array<SurfacePoint, 3> points;
    std::array<Vec3, 3> where;
    int count = 0;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t edge = topology.face_edge(f, k);
      if (edge < 0) continue;  // a face with a repeated vertex has no edge there
      const auto e = static_cast<std::size_t>(edge);
      const double t = edge_t[e];
      if (t < 0.0) continue;
      const std::int32_t v1 = topology.edge(e)[0];
      // Corners (k+1)%3 and (k+2)%3 hold the edge; put (1-t) on v1's corner.
      const int ca = (k + 1) % 3, cb = (k + 2) % 3;
      const int c1 = faces[f][ca] == v1 ? ca : cb, c2 = c1 == ca ? cb : ca;
      SurfacePoint sp;
      sp.face = static_cast<std::int32_t>(f);
      sp.bary = Vec3::Zero();
      sp.bary[c1] = 1.0 - t;
      sp.bary[c2] = t;
      points[count] = sp;
      where[count] = sp.position(surface.mesh());
      ++count;
    }
    if (count == 2) {
      ridges.segments.push_back({points[0], points[1], where[0], where[1]});
    } else if (count == 3) {
      SurfacePoint centroid;
      centroid.face = static_cast<std::int32_t>(f);
      centroid.bary = Vec3::Constant(1.0 / 3.0);
      const Vec3 pc = centroid.position(surface.mesh());
      for (int k = 0; k < 3; ++k) ridges.segments.push_back({points[k], centroid, where[k], pc});
    }
  }
  return ridges;
}

}  // namespace fabrica::hatching
