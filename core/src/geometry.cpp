#include "fabrica/core/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "curvature_internal.hpp"
#include "fabrica/core/error.hpp"
#include "geometry_kernels.hpp"

namespace fabrica {

namespace {

constexpr std::size_t kGrain = 2048;

void check_field_size(std::size_t got, std::size_t want, const char* what) {
  if (got != want)
    throw InputError(std::string(what) + ": the field has " + std::to_string(got) +
                     " values but the surface has " + std::to_string(want) +
                     " vertices; pass one value per vertex");
}

}  // namespace

namespace detail {

double kth_smallest(const std::vector<double>& values, std::size_t k) {
  const std::size_t n = values.size();
  if (n < (std::size_t(1) << 16)) {
    std::vector<double> copy(values);
    std::nth_element(copy.begin(), copy.begin() + static_cast<std::ptrdiff_t>(k), copy.end());
    return copy[k];
  }
  // Fixed chunks (independent of the thread count), each with its own
  // min/max and histogram; integer sums and min/max are order-independent.
  constexpr std::size_t kChunks = 32, kBins = 4096;
  const std::size_t chunk = (n + kChunks - 1) / kChunks;
  double lo_c[kChunks], hi_c[kChunks];
  parallel_chunks(kChunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t c = b; c < e; ++c) {
      double lo = values[std::min(n - 1, c * chunk)], hi = lo;
      for (std::size_t i = c * chunk; i < std::min(n, (c + 1) * chunk); ++i) {
        lo = std::min(lo, values[i]);
        hi = std::max(hi, values[i]);
      }
      lo_c[c] = lo;
      hi_c[c] = hi;
    }
  });
  const double lo = *std::min_element(lo_c, lo_c + kChunks);
  const double hi = *std::max_element(hi_c, hi_c + kChunks);
  if (!(hi > lo)) return lo;
  // Monotone binning: every value in a lower bin is <= every value in a
  // higher one.
  const double scale = static_cast<double>(kBins) / (hi - lo);
  auto bin = [&](double x) {
    return std::min(kBins - 1, static_cast<std::size_t>((x - lo) * scale));
  };
  std::vector<std::uint32_t> hist(kChunks * kBins, 0);
  parallel_chunks(kChunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t c = b; c < e; ++c) {
      std::uint32_t* h = hist.data() + c * kBins;
      for (std::size_t i = c * chunk; i < std::min(n, (c + 1) * chunk); ++i) ++h[bin(values[i])];
    }
  });
  std::size_t target = kBins, before = 0;
  for (std::size_t b = 0; b < kBins; ++b) {
    std::size_t count = 0;
    for (std::size_t c = 0; c < kChunks; ++c) count += hist[c * kBins + b];
    if (before + count > k) {
      target = b;
      break;
    }
    before += count;
  }
  std::vector<double> in_bin;
  for (std::size_t i = 0; i < n; ++i)
    if (bin(values[i]) == target) in_bin.push_back(values[i]);
  const std::size_t kk = k - before;
  std::nth_element(in_bin.begin(), in_bin.begin() + static_cast<std::ptrdiff_t>(kk), in_bin.end());
  return in_bin[kk];
}

}  // namespace detail

FaceNormalsAndAreas face_normals_and_areas(const TriangleMesh& mesh) {
  FaceNormalsAndAreas out;
  const std::size_t nf = mesh.faces.size();
  out.normals.resize(nf);
  out.areas.resize(nf);
  detail::parallel_chunks(nf, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const auto t = detail::triangle_shape(mesh, mesh.faces[f]);
      out.areas[f] = 0.5 * t.twice_area;
      out.normals[f] = t.degenerate ? Vec3::Zero() : Vec3(t.cross / t.twice_area);
    }
  });
  return out;
}

std::vector<Vec3> mixed_voronoi_corner_areas(const TriangleMesh& mesh, MixedAreaScheme scheme) {
  const std::size_t nf = mesh.faces.size();
  std::vector<Vec3> out(nf);
  detail::parallel_chunks(nf, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f)
      out[f] = detail::corner_areas(detail::triangle_shape(mesh, mesh.faces[f]), scheme);
  });
  return out;
}

std::vector<double> vertex_areas_from_corners(const Topology& topology,
                                              const std::vector<Vec3>& corner_areas) {
  const std::size_t nv = topology.vertex_count();
  std::vector<double> out(nv, 0.0);
  detail::parallel_chunks(nv, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const auto faces = topology.vertex_faces(v);
      const auto corners = topology.vertex_face_corners(v);
      double a = 0.0;
      for (std::size_t i = 0; i < faces.size(); ++i) a += corner_areas[faces[i]][corners[i]];
      out[v] = a;
    }
  });
  return out;
}

std::vector<Vec3> vertex_normals(const TriangleMesh& mesh, const Topology& topology,
                                 NormalWeighting weighting) {
  const std::size_t nf = mesh.faces.size();
  const std::size_t nv = mesh.positions.size();
  std::vector<Vec3> fn(nf), w(nf);
  detail::parallel_chunks(nf, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const auto t = detail::triangle_shape(mesh, mesh.faces[f]);
      fn[f] = t.degenerate ? Vec3::Zero() : Vec3(t.cross / t.twice_area);
      w[f] = detail::normal_corner_weights(t, weighting);
    }
  });
  std::vector<Vec3> out(nv, Vec3::Zero());
  detail::parallel_chunks(nv, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const auto faces = topology.vertex_faces(v);
      const auto corners = topology.vertex_face_corners(v);
      Vec3 n = Vec3::Zero();
      double wsum = 0.0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const double wi = w[faces[i]][corners[i]];
        n += wi * fn[faces[i]];
        wsum += wi;
      }
      const double len = n.norm();
      if (len > 1e-10 * wsum && wsum > 0.0) out[v] = n / len;
    }
  });
  return out;
}

Vec3 rotate_to_tangent_plane(const Vec3& x, const Vec3& from, const Vec3& to) {
  return detail::rotate_tangent(x, from, to);
}

Vec3 face_gradient(const Surface& surface, std::size_t face, std::span<const double> field) {
  const Face& f = surface.faces()[face];
  const Vec3& n = surface.face_normals()[face];
  const double twice_area = 2.0 * surface.face_areas()[face];
  if (n.isZero() || !(twice_area > 0.0)) return Vec3::Zero();
  const auto& p = surface.positions();
  const Vec3 sum = field[f[0]] * (p[f[2]] - p[f[1]]) + field[f[1]] * (p[f[0]] - p[f[2]]) +
                   field[f[2]] * (p[f[1]] - p[f[0]]);
  return n.cross(sum) / twice_area;
}

std::vector<Vec3> face_gradients(const Surface& surface, std::span<const double> field) {
  check_field_size(field.size(), surface.vertex_count(), "face_gradients");
  const std::size_t nf = surface.face_count();
  std::vector<Vec3> out(nf);
  surface.face_normals();
  surface.face_areas();
  detail::parallel_chunks(nf, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) out[f] = face_gradient(surface, f, field);
  });
  return out;
}

std::vector<Vec3> vertex_gradients(const Surface& surface, std::span<const double> field) {
  check_field_size(field.size(), surface.vertex_count(), "vertex_gradients");
  const std::vector<Vec3> fg = face_gradients(surface, field);
  const auto& topo = surface.topology();
  const auto& fn = surface.face_normals();
  const auto& vn = surface.vertex_normals();
  const auto& ca = surface.corner_areas();
  const std::size_t nv = surface.vertex_count();
  std::vector<Vec3> out(nv, Vec3::Zero());
  detail::parallel_chunks(nv, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      if (vn[v].isZero()) continue;
      const auto faces = topo.vertex_faces(v);
      const auto corners = topo.vertex_face_corners(v);
      Vec3 g = Vec3::Zero();
      double wsum = 0.0;
      for (std::size_t i = 0; i < faces.size(); ++i) {
        const auto f = static_cast<std::size_t>(faces[i]);
        if (fn[f].isZero()) continue;
        const double w = ca[f][corners[i]];
        g += w * detail::rotate_tangent(fg[f], fn[f], vn[v]);
        wsum += w;
      }
      if (wsum > 0.0) out[v] = g / wsum;
    }
  });
  return out;
}

std::vector<double> covariant_derivative(const Surface& surface, std::span<const double> field,
                                         std::span<const Vec3> directions) {
  check_field_size(directions.size(), surface.vertex_count(), "covariant_derivative (directions)");
  const std::vector<Vec3> g = vertex_gradients(surface, field);
  std::vector<double> out(g.size());
  for (std::size_t v = 0; v < g.size(); ++v) out[v] = g[v].dot(directions[v]);
  return out;
}

BoundingSphere bounding_sphere(const std::vector<Vec3>& points) {
  BoundingSphere s;
  if (points.empty()) return s;
  auto farthest = [&](const Vec3& from) {
    std::size_t best = 0;
    double bd = -1.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double d = (points[i] - from).squaredNorm();
      if (d > bd) {
        bd = d;
        best = i;
      }
    }
    return best;
  };
  const Vec3 y = points[farthest(points[0])];
  const Vec3 z = points[farthest(y)];
  s.center = 0.5 * (y + z);
  s.radius = 0.5 * (y - z).norm();
  for (const Vec3& p : points) {
    const double d = (p - s.center).norm();
    if (d > s.radius) {
      const double r = 0.5 * (s.radius + d);
      s.center += ((d - r) / d) * (p - s.center);
      s.radius = r;
    }
  }
  // Exact final pass: rounding in the growth steps never leaves a point out.
  double r2 = s.radius * s.radius;
  for (const Vec3& p : points) r2 = std::max(r2, (p - s.center).squaredNorm());
  s.radius = std::sqrt(r2);
  return s;
}

EdgeLengthStatistics edge_length_statistics(const TriangleMesh& mesh, const Topology& topology) {
  EdgeLengthStatistics st;
  const std::size_t ne = topology.edge_count();
  if (ne == 0) return st;
  std::vector<double> len(ne);
  // The edges' pairs are one array (Topology::edge reads it after checking,
  // per call, that it is held: released edges are rebuilt on first use).
  const std::array<std::int32_t, 2>* const edges = &topology.edge(0);
  detail::parallel_chunks(ne, 8192, [&](std::size_t begin, std::size_t end) {
    for (std::size_t e = begin; e < end; ++e) {
      const auto& ed = edges[e];
      len[e] = (mesh.positions[ed[0]] - mesh.positions[ed[1]]).norm();
    }
  });
  double sum = 0.0;
  st.min = len[0];
  st.max = len[0];
  for (double l : len) {
    sum += l;
    st.min = std::min(st.min, l);
    st.max = std::max(st.max, l);
  }
  st.mean = sum / static_cast<double>(ne);
  st.median = detail::kth_smallest(len, ne / 2);
  return st;
}

}  // namespace fabrica
