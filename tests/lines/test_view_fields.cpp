// The per-view vertex pass (n·v, K_r, the suggestive numerator, q1, t1 and
// the sign bytes) has two implementations: four vertices at a time with
// 256-bit vectors from LinePrecompute::vertex_blocks() (used when a
// precompute is given and the CPU has AVX2), and the portable one (two at a
// time with SSE2, or one by one). Both must give the same bits, on every
// vertex, including vertices whose curvature is invalid and the partial
// last block.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/extract.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

template <class T>
std::size_t differing_bits(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size()) + 1;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(T)) != 0;
  return n;
}

void expect_same_vertex_pass(const Surface& surface, const Camera& camera, bool cull) {
  LinePrecompute pre(surface);
  ViewFieldsRequest req;
  req.apparent_cull_threshold = cull ? std::optional<double>(1.0e3) : std::nullopt;
  const ViewFields simd = compute_view_fields(surface, camera, req, &pre);
  const ViewFields portable = compute_view_fields(surface, camera, req, nullptr);
  EXPECT_EQ(differing_bits(simd.ndotv, portable.ndotv), 0u);
  EXPECT_EQ(differing_bits(simd.kr, portable.kr), 0u);
  EXPECT_EQ(differing_bits(simd.sc_num, portable.sc_num), 0u);
  EXPECT_EQ(differing_bits(simd.q1, portable.q1), 0u);
  EXPECT_EQ(differing_bits(simd.t1, portable.t1), 0u);
  EXPECT_EQ(differing_bits(simd.t1_world, portable.t1_world), 0u);
  EXPECT_EQ(differing_bits(simd.signs, portable.signs), 0u);
}

// With `degenerate`, five vertices at one point joined by two zero-area
// faces are put first, so the first two blocks of four mix vertices with
// invalid curvature and valid ones.
Surface load(const char* rel, bool degenerate) {
  auto loaded = io::read_mesh(test::shared_data() / rel);
  io::prepare_for_lines(loaded.mesh);
  TriangleMesh mesh = std::move(loaded.mesh);
  if (degenerate) {
    TriangleMesh m;
    m.positions.assign(5, mesh.positions[0]);
    m.positions.insert(m.positions.end(), mesh.positions.begin(), mesh.positions.end());
    m.faces = {{0, 1, 2}, {2, 3, 4}};
    for (Face f : mesh.faces) m.faces.push_back({f[0] + 5, f[1] + 5, f[2] + 5});
    mesh = std::move(m);
  }
  return Surface(std::move(mesh));
}

}  // namespace

TEST(LinesViewFields, VertexPassSameBitsWithAndWithoutVertexBlocks) {
  for (const char* rel : {"meshes/anatomy/bones/gfxmorph_femur.stl", "meshes/classic/c3d_cow.obj",
                          "meshes/classic/libigl_camelhead.off"}) {
    SCOPED_TRACE(rel);
    const Surface surface = load(rel, std::string(rel).find("classic") != std::string::npos);
    const auto& valid = surface.curvature().valid;
    std::size_t invalid = 0;
    for (auto v : valid) invalid += v == 0;
    const BoundingBox box = bounding_box(surface.positions());
    Camera c;
    c.center = box.center();
    c.eye = c.center + Vec3(0.3, 0.2, 1.0).normalized() * 2.5 * box.diagonal();
    c.up = Vec3::UnitY();
    c.fov_deg = 30.0;
    c.width = c.height = 512;
    expect_same_vertex_pass(surface, c, true);
    expect_same_vertex_pass(surface, c, false);
    c.projection = Projection::orthographic;
    expect_same_vertex_pass(surface, c, true);
    std::printf("%s: %zu vertices, %zu with invalid curvature\n", rel, valid.size(), invalid);
  }
}
