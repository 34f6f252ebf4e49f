// Helpers shared by the tests: where the bundled data lives, analytic test
// surfaces (sphere, cylinder, torus, ellipsoid, plane) at any resolution.
#pragma once

#include <filesystem>
#include <string>

#include "fabrica/core/mesh.hpp"

namespace fabrica::test {

/// The bundled real data, unpacked from tests/data/ into the build folder:
/// meshes/ (anatomy, classic, volumes; tests/data/SOURCES.md).
std::filesystem::path bundled_data();
/// The bundled reference lines: rtsc/ (index.tsv and NAME_vK.seg.xz).
std::filesystem::path bundled_reference();
/// A fresh empty temporary folder for one test (unique per process).
std::filesystem::path temp_dir(const std::string& name);

/// UV sphere of radius r with `rings` latitude bands and `segments` longitudes.
TriangleMesh make_sphere(double r, int rings, int segments);
/// Geodesic icosphere (subdivided icosahedron) of radius r.
TriangleMesh make_icosphere(double r, int subdivisions);
/// Open cylinder of radius r and length h along z.
TriangleMesh make_cylinder(double r, double h, int rings, int segments);
/// Grid-triangulated torus (major R, minor r), nu x nv vertices; jitter moves
/// every vertex by up to `jitter` times the local edge length along the
/// surface, with a fixed seed.
TriangleMesh make_torus(double R, double r, int nu, int nv, double jitter = 0.0);
/// Ellipsoid with semi-axes a, b, c (a UV sphere scaled).
TriangleMesh make_ellipsoid(double a, double b, double c, int rings, int segments);
/// Flat square grid [0,s]^2 in z = 0 with n x n vertices.
TriangleMesh make_plane(double s, int n);

}  // namespace fabrica::test
