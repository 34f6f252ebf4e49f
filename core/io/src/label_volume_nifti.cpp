// NIfTI-1 and NIfTI-2 single-file volumes (.nii, .nii.gz).
//
// World coordinates of NIfTI are RAS mm. Orientation (as nibabel and 3D
// Slicer do): the sform when sform_code > 0, else the qform when
// qform_code > 0, else the bare pixdim scaling. The RAS affine is turned
// into LPS by negating its first two rows. Label names come from a label
// table in an XML header extension (Caret/Connectome Workbench
// <LabelTable>, which TotalSegmentator writes) when present.
#include <pugixml.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "fabrica/core/error.hpp"
#include "label_volume_internal.hpp"

namespace fabrica::io::volume_detail {
namespace {

class HeaderView {
 public:
  HeaderView(std::string_view bytes, bool swap) : bytes_(bytes), swap_(swap) {}
  template <class T>
  T get(std::size_t offset) const {
    T v;
    char tmp[sizeof(T)];
    std::memcpy(tmp, bytes_.data() + offset, sizeof(T));
    if (swap_) std::reverse(tmp, tmp + sizeof(T));
    std::memcpy(&v, tmp, sizeof(T));
    return v;
  }

 private:
  std::string_view bytes_;
  bool swap_;
};

ElementType nifti_type(int code, const std::string& what) {
  switch (code) {
    case 2:
      return ElementType::uint8;
    case 4:
      return ElementType::int16;
    case 8:
      return ElementType::int32;
    case 16:
      return ElementType::float32;
    case 64:
      return ElementType::float64;
    case 256:
      return ElementType::int8;
    case 512:
      return ElementType::uint16;
    case 768:
      return ElementType::uint32;
    case 1024:
      return ElementType::int64;
    case 1280:
      return ElementType::uint64;
    default:
      break;
  }
  throw InputError(what + ": NIfTI datatype " + std::to_string(code) +
                   " is not supported (complex, RGB and 128-bit types cannot hold labels)");
}

void collect_labels(const pugi::xml_node& node, std::vector<LabelInfo>& out) {
  for (const pugi::xml_node& child : node.children()) {
    if (std::strcmp(child.name(), "Label") == 0 && child.attribute("Key")) {
      LabelInfo info;
      info.value = child.attribute("Key").as_int();
      info.name = trim(child.text().get());
      if (child.attribute("Red") && child.attribute("Green") && child.attribute("Blue"))
        info.color = std::array<double, 3>{child.attribute("Red").as_double(),
                                           child.attribute("Green").as_double(),
                                           child.attribute("Blue").as_double()};
      if (!info.name.empty()) out.push_back(std::move(info));
    } else {
      collect_labels(child, out);
    }
  }
}

/// Label tables from header extensions (any ecode whose payload is XML with a
/// <LabelTable>: Caret = 14, TotalSegmentator writes 0).
std::vector<LabelInfo> extension_labels(std::string_view bytes, std::size_t start, std::size_t end,
                                        bool swap) {
  std::vector<LabelInfo> out;
  const HeaderView h(bytes, swap);
  std::size_t p = start;
  while (p + 8 <= end) {
    const auto esize = h.get<std::int32_t>(p);
    if (esize < 8 || p + static_cast<std::size_t>(esize) > end) break;
    const std::string_view payload = bytes.substr(p + 8, static_cast<std::size_t>(esize) - 8);
    if (payload.find("<LabelTable") != std::string_view::npos) {
      pugi::xml_document doc;
      // The payload may be zero-padded to a multiple of 16 bytes.
      const std::size_t len = std::min(payload.size(), payload.find('\0'));
      if (doc.load_buffer(payload.data(), len)) collect_labels(doc, out);
    }
    p += static_cast<std::size_t>(esize);
  }
  return out;
}

}  // namespace

LabelVolume read_nifti(const std::filesystem::path& path) {
  const std::string what = "volume '" + path.string() + "'";
  std::string bytes = read_file_bytes(path, what);
  if (bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
      static_cast<unsigned char>(bytes[1]) == 0x8b)
    bytes = inflate_bytes(bytes, std::numeric_limits<std::size_t>::max(), what);
  if (bytes.size() < 348)
    throw InputError(what + ": too short for a NIfTI header (" + std::to_string(bytes.size()) +
                     " bytes)");
  std::int32_t sizeof_hdr;
  std::memcpy(&sizeof_hdr, bytes.data(), 4);
  bool swap = false;
  int version = 0;
  if (sizeof_hdr == 348 || sizeof_hdr == 540) {
    version = sizeof_hdr == 348 ? 1 : 2;
  } else {
    swap = true;
    char tmp[4];
    std::memcpy(tmp, bytes.data(), 4);
    std::reverse(tmp, tmp + 4);
    std::memcpy(&sizeof_hdr, tmp, 4);
    if (sizeof_hdr == 348 || sizeof_hdr == 540) version = sizeof_hdr == 348 ? 1 : 2;
  }
  if (version == 0)
    throw InputError(what + ": not a NIfTI file (header size field is neither 348 nor 540)");
  if (bytes.size() < static_cast<std::size_t>(sizeof_hdr))
    throw InputError(what + ": file ends inside the NIfTI header");
  const HeaderView h(bytes, swap);

  // Field offsets of the NIfTI-1 and NIfTI-2 headers.
  struct Layout {
    std::size_t magic, datatype, dim, pixdim, vox_offset, scl_slope, scl_inter, qform_code,
        sform_code, quatern, srow;
  };
  const Layout L1{344, 70, 40, 76, 108, 112, 116, 252, 254, 256, 280};
  const Layout L2{4, 12, 16, 104, 168, 176, 184, 344, 348, 352, 400};
  const Layout& L = version == 1 ? L1 : L2;
  const std::string magic(bytes.data() + L.magic, 3);
  if (magic == "ni1" || magic == "ni2")
    throw InputError(what +
                     ": a two-file NIfTI (.hdr + .img) is not supported; save it as a "
                     "single .nii or .nii.gz");
  if (magic != "n+1" && magic != "n+2")
    throw InputError(what + ": NIfTI magic is missing (Analyze 7.5 files are not supported)");

  auto dim_at = [&](int i) -> long long {
    return version == 1 ? h.get<std::int16_t>(L.dim + 2 * i) : h.get<std::int64_t>(L.dim + 8 * i);
  };
  auto pixdim_at = [&](int i) -> double {
    return version == 1 ? h.get<float>(L.pixdim + 4 * i) : h.get<double>(L.pixdim + 8 * i);
  };
  auto real_at = [&](std::size_t offset) -> double {
    return version == 1 ? h.get<float>(offset) : h.get<double>(offset);
  };
  const std::size_t real = version == 1 ? 4 : 8;

  const long long ndim = dim_at(0);
  if (ndim < 1 || ndim > 7)
    throw InputError(what + ": NIfTI dim[0] = " + std::to_string(ndim) + " is invalid");
  LabelVolume volume;
  volume.format = "nifti";
  VolumeGeometry& g = volume.geometry;
  for (int a = 0; a < 3; ++a) {
    const long long d = a < ndim ? dim_at(a + 1) : 1;
    if (d < 1 || d > 1000000000)
      throw InputError(what + ": NIfTI dim[" + std::to_string(a + 1) + "] = " + std::to_string(d) +
                       " is invalid");
    g.dims[a] = static_cast<int>(d);
  }
  for (int a = 3; a < ndim; ++a)
    if (dim_at(a + 1) > 1)
      throw InputError(what + ": a " + std::to_string(ndim) +
                       "D NIfTI (time series or vector volume) is not supported; extract one 3D "
                       "volume first");

  SampleLayout layout;
  layout.type = nifti_type(h.get<std::int16_t>(L.datatype), what);
  layout.swap_bytes = swap;
  const double slope = real_at(L.scl_slope);
  const double intercept = real_at(L.scl_inter);
  if (slope != 0.0 && std::isfinite(slope) && std::isfinite(intercept)) {
    layout.scale_slope = slope;
    layout.scale_intercept = intercept;
  }

  // Orientation (RAS).
  Eigen::Matrix<double, 3, 4> affine = Eigen::Matrix<double, 3, 4>::Zero();
  const int qcode =
      version == 1 ? h.get<std::int16_t>(L.qform_code) : h.get<std::int32_t>(L.qform_code);
  const int sform_code =
      version == 1 ? h.get<std::int16_t>(L.sform_code) : h.get<std::int32_t>(L.sform_code);
  Vec3 pix(std::abs(pixdim_at(1)), std::abs(pixdim_at(2)), std::abs(pixdim_at(3)));
  for (int a = 0; a < 3; ++a)
    if (!(pix[a] > 0.0) || !std::isfinite(pix[a])) pix[a] = 1.0;
  if (sform_code > 0) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) affine(r, c) = real_at(L.srow + (4 * r + c) * real);
    volume.orientation_source =
        "NIfTI sform (code " + std::to_string(sform_code) + "), RAS converted to LPS";
  } else if (qcode > 0) {
    const double b = real_at(L.quatern), c = real_at(L.quatern + real),
                 d = real_at(L.quatern + 2 * real);
    const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
    Mat3 R;
    R << a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),
        2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
        2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b;
    const double qfac = pixdim_at(0) < 0.0 ? -1.0 : 1.0;
    affine.leftCols<3>() = R * Vec3(pix[0], pix[1], qfac * pix[2]).asDiagonal();
    affine.col(3) = Vec3(real_at(L.quatern + 3 * real), real_at(L.quatern + 4 * real),
                         real_at(L.quatern + 5 * real));
    volume.orientation_source =
        "NIfTI qform (code " + std::to_string(qcode) + "), RAS converted to LPS";
  } else {
    affine.leftCols<3>() = pix.asDiagonal();
    volume.orientation_source = "NIfTI without qform/sform: pixdim scaling only, RAS assumed";
    volume.notes.push_back("no qform or sform: orientation unknown, axes taken as RAS x, y, z");
  }
  affine.row(0) *= -1.0;  // RAS -> LPS
  affine.row(1) *= -1.0;
  for (int a = 0; a < 3; ++a) {
    const Vec3 col = affine.col(a);
    const double len = col.norm();
    if (!(len > 0.0) || !std::isfinite(len))
      throw InputError(what + ": NIfTI orientation matrix has a zero or invalid column " +
                       std::to_string(a) + "; the sform/qform is broken");
    g.spacing[a] = len;
    g.direction.col(a) = col / len;
  }
  g.origin = affine.col(3);
  check_geometry(g, what);

  // Voxel data.
  const double vox_offset_value = version == 1
                                      ? h.get<float>(L.vox_offset)
                                      : static_cast<double>(h.get<std::int64_t>(L.vox_offset));
  if (!(vox_offset_value >= 0.0) || vox_offset_value > static_cast<double>(bytes.size()))
    throw InputError(what + ": NIfTI vox_offset " + std::to_string(vox_offset_value) +
                     " points outside the file (truncated?)");
  const std::size_t vox_offset =
      std::max<std::size_t>(static_cast<std::size_t>(vox_offset_value), sizeof_hdr);
  const std::size_t header_end = static_cast<std::size_t>(sizeof_hdr);
  if (bytes.size() > header_end + 4 && bytes[header_end] != 0)
    volume.labels = extension_labels(bytes, header_end + 4, vox_offset, swap);
  decode_samples(std::string_view(bytes).substr(vox_offset), layout, volume, what);
  return volume;
}

}  // namespace fabrica::io::volume_detail
