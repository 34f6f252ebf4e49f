#include "test_support.hpp"

#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <string>

#include <unistd.h>

namespace fabrica::test {

std::filesystem::path bundled_data() { return FABRICA_TEST_MESHES; }
std::filesystem::path bundled_reference() { return FABRICA_TEST_REFERENCE; }

std::filesystem::path temp_dir(const std::string& name) {
  // ctest runs every test case as its own process, several at once: the
  // process id keeps two cases that use the same name apart.
  auto dir = std::filesystem::temp_directory_path() /
             ("fabrica-test-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

namespace {

constexpr double kPi = std::numbers::pi;

// A (rings+1) x segments grid on a surface of revolution-like map with
// closed poles collapsed to single vertices: f(theta in [0,pi], phi).
template <class F>
TriangleMesh make_closed_uv(int rings, int segments, F f) {
  TriangleMesh m;
  m.positions.push_back(f(0.0, 0.0));
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j)
      m.positions.push_back(f(kPi * i / rings, 2 * kPi * j / segments));
  m.positions.push_back(f(kPi, 0.0));
  const int south = static_cast<int>(m.positions.size()) - 1;
  auto idx = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) m.faces.push_back({0, idx(1, j), idx(1, j + 1)});
  for (int i = 1; i < rings - 1; ++i)
    for (int j = 0; j < segments; ++j) {
      m.faces.push_back({idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)});
      m.faces.push_back({idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)});
    }
  for (int j = 0; j < segments; ++j) m.faces.push_back({idx(rings - 1, j), south, idx(rings - 1, j + 1)});
  return m;
}

}  // namespace

TriangleMesh make_sphere(double r, int rings, int segments) {
  return make_closed_uv(rings, segments, [r](double t, double p) {
    return Vec3(r * std::sin(t) * std::cos(p), r * std::sin(t) * std::sin(p), r * std::cos(t));
  });
}

TriangleMesh make_ellipsoid(double a, double b, double c, int rings, int segments) {
  return make_closed_uv(rings, segments, [=](double t, double p) {
    return Vec3(a * std::sin(t) * std::cos(p), b * std::sin(t) * std::sin(p), c * std::cos(t));
  });
}

TriangleMesh make_icosphere(double r, int subdivisions) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  TriangleMesh m;
  m.positions = {{-1, g, 0}, {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                 {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  m.faces = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
             {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      m.positions.push_back(0.5 * (m.positions[a] + m.positions[b]));
      return mid[key] = static_cast<int>(m.positions.size()) - 1;
    };
    std::vector<Face> faces;
    for (const Face& f : m.faces) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      faces.push_back({f[0], ab, ca});
      faces.push_back({f[1], bc, ab});
      faces.push_back({f[2], ca, bc});
      faces.push_back({ab, bc, ca});
    }
    m.faces = std::move(faces);
  }
  for (Vec3& p : m.positions) p = r * p.normalized();
  return m;
}

TriangleMesh make_cylinder(double r, double h, int rings, int segments) {
  TriangleMesh m;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double p = 2 * kPi * j / segments;
      m.positions.emplace_back(r * std::cos(p), r * std::sin(p), -0.5 * h + h * i / rings);
    }
  auto idx = [&](int i, int j) { return i * segments + (j % segments); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.faces.push_back({idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)});
      m.faces.push_back({idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)});
    }
  return m;
}

TriangleMesh make_torus(double R, double r, int nu, int nv, double jitter) {
  TriangleMesh m;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const double du = 2 * kPi / nu, dv = 2 * kPi / nv;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      // Jitter in parameter space keeps every vertex exactly on the torus.
      const double u = i * du + jitter * du * uni(rng);
      const double v = j * dv + jitter * dv * uni(rng);
      m.positions.emplace_back((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                               r * std::sin(v));
    }
  auto idx = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.faces.push_back({idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)});
      m.faces.push_back({idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)});
    }
  return m;
}

TriangleMesh make_plane(double s, int n) {
  TriangleMesh m;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) m.positions.emplace_back(s * j / (n - 1), s * i / (n - 1), 0.0);
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j;
      m.faces.push_back({a, a + 1, a + n + 1});
      m.faces.push_back({a, a + n + 1, a + n});
    }
  return m;
}

}  // namespace fabrica::test
