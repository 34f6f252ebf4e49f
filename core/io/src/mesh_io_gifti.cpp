// GIfTI surface reader (.gii, and whole-file gzip .gii.gz). GIfTI 1.0 (NITRC
// gifti.projects.nitrc.org): an XML document whose DataArrays hold the
// surface: NIFTI_INTENT_POINTSET (Dim0 x 3 coordinates, float32) and
// NIFTI_INTENT_TRIANGLE (Dim0 x 3 zero-based vertex indices, int32).
// Encodings ASCII, Base64Binary and GZipBase64Binary (base64 of a zlib
// stream); either Endian; RowMajorOrder or ColumnMajorOrder. External data
// files are refused. Other DataArrays (normals, labels, shape data) are
// ignored. Coordinates are kept exactly as stored: the
// CoordinateSystemTransformMatrix is recorded in the notes, never applied.
// GIfTI surfaces from FreeSurfer, FSL, HCP and nilearn are in RAS (scanner,
// tkr-RAS, MNI or Talairach millimetres): the mesh is labelled RAS.
#include <pugixml.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "inflate.hpp"
#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

std::string inflate_zlib_or_gzip(std::string_view compressed, std::size_t expected,
                                 const std::string& name, const std::string& what) {
  return inflate_zlib_or_gzip(
      compressed, expected, InflateSize::exact,
      [&](const std::string& problem) { fail(name, what + ": " + problem); });
}

namespace {

/// Base64 (RFC 4648) with whitespace allowed anywhere.
std::string decode_base64(std::string_view text, const std::string& name, const std::string& what) {
  static const std::array<std::int8_t, 256> table = [] {
    std::array<std::int8_t, 256> t{};
    t.fill(-1);
    const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int i = 0; i < 64; ++i)
      t[static_cast<unsigned char>(alphabet[i])] = static_cast<std::int8_t>(i);
    for (char c : {' ', '\t', '\n', '\r', '\f', '\v'}) t[static_cast<unsigned char>(c)] = -2;
    t[static_cast<unsigned char>('=')] = -3;
    return t;
  }();
  std::string out;
  out.reserve(text.size() / 4 * 3 + 3);
  std::uint32_t group = 0;
  int count = 0;
  std::size_t padding = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    const int v = table[c];
    if (v == -2) continue;
    if (v == -3) {
      ++padding;
      continue;
    }
    if (v < 0) {
      std::string shown = "byte " + std::to_string(static_cast<int>(c));
      if (c >= 0x20 && c < 0x7f) {
        shown.assign(3, '\'');
        shown[1] = static_cast<char>(c);
      }
      fail(name, what + ": invalid base64 character " + shown + " at position " +
                     std::to_string(i) + " of the <Data> text");
    }
    if (padding > 0)
      fail(name,
           what + ": base64 data continues after the '=' padding at position " + std::to_string(i));
    group = (group << 6) | static_cast<std::uint32_t>(v);
    if (++count == 4) {
      out.push_back(static_cast<char>((group >> 16) & 0xff));
      out.push_back(static_cast<char>((group >> 8) & 0xff));
      out.push_back(static_cast<char>(group & 0xff));
      group = 0;
      count = 0;
    }
  }
  if (count == 1)
    fail(name, what + ": base64 data ends in the middle of a byte (truncated or damaged)");
  if (count == 2) out.push_back(static_cast<char>((group >> 4) & 0xff));
  if (count == 3) {
    out.push_back(static_cast<char>((group >> 10) & 0xff));
    out.push_back(static_cast<char>((group >> 2) & 0xff));
  }
  return out;
}

std::string trimmed(std::string_view s) {
  while (!s.empty() && TextCursor::is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && TextCursor::is_blank(s.back())) s.remove_suffix(1);
  return std::string(s);
}

/// All character data of an element (pcdata and CDATA sections joined).
std::string element_text(const pugi::xml_node& node) {
  std::string text;
  for (const pugi::xml_node& child : node.children())
    if (child.type() == pugi::node_pcdata || child.type() == pugi::node_cdata)
      text += child.value();
  return text;
}

enum class ElementType { uint8, int32, float32, float64 };

struct DataArray {
  std::size_t index = 0;  // position among the DataArrays (0-based)
  std::string intent;
  std::string what;  // "DataArray 1 (NIFTI_INTENT_TRIANGLE)" for messages
  ElementType type = ElementType::float32;
  std::size_t rows = 0;
  std::size_t columns = 1;
  pugi::xml_node node;
};

std::size_t element_size(ElementType t) {
  switch (t) {
    case ElementType::uint8:
      return 1;
    case ElementType::int32:
    case ElementType::float32:
      return 4;
    case ElementType::float64:
      return 8;
  }
  return 4;
}

std::size_t parse_count(const pugi::xml_node& node, const char* attribute, const std::string& name,
                        const std::string& what) {
  const std::string text = trimmed(node.attribute(attribute).value());
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, value);
  if (text.empty() || r.ec != std::errc() || r.ptr != end ||
      value > static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max()))
    fail(name, what + ": " + attribute + "=\"" + text.substr(0, 40) +
                   "\" is not a valid size (expected a non-negative integer)");
  return static_cast<std::size_t>(value);
}

DataArray describe(const pugi::xml_node& node, std::size_t index, const std::string& name) {
  DataArray a;
  a.index = index;
  a.node = node;
  a.intent = trimmed(node.attribute("Intent").value());
  a.what = "DataArray " + std::to_string(index) + " (" + a.intent + ")";
  const std::string type = trimmed(node.attribute("DataType").value());
  if (type == "NIFTI_TYPE_FLOAT32")
    a.type = ElementType::float32;
  else if (type == "NIFTI_TYPE_FLOAT64")
    a.type = ElementType::float64;
  else if (type == "NIFTI_TYPE_INT32")
    a.type = ElementType::int32;
  else if (type == "NIFTI_TYPE_UINT8")
    a.type = ElementType::uint8;
  else
    fail(name, a.what + ": DataType \"" + type.substr(0, 40) +
                   "\" is not supported (GIfTI allows NIFTI_TYPE_UINT8, NIFTI_TYPE_INT32 and "
                   "NIFTI_TYPE_FLOAT32)");
  std::size_t dimensionality = 0;
  if (node.attribute("Dimensionality"))
    dimensionality = parse_count(node, "Dimensionality", name, a.what);
  else
    dimensionality = node.attribute("Dim1") ? 2 : 1;
  if (dimensionality < 1 || dimensionality > 6)
    fail(name,
         a.what + ": Dimensionality=" + std::to_string(dimensionality) + " is outside 1 to 6");
  a.rows = parse_count(node, "Dim0", name, a.what);
  a.columns = 1;
  for (std::size_t d = 1; d < dimensionality; ++d) {
    const std::string attribute = "Dim" + std::to_string(d);
    if (!node.attribute(attribute.c_str()))
      fail(name, a.what + ": Dimensionality=" + std::to_string(dimensionality) + " but no " +
                     attribute + " attribute");
    const std::size_t extent = parse_count(node, attribute.c_str(), name, a.what);
    if (d == 1)
      a.columns = extent;
    else if (extent != 1)
      fail(name, a.what + ": " + attribute + "=" + std::to_string(extent) +
                     ": a surface array must be two-dimensional (Dim0 x Dim1)");
  }
  return a;
}

template <typename T>
T load_value(const char* p, bool swap) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, p, sizeof(T));
  if (swap) std::reverse(bytes, bytes + sizeof(T));
  T v;
  std::memcpy(&v, bytes, sizeof(T));
  return v;
}

/// Decodes the array's <Data> into Dim0 x Dim1 values in row-major order
/// (integers are exact in double).
std::vector<double> decode_values(const DataArray& a, const std::string& name) {
  const pugi::xml_node& node = a.node;
  const std::string encoding = trimmed(node.attribute("Encoding").value());
  const std::string external = trimmed(node.attribute("ExternalFileName").value());
  if (!external.empty() || encoding == "ExternalFileBinary")
    fail(name, a.what + ": external data files not supported (the array's data is in '" +
                   external.substr(0, 200) +
                   "'); save the surface with its data inside the .gii file "
                   "(Base64Binary or GZipBase64Binary encoding)");
  const std::string endian = trimmed(node.attribute("Endian").value());
  bool swap = false;
  if (endian == "BigEndian")
    swap = true;
  else if (!endian.empty() && endian != "LittleEndian")
    fail(name,
         a.what + ": Endian=\"" + endian.substr(0, 40) + "\" (expected LittleEndian or BigEndian)");
  const std::string order = trimmed(node.attribute("ArrayIndexingOrder").value());
  bool column_major = false;
  if (order == "ColumnMajorOrder")
    column_major = true;
  else if (!order.empty() && order != "RowMajorOrder")
    fail(name, a.what + ": ArrayIndexingOrder=\"" + order.substr(0, 40) +
                   "\" (expected RowMajorOrder or ColumnMajorOrder)");

  const pugi::xml_node data_node = node.child("Data");
  if (!data_node) fail(name, a.what + " has no <Data> element");
  const std::string text = element_text(data_node);
  const std::size_t count = a.rows * a.columns;
  // Sizes are checked against the data before anything that large is allocated.
  const std::size_t bytes_needed = count * element_size(a.type);
  if (encoding == "ASCII" && count > text.size() / 2 + 1)
    fail(name, a.what + ": Dim0 x Dim1 = " + std::to_string(a.rows) + " x " +
                   std::to_string(a.columns) + " values cannot fit in " +
                   std::to_string(text.size()) + " characters of ASCII data");
  if (encoding == "Base64Binary" && bytes_needed > text.size())
    fail(name, a.what + ": Dim0 x Dim1 = " + std::to_string(a.rows) + " x " +
                   std::to_string(a.columns) + " values need " + std::to_string(bytes_needed) +
                   " bytes, more than the " + std::to_string(text.size()) +
                   " characters of base64 data hold (wrong Dim0/Dim1 or truncated data)");
  // zlib expands at most ~1032:1.
  if (encoding == "GZipBase64Binary" && bytes_needed / 1100 > text.size())
    fail(name, a.what + ": Dim0 x Dim1 = " + std::to_string(a.rows) + " x " +
                   std::to_string(a.columns) + " values need " + std::to_string(bytes_needed) +
                   " bytes, more than the compressed data can hold (wrong Dim0/Dim1?)");
  std::vector<double> raw;
  if (encoding == "ASCII") {
    raw.resize(count);
    TextCursor c(text);
    for (std::size_t i = 0; i < count; ++i) {
      c.skip_blanks();
      if (c.at_end())
        fail(name, a.what + ": the ASCII data holds " + std::to_string(i) +
                       " numbers, Dim0 x Dim1 = " + std::to_string(a.rows) + " x " +
                       std::to_string(a.columns) + " needs " + std::to_string(count));
      const char* at = c.p;
      bool ok = false;
      if (a.type == ElementType::int32 || a.type == ElementType::uint8) {
        std::int64_t v = 0;
        ok = c.parse_integer(v, true) && c.token_ends_here();
        raw[i] = static_cast<double>(v);
      } else {
        ok = c.parse_double(raw[i], true);
      }
      if (!ok) {
        const char* e = at;
        while (e < c.end && !TextCursor::is_blank(*e) && e - at < 40) ++e;
        fail(name,
             a.what + ": ASCII value " + std::to_string(i) + " '" +
                 std::string(at, static_cast<std::size_t>(e - at)) + "' is not a " +
                 (a.type == ElementType::int32 || a.type == ElementType::uint8 ? "whole number"
                                                                               : "number"));
      }
    }
    c.skip_blanks();
    if (!c.at_end())
      fail(name, a.what + ": the ASCII data holds more than Dim0 x Dim1 = " +
                     std::to_string(a.rows) + " x " + std::to_string(a.columns) + " values");
  } else if (encoding == "Base64Binary" || encoding == "GZipBase64Binary") {
    std::string bytes = decode_base64(text, name, a.what);
    if (encoding == "GZipBase64Binary")
      bytes = inflate_zlib_or_gzip(bytes, bytes_needed, name, a.what);
    if (bytes.size() != bytes_needed)
      fail(name, a.what + ": the data holds " + std::to_string(bytes.size()) +
                     " bytes, Dim0 x Dim1 = " + std::to_string(a.rows) + " x " +
                     std::to_string(a.columns) + " values need " + std::to_string(bytes_needed) +
                     " (wrong Dim0/Dim1 or truncated data)");
    const char* p = bytes.data();
    raw.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      switch (a.type) {
        case ElementType::uint8:
          raw[i] = static_cast<unsigned char>(p[i]);
          break;
        case ElementType::int32:
          raw[i] = load_value<std::int32_t>(p + 4 * i, swap);
          break;
        case ElementType::float32:
          raw[i] = load_value<float>(p + 4 * i, swap);
          break;
        case ElementType::float64:
          raw[i] = load_value<double>(p + 8 * i, swap);
          break;
      }
    }
  } else {
    fail(name, a.what + ": Encoding=\"" + encoding.substr(0, 40) +
                   "\" is not supported (ASCII, Base64Binary or GZipBase64Binary)");
  }
  if (!column_major || a.columns == 1) return raw;
  std::vector<double> values(count);
  for (std::size_t i = 0; i < a.rows; ++i)
    for (std::size_t j = 0; j < a.columns; ++j) values[i * a.columns + j] = raw[j * a.rows + i];
  return values;
}

std::string metadata_value(const pugi::xml_node& array, const char* key) {
  for (const pugi::xml_node& md : array.child("MetaData").children("MD"))
    if (trimmed(md.child("Name").child_value()) == key)
      return trimmed(md.child("Value").child_value());
  return {};
}

void note_coordinate_systems(const DataArray& a, MeshFileInfo& info) {
  for (const pugi::xml_node& t : a.node.children("CoordinateSystemTransformMatrix")) {
    std::string note = "GIfTI coordinate system: DataSpace " +
                       trimmed(t.child("DataSpace").child_value()) + ", TransformedSpace " +
                       trimmed(t.child("TransformedSpace").child_value());
    const std::string matrix = element_text(t.child("MatrixData"));
    TextCursor m(matrix);
    bool identity = true;
    int parsed = 0;
    for (int k = 0; k < 16; ++k) {
      double v = 0;
      if (!m.parse_double(v, true)) break;
      ++parsed;
      if (v != (k % 5 == 0 ? 1.0 : 0.0)) identity = false;
    }
    if (parsed != 16)
      note += " (MatrixData unreadable; ignored)";
    else if (identity)
      note += " (identity matrix)";
    else
      note += " (matrix not applied: coordinates are kept as stored, in the DataSpace)";
    info.notes.push_back(note);
  }
}

}  // namespace

void read_gifti(std::string_view data, const std::string& name, const ReadOptions&,
                LoadedMesh& out) {
  TriangleMesh& mesh = out.mesh;
  MeshFileInfo& info = out.info;
  info.format = "gifti";
  const std::string xml = is_gzip(data)
                              ? inflate_zlib_or_gzip(data, std::numeric_limits<std::size_t>::max(),
                                                     name, "gzip-compressed GIfTI file")
                              : std::string(data);
  if (is_gzip(data)) info.notes.push_back("whole file gzip-compressed");
  if (xml.empty()) fail(name, "the GIfTI file is empty");
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed =
      doc.load_buffer(xml.data(), xml.size(), pugi::parse_default, pugi::encoding_auto);
  if (!parsed) {
    const auto offset =
        std::clamp<std::ptrdiff_t>(parsed.offset, 0, static_cast<std::ptrdiff_t>(xml.size()));
    const std::string_view before(xml.data(), static_cast<std::size_t>(offset));
    fail(name, std::string("not a valid GIfTI XML file: ") + parsed.description() + " (line " +
                   std::to_string(1 + std::count(before.begin(), before.end(), '\n')) + ")");
  }
  const pugi::xml_node root = doc.child("GIFTI");
  if (!root) {
    const pugi::xml_node first = doc.document_element();
    fail(name, std::string("not a GIfTI file: the root XML element is <") +
                   (first ? first.name() : "") + ">, expected <GIFTI>");
  }
  // Only the two arrays used are checked in detail: other arrays (normals,
  // labels, any data type) do not stop a surface from being read.
  std::size_t array_count = 0;
  std::optional<DataArray> points, triangles;
  std::vector<std::string> ignored;
  for (const pugi::xml_node& node : root.children("DataArray")) {
    const std::string intent = trimmed(node.attribute("Intent").value());
    if (intent == "NIFTI_INTENT_POINTSET" && !points)
      points = describe(node, array_count, name);
    else if (intent == "NIFTI_INTENT_TRIANGLE" && !triangles)
      triangles = describe(node, array_count, name);
    else
      ignored.push_back(intent.empty() ? std::string("(no Intent)") : intent);
    ++array_count;
  }
  if (!points)
    fail(name, "the GIfTI file has no NIFTI_INTENT_POINTSET DataArray (" +
                   std::to_string(array_count) +
                   " DataArrays): it holds per-vertex data (a .func/.shape/.label.gii?), "
                   "not a surface");
  if (!triangles)
    fail(name,
         "the GIfTI file has a NIFTI_INTENT_POINTSET but no NIFTI_INTENT_TRIANGLE "
         "DataArray: a point set without faces, not a surface");
  if (points->columns != 3)
    fail(name, points->what + ": Dim1=" + std::to_string(points->columns) +
                   ", a point set needs Dim1=3 (x y z)");
  if (triangles->columns != 3)
    fail(name, triangles->what + ": Dim1=" + std::to_string(triangles->columns) +
                   ", triangles need Dim1=3 (three vertex indices)");
  if (points->type != ElementType::float32 && points->type != ElementType::float64)
    fail(name, points->what + ": coordinates must be NIFTI_TYPE_FLOAT32");
  if (triangles->type != ElementType::int32 && triangles->type != ElementType::uint8)
    fail(name, triangles->what + ": indices must be NIFTI_TYPE_INT32");
  if (!ignored.empty()) {
    std::string note = "ignored DataArrays:";
    for (const std::string& s : ignored) {
      note += ' ';
      note += s.substr(0, 40);
    }
    info.notes.push_back(note);
  }
  const std::string encoding = trimmed(points->node.attribute("Encoding").value());
  info.binary = encoding != "ASCII";

  const std::vector<double> xyz = decode_values(*points, name);
  mesh.positions.resize(points->rows);
  for (std::size_t i = 0; i < points->rows; ++i)
    mesh.positions[i] = Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  const std::vector<double> corners = decode_values(*triangles, name);
  mesh.faces.resize(triangles->rows);
  const auto nv = static_cast<double>(points->rows);
  for (std::size_t f = 0; f < triangles->rows; ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const double v = corners[3 * f + k];
      if (v < 0 || v >= nv)
        fail(name, triangles->what + ": triangle " + std::to_string(f) + " refers to vertex " +
                       std::to_string(static_cast<std::int64_t>(v)) + ", but the point set has " +
                       std::to_string(points->rows) + " vertices (0 to " +
                       std::to_string(static_cast<std::int64_t>(nv) - 1) + ")");
      mesh.faces[f][k] = static_cast<std::int32_t>(v);
    }
  info.file_vertices = points->rows;
  info.file_polygons = triangles->rows;

  note_coordinate_systems(*points, info);
  std::string anatomy;
  for (const char* key :
       {"AnatomicalStructurePrimary", "AnatomicalStructureSecondary", "GeometricType"}) {
    const std::string v = metadata_value(points->node, key);
    if (!v.empty())
      anatomy.append(anatomy.empty() ? "" : ", ").append(key).append(" ").append(v.substr(0, 60));
  }
  if (!anatomy.empty()) info.notes.push_back("GIfTI metadata: " + anatomy);
  // GIfTI surfaces are RAS millimetres by convention (FreeSurfer, FSL, HCP,
  // MNI templates); a SPACE tag is not part of the format.
  info.tagged_space = Space::ras;
}

}  // namespace fabrica::io::detail
