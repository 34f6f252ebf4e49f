// MetaImage (.mha with the data attached, .mhd with a separate data file).
//
// ITK convention (the one every MetaImage writer follows): world coordinates
// are LPS and  p = Offset + D * (ElementSpacing .* index), where row a of
// the row-major TransformMatrix is the direction of index axis a (column a
// of D). AnatomicalOrientation is only used when there is no TransformMatrix;
// its letters name the side each axis comes FROM (ITK's "RAI" = identity).
#include <algorithm>
#include <bit>
#include <cmath>
#include <map>

#include "fabrica/core/error.hpp"
#include "label_volume_internal.hpp"

namespace fabrica::io::volume_detail {
namespace {

ElementType metaimage_type(const std::string& t, const std::string& what) {
  static const std::map<std::string, ElementType> types = {
      {"MET_CHAR", ElementType::int8},       {"MET_UCHAR", ElementType::uint8},
      {"MET_SHORT", ElementType::int16},     {"MET_USHORT", ElementType::uint16},
      {"MET_INT", ElementType::int32},       {"MET_UINT", ElementType::uint32},
      {"MET_LONG", ElementType::int32},      {"MET_ULONG", ElementType::uint32},
      {"MET_LONG_LONG", ElementType::int64}, {"MET_ULONG_LONG", ElementType::uint64},
      {"MET_FLOAT", ElementType::float32},   {"MET_DOUBLE", ElementType::float64}};
  const auto it = types.find(t);
  if (it == types.end())
    throw InputError(what + ": ElementType '" + t +
                     "' is not supported (use a scalar integer, "
                     "MET_FLOAT or MET_DOUBLE type)");
  return it->second;
}

bool is_true(const std::string& v) {
  const std::string l = lowercase(v);
  return l == "true" || l == "1" || l == "yes";
}

/// ITK orientation letter (the side the axis comes from) -> LPS unit vector.
Vec3 from_letter(char c, const std::string& what) {
  switch (std::toupper(static_cast<unsigned char>(c))) {
    case 'R':
      return Vec3(1, 0, 0);  // from right, towards left = +x (LPS)
    case 'L':
      return Vec3(-1, 0, 0);
    case 'A':
      return Vec3(0, 1, 0);  // from anterior, towards posterior = +y
    case 'P':
      return Vec3(0, -1, 0);
    case 'I':
      return Vec3(0, 0, 1);  // from inferior, towards superior = +z
    case 'S':
      return Vec3(0, 0, -1);
    default:
      break;
  }
  throw InputError(what + ": AnatomicalOrientation letter '" + std::string(1, c) +
                   "' is not one of R L A P I S");
}

}  // namespace

LabelVolume read_metaimage(const std::filesystem::path& path) {
  const std::string what = "volume '" + path.string() + "'";
  const std::string bytes = read_file_bytes(path, what);
  std::map<std::string, std::string> fields;  // lowercase key -> value
  std::size_t pos = 0;
  std::size_t data_start = std::string::npos;
  int line_number = 0;
  while (pos < bytes.size()) {
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos) eol = bytes.size();
    std::string line = bytes.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_number;
    const std::string t = trim(line);
    if (t.empty()) continue;
    const auto eq = t.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError(what + ": header line " + std::to_string(line_number) + " '" +
                       t.substr(0, 60) + "' is not 'Key = Value' (not a MetaImage header?)");
    const std::string key = lowercase(trim(t.substr(0, eq)));
    fields[key] = trim(t.substr(eq + 1));
    if (key == "elementdatafile") {
      data_start = std::min(pos, bytes.size());
      break;
    }
  }
  auto field = [&](const std::string& name) -> const std::string* {
    const auto it = fields.find(name);
    return it == fields.end() ? nullptr : &it->second;
  };
  auto require = [&](const std::string& name, const char* display) -> const std::string& {
    const std::string* v = field(name);
    if (v == nullptr) throw InputError(what + ": MetaImage header has no '" + display + "' field");
    return *v;
  };
  if (const std::string* ot = field("objecttype"); ot != nullptr && lowercase(*ot) != "image")
    throw InputError(what + ": MetaImage ObjectType is '" + *ot + "', not Image");
  const std::vector<double> ndims = parse_numbers(require("ndims", "NDims"), what, "NDims");
  if (ndims.size() != 1 || ndims[0] != 3)
    throw InputError(what + ": NDims must be 3 (a 3D volume)");
  const std::vector<double> dims = parse_numbers(require("dimsize", "DimSize"), what, "DimSize");
  if (dims.size() != 3) throw InputError(what + ": DimSize needs 3 numbers");
  const std::string data_file = require("elementdatafile", "ElementDataFile");
  if (const std::string* ch = field("elementnumberofchannels"))
    if (parse_numbers(*ch, what, "ElementNumberOfChannels") != std::vector<double>{1.0})
      throw InputError(what +
                       ": ElementNumberOfChannels must be 1 (a scalar label or level-set "
                       "volume)");

  LabelVolume volume;
  volume.format = "metaimage";
  VolumeGeometry& g = volume.geometry;
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 1 || dims[a] != std::floor(dims[a]) || dims[a] > 1e9)
      throw InputError(what + ": DimSize must be positive integers");
    g.dims[a] = static_cast<int>(dims[a]);
  }
  const std::string* sp = field("elementspacing");
  if (sp == nullptr) sp = field("elementsize");
  if (sp != nullptr) {
    const std::vector<double> s = parse_numbers(*sp, what, "ElementSpacing");
    if (s.size() != 3) throw InputError(what + ": ElementSpacing needs 3 numbers");
    g.spacing = Vec3(s[0], s[1], s[2]);
  }
  for (const char* key : {"offset", "origin", "position"}) {
    if (const std::string* o = field(key)) {
      const std::vector<double> v = parse_numbers(*o, what, key);
      if (v.size() != 3) throw InputError(what + ": " + key + " needs 3 numbers");
      g.origin = Vec3(v[0], v[1], v[2]);
      break;
    }
  }
  bool have_matrix = false;
  for (const char* key : {"transformmatrix", "rotation", "orientation"}) {
    if (const std::string* m = field(key)) {
      const std::vector<double> v = parse_numbers(*m, what, key);
      if (v.size() != 9) throw InputError(what + ": TransformMatrix needs 9 numbers");
      for (int a = 0; a < 3; ++a) g.direction.col(a) = Vec3(v[3 * a], v[3 * a + 1], v[3 * a + 2]);
      have_matrix = true;
      break;
    }
  }
  const std::string* anatomical = field("anatomicalorientation");
  if (have_matrix) {
    volume.orientation_source = "MetaImage TransformMatrix (LPS)";
    for (int a = 0; a < 3; ++a) {
      const double len = g.direction.col(a).norm();
      if (len > 0.0 && std::isfinite(len)) g.direction.col(a) /= len;
    }
  } else if (anatomical != nullptr && anatomical->size() == 3 && lowercase(*anatomical) != "???") {
    for (int a = 0; a < 3; ++a) g.direction.col(a) = from_letter((*anatomical)[a], what);
    volume.orientation_source = "MetaImage AnatomicalOrientation " + *anatomical + " (LPS)";
  } else {
    volume.orientation_source = "MetaImage without TransformMatrix: identity (LPS)";
  }
  check_geometry(g, what);

  SampleLayout layout;
  layout.type = metaimage_type(require("elementtype", "ElementType"), what);
  bool big_endian = false;
  if (const std::string* msb = field("binarydatabyteordermsb")) big_endian = is_true(*msb);
  if (const std::string* msb = field("elementbyteordermsb")) big_endian = is_true(*msb);
  layout.swap_bytes = big_endian != (std::endian::native == std::endian::big);
  const bool binary = field("binarydata") == nullptr || is_true(*field("binarydata"));
  const bool compressed = field("compresseddata") != nullptr && is_true(*field("compresseddata"));
  long long header_size = 0;
  if (const std::string* hs = field("headersize"))
    header_size = static_cast<long long>(parse_numbers(*hs, what, "HeaderSize").at(0));

  std::string detached;
  std::string_view data;
  if (lowercase(data_file) == "local") {
    data = std::string_view(bytes).substr(data_start);
  } else {
    if (data_file.rfind("LIST", 0) == 0 || data_file.find('%') != std::string::npos)
      throw InputError(what + ": data split over several files (ElementDataFile = " + data_file +
                       ") is not supported; save the volume as one .mha");
    const std::filesystem::path data_path = path.parent_path() / data_file;
    detached = read_file_bytes(data_path, what + " (data file '" + data_path.string() + "')");
    data = detached;
  }
  const std::size_t needed = g.voxel_count() * element_size(layout.type);
  // HeaderSize = -1 (data at the end) only means something for raw binary data.
  skip_to_samples(data, header_size == -1 && (compressed || !binary) ? 0 : header_size, needed,
                  what, "HeaderSize runs past the end of the data");
  if (!binary) {
    decode_text_samples(data, layout, volume, what);
  } else if (compressed) {
    // CompressedDataSize is not trusted: files in the wild (VTK's frog) carry
    // a stale value; the zlib stream knows where it ends.
    const std::string inflated = inflate_bytes(data, needed, what);
    decode_samples(inflated, layout, volume, what);
  } else {
    decode_samples(data, layout, volume, what);
  }
  return volume;
}

}  // namespace fabrica::io::volume_detail
