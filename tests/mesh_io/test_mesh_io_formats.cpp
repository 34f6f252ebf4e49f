// Round trips through every writable format and the format features the
// readers promise (OBJ reference forms, polygons, PLY tristrips and
// endianness, OFF variants, STL detection and welding, SPACE tags).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "fabrica/io/mesh_io.hpp"
#include "mesh_io_test_util.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

using io::read_mesh;
using io::write_mesh;

struct WriteCase {
  const char* ext;
  bool binary;
  bool float_precision;  // positions stored as float (binary STL)
  bool soup;             // vertex order = first appearance (STL)
};

class RoundTrip : public ::testing::TestWithParam<WriteCase> {};

/// Vertices renumbered in order of first appearance in the faces (STL order).
std::vector<int> first_appearance(const TriangleMesh& m) {
  std::vector<int> order(m.vertex_count(), -1);
  int next = 0;
  for (const Face& f : m.faces)
    for (int v : f)
      if (order[static_cast<std::size_t>(v)] < 0) order[static_cast<std::size_t>(v)] = next++;
  return order;
}

TEST_P(RoundTrip, KeepsPositionsFacesOrderAndSpaceTag) {
  const WriteCase c = GetParam();
  TriangleMesh mesh = test::make_torus(30.0, 9.0, 24, 16, 0.2);
  // Coordinates that are not short decimals, some negative, far from origin.
  for (Vec3& p : mesh.positions) p = p * 1.0000001 + Vec3(-123.456789, 0.1, 1e3 / 3.0);
  mesh.space = Space::ras;
  const auto dir = test::temp_dir(std::string("mesh_io_rt_") + c.ext + (c.binary ? "b" : "a"));
  const auto path = dir / (std::string("torus.") + c.ext);
  io::WriteOptions wo;
  wo.binary = c.binary;
  write_mesh(mesh, path, wo);
  const io::LoadedMesh loaded = read_mesh(path);

  EXPECT_EQ(loaded.mesh.space, Space::ras);
  EXPECT_EQ(loaded.mesh.space_source, SpaceSource::file_tag);
  ASSERT_TRUE(loaded.info.tagged_space.has_value());
  EXPECT_EQ(loaded.info.binary,
            c.binary && (std::string(c.ext) == "ply" || std::string(c.ext) == "stl"));
  ASSERT_EQ(loaded.mesh.vertex_count(), mesh.vertex_count());
  ASSERT_EQ(loaded.mesh.face_count(), mesh.face_count());

  std::vector<int> map(mesh.vertex_count());
  if (c.soup)
    map = first_appearance(mesh);
  else
    for (std::size_t i = 0; i < map.size(); ++i) map[i] = static_cast<int>(i);

  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const Vec3& got = loaded.mesh.positions[static_cast<std::size_t>(map[i])];
    for (int k = 0; k < 3; ++k) {
      const double expected = c.float_precision
                                  ? static_cast<double>(static_cast<float>(mesh.positions[i][k]))
                                  : mesh.positions[i][k];
      ASSERT_EQ(got[k], expected) << c.ext << " vertex " << i << " coordinate " << k;
    }
  }
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(loaded.mesh.faces[f][k], map[static_cast<std::size_t>(mesh.faces[f][k])])
          << c.ext << " face " << f;

  // Without the tag the space is the documented default.
  wo.write_space_tag = false;
  write_mesh(mesh, path, wo);
  const io::LoadedMesh untagged = read_mesh(path);
  EXPECT_FALSE(untagged.info.tagged_space.has_value());
  EXPECT_EQ(untagged.mesh.space, Space::lps);
  EXPECT_EQ(untagged.mesh.space_source, SpaceSource::default_assumed);
}

INSTANTIATE_TEST_SUITE_P(
    AllWritableFormats, RoundTrip,
    ::testing::Values(WriteCase{"obj", false, false, false}, WriteCase{"off", false, false, false},
                      WriteCase{"ply", true, false, false}, WriteCase{"ply", false, false, false},
                      WriteCase{"stl", true, true, true}, WriteCase{"stl", false, false, true}),
    [](const auto& info) {
      return std::string(info.param.ext) + (info.param.binary ? "_binary" : "_ascii");
    });

TEST(MeshIoSpace, UserOverrideWinsOverTagAndCoordinatesAreUnchanged) {
  const auto dir = test::temp_dir("mesh_io_space");
  test::write_bytes(dir / "tagged.obj",
                    "# Created by 3D Slicer SPACE=RAS\nv 1 2 3\nv 4 5 6\nv 7 8 10\nf 1 2 3\n");
  const auto tagged = read_mesh(dir / "tagged.obj");
  EXPECT_EQ(tagged.mesh.space, Space::ras);
  EXPECT_EQ(tagged.mesh.space_source, SpaceSource::file_tag);
  io::ReadOptions ro;
  ro.space = Space::lps;
  const auto overridden = read_mesh(dir / "tagged.obj", ro);
  EXPECT_EQ(overridden.mesh.space, Space::lps);
  EXPECT_EQ(overridden.mesh.space_source, SpaceSource::user_override);
  EXPECT_EQ(overridden.info.tagged_space, Space::ras);
  EXPECT_EQ(overridden.mesh.positions[2], Vec3(7, 8, 10));  // label only, no flip

  // Slicer's binary STL header and ascii `solid` line.
  std::string header(80, ' ');
  std::memcpy(header.data(), "SPACE=LPS", 9);
  std::string stl = header;
  const std::uint32_t n = 1;
  stl.append(reinterpret_cast<const char*>(&n), 4);
  const float rec[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  stl.append(reinterpret_cast<const char*>(rec), sizeof rec);
  stl.append(2, '\0');
  test::write_bytes(dir / "slicer.stl", stl);
  EXPECT_EQ(read_mesh(dir / "slicer.stl").mesh.space_source, SpaceSource::file_tag);
  test::write_bytes(dir / "ascii.stl",
                    "solid Slicer SPACE=RAS\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                    "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid Slicer\n");
  EXPECT_EQ(read_mesh(dir / "ascii.stl").mesh.space, Space::ras);
  test::write_bytes(
      dir / "tag.ply",
      "ply\nformat ascii 1.0\ncomment SPACE=RAS\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(read_mesh(dir / "tag.ply").mesh.space, Space::ras);
}

TEST(MeshIoObj, ReferenceFormsNegativeIndicesPolygonsComments) {
  const auto dir = test::temp_dir("mesh_io_obj");
  test::write_bytes(dir / "forms.obj",
                    "# comment\r\nmtllib x.mtl\r\no thing\r\n"
                    "v 0 0 0\r\nv 1 0 0 1.0\r\nv 1 1 0 0.5 0.5 0.5\r\nv 0 1 0\r\n"
                    "vt 0 0\nvn 0 0 1\n"
                    "g group\nusemtl m\ns off\n"
                    "f 1/1/1 2/1/1 3/1/1\n"
                    "f -4//1 -2//1 -1//1  # trailing comment\n"
                    "v 0.5 0.5 1\n"
                    "f 1/1 2/1 5/1 4/1\n"  // quad -> 2 triangles
                    "l 1 2\n");
  const auto r = read_mesh(dir / "forms.obj");
  ASSERT_EQ(r.mesh.vertex_count(), 5u);
  const std::vector<Face> expected = {{0, 1, 2}, {0, 2, 3}, {0, 1, 4}, {0, 4, 3}};
  EXPECT_EQ(r.mesh.faces, expected);
  EXPECT_EQ(r.info.file_polygons, 3u);
  EXPECT_EQ(r.info.triangulated_polygons, 1u);
  EXPECT_EQ(r.mesh.positions[1], Vec3(1, 0, 0));
  EXPECT_EQ(r.mesh.positions[4], Vec3(0.5, 0.5, 1));
  EXPECT_TRUE(r.info.file_normals.empty());  // not asked for

  // A UTF-8 byte-order mark must not hide the first vertex.
  test::write_bytes(dir / "bom.obj", "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(read_mesh(dir / "bom.obj").mesh.vertex_count(), 3u);
}

TEST(MeshIoPly, TriangleStripsWithRestartsAndDegenerates) {
  const auto dir = test::temp_dir("mesh_io_strips");
  // Strip 0 1 2 3 4, restart, 5 6 7 7 8 (a repeated vertex: degenerate
  // triangles 6 7 7 and 7 7 8 are dropped).
  std::string header =
      "ply\nformat ascii 1.0\nelement vertex 9\nproperty float x\nproperty float y\n"
      "property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n";
  std::string body;
  for (int i = 0; i < 9; ++i)
    body +=
        std::to_string(i % 3) + " " + std::to_string(i / 3) + " " + std::to_string(i * i) + "\n";
  body += "11 0 1 2 3 4 -1 5 6 7 7 8\n";
  test::write_bytes(dir / "strips.ply", header + body);
  const auto r = read_mesh(dir / "strips.ply");
  const std::vector<Face> expected = {{0, 1, 2}, {1, 3, 2}, {2, 3, 4}, {5, 6, 7}};
  EXPECT_EQ(r.mesh.faces, expected);
  ASSERT_EQ(r.info.notes.size(), 1u);
  EXPECT_NE(r.info.notes[0].find("2 degenerate"), std::string::npos) << r.info.notes[0];
}

// A face element of triangles, or a triangle strip, is read into storage of
// its size (reserved from the element count or the strip's length, not
// grown by doubling: up to twice the memory).
TEST(MeshIoPly, TriangleFacesAreReadWithoutOverReserve) {
  const auto dir = test::temp_dir("mesh_io_ply_reserve");
  const int n = 1000;
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face " +
      std::to_string(n) + "\nproperty list uchar int vertex_indices\n";
  std::string ascii = head;
  ascii += "end_header\n0 0 0\n1 0 0\n0 1 0\n";
  for (int i = 0; i < n; ++i) ascii += "3 0 1 2\n";
  std::string binary = head;
  binary.replace(binary.find("ascii"), 5, "binary_little_endian");
  binary += "end_header\n";
  for (int v = 0; v < 3; ++v) {
    const float p[3] = {v == 1 ? 1.0f : 0.0f, v == 2 ? 1.0f : 0.0f, 0.0f};
    binary.append(reinterpret_cast<const char*>(p), sizeof p);
  }
  for (int i = 0; i < n; ++i) {
    const std::uint8_t three = 3;
    const std::int32_t c[3] = {0, 1, 2};
    binary.append(reinterpret_cast<const char*>(&three), 1);
    binary.append(reinterpret_cast<const char*>(c), sizeof c);
  }
  // And one strip of n triangles (n + 2 indices, alternating 0 1 2 3 ...).
  std::string strip =
      "ply\nformat ascii 1.0\nelement vertex " + std::to_string(n + 2) +
      "\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\n"
      "property list int int vertex_indices\nend_header\n";
  for (int v = 0; v < n + 2; ++v)
    strip += std::to_string(v / 2) + " " + std::to_string(v % 2) + " 0\n";
  strip += std::to_string(n + 2);
  for (int v = 0; v < n + 2; ++v) strip += " " + std::to_string(v);
  strip += "\n";
  for (const auto& [name, bytes] :
       {std::pair{"a.ply", ascii}, std::pair{"b.ply", binary}, std::pair{"s.ply", strip}}) {
    test::write_bytes(dir / name, bytes);
    const auto r = read_mesh(dir / name);
    ASSERT_EQ(r.mesh.faces.size(), static_cast<std::size_t>(n)) << name;
    EXPECT_EQ(r.mesh.faces.capacity(), r.mesh.faces.size()) << name;
  }
}

TEST(MeshIoPly, BigAndLittleEndianAnyPropertyOrderAndTypes) {
  const auto dir = test::temp_dir("mesh_io_ply_endian");
  // Properties in unusual order and types, an extra element with a list.
  auto make = [](bool big) {
    std::string h = std::string("ply\nformat ") +
                    (big ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\nelement vertex 4\nproperty uchar red\nproperty double z\n"
                    "property short x\nproperty float y\nproperty float nx\nproperty float ny\n"
                    "property float nz\nelement material 1\nproperty list uchar float stuff\n"
                    "element face 1\nproperty int flags\nproperty list uint8 uint32 vertex_index\n"
                    "end_header\n";
    std::string b;
    auto put = [&](const void* v, std::size_t n) {
      std::string bytes(static_cast<const char*>(v), n);
      if (big) std::reverse(bytes.begin(), bytes.end());
      b += bytes;
    };
    for (int i = 0; i < 4; ++i) {
      const std::uint8_t red = 7;
      const double z = 0.25 * i;
      const std::int16_t x = static_cast<std::int16_t>(-i);
      const float y = 1.5f * static_cast<float>(i);
      const float n[3] = {0, 0, 1};
      put(&red, 1), put(&z, 8), put(&x, 2), put(&y, 4), put(&n[0], 4), put(&n[1], 4), put(&n[2], 4);
    }
    const std::uint8_t two = 2;
    const float f = 1;
    put(&two, 1), put(&f, 4), put(&f, 4);
    const std::int32_t flags = 99;
    const std::uint8_t four = 4;
    put(&flags, 4), put(&four, 1);
    for (std::uint32_t v : {0u, 1u, 2u, 3u}) put(&v, 4);
    return h + b;
  };
  for (bool big : {false, true}) {
    const auto path = dir / (big ? "big.ply" : "little.ply");
    test::write_bytes(path, make(big));
    io::ReadOptions ro;
    ro.keep_file_normals = true;
    const auto r = read_mesh(path, ro);
    ASSERT_EQ(r.mesh.vertex_count(), 4u);
    EXPECT_TRUE(r.info.binary);
    for (int i = 0; i < 4; ++i)
      EXPECT_EQ(r.mesh.positions[static_cast<std::size_t>(i)], Vec3(-i, 1.5 * i, 0.25 * i)) << big;
    const std::vector<Face> expected = {{0, 1, 2}, {0, 2, 3}};
    EXPECT_EQ(r.mesh.faces, expected);
    ASSERT_EQ(r.info.file_normals.size(), 4u);
    EXPECT_EQ(r.info.file_normals[3], Vec3(0, 0, 1));
  }
}

TEST(MeshIoOff, HeaderVariantsColoursCommentsNormals) {
  const auto dir = test::temp_dir("mesh_io_off");
  test::write_bytes(dir / "c.off",
                    "COFF\n# a comment\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
                    "# SPACE=RAS\n1 1 0 0 0 255 255\n0 1 0 1 1 1 1\n4 0 1 2 3 0.5 0.5 0.5\n"
                    "3 0 2 3\n");
  const auto c = read_mesh(dir / "c.off");
  EXPECT_EQ(c.mesh.vertex_count(), 4u);
  const std::vector<Face> expected = {{0, 1, 2}, {0, 2, 3}, {0, 2, 3}};
  EXPECT_EQ(c.mesh.faces, expected);
  EXPECT_EQ(c.mesh.space, Space::ras);
  test::write_bytes(dir / "n.off",
                    "NOFF 3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0.6 0 0.8\n3 0 1 2\n");
  io::ReadOptions ro;
  ro.keep_file_normals = true;
  const auto n = read_mesh(dir / "n.off", ro);
  ASSERT_EQ(n.info.file_normals.size(), 3u);
  EXPECT_EQ(n.info.file_normals[2], Vec3(0.6, 0, 0.8));
  EXPECT_EQ(n.mesh.positions[2], Vec3(0, 1, 0));
}

TEST(MeshIoStl, AsciiMultipleSolidsWeldExactlyAndSolidHeaderedBinary) {
  const auto dir = test::temp_dir("mesh_io_stl");
  // Two solids; 0 and 1e-30 are different points and must not be welded.
  test::write_bytes(dir / "two.stl",
                    "solid a\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n"
                    "   vertex 0 1 0\n  endloop\n endfacet\nendsolid a\n"
                    "solid b\n facet normal 0 0 1\n  outer loop\n   vertex 1 0 0\n   vertex 1 1 0\n"
                    "   vertex 0 1 0\n  endloop\n endfacet\n facet normal 0 0 1\n  outer loop\n"
                    "   vertex 1e-30 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\n"
                    "endsolid b\n");
  const auto r = read_mesh(dir / "two.stl");
  EXPECT_FALSE(r.info.binary);
  EXPECT_EQ(r.mesh.vertex_count(), 5u);
  EXPECT_EQ(r.info.file_vertices, 9u);
  EXPECT_EQ(r.info.welded_vertices, 4u);
  const std::vector<Face> expected = {{0, 1, 2}, {1, 3, 2}, {4, 1, 2}};
  EXPECT_EQ(r.mesh.faces, expected);

  // A binary STL whose header starts with "solid" (common) is still binary.
  std::string stl(80, ' ');
  std::memcpy(stl.data(), "solid exported", 14);
  const std::uint32_t n = 2;
  stl.append(reinterpret_cast<const char*>(&n), 4);
  const float t[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0},
                          {0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 0}};
  for (const auto& rec : t) {
    stl.append(reinterpret_cast<const char*>(rec), sizeof rec);
    stl.append(2, '\0');
  }
  test::write_bytes(dir / "solid_binary.stl", stl);
  const auto b = read_mesh(dir / "solid_binary.stl");
  EXPECT_TRUE(b.info.binary);
  EXPECT_EQ(b.mesh.vertex_count(), 4u);
  const std::vector<Face> expected_b = {{0, 1, 2}, {1, 3, 2}};
  EXPECT_EQ(b.mesh.faces, expected_b);
}

TEST(MeshIoWrite, RejectsUnknownExtensionAndLeavesNothingBehind) {
  const auto dir = test::temp_dir("mesh_io_write");
  const TriangleMesh mesh = test::make_icosphere(1.0, 1);
  EXPECT_THROW(write_mesh(mesh, dir / "x.vtp"), InputError);
  EXPECT_THROW(write_mesh(mesh, dir / "missing_folder" / "x.obj"), OutputError);
  TriangleMesh bad = mesh;
  bad.faces[3][1] = 1000;
  EXPECT_THROW(write_mesh(bad, dir / "bad.obj"), InputError);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace
}  // namespace fabrica
