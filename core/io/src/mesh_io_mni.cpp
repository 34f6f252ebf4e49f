// MNI BIC object file reader (.obj files from the Montreal Neurological
// Institute tools: bicpl, CIVET, BrainSuite exports; not Wavefront OBJ).
// Ascii polygon objects only:
//
//   P ambient diffuse specular_reflectance specular_exponent opacity n_points
//   n_points x y z                 (vertex positions)
//   n_points nx ny nz              (vertex normals)
//   n_items                        (number of polygons)
//   colour_flag colours            (0: one RGBA, 1: one per polygon, 2: one per vertex)
//   end_indices[n_items]           (cumulative corner counts)
//   indices[end_indices[n_items-1]]
//
// Several `P` objects in one file are concatenated (later objects' indices
// are offset). Line objects (`L`), other object types and the binary form
// (lower-case object letter) are refused with a message. Coordinates are
// MINC world coordinates: RAS millimetres (MNI/Talairach space).
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

bool is_mni_object_letter(char c) {
  return c == 'P' || c == 'L' || c == 'M' || c == 'Q' || c == 'T' || c == 'V' || c == 'X' ||
         c == 'F';
}

const char* object_description(char c) {
  switch (c) {
    case 'L':
      return "lines";
    case 'Q':
      return "a quadmesh";
    case 'T':
      return "text";
    default:
      return "a non-polygon object";
  }
}

}  // namespace

bool looks_like_mni_obj(std::string_view data) {
  TextCursor c(data);
  c.skip_blanks();
  if (c.at_end()) return false;
  // Binary MNI objects: the lower-case letter is followed by binary numbers.
  const char first = *c.p;
  if (first == 'p' && c.p + 1 < c.end && !TextCursor::is_blank(c.p[1])) return true;
  const std::string_view letter = c.token();
  if (letter.size() != 1 || !is_mni_object_letter(letter[0])) return false;
  double v = 0;
  return c.parse_double(v, true);
}

void read_mni_obj(std::string_view data, const std::string& name, const ReadOptions& options,
                  LoadedMesh& out) {
  TriangleMesh& mesh = out.mesh;
  MeshFileInfo& info = out.info;
  info.format = "mni_obj";
  info.binary = false;
  TextCursor c(data);
  auto error_at = [&](const char* at, const std::string& what) {
    fail(name, "line " + std::to_string(line_number(data, at)) + ": " + what);
  };
  auto count = [&](const char* what, std::int64_t max_value) -> std::int64_t {
    c.skip_blanks();
    const char* at = c.p;
    std::int64_t v = 0;
    if (c.at_end())
      error_at(at, std::string("file ends where the ") + what + " should be (truncated file?)");
    if (!c.parse_integer(v, true) || !c.token_ends_here())
      error_at(at, std::string("expected the ") + what + " (a whole number), found '" +
                       std::string(c.rest_of_line().substr(0, 40)) + "'");
    if (v < 0 || v > max_value)
      error_at(at, std::string("the ") + what + " " + std::to_string(v) +
                       " is out of range (0 to " + std::to_string(max_value) + ")");
    return v;
  };
  auto number = [&](double& v, const std::string& what) {
    c.skip_blanks();
    const char* at = c.p;
    if (c.at_end()) error_at(at, "file ends within " + what + " (truncated file?)");
    if (!c.parse_double(v, true))
      error_at(at, what + ": expected a number, found '" +
                       std::string(c.rest_of_line().substr(0, 40)) + "'");
  };
  // Upper bound for counts: every value takes at least two characters.
  const auto max_count =
      static_cast<std::int64_t>(std::min<std::size_t>(data.size() / 2 + 1, kMaxMeshElements));

  std::size_t objects = 0;
  std::vector<std::int32_t> polygon;
  for (;;) {
    c.skip_blanks();
    if (c.at_end()) break;
    const char* object_at = c.p;
    if (*c.p >= 'a' && *c.p <= 'z' && is_mni_object_letter(static_cast<char>(*c.p - 'a' + 'A')) &&
        c.p + 1 < c.end && !TextCursor::is_blank(c.p[1]))
      error_at(object_at,
               "binary MNI .obj files are not supported; convert the file to ascii first "
               "(for example with the MNI tool 'ascii_binary')");
    const std::string_view letter = c.token();
    if (letter != "P") {
      if (letter.size() == 1 && is_mni_object_letter(letter[0]))
        error_at(object_at, "MNI .obj object '" + std::string(letter) + "' holds " +
                                object_description(letter[0]) +
                                ", not a polygon surface: fabrica reads polygon objects ('P')");
      error_at(object_at, objects == 0 ? "not an MNI .obj file (expected 'P' for polygons)"
                                       : "unexpected '" + std::string(letter.substr(0, 40)) +
                                             "' after the last polygon object (data left over?)");
    }
    const std::string object = objects == 0 ? "" : " (object " + std::to_string(objects) + ")";
    for (const char* property :
         {"ambient", "diffuse", "specular reflectance", "specular exponent", "opacity"}) {
      double v = 0;
      number(v, std::string("surface property '") + property + "'" + object);
    }
    const std::int64_t n_points = count(("number of points" + object).c_str(), max_count);
    const auto offset = static_cast<std::int64_t>(mesh.positions.size());
    if (offset + n_points > std::numeric_limits<std::int32_t>::max())
      error_at(object_at, "too many points for fabrica (more than 2^31)");
    mesh.positions.resize(static_cast<std::size_t>(offset + n_points));
    const std::string counts = " (the object declares " + std::to_string(n_points) + " points)";
    for (std::int64_t i = 0; i < n_points; ++i) {
      Vec3& p = mesh.positions[static_cast<std::size_t>(offset + i)];
      for (int k = 0; k < 3; ++k) number(p[k], "point " + std::to_string(i) + counts);
    }
    if (options.keep_file_normals) info.file_normals.resize(mesh.positions.size());
    for (std::int64_t i = 0; i < n_points; ++i) {
      Vec3 n;
      for (int k = 0; k < 3; ++k) number(n[k], "normal " + std::to_string(i) + counts);
      if (options.keep_file_normals) info.file_normals[static_cast<std::size_t>(offset + i)] = n;
    }
    const std::int64_t n_items = count(("number of polygons" + object).c_str(), max_count);
    const std::int64_t colour_flag = count("colour flag", 2);
    const std::int64_t colours = colour_flag == 0 ? 1 : colour_flag == 1 ? n_items : n_points;
    for (std::int64_t i = 0; i < 4 * colours; ++i) {
      double v = 0;
      number(v, "colour " + std::to_string(i / 4) + " (r g b a)");
    }
    std::vector<std::int64_t> end_indices(static_cast<std::size_t>(n_items));
    std::int64_t previous = 0;
    for (std::int64_t i = 0; i < n_items; ++i) {
      const char* at = (c.skip_blanks(), c.p);
      const std::int64_t e = count("end index of polygon", max_count);
      if (e < previous + 3)
        error_at(at, "polygon " + std::to_string(i) + " has " + std::to_string(e - previous) +
                         " corners (end index " + std::to_string(e) + " after " +
                         std::to_string(previous) + "): a polygon needs at least 3");
      end_indices[static_cast<std::size_t>(i)] = e;
      previous = e;
    }
    std::int64_t start = 0;
    for (std::int64_t i = 0; i < n_items; ++i) {
      polygon.clear();
      const std::int64_t end = end_indices[static_cast<std::size_t>(i)];
      for (std::int64_t k = start; k < end; ++k) {
        c.skip_blanks();
        const char* at = c.p;
        if (c.at_end())
          error_at(at, "file ends in the indices of polygon " + std::to_string(i) + " of " +
                           std::to_string(n_items) + " (truncated file?)");
        std::int64_t v = 0;
        if (!c.parse_integer(v, true) || !c.token_ends_here())
          error_at(at, "polygon " + std::to_string(i) + ": expected a vertex index, found '" +
                           std::string(c.rest_of_line().substr(0, 40)) + "'");
        if (v < 0 || v >= n_points)
          error_at(at, "polygon " + std::to_string(i) + " refers to point " + std::to_string(v) +
                           ", but the object has " + std::to_string(n_points) + " points (0 to " +
                           std::to_string(n_points - 1) + ")");
        polygon.push_back(static_cast<std::int32_t>(offset + v));
      }
      add_polygon(polygon.data(), polygon.size(), mesh, info);
      start = end;
    }
    info.file_polygons += static_cast<std::size_t>(n_items);
    ++objects;
  }
  if (objects == 0) fail(name, "the file is blank: no MNI polygon object");
  info.file_vertices = mesh.positions.size();
  if (objects > 1)
    info.notes.push_back(std::to_string(objects) + " MNI polygon objects joined into one mesh");
  // MINC world coordinates are RAS millimetres (MNI/Talairach space).
  info.tagged_space = Space::ras;
}

}  // namespace fabrica::io::detail
