#include "fabrica/lines/zero_crossing.hpp"

#include <algorithm>
#include <cmath>

#include "parallel.hpp"

namespace fabrica {

namespace {

// An endpoint on the edge joining corners ca and cb of face f, at fraction
// t from vertex face[ca] (already canonicalised by the caller).
inline SegmentEnd edge_end(const Surface& surface, std::size_t f, int ca, int cb, double t) {
  const Face& face = surface.faces()[f];
  const auto& pos = surface.positions();
  SegmentEnd e;
  e.anchor.face = static_cast<std::int32_t>(f);
  e.anchor.bary = Vec3::Zero();
  e.anchor.bary[ca] = 1.0 - t;
  e.anchor.bary[cb] = t;
  e.position = (1.0 - t) * pos[face[ca]] + t * pos[face[cb]];
  e.element = surface.topology().face_edge(f, 3 - ca - cb);
  e.kind = EndKind::edge;
  return e;
}

inline SegmentEnd lerp_end(const SegmentEnd& a, const SegmentEnd& b, double z) {
  SegmentEnd e;
  e.anchor.face = a.anchor.face;
  e.anchor.bary = (1.0 - z) * a.anchor.bary + z * b.anchor.bary;
  e.position = (1.0 - z) * a.position + z * b.position;
  e.kind = EndKind::interior;
  e.element = -1;
  return e;
}

inline float fade_strength(double num, double den, double fade) {
  if (fade <= 0.0) return 1.0f;
  const double d = den * fade + num;
  if (d == 0.0) return 0.0f;
  const double s = num / d;
  return static_cast<float>(std::clamp(std::isfinite(s) ? s : 0.0, 0.0, 1.0));
}

inline bool lone_sign(double a, double b, double c) {
  return (a < 0.0 && b >= 0.0 && c >= 0.0) || (a > 0.0 && b <= 0.0 && c <= 0.0);
}

// Fraction along the edge from the vertex with the lower index, from values
// (va at ia, vb at ib): returns (corner of the lower vertex, t).
struct EdgeParam {
  int c_lo, c_hi;
  double t;
};
inline EdgeParam scalar_edge(const Face& face, int ca, int cb, double va, double vb) {
  if (face[ca] > face[cb]) {
    std::swap(ca, cb);
    std::swap(va, vb);
  }
  const double d = va - vb;
  double t = d != 0.0 ? va / d : 0.5;
  t = std::clamp(t, 0.0, 1.0);
  return {ca, cb, t};
}

void scalar_face(const Surface& surface, std::size_t f, std::span<const double> val,
                 const ScalarCrossingOptions& o, std::vector<LineSegment>& out) {
  const Face& face = surface.faces()[f];
  const int i0 = face[0], i1 = face[1], i2 = face[2];
  if (!o.cull.empty() && o.cull[i0] <= 0.0 && o.cull[i1] <= 0.0 && o.cull[i2] <= 0.0) return;
  const bool test = !o.test_num.empty();
  const bool has_den = !o.test_den.empty();
  if (test) {
    const auto& n = o.test_num;
    if (!has_den) {
      if (n[i0] <= 0.0 && n[i1] <= 0.0 && n[i2] <= 0.0) return;
    } else {
      const auto& d = o.test_den;
      if (n[i0] <= 0.0 && d[i0] >= 0.0 && n[i1] <= 0.0 && d[i1] >= 0.0 && n[i2] <= 0.0 &&
          d[i2] >= 0.0)
        return;
      if (n[i0] >= 0.0 && d[i0] <= 0.0 && n[i1] >= 0.0 && d[i1] <= 0.0 && n[i2] >= 0.0 &&
          d[i2] <= 0.0)
        return;
    }
  }
  const double s[3] = {val[i0], val[i1], val[i2]};
  int k;
  if (lone_sign(s[0], s[1], s[2]))
    k = 0;
  else if (lone_sign(s[1], s[2], s[0]))
    k = 1;
  else if (lone_sign(s[2], s[0], s[1]))
    k = 2;
  else
    return;
  const int c0 = k, c1 = (k + 1) % 3, c2 = (k + 2) % 3;
  const EdgeParam e1 = scalar_edge(face, c0, c1, s[c0], s[c1]);
  const EdgeParam e2 = scalar_edge(face, c0, c2, s[c0], s[c2]);
  SegmentEnd p1 = edge_end(surface, f, e1.c_lo, e1.c_hi, e1.t);
  SegmentEnd p2 = edge_end(surface, f, e2.c_lo, e2.c_hi, e2.t);

  auto interp = [&](std::span<const double> a, const EdgeParam& e) {
    return (1.0 - e.t) * a[face[e.c_lo]] + e.t * a[face[e.c_hi]];
  };
  double num1 = 1.0, num2 = 1.0, den1 = 1.0, den2 = 1.0;
  double z1 = 0.0, z2 = 0.0;
  bool valid1 = true;
  if (test) {
    num1 = interp(o.test_num, e1);
    num2 = interp(o.test_num, e2);
    if (has_den) {
      den1 = interp(o.test_den, e1);
      den2 = interp(o.test_den, e2);
    }
    valid1 = (num1 >= 0.0) == (den1 >= 0.0);
    if ((num1 >= 0.0) != (num2 >= 0.0)) z1 = num1 / (num1 - num2);
    if ((den1 >= 0.0) != (den2 >= 0.0)) z2 = den1 / (den1 - den2);
    if (z1 == 0.0) {
      z1 = z2;
      z2 = 0.0;
    } else if (z2 < z1) {
      std::swap(z1, z2);
    }
  }
  if (!valid1 && z1 == 0.0 && z2 == 0.0) return;

  // Up to four points, consumed in pairs (rtsc's GL_LINES logic).
  SegmentEnd pts[4];
  int npts = 0;
  if (valid1) {
    p1.strength = fade_strength(num1, den1, o.fade);
    pts[npts++] = p1;
  }
  auto clip = [&](double z) {
    SegmentEnd e = lerp_end(p1, p2, z);
    e.strength = fade_strength((1.0 - z) * num1 + z * num2, (1.0 - z) * den1 + z * den2, o.fade);
    return e;
  };
  if (z1 != 0.0) pts[npts++] = clip(z1);
  if (z2 != 0.0) pts[npts++] = clip(z2);
  if (npts != 2) {
    p2.strength = fade_strength(num2, den2, o.fade);
    pts[npts++] = p2;
  }
  for (int i = 0; i + 1 < npts; i += 2) {
    LineSegment seg;
    seg.face = static_cast<std::int32_t>(f);
    seg.end[0] = pts[i];
    seg.end[1] = pts[i + 1];
    out.push_back(seg);
  }
}

struct VectorFace {
  const Surface& surface;
  std::span<const double> delta;
  std::span<const Vec3> dir;
  std::span<const double> mag;
  const VectorCrossingOptions& o;
};

// rtsc's draw_segment_ridge / draw_segment_app_ridge for corners (c0,c1,c2)
// of face f: crossing on edge c0-c1 joined to the crossing on c1-c2 (or the
// centroid).
void vector_segment(const VectorFace& vf, std::size_t f, int c0, int c1, int c2, const Vec3 E[3],
                    bool to_center, std::vector<LineSegment>& out) {
  const Surface& surface = vf.surface;
  const Face& face = surface.faces()[f];
  const auto& pos = surface.positions();
  auto edge = [&](int ca, int cb, double& m) {
    if (face[ca] > face[cb]) std::swap(ca, cb);
    const double da = std::abs(vf.delta[face[ca]]), db = std::abs(vf.delta[face[cb]]);
    const double t = da + db > 0.0 ? da / (da + db) : 0.5;
    m = std::abs((1.0 - t) * vf.mag[face[ca]] + t * vf.mag[face[cb]]);
    return edge_end(surface, f, ca, cb, t);
  };
  double m01, m12;
  SegmentEnd a = edge(c0, c1, m01);
  SegmentEnd b;
  if (to_center) {
    b.anchor.face = static_cast<std::int32_t>(f);
    b.anchor.bary = Vec3::Constant(1.0 / 3.0);
    b.position = (pos[face[0]] + pos[face[1]] + pos[face[2]]) / 3.0;
    b.kind = EndKind::centroid;
    b.element = static_cast<std::int32_t>(f);
    m12 = std::abs(vf.mag[face[0]] + vf.mag[face[1]] + vf.mag[face[2]]) / 3.0;
  } else {
    b = edge(c1, c2, m12);
  }
  const double t = vf.o.threshold;
  const double k01 = std::max(m01 - t, 0.0), k12 = std::max(m12 - t, 0.0);
  if (k01 == 0.0 && k12 == 0.0) return;
  if (vf.o.test == ExtremumTest::perpendicular) {
    const Vec3 n = (pos[face[1]] - pos[face[0]]).cross(pos[face[2]] - pos[face[0]]);
    const Vec3 perp = n.cross(a.position - b.position);
    if (E[c0].dot(perp) <= 0.0 || E[c1].dot(perp) >= 0.0 || E[c2].dot(perp) <= 0.0) return;
  }
  if (vf.o.keep_raw_magnitude) {
    a.strength = static_cast<float>(m01);
    b.strength = static_cast<float>(m12);
  } else {
    a.strength = t > 0.0 ? static_cast<float>(k01 / (k01 + t)) : 1.0f;
    b.strength = t > 0.0 ? static_cast<float>(k12 / (k12 + t)) : 1.0f;
  }
  LineSegment seg;
  seg.face = static_cast<std::int32_t>(f);
  seg.end[0] = a;
  seg.end[1] = b;
  out.push_back(seg);
}

void vector_face(const VectorFace& vf, std::size_t f, std::vector<LineSegment>& out) {
  const Surface& surface = vf.surface;
  const Face& face = surface.faces()[f];
  const int v[3] = {face[0], face[1], face[2]};
  const auto& o = vf.o;
  if (!o.cull.empty() && o.cull[v[0]] <= 0.0 && o.cull[v[1]] <= 0.0 && o.cull[v[2]] <= 0.0) return;
  if (!o.vertex_mask.empty() &&
      (!o.vertex_mask[v[0]] || !o.vertex_mask[v[1]] || !o.vertex_mask[v[2]]))
    return;
  if (vf.mag[v[0]] <= o.threshold && vf.mag[v[1]] <= o.threshold && vf.mag[v[2]] <= o.threshold)
    return;
  const Vec3 E[3] = {vf.delta[v[0]] * vf.dir[v[0]], vf.delta[v[1]] * vf.dir[v[1]],
                     vf.delta[v[2]] * vf.dir[v[2]]};
  bool z01 = E[0].dot(E[1]) <= 0.0;
  bool z12 = E[1].dot(E[2]) <= 0.0;
  bool z20 = E[2].dot(E[0]) <= 0.0;
  if (int(z01) + int(z12) + int(z20) < 2) return;
  if (o.test == ExtremumTest::edge) {
    const auto& pos = surface.positions();
    const Vec3 d01 = pos[v[1]] - pos[v[0]], d12 = pos[v[2]] - pos[v[1]],
               d20 = pos[v[0]] - pos[v[2]];
    z01 = z01 && (E[0].dot(d01) >= 0.0 || E[1].dot(d01) <= 0.0);
    z12 = z12 && (E[1].dot(d12) >= 0.0 || E[2].dot(d12) <= 0.0);
    z20 = z20 && (E[2].dot(d20) >= 0.0 || E[0].dot(d20) <= 0.0);
    if (int(z01) + int(z12) + int(z20) < 2) return;
  }
  if (!z01) {
    vector_segment(vf, f, 1, 2, 0, E, false, out);
  } else if (!z12) {
    vector_segment(vf, f, 2, 0, 1, E, false, out);
  } else if (!z20) {
    vector_segment(vf, f, 0, 1, 2, E, false, out);
  } else {
    vector_segment(vf, f, 1, 2, 0, E, true, out);
    vector_segment(vf, f, 2, 0, 1, E, true, out);
    vector_segment(vf, f, 0, 1, 2, E, true, out);
  }
}

}  // namespace

void scalar_zero_crossings(const Surface& surface, std::span<const double> values,
                           const ScalarCrossingOptions& options, std::vector<LineSegment>& out) {
  (void)surface.topology();
  detail::parallel_chunks<LineSegment>(
      surface.face_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
        for (std::size_t f = b; f < e; ++f) scalar_face(surface, f, values, options, part);
      },
      out);
}

void vector_zero_crossings(const Surface& surface, std::span<const double> derivative,
                           std::span<const Vec3> direction, std::span<const double> magnitude,
                           const VectorCrossingOptions& options, std::vector<LineSegment>& out) {
  (void)surface.topology();
  const VectorFace vf{surface, derivative, direction, magnitude, options};
  detail::parallel_chunks<LineSegment>(
      surface.face_count(),
      [&](std::size_t b, std::size_t e, std::vector<LineSegment>& part) {
        for (std::size_t f = b; f < e; ++f) vector_face(vf, f, part);
      },
      out);
}

}  // namespace fabrica
