// Wavefront OBJ reader and writer. Reads `v` and `f` records (v, v/vt,
// v//vn, v/vt/vn references; negative indices count back from the last
// vertex read), fan-triangulates polygons, ignores everything else (groups,
// materials, texture coordinates, lines, points).
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

struct ObjVertexNormals {
  std::vector<Vec3> normals;            // vn records
  std::vector<std::int64_t> normal_of;  // per vertex: vn index, -1 none
  bool ambiguous = false;               // a vertex used with two different vn
  bool referenced = false;              // some face corner named a vn
};

}  // namespace

void read_obj(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out) {
  TriangleMesh& mesh = out.mesh;
  MeshFileInfo& info = out.info;
  info.format = "obj";
  info.binary = false;
  TextCursor c(data);
  ObjVertexNormals vn;
  std::vector<std::int32_t> polygon;
  mesh.positions.reserve(data.size() / 64);
  mesh.faces.reserve(data.size() / 32);

  auto error_at = [&](const char* at, const std::string& what) {
    fail(name, "line " + std::to_string(line_number(data, at)) + ": " + what);
  };
  auto token_at = [&](const char* at) {
    const char* e = at;
    while (e < c.end && !TextCursor::is_blank(*e)) ++e;
    std::string quoted(1, '\'');
    quoted.append(at, static_cast<std::size_t>(std::min<std::ptrdiff_t>(e - at, 40)));
    quoted.push_back('\'');
    return quoted;
  };
  // OBJ indices: 1-based, negative = relative to the records read so far.
  auto resolve = [&](std::int64_t index, std::size_t count, const char* at,
                     const char* what) -> std::int64_t {
    if (index == 0) error_at(at, std::string(what) + " index 0 in a face (OBJ indices start at 1)");
    const std::int64_t resolved = index > 0 ? index - 1 : static_cast<std::int64_t>(count) + index;
    if (resolved < 0)
      error_at(at, std::string("face refers to ") + what + " " + std::to_string(index) +
                       ", before the first " + what);
    if (resolved > std::numeric_limits<std::int32_t>::max())
      error_at(at, std::string("face refers to ") + what + " " + std::to_string(index) +
                       ", more than fabrica supports");
    return resolved;
  };

  while (!c.at_end()) {
    c.skip_spaces();
    if (c.at_end()) break;
    if (*c.p == '\n') {
      ++c.p;
      continue;
    }
    if (*c.p == '#') {
      if (!info.tagged_space) info.tagged_space = find_space_tag(c.rest_of_line());
      c.skip_line();
      continue;
    }
    const char* keyword = c.p;
    while (c.p < c.end && !TextCursor::is_blank(*c.p)) ++c.p;
    const std::string_view key(keyword, static_cast<std::size_t>(c.p - keyword));
    if (key == "v") {
      Vec3 v;
      for (int k = 0; k < 3; ++k)
        if (!c.parse_double(v[k]))
          error_at(keyword, "vertex " + std::to_string(mesh.positions.size() + 1) +
                                " needs three numbers x y z, found " + token_at(c.p));
      mesh.positions.push_back(v);
    } else if (key == "f") {
      polygon.clear();
      while (!c.at_line_end()) {
        const char* at = c.p;
        std::int64_t vi = 0, ti = 0, ni = 0;
        bool has_normal = false;
        if (!c.parse_integer(vi)) error_at(at, "bad face vertex reference " + token_at(at));
        if (c.p < c.end && *c.p == '/') {
          ++c.p;
          if (c.p < c.end && *c.p != '/' && !c.parse_integer(ti))
            error_at(at, "bad face vertex reference " + token_at(at));
          if (c.p < c.end && *c.p == '/') {
            ++c.p;
            if (!c.parse_integer(ni)) error_at(at, "bad face vertex reference " + token_at(at));
            has_normal = true;
          }
        }
        if (!c.token_ends_here()) error_at(at, "bad face vertex reference " + token_at(at));
        const std::int64_t v = resolve(vi, mesh.positions.size(), at, "vertex");
        polygon.push_back(static_cast<std::int32_t>(v));
        if (options.keep_file_normals && has_normal) {
          const std::int64_t n = resolve(ni, vn.normals.size(), at, "normal");
          vn.referenced = true;
          const auto vu = static_cast<std::size_t>(v);
          if (vn.normal_of.size() <= vu) vn.normal_of.resize(vu + 1, -1);
          if (vn.normal_of[vu] < 0)
            vn.normal_of[vu] = n;
          else if (vn.normal_of[vu] != n)
            vn.ambiguous = true;
        }
      }
      if (polygon.size() < 3)
        error_at(keyword, "face " + std::to_string(info.file_polygons + 1) + " has only " +
                              std::to_string(polygon.size()) + " vertices (a face needs 3)");
      ++info.file_polygons;
      add_polygon(polygon.data(), polygon.size(), mesh, info);
    } else if (key == "vn" && options.keep_file_normals) {
      Vec3 n;
      for (int k = 0; k < 3; ++k)
        if (!c.parse_double(n[k])) error_at(keyword, "normal needs three numbers");
      vn.normals.push_back(n);
    }
    c.skip_line();
  }
  info.file_vertices = mesh.positions.size();

  if (options.keep_file_normals && !vn.normals.empty()) {
    const std::size_t nv = mesh.positions.size();
    bool complete = !vn.ambiguous;
    std::vector<Vec3> normals(nv, Vec3::Zero());
    if (vn.referenced) {
      for (std::size_t i = 0; i < nv && complete; ++i) {
        if (i >= vn.normal_of.size() || vn.normal_of[i] < 0 ||
            vn.normal_of[i] >= static_cast<std::int64_t>(vn.normals.size()))
          complete = false;
        else
          normals[i] = vn.normals[static_cast<std::size_t>(vn.normal_of[i])];
      }
    } else if (vn.normals.size() == nv) {
      normals = vn.normals;
    } else {
      complete = false;
    }
    if (complete)
      info.file_normals = std::move(normals);
    else
      info.notes.push_back(
          "the file's vertex normals were not kept: they do not map one-to-one to vertices");
  }
}

void write_obj(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options) {
  TextWriter w(out);
  w.text("# written by fabrica: ")
      .integer(static_cast<std::int64_t>(mesh.vertex_count()))
      .text(" vertices, ")
      .integer(static_cast<std::int64_t>(mesh.face_count()))
      .text(" triangles, millimetres\n");
  if (options.write_space_tag) w.text("# " + space_tag(mesh) + "\n");
  for (const Vec3& p : mesh.positions)
    w.text("v ").number(p.x()).text(" ").number(p.y()).text(" ").number(p.z()).text("\n");
  for (const Face& f : mesh.faces)
    w.text("f ").integer(f[0] + 1).text(" ").integer(f[1] + 1).text(" ").integer(f[2] + 1).text(
        "\n");
  w.flush();
}

}  // namespace fabrica::io::detail
