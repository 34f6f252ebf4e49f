// STL reader and writer. Binary STL is recognised by its size (84 + 50 n
// bytes for n triangles), ascii STL by a leading `solid` and a successful
// parse. STL is a triangle soup: points with bit-identical coordinates are
// welded, vertices numbered in order of first appearance. Stored facet
// normals are ignored (writers compute them from the triangle).
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

struct AsciiStlError {
  const char* at;
  std::string what;
};

bool starts_with_solid(std::string_view data) {
  TextCursor c(data);
  c.skip_blanks();
  const std::string_view t = c.token();
  return iequals(t, "solid");
}

void parse_ascii_stl(std::string_view data, LoadedMesh& out, std::size_t& corners) {
  TextCursor c(data);
  TriangleMesh& mesh = out.mesh;
  PointWelder welder(data.size() / 250 + 16);
  auto expect = [&](const char* word) {
    const char* at = (c.skip_blanks(), c.p);
    if (!iequals(c.token(), word)) throw AsciiStlError{at, std::string("expected '") + word + "'"};
  };
  auto number = [&]() {
    double v = 0;
    const char* at = (c.skip_blanks(), c.p);
    if (!c.parse_double(v, true)) throw AsciiStlError{at, "expected a number"};
    return v;
  };
  expect("solid");
  if (!out.info.tagged_space) out.info.tagged_space = find_space_tag(c.rest_of_line());
  c.skip_line();
  for (;;) {
    c.skip_blanks();
    if (c.at_end()) {
      out.info.notes.push_back("ascii STL has no 'endsolid' line");
      return;
    }
    const char* at = c.p;
    const std::string_view key = c.token();
    if (iequals(key, "endsolid")) {
      c.skip_line();
      c.skip_blanks();
      if (c.at_end()) return;
      expect("solid");  // another solid follows
      c.skip_line();
      continue;
    }
    if (!iequals(key, "facet")) throw AsciiStlError{at, "expected 'facet' or 'endsolid'"};
    expect("normal");
    for (int k = 0; k < 3; ++k) (void)number();
    expect("outer");
    expect("loop");
    Face f;
    for (int k = 0; k < 3; ++k) {
      expect("vertex");
      Vec3 p;
      p.x() = number();
      p.y() = number();
      p.z() = number();
      f[k] = welder.insert(p, mesh.positions);
      ++corners;
    }
    expect("endloop");
    expect("endfacet");
    mesh.faces.push_back(f);
  }
}

}  // namespace

void read_stl(std::string_view data, const std::string& name, const ReadOptions&, LoadedMesh& out) {
  MeshFileInfo& info = out.info;
  TriangleMesh& mesh = out.mesh;
  info.format = "stl";
  std::uint64_t declared = 0;
  std::uint64_t binary_size = 0;
  if (data.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, data.data() + 80, 4);
    declared = n;
    binary_size = 84 + 50 * declared;
  }
  if (data.size() >= 84 && data.size() == binary_size) {
    if (declared > static_cast<std::uint64_t>(kMaxMeshElements))
      fail(name, "the header declares " + std::to_string(declared) + " triangles, more than the " +
                     std::to_string(kMaxMeshElements) + " fabrica reads");
    info.binary = true;
    info.tagged_space = find_space_tag(std::string_view(data.data(), 80));
    mesh.faces.resize(static_cast<std::size_t>(declared));
    PointWelder welder(static_cast<std::size_t>(declared) / 2 + 16);
    const char* p = data.data() + 84;
    for (std::size_t t = 0; t < declared; ++t, p += 50) {
      float xyz[9];
      std::memcpy(xyz, p + 12, sizeof xyz);  // skip the stored normal
      for (int k = 0; k < 3; ++k)
        mesh.faces[t][k] =
            welder.insert(Vec3(xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]), mesh.positions);
    }
    info.file_vertices = 3 * static_cast<std::size_t>(declared);
  } else if (starts_with_solid(data)) {
    std::size_t corners = 0;
    try {
      parse_ascii_stl(data, out, corners);
    } catch (const AsciiStlError& e) {
      fail(name, "not a valid ascii STL file: line " + std::to_string(line_number(data, e.at)) +
                     ": " + e.what +
                     (data.size() >= 84 ? " (nor a binary STL: " + std::to_string(data.size()) +
                                              " bytes does not match 84 + 50 x " +
                                              std::to_string(declared) + " triangles)"
                                        : ""));
    }
    info.binary = false;
    info.file_vertices = corners;
  } else if (data.size() >= 84 && data.size() < binary_size && declared < (1u << 26)) {
    fail(name, "truncated binary STL: the header declares " + std::to_string(declared) +
                   " triangles (" + std::to_string(binary_size) + " bytes) but the file has " +
                   std::to_string(data.size()) + " bytes");
  } else {
    fail(name, "not an STL file: neither ascii STL (starting with 'solid') nor binary STL (" +
                   std::to_string(data.size()) + " bytes" +
                   (data.size() >= 84 ? " does not match 84 + 50 x " + std::to_string(declared) +
                                            " declared triangles)"
                                      : ", shorter than the 84-byte binary header)"));
  }
  info.file_polygons = mesh.faces.size();
  info.welded_vertices = info.file_vertices - mesh.positions.size();
}

void write_stl(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options) {
  TextWriter w(out);
  const std::string title = "fabrica mesh, millimetres" +
                            (options.write_space_tag ? " " + space_tag(mesh) : std::string());
  auto normal_of = [&](const Face& f) -> Vec3 {
    const Vec3& a = mesh.positions[static_cast<std::size_t>(f[0])];
    const Vec3& b = mesh.positions[static_cast<std::size_t>(f[1])];
    const Vec3& c = mesh.positions[static_cast<std::size_t>(f[2])];
    const Vec3 n = (b - a).cross(c - a);
    const double len = n.norm();
    return len > 0 && std::isfinite(len) ? Vec3(n / len) : Vec3::Zero();
  };
  if (options.binary) {
    // 80-byte header (must not start with "solid": readers would take it for ascii).
    char header[80];
    std::memset(header, ' ', sizeof header);
    std::memcpy(header, title.data(), std::min(title.size(), sizeof header));
    w.bytes(header, sizeof header);
    put_le(w, static_cast<std::uint32_t>(mesh.face_count()));
    for (const Face& f : mesh.faces) {
      const Vec3 n = normal_of(f);
      float record[12];
      for (int k = 0; k < 3; ++k) record[k] = static_cast<float>(n[k]);
      for (int v = 0; v < 3; ++v)
        for (int k = 0; k < 3; ++k)
          record[3 + 3 * v + k] =
              static_cast<float>(mesh.positions[static_cast<std::size_t>(f[v])][k]);
      w.bytes(record, sizeof record);
      put_le(w, std::uint16_t{0});
    }
  } else {
    w.text("solid " + title + "\n");
    for (const Face& f : mesh.faces) {
      const Vec3 n = normal_of(f);
      w.text("facet normal ").number(n.x()).text(" ").number(n.y()).text(" ").number(n.z());
      w.text("\n  outer loop\n");
      for (int v = 0; v < 3; ++v) {
        const Vec3& p = mesh.positions[static_cast<std::size_t>(f[v])];
        w.text("    vertex ").number(p.x()).text(" ").number(p.y()).text(" ").number(p.z());
        w.text("\n");
      }
      w.text("  endloop\nendfacet\n");
    }
    w.text("endsolid fabrica\n");
  }
  w.flush();
}

}  // namespace fabrica::io::detail
