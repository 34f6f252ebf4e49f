// OFF (Geomview Object File Format) reader and writer. Headers OFF, COFF,
// NOFF, CNOFF, STOFF (and combinations) are read; colours and texture
// coordinates are ignored; `#` comments are allowed anywhere. 4OFF, nOFF and
// binary OFF are rejected with a message.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

void read_off(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out) {
  TriangleMesh& mesh = out.mesh;
  MeshFileInfo& info = out.info;
  info.format = "off";
  info.binary = false;
  TextCursor c(data);

  auto error_at = [&](const char* at, const std::string& what) {
    fail(name, "line " + std::to_string(line_number(data, at)) + ": " + what);
  };
  // Space tags live in comments; scan them all (they are few and short).
  for (TextCursor s(data); !s.at_end();) {
    s.skip_blanks();
    if (s.at_end()) break;
    if (*s.p == '#') {
      if (auto tag = find_space_tag(s.rest_of_line())) {
        info.tagged_space = tag;
        break;
      }
    }
    s.skip_line();
  }

  c.skip_blanks_and_comments();
  bool has_normals = false;
  const char* header_at = c.p;
  if (c.at_end()) fail(name, "OFF file holds only comments and blank lines");
  const char* first = c.p;
  const std::string_view first_token = c.token();
  c.p = first;
  const bool has_header =
      first_token.size() >= 3 && first_token.substr(first_token.size() - 3) == "OFF";
  if (has_header || !(std::isdigit(static_cast<unsigned char>(*first)) || *first == '+')) {
    // Header keyword: [ST][C][N][4][n]OFF; the counts may follow on the same line.
    const std::string_view keyword = c.token();
    if (!has_header)
      error_at(header_at,
               "not an OFF file: expected the header 'OFF' (or COFF, NOFF, ...), found '" +
                   std::string(keyword.substr(0, 40)) + "'");
    for (char k : keyword.substr(0, keyword.size() - 3)) {
      if (k == 'N')
        has_normals = true;
      else if (k == '4' || k == 'n')
        error_at(header_at, "'" + std::string(keyword) +
                                "' files (4D or n-dimensional vertices) are not supported");
      else if (k != 'C' && k != 'S' && k != 'T')
        error_at(header_at, "unknown OFF header '" + std::string(keyword) + "'");
    }
    c.skip_spaces();
    if (c.rest_of_line().substr(0, 6) == "BINARY")
      error_at(header_at, "binary OFF is not supported; save it as ascii OFF, PLY or STL");
  }
  std::int64_t nv = -1, nf = -1;
  c.skip_blanks_and_comments();
  const char* counts_at = c.p;
  if (!c.parse_integer(nv, true) || !c.token_ends_here() || !c.parse_integer(nf, true) ||
      !c.token_ends_here())
    error_at(counts_at, "expected the counts 'vertices faces edges' after the OFF header");
  c.skip_line();  // the edge count is not used
  if (nv < 0 || nf < 0) error_at(counts_at, "negative vertex or face count");
  if (nv > std::numeric_limits<std::int32_t>::max() ||
      static_cast<std::uint64_t>(nv) > data.size() / 2 + 1)
    error_at(counts_at, "the header declares " + std::to_string(nv) +
                            " vertices, more than the file can hold");
  if (static_cast<std::uint64_t>(nf) > data.size() / 2 + 1 || nf > kMaxMeshElements)
    error_at(counts_at,
             "the header declares " + std::to_string(nf) + " faces, more than the file can hold");
  info.file_vertices = static_cast<std::size_t>(nv);
  info.file_polygons = static_cast<std::size_t>(nf);
  mesh.positions.resize(static_cast<std::size_t>(nv));
  if (has_normals && options.keep_file_normals) info.file_normals.resize(mesh.positions.size());
  mesh.faces.reserve(static_cast<std::size_t>(nf));

  const std::string counts = " (the header declares " + std::to_string(nv) + " vertices and " +
                             std::to_string(nf) + " faces)";
  for (std::int64_t i = 0; i < nv; ++i) {
    c.skip_blanks_and_comments();
    if (c.at_end()) error_at(c.p, "file ends after " + std::to_string(i) + " vertices" + counts);
    const char* at = c.p;
    Vec3& v = mesh.positions[static_cast<std::size_t>(i)];
    for (int k = 0; k < 3; ++k)
      if (!c.parse_double(v[k], true))
        error_at(at, "vertex " + std::to_string(i) + " needs three numbers x y z" + counts);
    if (has_normals) {
      Vec3 n;
      for (int k = 0; k < 3; ++k)
        if (!c.parse_double(n[k], true))
          error_at(at, "vertex " + std::to_string(i) + " needs a normal (NOFF)");
      if (options.keep_file_normals) info.file_normals[static_cast<std::size_t>(i)] = n;
    }
    c.skip_line();  // colour / texture coordinates
  }
  std::vector<std::int32_t> polygon;
  for (std::int64_t f = 0; f < nf; ++f) {
    c.skip_blanks_and_comments();
    if (c.at_end()) error_at(c.p, "file ends after " + std::to_string(f) + " faces" + counts);
    const char* at = c.p;
    std::int64_t n = 0;
    if (!c.parse_integer(n, true) || !c.token_ends_here())
      error_at(at, "face " + std::to_string(f) + ": expected its vertex count, found '" +
                       std::string(c.rest_of_line().substr(0, 40)) + "'" + counts);
    if (n < 3 || n > nv)
      error_at(at, "face " + std::to_string(f) + " has " + std::to_string(n) +
                       " vertices (needs 3 to " + std::to_string(std::max<std::int64_t>(nv, 3)) +
                       ")" + counts);
    polygon.clear();
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t index = 0;
      if (!c.parse_integer(index, true) || !c.token_ends_here())
        error_at(at, "face " + std::to_string(f) + ": expected " + std::to_string(n) +
                         " vertex indices");
      if (index < 0 || index >= nv)
        error_at(at, "face " + std::to_string(f) + " refers to vertex " + std::to_string(index) +
                         ", but the file has " + std::to_string(nv) + " vertices (0 to " +
                         std::to_string(nv - 1) + ")");
      polygon.push_back(static_cast<std::int32_t>(index));
    }
    add_polygon(polygon.data(), polygon.size(), mesh, info);
    c.skip_line();  // face colour
  }
  c.skip_blanks_and_comments();
  if (!c.at_end()) error_at(c.p, "more data after the last face than the header declares" + counts);
}

void write_off(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options) {
  TextWriter w(out);
  w.text("OFF\n# written by fabrica, millimetres\n");
  if (options.write_space_tag) w.text("# " + space_tag(mesh) + "\n");
  w.integer(static_cast<std::int64_t>(mesh.vertex_count()))
      .text(" ")
      .integer(static_cast<std::int64_t>(mesh.face_count()))
      .text(" 0\n");
  write_ascii_vertices_and_faces(w, mesh);
  w.flush();
}

}  // namespace fabrica::io::detail
