// Legacy VTK (.vtk) POLYDATA reader, ascii and binary (big endian), classic
// cell arrays (format < 5) and OFFSETS/CONNECTIVITY arrays (format 5.x).
// Written here instead of using vtkPolyDataReader, which crashes on
// truncated files. Polygons are fan-triangulated and triangle strips unrolled
// (odd triangles flipped, triangles with a repeated vertex dropped); vertex
// and line cells, point/cell data and field data are ignored.
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

enum class VtkType { u8, i8, u16, i16, u32, i32, u64, i64, f32, f64 };

std::optional<VtkType> parse_vtk_type(std::string_view t) {
  if (iequals(t, "unsigned_char")) return VtkType::u8;
  if (iequals(t, "char")) return VtkType::i8;
  if (iequals(t, "unsigned_short")) return VtkType::u16;
  if (iequals(t, "short")) return VtkType::i16;
  if (iequals(t, "unsigned_int")) return VtkType::u32;
  if (iequals(t, "int") || iequals(t, "vtkIdType")) return VtkType::i32;
  if (iequals(t, "unsigned_long") || iequals(t, "vtktypeuint64")) return VtkType::u64;
  if (iequals(t, "long") || iequals(t, "vtktypeint64")) return VtkType::i64;
  if (iequals(t, "float")) return VtkType::f32;
  if (iequals(t, "double")) return VtkType::f64;
  return std::nullopt;
}

std::size_t vtk_type_size(VtkType t) {
  switch (t) {
    case VtkType::u8:
    case VtkType::i8:
      return 1;
    case VtkType::u16:
    case VtkType::i16:
      return 2;
    case VtkType::u32:
    case VtkType::i32:
    case VtkType::f32:
      return 4;
    default:
      return 8;
  }
}

template <typename T>
T load_big_endian(const char* p) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return v;
}

double load_value(const char* p, VtkType t) {
  switch (t) {
    case VtkType::u8:
      return static_cast<unsigned char>(*p);
    case VtkType::i8:
      return static_cast<signed char>(*p);
    case VtkType::u16:
      return load_big_endian<std::uint16_t>(p);
    case VtkType::i16:
      return load_big_endian<std::int16_t>(p);
    case VtkType::u32:
      return load_big_endian<std::uint32_t>(p);
    case VtkType::i32:
      return load_big_endian<std::int32_t>(p);
    case VtkType::u64:
      return static_cast<double>(load_big_endian<std::uint64_t>(p));
    case VtkType::i64:
      return static_cast<double>(load_big_endian<std::int64_t>(p));
    case VtkType::f32:
      return load_big_endian<float>(p);
    case VtkType::f64:
      return load_big_endian<double>(p);
  }
  return 0;
}

std::int64_t load_integer(const char* p, VtkType t) {
  switch (t) {
    case VtkType::u64: {
      const auto v = load_big_endian<std::uint64_t>(p);
      return v > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())
                 ? -1
                 : static_cast<std::int64_t>(v);
    }
    case VtkType::i64:
      return load_big_endian<std::int64_t>(p);
    default:
      return static_cast<std::int64_t>(load_value(p, t));
  }
}

class LegacyParser {
 public:
  LegacyParser(std::string_view data, const std::string& name)
      : data_(data), name_(name), c_(data) {}

  [[noreturn]] void error(const char* at, const std::string& what) const {
    fail(name_, "line " + std::to_string(line_number(data_, at)) + ": " + what);
  }

  void parse(LoadedMesh& out) {
    MeshFileInfo& info = out.info;
    TriangleMesh& mesh = out.mesh;
    std::string_view line = c_.rest_of_line();
    if (line.substr(0, 22) != "# vtk DataFile Version")
      error(c_.p, "not a legacy VTK file (the first line is not '# vtk DataFile Version ...')");
    c_.skip_line();
    info.tagged_space = find_space_tag(c_.rest_of_line());  // the title line
    c_.skip_line();
    const char* at = (c_.skip_blanks(), c_.p);
    const std::string_view encoding = c_.token();
    if (iequals(encoding, "BINARY"))
      binary_ = true;
    else if (!iequals(encoding, "ASCII"))
      error(at, "expected ASCII or BINARY on the third line");
    info.binary = binary_;
    at = (c_.skip_blanks(), c_.p);
    if (!iequals(c_.token(), "DATASET")) error(at, "expected 'DATASET POLYDATA'");
    const std::string_view kind = c_.token();
    if (!iequals(kind, "POLYDATA"))
      error(at, "not a legacy VTK POLYDATA file (DATASET " + std::string(kind.substr(0, 40)) +
                    "; only POLYDATA is read)");

    bool have_points = false;
    std::vector<Face> polygon_faces, strip_faces;
    std::size_t degenerate = 0, ignored_cells = 0;
    for (;;) {
      c_.skip_blanks();
      if (c_.at_end()) break;
      at = c_.p;
      const std::string_view key = c_.token();
      if (iequals(key, "POINTS")) {
        if (have_points) error(at, "a second POINTS section");
        have_points = true;
        const std::int64_t n = count(at, "POINTS");
        const VtkType type = data_type(at);
        if (n > std::numeric_limits<std::int32_t>::max()) error(at, "too many points");
        const std::vector<double> values = read_values(at, static_cast<std::uint64_t>(3 * n), type);
        mesh.positions.resize(static_cast<std::size_t>(n));
        for (std::size_t i = 0; i < mesh.positions.size(); ++i)
          mesh.positions[i] = Vec3(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
      } else if (iequals(key, "METADATA")) {
        // Ends at the first blank line.
        c_.skip_line();
        while (!c_.at_end()) {
          const std::string_view l = c_.rest_of_line();
          c_.skip_line();
          if (l.find_first_not_of(" \t\r") == std::string_view::npos) break;
        }
      } else if (iequals(key, "VERTICES") || iequals(key, "LINES") || iequals(key, "POLYGONS") ||
                 iequals(key, "TRIANGLE_STRIPS")) {
        if (!have_points) error(at, std::string(key) + " before POINTS");
        const bool polygons = iequals(key, "POLYGONS");
        const bool strips = iequals(key, "TRIANGLE_STRIPS");
        const std::vector<std::vector<std::int64_t>> cells = read_cells(at, std::string(key));
        const auto np = static_cast<std::int64_t>(mesh.positions.size());
        for (const auto& cell : cells) {
          if (!polygons && !strips) {
            ++ignored_cells;
            continue;
          }
          for (std::int64_t id : cell)
            if (id < 0 || id >= np)
              error(at, std::string(key) + " refers to point " + std::to_string(id) +
                            ", but the file has " + std::to_string(np) + " points");
          if (polygons) {
            ++info.file_polygons;
            if (cell.size() < 3)
              error(at, "a polygon with " + std::to_string(cell.size()) + " points (needs 3)");
            for (std::size_t k = 1; k + 1 < cell.size(); ++k)
              polygon_faces.push_back({static_cast<std::int32_t>(cell[0]),
                                       static_cast<std::int32_t>(cell[k]),
                                       static_cast<std::int32_t>(cell[k + 1])});
            if (cell.size() > 3) ++info.triangulated_polygons;
          } else {
            for (std::size_t k = 2; k < cell.size(); ++k) {
              const auto a = static_cast<std::int32_t>(cell[k - 2]);
              const auto b = static_cast<std::int32_t>(cell[k - 1]);
              const auto c = static_cast<std::int32_t>(cell[k]);
              ++info.file_polygons;
              if (a == b || b == c || a == c)
                ++degenerate;
              else if (k % 2 == 0)
                strip_faces.push_back({a, b, c});
              else
                strip_faces.push_back({a, c, b});
            }
          }
        }
      } else if (iequals(key, "POINT_DATA") || iequals(key, "CELL_DATA") || iequals(key, "FIELD")) {
        info.notes.push_back("point, cell and field data of the legacy VTK file were ignored");
        break;
      } else {
        error(at, "unexpected keyword '" + std::string(key.substr(0, 40)) + "' in POLYDATA");
      }
    }
    if (!have_points) fail(name_, "legacy VTK file has no POINTS");
    info.file_vertices = mesh.positions.size();
    // VTK's cell order: vertices, lines, polygons, strips.
    mesh.faces = std::move(polygon_faces);
    mesh.faces.insert(mesh.faces.end(), strip_faces.begin(), strip_faces.end());
    if (degenerate > 0)
      info.notes.push_back("skipped " + std::to_string(degenerate) +
                           " degenerate triangle-strip triangles (repeated vertex)");
    if (ignored_cells > 0)
      info.notes.push_back("ignored " + std::to_string(ignored_cells) + " vertex and line cells");
  }

 private:
  std::int64_t count(const char* at, const std::string& what) {
    std::int64_t n = -1;
    if (!c_.parse_integer(n) || !c_.token_ends_here() || n < 0)
      error(at, "expected a count after " + what);
    if (n > kMaxMeshElements)
      error(at, what + " declares " + std::to_string(n) + ", more than the " +
                    std::to_string(kMaxMeshElements) + " fabrica reads");
    return n;
  }
  VtkType data_type(const char* at) {
    c_.skip_spaces();
    const std::string_view t = c_.token();
    const auto type = parse_vtk_type(t);
    if (!type) error(at, "unknown or unsupported data type '" + std::string(t.substr(0, 40)) + "'");
    return *type;
  }

  /// Reads n values of `type` as T (double, or std::int64_t for counts and
  /// indices, which must be integers); the cursor is on the line of the
  /// keyword.
  template <typename T>
  std::vector<T> read_array(const char* at, std::uint64_t n, VtkType type) {
    constexpr bool integers = std::is_same_v<T, std::int64_t>;
    std::vector<T> values;
    if (binary_) {
      c_.skip_line();
      const std::uint64_t bytes = n * vtk_type_size(type);
      if (static_cast<std::uint64_t>(c_.end - c_.p) < bytes)
        error(at, "file ends inside the binary data (truncated file or wrong count)");
      values.resize(static_cast<std::size_t>(n));
      for (std::size_t i = 0; i < values.size(); ++i) {
        const char* const data = c_.p + i * vtk_type_size(type);
        if constexpr (integers)
          values[i] = load_integer(data, type);
        else
          values[i] = load_value(data, type);
      }
      c_.p += bytes;
      return values;
    }
    if (n > static_cast<std::uint64_t>(c_.end - c_.p) / 2 + 1)
      error(at, "the count " + std::to_string(n) +
                    " is larger than the file can hold (truncated file or wrong count)");
    values.resize(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < values.size(); ++i) {
      c_.skip_blanks();
      if (c_.at_end())
        error(at, "file ends after " + std::to_string(i) + " of " + std::to_string(n) +
                      " values (truncated file or wrong count)");
      const char* v = c_.p;
      if constexpr (integers) {
        if (!c_.parse_integer(values[i], true) || !c_.token_ends_here())
          error(v, "expected an integer");
      } else {
        if (!c_.parse_double(values[i], true)) error(v, "expected a number");
      }
    }
    return values;
  }
  std::vector<double> read_values(const char* at, std::uint64_t n, VtkType type) {
    return read_array<double>(at, n, type);
  }
  std::vector<std::int64_t> read_integers(const char* at, std::uint64_t n, VtkType type) {
    return read_array<std::int64_t>(at, n, type);
  }

  /// Cells of a VERTICES/LINES/POLYGONS/TRIANGLE_STRIPS section, both layouts.
  std::vector<std::vector<std::int64_t>> read_cells(const char* at, const std::string& key) {
    const std::int64_t a = count(at, key);
    const std::int64_t b = count(at, key);
    std::vector<std::vector<std::int64_t>> cells;
    // Format 5: OFFSETS <type> (a values) then CONNECTIVITY <type> (b values).
    TextCursor peek = c_;
    peek.skip_line();
    peek.skip_blanks();
    const std::string_view next = peek.token();
    if (iequals(next, "OFFSETS")) {
      c_.skip_line();
      c_.skip_blanks();
      const char* offsets_at = c_.p;
      (void)c_.token();
      const auto offsets =
          read_integers(offsets_at, static_cast<std::uint64_t>(a), data_type(offsets_at));
      c_.skip_blanks();
      const char* conn_at = c_.p;
      if (!iequals(c_.token(), "CONNECTIVITY"))
        error(conn_at, "expected CONNECTIVITY after OFFSETS");
      const auto conn = read_integers(conn_at, static_cast<std::uint64_t>(b), data_type(conn_at));
      if (a == 0) return cells;
      if (offsets.front() != 0 || offsets.back() != b)
        error(offsets_at, key + " offsets do not match the connectivity size");
      for (std::size_t i = 0; i + 1 < offsets.size(); ++i)
        if (offsets[i + 1] < offsets[i]) error(offsets_at, key + " offsets decrease");
      for (std::size_t i = 0; i + 1 < offsets.size(); ++i)
        cells.emplace_back(conn.begin() + offsets[i], conn.begin() + offsets[i + 1]);
      return cells;
    }
    // Classic: a cells, b integers: n id0 ... id(n-1) per cell.
    const auto ints = read_integers(at, static_cast<std::uint64_t>(b), VtkType::i32);
    std::size_t p = 0;
    for (std::int64_t i = 0; i < a; ++i) {
      if (p >= ints.size())
        error(at, key + ": fewer values than its " + std::to_string(a) + " cells need");
      const std::int64_t n = ints[p++];
      if (n < 0 || static_cast<std::uint64_t>(n) > ints.size() - p)
        error(at,
              key + ": cell " + std::to_string(i) + " has a bad point count " + std::to_string(n));
      cells.emplace_back(
          ints.begin() + static_cast<std::ptrdiff_t>(p),
          ints.begin() + static_cast<std::ptrdiff_t>(p + static_cast<std::size_t>(n)));
      p += static_cast<std::size_t>(n);
    }
    if (p != ints.size())
      error(at, key + ": " + std::to_string(ints.size()) + " values declared but the " +
                    std::to_string(a) + " cells use " + std::to_string(p));
    return cells;
  }

  std::string_view data_;
  const std::string& name_;
  TextCursor c_;
  bool binary_ = false;
};

}  // namespace

void read_vtk_legacy(std::string_view data, const std::string& name, const ReadOptions& options,
                     LoadedMesh& out) {
  out.info.format = "vtk";
  LegacyParser(data, name).parse(out);
  if (options.keep_file_normals)
    out.info.notes.push_back("normals stored in legacy VTK files are not read");
}

}  // namespace fabrica::io::detail
