// Test helpers for surface curves: curves traced along a level set of a
// vertex function (points on edges), curves along vertex paths (points at
// vertices), a check that a curve is a valid edge polyline, small fan meshes.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface_curve.hpp"
#include "fabrica/core/topology.hpp"

namespace fabrica::test {

/// The zero set of a per-vertex function (no vertex value may be exactly 0)
/// as a surface curve of edge points: its first component, open if it meets
/// the boundary (then it starts on a boundary edge), closed otherwise.
inline SurfaceCurve level_set_curve(const TriangleMesh& mesh, const Topology& topology,
                                    const std::vector<double>& values) {
  auto crosses = [&](std::int32_t e) {
    const auto& ed = topology.edge(static_cast<std::size_t>(e));
    return (values[ed[0]] > 0.0) != (values[ed[1]] > 0.0);
  };
  auto point_on = [&](std::int32_t e) {
    const auto& ed = topology.edge(static_cast<std::size_t>(e));
    const double t = values[ed[0]] / (values[ed[0]] - values[ed[1]]);
    return from_edge_point(mesh, topology, EdgePoint{e, t});
  };
  auto other_crossing = [&](std::int32_t f, std::int32_t entry) {
    for (int k = 0; k < 3; ++k) {
      const auto e = topology.face_edge(static_cast<std::size_t>(f), k);
      if (e != entry && crosses(e)) return e;
    }
    return std::int32_t{-1};
  };
  auto other_face = [&](std::int32_t e, std::int32_t f) {
    const auto fs = topology.edge_faces(static_cast<std::size_t>(e));
    if (fs.size() != 2) return std::int32_t{-1};
    return fs[0] == f ? fs[1] : fs[0];
  };
  SurfaceCurve curve;
  std::int32_t start = -1;
  for (std::size_t e = 0; e < topology.edge_count(); ++e)
    if (topology.is_boundary_edge(e) && crosses(static_cast<std::int32_t>(e))) {
      start = static_cast<std::int32_t>(e);
      break;
    }
  curve.closed = start < 0;
  if (curve.closed)
    for (std::size_t e = 0; e < topology.edge_count() && start < 0; ++e)
      if (crosses(static_cast<std::int32_t>(e))) start = static_cast<std::int32_t>(e);
  if (start < 0) return curve;
  curve.points.push_back(point_on(start));
  std::int32_t face = topology.edge_faces(static_cast<std::size_t>(start))[0];
  std::int32_t entry = start;
  for (std::size_t guard = 0; guard < topology.edge_count(); ++guard) {
    const std::int32_t exit = other_crossing(face, entry);
    if (exit < 0 || exit == start) break;
    curve.points.push_back(point_on(exit));
    face = other_face(exit, face);
    if (face < 0) break;
    entry = exit;
  }
  return curve;
}

/// A curve through the given mesh vertices (each point at a vertex).
inline SurfaceCurve vertex_path_curve(const TriangleMesh& mesh, const Topology& topology,
                                      const std::vector<std::int32_t>& vertices,
                                      bool closed = false) {
  SurfaceCurve curve;
  curve.closed = closed;
  for (const auto v : vertices) {
    const auto f = topology.vertex_faces(static_cast<std::size_t>(v))[0];
    SurfacePoint p;
    p.face = f;
    for (int k = 0; k < 3; ++k)
      if (mesh.faces[static_cast<std::size_t>(f)][k] == v) p.bary[k] = 1.0;
    curve.points.push_back(p);
  }
  return curve;
}

/// Asserts that `curve` is a valid surface curve whose every point (except
/// the ends of an open curve) lies exactly on a mesh edge or vertex, and that
/// each segment i lies in points[i].face.
inline void expect_edge_polyline(const TriangleMesh& mesh, const Topology& topology,
                                 const SurfaceCurve& curve) {
  ASSERT_NO_THROW(validate_surface_curve(mesh, topology, curve));
  const std::size_t n = curve.points.size();
  for (std::size_t i = 0; i < n; ++i) {
    const SurfacePoint& p = curve.points[i];
    ASSERT_TRUE(p.bary.allFinite()) << "point " << i;
    EXPECT_GE(p.bary.minCoeff(), 0.0) << "point " << i;
    EXPECT_NEAR(p.bary.sum(), 1.0, 1e-12) << "point " << i;
    const bool endpoint = !curve.closed && (i == 0 || i + 1 == n);
    if (!endpoint) {
      EXPECT_EQ(p.bary.minCoeff(), 0.0) << "point " << i << " is not on an edge";
    }
    if (i + 1 < n || curve.closed) {
      const SurfacePoint& q = curve.points[(i + 1) % n];
      // q must be expressible in p's face: its support corners are corners of p.face.
      EXPECT_GE(common_face(mesh, topology, p, q), 0) << "segment " << i;
      const auto& F = mesh.faces[static_cast<std::size_t>(p.face)];
      const auto& G = mesh.faces[static_cast<std::size_t>(q.face)];
      for (int k = 0; k < 3; ++k)
        if (q.bary[k] > 1e-12) {
          const bool found = F[0] == G[k] || F[1] == G[k] || F[2] == G[k];
          EXPECT_TRUE(found) << "segment " << i << " leaves points[" << i << "].face";
        }
    }
  }
}

/// A fan of `count` triangles around vertex 0 at `apex`, with the ring
/// vertices 1..count at unit distance in xy, at heights z(k), plus an outer
/// ring (vertices count+1..2count) at radius 2 and the same heights, so the
/// fan's ring vertices are interior. Counter-clockwise seen from +z.
inline TriangleMesh make_fan(int count, const Vec3& apex, const std::function<double(int)>& z) {
  TriangleMesh m;
  m.positions.push_back(apex);
  for (int ring = 1; ring <= 2; ++ring)
    for (int k = 0; k < count; ++k) {
      const double a = 2.0 * std::numbers::pi * k / count;
      m.positions.emplace_back(ring * std::cos(a), ring * std::sin(a), ring * z(k));
    }
  for (int k = 0; k < count; ++k) {
    const int a = 1 + k, b = 1 + (k + 1) % count;
    m.faces.push_back({0, a, b});
    m.faces.push_back({a, a + count, b + count});
    m.faces.push_back({a, b + count, b});
  }
  return m;
}

/// Minimal ASCII OFF reader for triangle meshes (comment lines start with '#').
inline TriangleMesh read_off_triangles(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> tokens;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string tok;
    while (ls >> tok) tokens.push_back(tok);
  }
  TriangleMesh m;
  if (tokens.size() < 4 || tokens[0] != "OFF") return m;
  const std::size_t nv = std::stoul(tokens[1]), nf = std::stoul(tokens[2]);
  std::size_t k = 4;
  for (std::size_t v = 0; v < nv; ++v, k += 3)
    m.positions.emplace_back(std::stod(tokens[k]), std::stod(tokens[k + 1]),
                             std::stod(tokens[k + 2]));
  for (std::size_t f = 0; f < nf; ++f) {
    const int count = std::stoi(tokens[k]);
    if (count == 3)
      m.faces.push_back(
          {std::stoi(tokens[k + 1]), std::stoi(tokens[k + 2]), std::stoi(tokens[k + 3])});
    k += 1 + static_cast<std::size_t>(count);
  }
  return m;
}

}  // namespace fabrica::test
