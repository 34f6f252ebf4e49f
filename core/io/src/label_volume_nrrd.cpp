// NRRD (.nrrd, .nhdr) and 3D Slicer segmentation (.seg.nrrd) reader.
//
// Header fields used (NRRD format 0004/0005): type, dimension, sizes,
// encoding (raw, gzip, ascii), endian, space / space dimension, space
// directions, space origin, spacings (when there are no space directions),
// kinds, data file, byte skip, line skip; Slicer key/value pairs
// Segment<N>_Name/_LabelValue/_Layer/_Color. A 4D file has one non-spatial
// axis (first or last): each of its values is one label-map layer.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "fabrica/core/error.hpp"
#include "label_volume_internal.hpp"

namespace fabrica::io::volume_detail {
namespace {

std::optional<ElementType> nrrd_type(const std::string& t) {
  static const std::map<std::string, ElementType> types = {
      {"signed char", ElementType::int8},
      {"int8", ElementType::int8},
      {"int8_t", ElementType::int8},
      {"uchar", ElementType::uint8},
      {"unsigned char", ElementType::uint8},
      {"uint8", ElementType::uint8},
      {"uint8_t", ElementType::uint8},
      {"short", ElementType::int16},
      {"short int", ElementType::int16},
      {"signed short", ElementType::int16},
      {"signed short int", ElementType::int16},
      {"int16", ElementType::int16},
      {"int16_t", ElementType::int16},
      {"ushort", ElementType::uint16},
      {"unsigned short", ElementType::uint16},
      {"unsigned short int", ElementType::uint16},
      {"uint16", ElementType::uint16},
      {"uint16_t", ElementType::uint16},
      {"int", ElementType::int32},
      {"signed int", ElementType::int32},
      {"int32", ElementType::int32},
      {"int32_t", ElementType::int32},
      {"uint", ElementType::uint32},
      {"unsigned int", ElementType::uint32},
      {"uint32", ElementType::uint32},
      {"uint32_t", ElementType::uint32},
      {"longlong", ElementType::int64},
      {"long long", ElementType::int64},
      {"long long int", ElementType::int64},
      {"signed long long", ElementType::int64},
      {"signed long long int", ElementType::int64},
      {"int64", ElementType::int64},
      {"int64_t", ElementType::int64},
      {"ulonglong", ElementType::uint64},
      {"unsigned long long", ElementType::uint64},
      {"unsigned long long int", ElementType::uint64},
      {"uint64", ElementType::uint64},
      {"uint64_t", ElementType::uint64},
      {"float", ElementType::float32},
      {"double", ElementType::float64}};
  const auto it = types.find(t);
  if (it == types.end()) return std::nullopt;
  return it->second;
}

/// "(x,y,z) none (x,y,z)" -> one optional vector per axis.
std::vector<std::optional<Vec3>> parse_space_directions(const std::string& text,
                                                        const std::string& what) {
  std::vector<std::optional<Vec3>> out;
  std::size_t p = 0;
  while (p < text.size()) {
    while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p]))) ++p;
    if (p >= text.size()) break;
    if (text.compare(p, 4, "none") == 0) {
      out.emplace_back(std::nullopt);
      p += 4;
      continue;
    }
    if (text[p] != '(')
      throw InputError(what +
                       ": 'space directions' should list vectors like (1,0,0) or 'none', "
                       "reads '" +
                       text + "'");
    const auto close = text.find(')', p);
    if (close == std::string::npos)
      throw InputError(what + ": 'space directions' has an unclosed '('");
    const std::vector<double> v =
        parse_numbers(text.substr(p + 1, close - p - 1), what, "space directions");
    if (v.size() != 3)
      throw InputError(what + ": 'space directions' vectors need 3 components (3D space), found " +
                       std::to_string(v.size()));
    out.emplace_back(Vec3(v[0], v[1], v[2]));
    p = close + 1;
  }
  return out;
}

Vec3 parse_vector(const std::string& text, const std::string& what, const std::string& field) {
  std::string inner = text;
  std::replace(inner.begin(), inner.end(), '(', ' ');
  std::replace(inner.begin(), inner.end(), ')', ' ');
  const std::vector<double> v = parse_numbers(inner, what, field);
  if (v.size() != 3)
    throw InputError(what + ": '" + field + "' needs 3 numbers, found " + std::to_string(v.size()));
  return {v[0], v[1], v[2]};
}

long long parse_integer(const std::string& text, const std::string& what,
                        const std::string& field) {
  const std::vector<double> v = parse_numbers(text, what, field);
  if (v.size() != 1 || v[0] != std::floor(v[0]) || std::abs(v[0]) > 9e18)
    throw InputError(what + ": '" + field + "' should be one integer, reads '" + text + "'");
  return static_cast<long long>(v[0]);
}

struct SegmentFields {
  std::optional<std::string> name;
  std::optional<int> value;
  std::optional<int> layer;
  std::optional<std::array<double, 3>> color;
};

}  // namespace

LabelVolume read_nrrd(const std::filesystem::path& path) {
  const std::string what = "volume '" + path.string() + "'";
  const std::string bytes = read_file_bytes(path, what);
  if (bytes.rfind("NRRD000", 0) != 0)
    throw InputError(what + ": not a NRRD file (the first line should be NRRD0004 or similar)");

  std::map<std::string, std::string> fields;      // lowercase field name -> value
  std::map<std::string, std::string> key_values;  // key:=value pairs, case kept
  std::size_t pos = bytes.find('\n');
  if (pos == std::string::npos) throw InputError(what + ": header has no end of line");
  ++pos;
  std::size_t data_start = bytes.size();
  bool header_closed = false;
  while (pos < bytes.size()) {
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos) eol = bytes.size();
    std::string line = bytes.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = eol + 1;
    if (line.empty()) {
      data_start = std::min(pos, bytes.size());
      header_closed = true;
      break;
    }
    if (line[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos)
      throw InputError(what + ": header line '" + line.substr(0, 80) +
                       "' is neither 'field: value' nor 'key:=value' (garbled header?)");
    if (colon + 1 < line.size() && line[colon + 1] == '=') {
      key_values[line.substr(0, colon)] = line.substr(colon + 2);
    } else {
      fields[lowercase(trim(line.substr(0, colon)))] = trim(line.substr(colon + 1));
    }
  }
  auto field = [&](const std::string& name) -> const std::string* {
    const auto it = fields.find(name);
    return it == fields.end() ? nullptr : &it->second;
  };
  auto require = [&](const std::string& name) -> const std::string& {
    const std::string* v = field(name);
    if (v == nullptr) throw InputError(what + ": NRRD header has no '" + name + "' field");
    return *v;
  };

  // Element type, dimension, sizes.
  const std::string type_text = lowercase(require("type"));
  const std::optional<ElementType> type = nrrd_type(type_text);
  if (!type)
    throw InputError(what + ": NRRD type '" + type_text +
                     "' is not supported (use an integer "
                     "type, float or double)");
  const long long dimension = parse_integer(require("dimension"), what, "dimension");
  if (dimension != 3 && dimension != 4)
    throw InputError(what + ": NRRD dimension is " + std::to_string(dimension) +
                     "; fabrica needs a 3D volume (or 4D layered segmentation)");
  const std::vector<double> size_values = parse_numbers(require("sizes"), what, "sizes");
  if (static_cast<long long>(size_values.size()) != dimension)
    throw InputError(what + ": 'sizes' lists " + std::to_string(size_values.size()) +
                     " numbers but dimension is " + std::to_string(dimension));
  std::vector<std::size_t> sizes;
  for (double s : size_values) {
    if (s < 1 || s != std::floor(s) || s > 1e9)
      throw InputError(what + ": 'sizes' must be positive integers");
    sizes.push_back(static_cast<std::size_t>(s));
  }

  // Which axes are spatial.
  std::vector<bool> spatial(static_cast<std::size_t>(dimension), true);
  std::vector<std::optional<Vec3>> directions;
  if (const std::string* sd = field("space directions")) {
    directions = parse_space_directions(*sd, what);
    if (static_cast<long long>(directions.size()) != dimension)
      throw InputError(what + ": 'space directions' lists " + std::to_string(directions.size()) +
                       " axes but dimension is " + std::to_string(dimension));
    for (std::size_t a = 0; a < directions.size(); ++a) spatial[a] = directions[a].has_value();
  } else if (const std::string* kinds = field("kinds")) {
    std::istringstream in(*kinds);
    std::vector<std::string> kind_list;
    for (std::string k; in >> k;) kind_list.push_back(lowercase(k));
    if (static_cast<long long>(kind_list.size()) == dimension)
      for (std::size_t a = 0; a < kind_list.size(); ++a)
        spatial[a] = kind_list[a] == "domain" || kind_list[a] == "space";
  } else if (dimension == 4) {
    spatial[0] = false;  // Slicer's convention: the list axis comes first
  }
  std::vector<int> spatial_axes, other_axes;
  for (int a = 0; a < dimension; ++a) (spatial[a] ? spatial_axes : other_axes).push_back(a);
  if (spatial_axes.size() != 3)
    throw InputError(what + ": fabrica needs exactly 3 spatial axes, the header gives " +
                     std::to_string(spatial_axes.size()));

  LabelVolume volume;
  volume.format = "nrrd";
  VolumeGeometry& g = volume.geometry;
  for (int a = 0; a < 3; ++a) g.dims[a] = static_cast<int>(sizes[spatial_axes[a]]);
  SampleLayout layout;
  layout.type = *type;
  if (!other_axes.empty()) {
    const int list_axis = other_axes[0];
    layout.layer_count = sizes[list_axis];
    if (list_axis == 0) {
      layout.voxel_stride = layout.layer_count;
      layout.layer_stride = 1;
    } else if (list_axis == dimension - 1) {
      layout.voxel_stride = 1;
      layout.layer_stride = g.voxel_count();
    } else {
      throw InputError(what + ": the non-spatial axis must be the first or the last one");
    }
  }

  // Orientation: NRRD world = origin + sum_a index_a * direction_a, in `space`.
  double flip_x = 1.0, flip_y = 1.0;
  std::string space_name = "LPS (no 'space' field; assumed)";
  if (const std::string* space = field("space")) {
    const std::string s = lowercase(*space);
    if (s == "left-posterior-superior" || s == "lps" || s == "left-posterior-superior-time") {
      space_name = "LPS";
    } else if (s == "right-anterior-superior" || s == "ras" ||
               s == "right-anterior-superior-time") {
      flip_x = flip_y = -1.0;
      space_name = "RAS, converted to LPS";
    } else if (s == "left-anterior-superior" || s == "las" || s == "left-anterior-superior-time") {
      flip_y = -1.0;
      space_name = "LAS, converted to LPS";
    } else if (s == "scanner-xyz" || s == "3d-right-handed" || s == "3d-left-handed" ||
               s == "scanner-xyz-time" || s == "3d-right-handed-time" ||
               s == "3d-left-handed-time") {
      space_name = "'" + *space + "' (not anatomical; taken as LPS)";
      volume.notes.push_back("space '" + *space + "' is not anatomical; coordinates taken as LPS");
    } else {
      throw InputError(what + ": NRRD space '" + *space + "' is not known");
    }
  }
  if (!directions.empty()) {
    for (int a = 0; a < 3; ++a) {
      const Vec3 d = *directions[spatial_axes[a]];
      const double len = d.norm();
      if (!(len > 0.0) || !std::isfinite(len))
        throw InputError(what + ": space direction of axis " + std::to_string(spatial_axes[a]) +
                         " has zero or invalid length");
      g.spacing[a] = len;
      g.direction.col(a) = d / len;
    }
    volume.orientation_source = "NRRD space directions, space " + space_name;
  } else {
    g.direction.setIdentity();
    if (const std::string* sp = field("spacings")) {
      std::istringstream in(*sp);
      std::vector<std::string> tokens;
      for (std::string t; in >> t;) tokens.push_back(t);
      if (static_cast<long long>(tokens.size()) != dimension)
        throw InputError(what + ": 'spacings' lists " + std::to_string(tokens.size()) +
                         " values but dimension is " + std::to_string(dimension));
      for (int a = 0; a < 3; ++a) {
        const std::string& t = tokens[spatial_axes[a]];
        if (lowercase(t) == "nan") {
          g.spacing[a] = 1.0;
          continue;
        }
        const std::vector<double> v = parse_numbers(t, what, "spacings");
        if (v.size() != 1)  // "," parses as no number (fuzz_nrrd finding: read past the end)
          throw InputError(what + ": 'spacings' should hold one number per axis, reads '" + t +
                           "'");
        g.spacing[a] = v[0];
      }
    }
    volume.orientation_source =
        "NRRD without space directions: axes along x, y, z (" + space_name + ")";
    volume.notes.push_back("no 'space directions': axes assumed aligned with LPS x, y, z");
  }
  if (const std::string* o = field("space origin"))
    g.origin = parse_vector(*o, what, "space origin");
  g.direction.row(0) *= flip_x;
  g.direction.row(1) *= flip_y;
  g.origin.x() *= flip_x;
  g.origin.y() *= flip_y;
  check_geometry(g, what);

  // Voxel data.
  const std::string encoding = lowercase(require("encoding"));
  const std::size_t esize = element_size(*type);
  if (esize > 1) {
    const std::string* endian = field("endian");
    const bool big = endian != nullptr && lowercase(*endian) == "big";
    if (endian == nullptr && encoding != "ascii" && encoding != "text" && encoding != "txt")
      volume.notes.push_back("no 'endian' field: little endian assumed");
    layout.swap_bytes = big != (std::endian::native == std::endian::big);
  }
  std::string detached;
  std::string_view data;
  const std::string* data_file = field("data file");
  if (data_file == nullptr) data_file = field("datafile");
  if (data_file != nullptr) {
    const std::string df = trim(*data_file);
    if (df.rfind("LIST", 0) == 0 || df.find('%') != std::string::npos ||
        df.find(' ') != std::string::npos)
      throw InputError(what + ": data split over several files ('data file: " + df +
                       "') is not supported; save the volume as one .nrrd");
    const std::filesystem::path data_path = path.parent_path() / df;
    detached = read_file_bytes(data_path, what + " (data file '" + data_path.string() + "')");
    data = detached;
  } else {
    if (!header_closed)
      throw InputError(what + ": header never ends (no blank line) and names no data file");
    data = std::string_view(bytes).substr(data_start);
  }
  long long line_skip = 0, byte_skip = 0;
  if (const std::string* ls = field("line skip")) line_skip = parse_integer(*ls, what, "line skip");
  if (const std::string* ls = field("lineskip")) line_skip = parse_integer(*ls, what, "lineskip");
  if (const std::string* bs = field("byte skip")) byte_skip = parse_integer(*bs, what, "byte skip");
  if (const std::string* bs = field("byteskip")) byte_skip = parse_integer(*bs, what, "byteskip");
  for (long long l = 0; l < line_skip; ++l) {
    const auto eol = data.find('\n');
    if (eol == std::string_view::npos) throw InputError(what + ": 'line skip' runs past the data");
    data.remove_prefix(eol + 1);
  }
  const std::size_t needed = g.voxel_count() * layout.layer_count * esize;
  std::string inflated;
  if (encoding == "raw") {
    skip_to_samples(data, byte_skip, needed, what, "'byte skip' runs past the data");
    decode_samples(data, layout, volume, what);
  } else if (encoding == "gzip" || encoding == "gz") {
    const std::size_t skip = byte_skip > 0 ? static_cast<std::size_t>(byte_skip) : 0;
    inflated = inflate_bytes(data, needed + skip, what);
    decode_samples(std::string_view(inflated).substr(skip), layout, volume, what);
  } else if (encoding == "ascii" || encoding == "text" || encoding == "txt") {
    decode_text_samples(data, layout, volume, what);
  } else {
    throw InputError(what + ": NRRD encoding '" + encoding +
                     "' is not supported (use raw, gzip or ascii)");
  }

  // 3D Slicer segment metadata.
  std::map<int, SegmentFields> segments;
  for (const auto& [key, value] : key_values) {
    if (key.rfind("Segment", 0) != 0) continue;
    std::size_t p = 7;
    while (p < key.size() && std::isdigit(static_cast<unsigned char>(key[p]))) ++p;
    if (p == 7 || p >= key.size() || key[p] != '_') continue;
    int index = 0;
    if (const auto r = std::from_chars(key.data() + 7, key.data() + p, index); r.ec != std::errc())
      throw InputError(what + ": field '" + key + "': the segment number is too large");
    const std::string name = key.substr(p + 1);
    SegmentFields& s = segments[index];
    const std::string v = trim(value);
    const std::string field_name = key;
    auto as_int = [&](const std::string& text) {
      const long long n = parse_integer(text, what, field_name);
      if (n < std::numeric_limits<std::int32_t>::min() ||
          n > std::numeric_limits<std::int32_t>::max())
        throw InputError(what + ": field '" + field_name + "' = " + text +
                         " does not fit a 32-bit label");
      return static_cast<int>(n);
    };
    if (name == "Name") {
      check_utf8_name(v, what, "field '" + field_name + "'");
      s.name = v;
    } else if (name == "LabelValue") {
      s.value = as_int(v);
    } else if (name == "Layer") {
      s.layer = as_int(v);
    } else if (name == "Color") {
      const std::vector<double> c = parse_numbers(v, what, field_name);
      if (c.size() >= 3) s.color = std::array<double, 3>{c[0], c[1], c[2]};
    }
  }
  for (const auto& [index, s] : segments) {
    LabelInfo info;
    info.value = s.value.value_or(1);
    info.layer = s.layer.value_or(layout.layer_count > 1 ? index : 0);
    if (info.layer < 0 || static_cast<std::size_t>(info.layer) >= layout.layer_count)
      throw InputError(what + ": Segment" + std::to_string(index) + " is in layer " +
                       std::to_string(info.layer) + " but the file has " +
                       std::to_string(layout.layer_count) + " layer(s)");
    info.name = s.name.value_or("Segment_" + std::to_string(index));
    info.color = s.color;
    volume.labels.push_back(std::move(info));
  }
  if (!segments.empty()) volume.format = "seg.nrrd";
  return volume;
}

}  // namespace fabrica::io::volume_detail
