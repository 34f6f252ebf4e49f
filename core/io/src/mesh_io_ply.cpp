// PLY (Stanford polygon file) reader and writer. Reads ascii, binary little
// and big endian files with any property types and order: `vertex` x y z
// (nx ny nz when normals are asked for), `face` index lists (fan-triangulated)
// and `tristrips` lists (-1 restarts a strip; odd triangles of a strip are
// flipped; triangles with a repeated vertex are dropped). Other elements and
// properties are skipped. Writes binary little endian (double x y z) or ascii.
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

enum class PlyType : std::uint8_t { i8, u8, i16, u16, i32, u32, f32, f64 };

std::size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8:
      return 1;
    case PlyType::i16:
    case PlyType::u16:
      return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32:
      return 4;
    case PlyType::f64:
      return 8;
  }
  return 0;
}

bool is_integer_type(PlyType t) {
  return t != PlyType::f32 && t != PlyType::f64;
}

std::optional<PlyType> parse_type(std::string_view s) {
  if (s == "char" || s == "int8") return PlyType::i8;
  if (s == "uchar" || s == "uint8") return PlyType::u8;
  if (s == "short" || s == "int16") return PlyType::i16;
  if (s == "ushort" || s == "uint16") return PlyType::u16;
  if (s == "int" || s == "int32") return PlyType::i32;
  if (s == "uint" || s == "uint32") return PlyType::u32;
  if (s == "float" || s == "float32") return PlyType::f32;
  if (s == "double" || s == "float64") return PlyType::f64;
  return std::nullopt;
}

enum class Role : std::uint8_t { skip, x, y, z, nx, ny, nz, face_indices, strip_indices };

struct PlyProperty {
  std::string name;
  bool list = false;
  PlyType type = PlyType::f32;       // scalar type, or list item type
  PlyType count_type = PlyType::u8;  // list length type
  Role role = Role::skip;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

// Thrown by the sources; turned into messages with element/record context.
struct Truncated {};
struct BadValue {
  std::string what;
};

template <typename T>
T byte_swapped(T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

template <bool Swap>
struct BinarySource {
  const unsigned char* p;
  const unsigned char* end;

  template <typename T>
  T load() {
    if (static_cast<std::size_t>(end - p) < sizeof(T)) throw Truncated{};
    T v;
    std::memcpy(&v, p, sizeof(T));
    p += sizeof(T);
    if constexpr (Swap) v = byte_swapped(v);
    return v;
  }
  /// The next value of type t, converted to R.
  template <typename R>
  R value(PlyType t) {
    switch (t) {
      case PlyType::i8:
        return static_cast<R>(load<std::int8_t>());
      case PlyType::u8:
        return static_cast<R>(load<std::uint8_t>());
      case PlyType::i16:
        return static_cast<R>(load<std::int16_t>());
      case PlyType::u16:
        return static_cast<R>(load<std::uint16_t>());
      case PlyType::i32:
        return static_cast<R>(load<std::int32_t>());
      case PlyType::u32:
        return static_cast<R>(load<std::uint32_t>());
      case PlyType::f32:
        return static_cast<R>(load<float>());
      case PlyType::f64:
        return static_cast<R>(load<double>());
    }
    return 0;
  }
  double scalar(PlyType t) { return value<double>(t); }
  std::int64_t integer(PlyType t) {
    if (!is_integer_type(t))
      throw BadValue{"a list of floating-point numbers where integers are needed"};
    return value<std::int64_t>(t);
  }
  void skip(PlyType t, std::uint64_t n) {
    const std::uint64_t bytes = n * type_size(t);
    if (static_cast<std::uint64_t>(end - p) < bytes) throw Truncated{};
    p += bytes;
  }
};

struct AsciiSource {
  TextCursor c;

  double scalar(PlyType) {
    double v = 0;
    c.skip_blanks();
    if (c.at_end()) throw Truncated{};
    const char* at = c.p;
    if (!c.parse_double(v, true))
      throw BadValue{"'" + std::string(token_at(at)) + "' is not a number"};
    return v;
  }
  std::int64_t integer(PlyType) {
    std::int64_t v = 0;
    c.skip_blanks();
    if (c.at_end()) throw Truncated{};
    const char* at = c.p;
    if (!c.parse_integer(v, true) || !c.token_ends_here())
      throw BadValue{"'" + std::string(token_at(at)) + "' is not an integer"};
    return v;
  }
  void skip(PlyType, std::uint64_t n) {
    for (std::uint64_t i = 0; i < n; ++i)
      if (c.token().empty()) throw Truncated{};
  }
  std::string_view token_at(const char* at) const {
    const char* e = at;
    while (e < c.end && !TextCursor::is_blank(*e) && e - at < 40) ++e;
    return {at, static_cast<std::size_t>(e - at)};
  }
};

struct PlyState {
  LoadedMesh& out;
  const ReadOptions& options;
  std::size_t element = 0;   // index into elements, for messages
  std::uint64_t record = 0;  // record within the element
  std::size_t degenerate_strip_triangles = 0;
  std::size_t body_bytes = 0;  // the size of the body, bounding reservations
  bool binary = false;
};

template <typename Source>
void read_body(Source& src, const std::vector<PlyElement>& elements, PlyState& st) {
  TriangleMesh& mesh = st.out.mesh;
  MeshFileInfo& info = st.out.info;
  std::vector<std::int32_t> polygon;
  std::int64_t nv = 0;
  for (const PlyElement& e : elements)
    if (e.name == "vertex") nv = static_cast<std::int64_t>(e.count);

  auto check_index = [&](std::int64_t index) {
    if (index < 0 || index >= nv)
      throw BadValue{"refers to vertex " + std::to_string(index) + ", but the file has " +
                     std::to_string(nv) + " vertices"};
    return static_cast<std::int32_t>(index);
  };

  for (st.element = 0; st.element < elements.size(); ++st.element) {
    const PlyElement& e = elements[st.element];
    const bool is_vertex = e.name == "vertex";
    const bool keep_normals = is_vertex && st.options.keep_file_normals;
    if (is_vertex) {
      mesh.positions.resize(e.count, Vec3::Zero());
      if (keep_normals) info.file_normals.resize(e.count, Vec3::Zero());
    }
    // A face element of triangles gives one face per record: room for them
    // at once, instead of growing by doubling (up to twice the size kept).
    // At most what the body could hold: a face record has a count and at
    // least three indices (binary), or "3 0 1 2" and a blank (ascii).
    for (const PlyProperty& prop : e.properties)
      if (prop.list && prop.role == Role::face_indices) {
        const std::size_t min_record =
            st.binary ? type_size(prop.count_type) + 3 * type_size(prop.type) : 8;
        const auto most = static_cast<std::uint64_t>(st.body_bytes / min_record + 1);
        mesh.faces.reserve(mesh.faces.size() + static_cast<std::size_t>(std::min(e.count, most)));
      }
    // Tristrip state runs across the records of a tristrips element.
    for (st.record = 0; st.record < e.count; ++st.record) {
      for (const PlyProperty& prop : e.properties) {
        if (!prop.list) {
          if (prop.role == Role::skip) {
            src.skip(prop.type, 1);
            continue;
          }
          const double v = src.scalar(prop.type);
          const auto r = static_cast<std::size_t>(st.record);
          switch (prop.role) {
            case Role::x:
              mesh.positions[r].x() = v;
              break;
            case Role::y:
              mesh.positions[r].y() = v;
              break;
            case Role::z:
              mesh.positions[r].z() = v;
              break;
            case Role::nx:
              if (keep_normals) info.file_normals[r].x() = v;
              break;
            case Role::ny:
              if (keep_normals) info.file_normals[r].y() = v;
              break;
            case Role::nz:
              if (keep_normals) info.file_normals[r].z() = v;
              break;
            default:
              break;
          }
          continue;
        }
        const std::int64_t n = src.integer(prop.count_type);
        if (n < 0) throw BadValue{"negative list length " + std::to_string(n)};
        if (prop.role == Role::face_indices) {
          if (n < 3)
            throw BadValue{"a face with " + std::to_string(n) + " vertices (a face needs 3)"};
          polygon.clear();
          for (std::int64_t k = 0; k < n; ++k)
            polygon.push_back(check_index(src.integer(prop.type)));
          ++info.file_polygons;
          add_polygon(polygon.data(), polygon.size(), mesh, info);
        } else if (prop.role == Role::strip_indices) {
          // At most n - 2 triangles (fewer with restarts and degenerate
          // ones), at most as many as the body holds indices.
          const auto most = static_cast<std::uint64_t>(
              st.body_bytes / (st.binary ? type_size(prop.type) : std::size_t{2}) + 1);
          if (n > 2)
            mesh.faces.reserve(mesh.faces.size() + static_cast<std::size_t>(std::min<std::uint64_t>(
                                                       static_cast<std::uint64_t>(n - 2), most)));
          std::int32_t a = -1, b = -1;
          std::int64_t in_strip = 0;  // vertices in the current strip
          for (std::int64_t k = 0; k < n; ++k) {
            const std::int64_t index = src.integer(prop.type);
            if (index == -1) {
              in_strip = 0;
              continue;
            }
            const std::int32_t c = check_index(index);
            if (++in_strip >= 3) {
              ++info.file_polygons;
              if (a == b || b == c || a == c)
                ++st.degenerate_strip_triangles;
              else if (in_strip % 2 == 1)
                mesh.faces.push_back({a, b, c});
              else
                mesh.faces.push_back({a, c, b});
            }
            a = b;
            b = c;
          }
        } else {
          src.skip(prop.type, static_cast<std::uint64_t>(n));
        }
      }
    }
  }
}

}  // namespace

void read_ply(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out) {
  MeshFileInfo& info = out.info;
  info.format = "ply";
  auto header_error = [&](std::size_t line, const std::string& what) {
    fail(name, "PLY header line " + std::to_string(line) + ": " + what);
  };

  // ---- header
  enum class Encoding { ascii, little, big } encoding = Encoding::ascii;
  bool have_format = false;
  std::vector<PlyElement> elements;
  std::size_t pos = 0, line = 0;
  bool ended = false;
  while (pos < data.size() && !ended) {
    std::size_t eol = data.find('\n', pos);
    if (eol == std::string_view::npos) eol = data.size();
    std::string_view text = data.substr(pos, eol - pos);
    pos = eol + 1;
    ++line;
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    if (line == 1) {
      if (text != "ply") fail(name, "not a PLY file (the first line is not 'ply')");
      continue;
    }
    TextCursor c(text);
    const std::string_view key = c.token();
    if (key.empty()) continue;
    if (key == "comment" || key == "obj_info") {
      if (!info.tagged_space) info.tagged_space = find_space_tag(text);
    } else if (key == "format") {
      const std::string_view f = c.token();
      if (f == "ascii")
        encoding = Encoding::ascii;
      else if (f == "binary_little_endian")
        encoding = Encoding::little;
      else if (f == "binary_big_endian")
        encoding = Encoding::big;
      else
        header_error(line, "unknown format '" + std::string(f) + "'");
      have_format = true;
    } else if (key == "element") {
      PlyElement e;
      e.name = std::string(c.token());
      std::int64_t count = -1;
      if (e.name.empty() || !c.parse_integer(count, false) || count < 0)
        header_error(line, "expected 'element <name> <count>'");
      if (count > kMaxMeshElements)
        header_error(line, "the header declares " + std::to_string(count) + " '" + e.name +
                               "' records, more than the " + std::to_string(kMaxMeshElements) +
                               " fabrica reads");
      e.count = static_cast<std::uint64_t>(count);
      elements.push_back(std::move(e));
    } else if (key == "property") {
      if (elements.empty()) header_error(line, "property before any element");
      PlyProperty p;
      std::string_view t = c.token();
      if (t == "list") {
        p.list = true;
        const auto ct = parse_type(c.token());
        const auto it = parse_type(c.token());
        if (!ct || !it) header_error(line, "unknown list type");
        if (!is_integer_type(*ct)) header_error(line, "a list length must have an integer type");
        p.count_type = *ct;
        p.type = *it;
      } else {
        const auto st = parse_type(t);
        if (!st) header_error(line, "unknown property type '" + std::string(t) + "'");
        p.type = *st;
      }
      p.name = std::string(c.token());
      if (p.name.empty()) header_error(line, "property without a name");
      elements.back().properties.push_back(std::move(p));
    } else if (key == "end_header") {
      ended = true;
    } else {
      header_error(line, "unknown keyword '" + std::string(key.substr(0, 40)) + "'");
    }
  }
  if (!ended) fail(name, "PLY header has no 'end_header' line (truncated file?)");
  if (!have_format) fail(name, "PLY header has no 'format' line");
  info.binary = encoding != Encoding::ascii;

  // ---- roles
  bool have_vertex = false;
  for (PlyElement& e : elements) {
    if (e.name == "vertex") {
      if (have_vertex) fail(name, "PLY file has two 'vertex' elements");
      have_vertex = true;
      int found = 0;
      for (PlyProperty& p : e.properties) {
        if (p.list) continue;
        if (p.name == "x")
          p.role = Role::x, found |= 1;
        else if (p.name == "y")
          p.role = Role::y, found |= 2;
        else if (p.name == "z")
          p.role = Role::z, found |= 4;
        else if (p.name == "nx")
          p.role = Role::nx;
        else if (p.name == "ny")
          p.role = Role::ny;
        else if (p.name == "nz")
          p.role = Role::nz;
      }
      if (found != 7) fail(name, "PLY 'vertex' element lacks an x, y or z property");
      info.file_vertices = static_cast<std::size_t>(e.count);
      if (e.count > static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max()))
        fail(name, "PLY file declares " + std::to_string(e.count) + " vertices, too many");
    } else if (e.name == "face" || e.name == "tristrips") {
      const Role role = e.name == "face" ? Role::face_indices : Role::strip_indices;
      PlyProperty* indices = nullptr;
      for (PlyProperty& p : e.properties)
        if (p.list && (p.name == "vertex_indices" || p.name == "vertex_index")) indices = &p;
      if (!indices) {
        int lists = 0;
        for (PlyProperty& p : e.properties)
          if (p.list) ++lists, indices = &p;
        if (lists != 1) indices = nullptr;
      }
      if (!indices)
        fail(name, "PLY '" + e.name + "' element has no 'vertex_indices' list property");
      if (!is_integer_type(indices->type))
        fail(name, "PLY '" + e.name + "' vertex indices have a floating-point type");
      indices->role = role;
    }
  }
  if (!have_vertex) fail(name, "PLY file has no 'vertex' element");

  // Cheap plausibility check before any allocation: every record needs at
  // least one byte (binary) or two characters (ascii).
  const std::size_t body = data.size() - std::min(pos, data.size());
  for (const PlyElement& e : elements) {
    std::uint64_t min_bytes = 0;
    for (const PlyProperty& p : e.properties)
      min_bytes += p.list ? type_size(p.count_type) : type_size(p.type);
    if (!info.binary) min_bytes = 2 * e.properties.size();
    if (min_bytes > 0 && e.count > body / min_bytes + 1)
      fail(name,
           "PLY header declares " + std::to_string(e.count) + " '" + e.name +
               "' records, but the file is too short for them (truncated file or wrong count)");
  }

  // ---- body
  PlyState st{out, options};
  st.body_bytes = body;
  st.binary = info.binary;
  const std::string_view rest = data.substr(std::min(pos, data.size()));
  auto context = [&]() {
    const PlyElement& e = elements[std::min(st.element, elements.size() - 1)];
    return "'" + e.name + "' record " + std::to_string(st.record) + " of " +
           std::to_string(e.count);
  };
  try {
    if (encoding == Encoding::ascii) {
      AsciiSource src{TextCursor(rest)};
      read_body(src, elements, st);
      src.c.skip_blanks();
      if (!src.c.at_end())
        fail(name,
             "more data after the last element than the PLY header declares "
             "(wrong element count?)");
    } else {
      const auto* b = reinterpret_cast<const unsigned char*>(rest.data());
      const auto* e = b + rest.size();
      std::size_t left = 0;
      if (encoding == Encoding::little) {
        BinarySource<false> src{b, e};
        read_body(src, elements, st);
        left = static_cast<std::size_t>(src.end - src.p);
      } else {
        BinarySource<true> src{b, e};
        read_body(src, elements, st);
        left = static_cast<std::size_t>(src.end - src.p);
      }
      bool only_padding = left <= 16;
      for (std::size_t i = rest.size() - left; i < rest.size() && only_padding; ++i)
        only_padding = rest[i] == '\0' || TextCursor::is_blank(rest[i]);
      if (!only_padding)
        fail(name, std::to_string(left) +
                       " bytes left after the last element the PLY header declares "
                       "(wrong element count?)");
    }
  } catch (const Truncated&) {
    fail(name, "file ends in " + context() + " (truncated file or wrong count in the header)");
  } catch (const BadValue& bad) {
    fail(name, context() + ": " + bad.what);
  }
  if (st.degenerate_strip_triangles > 0)
    info.notes.push_back("skipped " + std::to_string(st.degenerate_strip_triangles) +
                         " degenerate triangle-strip triangles (repeated vertex)");
}

void write_ply(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options) {
  TextWriter w(out);
  w.text("ply\nformat ")
      .text(options.binary ? "binary_little_endian" : "ascii")
      .text(" 1.0\ncomment written by fabrica, millimetres\n");
  if (options.write_space_tag) w.text("comment " + space_tag(mesh) + "\n");
  w.text("element vertex ")
      .integer(static_cast<std::int64_t>(mesh.vertex_count()))
      .text("\nproperty double x\nproperty double y\nproperty double z\nelement face ")
      .integer(static_cast<std::int64_t>(mesh.face_count()))
      .text("\nproperty list uchar int vertex_indices\nend_header\n");
  if (options.binary) {
    for (const Vec3& p : mesh.positions) {
      put_le(w, p.x());
      put_le(w, p.y());
      put_le(w, p.z());
    }
    for (const Face& f : mesh.faces) {
      put_le(w, std::uint8_t{3});
      put_le(w, f[0]);
      put_le(w, f[1]);
      put_le(w, f[2]);
    }
  } else {
    write_ascii_vertices_and_faces(w, mesh);
  }
  w.flush();
}

}  // namespace fabrica::io::detail
