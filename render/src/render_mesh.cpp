#include "fabrica/render/render_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica::render {

namespace {

void bounding_sphere(RenderMesh& m) {
  const std::size_t n = m.vertex_count();
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 p(m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  m.center = 0.5 * (lo + hi);
  m.box_min = lo;
  m.box_max = hi;
  double r2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 p(m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]);
    r2 = std::max(r2, (p - m.center).squaredNorm());
  }
  m.radius = std::sqrt(r2);
  double sum = 0.0;
  const std::size_t t = m.triangle_count();
  for (std::size_t f = 0; f < t; ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = m.indices[3 * f + k], b = m.indices[3 * f + (k + 1) % 3];
      const Vec3 pa(m.positions[3 * a], m.positions[3 * a + 1], m.positions[3 * a + 2]);
      const Vec3 pb(m.positions[3 * b], m.positions[3 * b + 1], m.positions[3 * b + 2]);
      sum += (pa - pb).norm();
    }
  }
  m.mean_edge_length = t ? sum / double(3 * t) : 0.0;
}

// Every directed edge (a, b) once and its twin (b, a) once: closed and
// consistently oriented; then outward if the signed volume is positive.
bool is_closed_outward(const RenderMesh& m) {
  const std::size_t t = m.triangle_count();
  if (t == 0) return false;
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * t);
  double volume = 0.0;
  for (std::size_t f = 0; f < t; ++f) {
    const std::uint32_t* v = &m.indices[3 * f];
    for (int k = 0; k < 3; ++k) edges.push_back(std::uint64_t(v[k]) << 32 | v[(k + 1) % 3]);
    auto p = [&](int k) {
      const float* q = &m.positions[3 * std::size_t(v[k])];
      return Vec3(q[0], q[1], q[2]);
    };
    volume += p(0).dot(p(1).cross(p(2)));
  }
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size(); ++i) {
    if (i + 1 < edges.size() && edges[i + 1] == edges[i]) return false;  // twice the same way
    const std::uint64_t twin = edges[i] << 32 | edges[i] >> 32;
    if (!std::binary_search(edges.begin(), edges.end(), twin)) return false;  // a border
  }
  return volume > 0.0;
}

}  // namespace

RenderMesh make_render_mesh(const TriangleMesh& mesh, const std::vector<Vec3>& normals) {
  if (mesh.positions.empty() || mesh.faces.empty())
    throw InputError("cannot draw an empty mesh (no vertices or no faces)");
  if (normals.size() != mesh.positions.size())
    throw InputError("render mesh: " + std::to_string(normals.size()) + " normals for " +
                     std::to_string(mesh.positions.size()) + " vertices");
  RenderMesh m;
  const std::size_t n = mesh.positions.size();
  m.positions.resize(3 * n);
  m.normals.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      m.positions[3 * i + c] = static_cast<float>(mesh.positions[i][c]);
      m.normals[3 * i + c] = static_cast<float>(normals[i][c]);
    }
  }
  m.indices.reserve(3 * mesh.faces.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const auto v = mesh.faces[f][k];
      if (v < 0 || static_cast<std::size_t>(v) >= n)
        throw InputError("render mesh: face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(v) + " of " + std::to_string(n));
      m.indices.push_back(static_cast<std::uint32_t>(v));
    }
  }
  bounding_sphere(m);
  m.closed_outward = is_closed_outward(m);
  return m;
}

RenderMesh make_render_mesh(const TriangleMesh& mesh) {
  std::vector<Vec3> normals(mesh.positions.size(), Vec3::Zero());
  const auto n = static_cast<std::int64_t>(mesh.positions.size());
  for (const auto& f : mesh.faces) {
    if (f[0] < 0 || f[1] < 0 || f[2] < 0 || f[0] >= n || f[1] >= n || f[2] >= n)
      continue;  // make_render_mesh(mesh, normals) reports it
    const Vec3 &a = mesh.positions[f[0]], &b = mesh.positions[f[1]], &c = mesh.positions[f[2]];
    const Vec3 area = (b - a).cross(c - a);  // twice the area, along the face's normal
    for (int k = 0; k < 3; ++k) normals[f[k]] += area;
  }
  for (Vec3& v : normals) {
    const double len = v.norm();
    v = len > 0.0 && std::isfinite(len) ? Vec3(v / len) : Vec3::Zero();
  }
  return make_render_mesh(mesh, normals);
}

void set_curvature(RenderMesh& m, const std::vector<double>& k1, const std::vector<double>& k2,
                   const std::vector<Vec3>& e1, const std::vector<Vec3>& e2) {
  const std::size_t n = m.vertex_count();
  if (k1.size() != n || k2.size() != n || e1.size() != n || e2.size() != n)
    throw InputError("render mesh: curvature arrays do not match the vertex count");
  m.k1.resize(n);
  m.k2.resize(n);
  m.e1.resize(3 * n);
  m.e2.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    m.k1[i] = static_cast<float>(k1[i]);
    m.k2[i] = static_cast<float>(k2[i]);
    for (int c = 0; c < 3; ++c) {
      m.e1[3 * i + c] = static_cast<float>(e1[i][c]);
      m.e2[3 * i + c] = static_cast<float>(e2[i][c]);
    }
  }
}

}  // namespace fabrica::render
