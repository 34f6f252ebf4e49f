// Volume reading shared by all formats: file bytes, zlib/gzip inflation,
// sample decoding into label maps or scalars, format dispatch, label tables.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"
#include "inflate.hpp"
#include "label_volume_internal.hpp"

namespace fabrica::io {
namespace volume_detail {

void skip_to_samples(std::string_view& data, long long skip, std::size_t needed,
                     const std::string& what, const char* past_end) {
  if (skip == -1) {
    if (data.size() < needed)
      throw InputError(what + ": voxel data holds " + std::to_string(data.size()) +
                       " bytes but the header describes " + std::to_string(needed));
    data = data.substr(data.size() - needed);
  } else if (skip > 0) {
    if (static_cast<std::size_t>(skip) > data.size()) throw InputError(what + ": " + past_end);
    data.remove_prefix(static_cast<std::size_t>(skip));
  }
}

std::size_t element_size(ElementType type) {
  switch (type) {
    case ElementType::int8:
    case ElementType::uint8:
      return 1;
    case ElementType::int16:
    case ElementType::uint16:
      return 2;
    case ElementType::int32:
    case ElementType::uint32:
    case ElementType::float32:
      return 4;
    case ElementType::int64:
    case ElementType::uint64:
    case ElementType::float64:
      return 8;
  }
  return 1;
}

const char* to_string(ElementType type) {
  switch (type) {
    case ElementType::int8:
      return "int8";
    case ElementType::uint8:
      return "uint8";
    case ElementType::int16:
      return "int16";
    case ElementType::uint16:
      return "uint16";
    case ElementType::int32:
      return "int32";
    case ElementType::uint32:
      return "uint32";
    case ElementType::int64:
      return "int64";
    case ElementType::uint64:
      return "uint64";
    case ElementType::float32:
      return "float32";
    case ElementType::float64:
      return "float64";
  }
  return "?";
}

std::string lowercase(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<double> parse_numbers(std::string_view text, const std::string& what,
                                  const std::string& field) {
  std::vector<double> out;
  std::string buffer(text);
  const char* p = buffer.c_str();
  while (true) {
    while (*p != 0 && (std::isspace(static_cast<unsigned char>(*p)) || *p == ',')) ++p;
    if (*p == 0) break;
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p)
      throw InputError(what + ": field '" + field + "' should hold numbers but reads '" +
                       trim(text) + "'");
    out.push_back(v);
    p = end;
  }
  return out;
}

std::string read_file_bytes(const std::filesystem::path& path, const std::string& what) {
  return read_input_file(path, what);
}

std::string inflate_bytes(std::string_view compressed, std::size_t expected,
                          const std::string& what) {
  // Volume headers give the size of the samples; data after them is ignored.
  return detail::inflate_zlib_or_gzip(
      compressed, expected, detail::InflateSize::at_least,
      [&](const std::string& problem) { throw InputError(what + ": " + problem); });
}

namespace {

template <class T>
T load_sample(const char* p, bool swap) {
  T v;
  if constexpr (sizeof(T) == 1) {
    std::memcpy(&v, p, 1);
  } else {
    char tmp[sizeof(T)];
    std::memcpy(tmp, p, sizeof(T));
    if (swap) std::reverse(tmp, tmp + sizeof(T));
    std::memcpy(&v, tmp, sizeof(T));
  }
  return v;
}

template <class T>
void decode_typed(const char* data, const SampleLayout& layout, LabelVolume& volume,
                  const std::string& what) {
  const std::size_t n = volume.geometry.voxel_count();
  const std::size_t layers = layout.layer_count;
  auto sample = [&](std::size_t layer, std::size_t voxel) {
    const std::size_t index = voxel * layout.voxel_stride + layer * layout.layer_stride;
    return load_sample<T>(data + index * sizeof(T), layout.swap_bytes);
  };
  const bool scaled = layout.scale_slope != 1.0 || layout.scale_intercept != 0.0;
  auto value = [&](T raw) {
    const double x = static_cast<double>(raw);
    return scaled ? layout.scale_slope * x + layout.scale_intercept : x;
  };
  constexpr double int_max = std::numeric_limits<std::int32_t>::max();
  constexpr double int_min = std::numeric_limits<std::int32_t>::min();

  bool integral = std::is_integral_v<T> && !scaled;
  if (!integral) {
    integral = true;
    std::size_t non_finite = 0;
    for (std::size_t l = 0; l < layers; ++l)
      for (std::size_t v = 0; v < n; ++v) {
        const double x = value(sample(l, v));
        if (!std::isfinite(x)) {
          ++non_finite;
          continue;
        }
        if (integral && (x != std::floor(x) || x > int_max || x < int_min)) integral = false;
      }
    if (non_finite > 0)
      throw InputError(what + ": " + std::to_string(non_finite) +
                       " voxels are not finite numbers (NaN or infinity); replace them (e.g. "
                       "with the background value) before extracting surfaces");
  }
  if (integral) {
    volume.integer_labels = true;
    volume.scalars.clear();
    volume.layers.assign(layers, std::vector<std::int32_t>(n));
    for (std::size_t l = 0; l < layers; ++l) {
      std::int32_t* out = volume.layers[l].data();
      for (std::size_t v = 0; v < n; ++v) {
        const T raw = sample(l, v);
        if constexpr (std::is_integral_v<T> && sizeof(T) < 4) {
          out[v] = static_cast<std::int32_t>(raw);
        } else if constexpr (std::is_integral_v<T>) {
          if (scaled || static_cast<double>(raw) > int_max || static_cast<double>(raw) < int_min) {
            const double x = value(raw);
            if (x > int_max || x < int_min)
              throw InputError(what + ": label value " + std::to_string(x) + " at voxel " +
                               std::to_string(v) + " does not fit a 32-bit label");
            out[v] = static_cast<std::int32_t>(std::llround(x));
          } else {
            out[v] = static_cast<std::int32_t>(raw);
          }
        } else {
          out[v] = static_cast<std::int32_t>(std::llround(value(raw)));
        }
      }
    }
    return;
  }
  if (layers > 1)
    throw InputError(what +
                     ": a volume with several layers must hold integer labels, but "
                     "it holds fractional values");
  volume.integer_labels = false;
  volume.layers.clear();
  volume.scalars.resize(n);
  for (std::size_t v = 0; v < n; ++v) {
    const double x = value(sample(0, v));
    if (std::abs(x) > FLT_MAX)
      throw InputError(what + ": value " + std::to_string(x) + " at voxel " + std::to_string(v) +
                       " is out of the single-precision range fabrica works in");
    volume.scalars[v] = static_cast<float>(x);
  }
}

std::size_t sample_count(const SampleLayout& layout, const LabelVolume& volume) {
  return volume.geometry.voxel_count() * layout.layer_count;
}

}  // namespace

void decode_samples(std::string_view bytes, const SampleLayout& layout, LabelVolume& volume,
                    const std::string& what) {
  check_sample_count(volume.geometry, layout.layer_count, what);
  const std::size_t needed = sample_count(layout, volume) * element_size(layout.type);
  if (bytes.size() < needed)
    throw InputError(what + ": voxel data holds " + std::to_string(bytes.size()) +
                     " bytes but the header describes " + std::to_string(needed) + " (" +
                     std::to_string(sample_count(layout, volume)) + " samples of " +
                     to_string(layout.type) + "); the file is truncated or the header is wrong");
  const char* d = bytes.data();
  switch (layout.type) {
    case ElementType::int8:
      return decode_typed<std::int8_t>(d, layout, volume, what);
    case ElementType::uint8:
      return decode_typed<std::uint8_t>(d, layout, volume, what);
    case ElementType::int16:
      return decode_typed<std::int16_t>(d, layout, volume, what);
    case ElementType::uint16:
      return decode_typed<std::uint16_t>(d, layout, volume, what);
    case ElementType::int32:
      return decode_typed<std::int32_t>(d, layout, volume, what);
    case ElementType::uint32:
      return decode_typed<std::uint32_t>(d, layout, volume, what);
    case ElementType::int64:
      return decode_typed<std::int64_t>(d, layout, volume, what);
    case ElementType::uint64:
      return decode_typed<std::uint64_t>(d, layout, volume, what);
    case ElementType::float32:
      return decode_typed<float>(d, layout, volume, what);
    case ElementType::float64:
      return decode_typed<double>(d, layout, volume, what);
  }
}

void decode_text_samples(std::string_view text, const SampleLayout& layout, LabelVolume& volume,
                         const std::string& what) {
  check_sample_count(volume.geometry, layout.layer_count, what);
  const std::size_t needed = sample_count(layout, volume);
  // Every value takes at least one character and a separator.
  if (needed > text.size() / 2 + 1)
    throw InputError(what + ": the header describes " + std::to_string(needed) +
                     " values but the text voxel data has only " + std::to_string(text.size()) +
                     " characters; the file is truncated or the header is wrong");
  std::vector<double> values;
  values.reserve(needed);
  std::string buffer(text);
  const char* p = buffer.c_str();
  while (values.size() < needed) {
    while (*p != 0 && (std::isspace(static_cast<unsigned char>(*p)) || *p == ',')) ++p;
    if (*p == 0) break;
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p)
      throw InputError(what + ": text voxel data has a non-number after " +
                       std::to_string(values.size()) + " values");
    values.push_back(v);
    p = end;
  }
  if (values.size() < needed)
    throw InputError(what + ": text voxel data holds " + std::to_string(values.size()) +
                     " values but the header describes " + std::to_string(needed));
  SampleLayout as_double = layout;
  as_double.type = ElementType::float64;
  as_double.swap_bytes = false;
  if (layout.type != ElementType::float32 && layout.type != ElementType::float64)
    for (double& v : values) v = std::round(v);
  decode_typed<double>(reinterpret_cast<const char*>(values.data()), as_double, volume, what);
}

void check_sample_count(const VolumeGeometry& g, std::size_t layer_count, const std::string& what) {
  const double samples = static_cast<double>(g.dims[0]) * static_cast<double>(g.dims[1]) *
                         static_cast<double>(g.dims[2]) * static_cast<double>(layer_count);
  if (samples > kMaxVoxelSamples)
    throw InputError(what + ": the header declares " + std::to_string(g.dims[0]) + " x " +
                     std::to_string(g.dims[1]) + " x " + std::to_string(g.dims[2]) + " voxels" +
                     (layer_count > 1 ? " x " + std::to_string(layer_count) + " layers" : "") +
                     ", more than the " + std::to_string(static_cast<long long>(kMaxVoxelSamples)) +
                     " fabrica reads; crop or resample the volume");
}

void check_utf8_name(std::string_view name, const std::string& what, const std::string& field) {
  std::size_t i = 0;
  while (i < name.size()) {
    const auto c = static_cast<unsigned char>(name[i]);
    const std::size_t len = c < 0x80           ? 1
                            : (c >> 5) == 0x6  ? 2
                            : (c >> 4) == 0xE  ? 3
                            : (c >> 3) == 0x1E ? 4
                                               : 0;
    bool ok = len > 0 && i + len <= name.size() && !(c < 0x20 && c != '\t');
    for (std::size_t k = 1; ok && k < len; ++k)
      ok = (static_cast<unsigned char>(name[i + k]) & 0xC0) == 0x80;
    if (!ok)
      throw InputError(what + ": " + field + " is not UTF-8 text (byte " + std::to_string(i) +
                       "); save the file with UTF-8 names");
    i += len;
  }
}

void check_geometry(const VolumeGeometry& g, const std::string& what) {
  for (int a = 0; a < 3; ++a)
    if (g.dims[a] <= 0)
      throw InputError(what + ": size along axis " + std::to_string(a) + " is " +
                       std::to_string(g.dims[a]) + "; every axis needs at least one voxel");
  check_sample_count(g, 1, what);
  if (!g.spacing.allFinite() || (g.spacing.array() <= 0.0).any())
    throw InputError(what + ": voxel spacing must be positive and finite");
  if ((g.spacing.array() < kMinSpacingMm).any() || (g.spacing.array() > kMaxSpacingMm).any())
    throw InputError(what + ": voxel spacing " + std::to_string(g.spacing.minCoeff()) + " to " +
                     std::to_string(g.spacing.maxCoeff()) + " mm is outside the " +
                     std::to_string(kMinSpacingMm) + " to " + std::to_string(kMaxSpacingMm) +
                     " mm fabrica accepts; check the header's spacing or directions");
  if (!g.origin.allFinite()) throw InputError(what + ": origin is not a finite position");
  const Vec3 extent(g.dims[0] * g.spacing[0], g.dims[1] * g.spacing[1], g.dims[2] * g.spacing[2]);
  if (g.origin.cwiseAbs().maxCoeff() > kMaxCoordinateMm || extent.maxCoeff() > kMaxCoordinateMm)
    throw InputError(what + ": the volume lies more than " + std::to_string(kMaxCoordinateMm) +
                     " mm from the origin; check the header's origin and spacing");
  if (!g.direction.allFinite() || std::abs(g.direction.determinant()) < 1e-6)
    throw InputError(what +
                     ": axis directions are degenerate (parallel or zero); cannot place "
                     "voxels in patient space");
}

}  // namespace volume_detail

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

LabelVolume read_label_volume(const std::filesystem::path& path) {
  using namespace volume_detail;
  const std::string name = lowercase(path.filename().string());
  const std::string what = "volume '" + path.string() + "'";
  LabelVolume volume;
  if (ends_with(name, ".nrrd") || ends_with(name, ".nhdr")) {
    volume = read_nrrd(path);
  } else if (ends_with(name, ".mha") || ends_with(name, ".mhd")) {
    volume = read_metaimage(path);
  } else if (ends_with(name, ".nii") || ends_with(name, ".nii.gz")) {
    volume = read_nifti(path);
  } else {
    // Unknown extension: sniff the first bytes.
    require_regular_file(path, what);
    std::ifstream in(path, std::ios::binary);
    char head[64] = {};
    in.read(head, sizeof head);
    const std::string start(head, static_cast<std::size_t>(in.gcount()));
    if (start.rfind("NRRD000", 0) == 0) {
      volume = read_nrrd(path);
    } else if (start.find("NDims") != std::string::npos ||
               start.find("ObjectType") != std::string::npos) {
      volume = read_metaimage(path);
    } else if (start.size() >= 4 &&
               (start[0] == '\x1f' || start.compare(0, 4, "\x5c\x01\0\0", 4) == 0 ||
                start.compare(0, 4, "\x1c\x02\0\0", 4) == 0)) {
      volume = read_nifti(path);
    } else {
      throw InputError(what +
                       ": unknown volume format; use .nrrd, .seg.nrrd, .nhdr, .mha, .mhd, "
                       ".nii or .nii.gz");
    }
  }
  volume.path = path.string();
  volume.geometry.space = Space::lps;
  check_geometry(volume.geometry, what);
  return volume;
}

std::vector<LabelInfo> read_label_names(const std::filesystem::path& path) {
  using namespace volume_detail;
  const std::string what = "label table '" + path.string() + "'";
  const std::string text = read_file_bytes(path, what);
  std::vector<LabelInfo> out;
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    const std::string t = trim(line);
    if (t.empty()) continue;
    std::istringstream fields(t);
    std::vector<std::string> tokens;
    for (std::string tok; fields >> tok;) tokens.push_back(tok);
    // ITK-SNAP: IDX R G B A VIS MSH "LABEL"; Slicer/plain: VALUE NAME [R G B [A]].
    LabelInfo info;
    auto as_int = [&](const std::string& s, int& v) {
      const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
      return r.ec == std::errc() && r.ptr == s.data() + s.size();
    };
    if (!as_int(tokens[0], info.value))
      throw InputError(what + ": line " + std::to_string(line_number) +
                       " should start with an integer label value, reads '" + t + "'");
    const auto quote = t.find('"');
    std::vector<double> rgb;
    if (quote != std::string::npos) {
      const auto close = t.find('"', quote + 1);
      info.name =
          t.substr(quote + 1, close == std::string::npos ? std::string::npos : close - quote - 1);
      check_utf8_name(info.name, what, "the name on line " + std::to_string(line_number));
      const std::vector<double> nums =
          parse_numbers(t.substr(tokens[0].size(), quote - tokens[0].size()), what,
                        "line " + std::to_string(line_number));
      rgb.assign(nums.begin(), nums.begin() + std::min<std::size_t>(3, nums.size()));
    } else {
      if (tokens.size() < 2)
        throw InputError(what + ": line " + std::to_string(line_number) +
                         " has a label value but no name");
      info.name = tokens[1];
      check_utf8_name(info.name, what, "the name on line " + std::to_string(line_number));
      for (std::size_t k = 2; k < tokens.size() && rgb.size() < 3; ++k)
        for (double c : parse_numbers(tokens[k], what, "line " + std::to_string(line_number)))
          if (rgb.size() < 3) rgb.push_back(c);  // "," holds no number: nothing to take
    }
    if (rgb.size() == 3) {
      const bool bytes = rgb[0] > 1.0 || rgb[1] > 1.0 || rgb[2] > 1.0;
      std::array<double, 3> c{};
      for (int k = 0; k < 3; ++k) c[k] = std::clamp(bytes ? rgb[k] / 255.0 : rgb[k], 0.0, 1.0);
      info.color = c;
    }
    out.push_back(std::move(info));
  }
  return out;
}

}  // namespace fabrica::io
