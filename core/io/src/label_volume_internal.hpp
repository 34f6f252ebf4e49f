// Internal helpers shared by the volume readers (not installed, not public).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "fabrica/io/label_volume.hpp"

namespace fabrica::io::volume_detail {

enum class ElementType {
  int8,
  uint8,
  int16,
  uint16,
  int32,
  uint32,
  int64,
  uint64,
  float32,
  float64
};

std::size_t element_size(ElementType type);
const char* to_string(ElementType type);

/// Whole file as bytes; InputError naming `what` when it cannot be read.
std::string read_file_bytes(const std::filesystem::path& path, const std::string& what);

/// Drops what precedes the samples in `data`: `skip` bytes (0: none), or
/// with skip == -1 all but the last `needed` bytes (MetaImage HeaderSize,
/// NRRD byte skip). Throws InputError prefixed with `what`, ending with
/// `past_end` when skip exceeds the data.
void skip_to_samples(std::string_view& data, long long skip, std::size_t needed,
                     const std::string& what, const char* past_end);

/// Inflates a zlib or gzip stream (auto-detected; concatenated gzip members
/// are followed) and returns at most `expected` bytes. InputError when the
/// stream is corrupt or yields fewer bytes than `expected`.
std::string inflate_bytes(std::string_view compressed, std::size_t expected,
                          const std::string& what);

/// How the stored samples map to voxels and layers.
struct SampleLayout {
  ElementType type = ElementType::uint8;
  bool swap_bytes = false;       ///< file endianness differs from the machine's
  std::size_t layer_count = 1;   ///< values of the non-spatial axis (1 if none)
  std::size_t layer_stride = 0;  ///< sample stride between layers (when layer_count > 1)
  std::size_t voxel_stride = 1;  ///< sample stride between consecutive voxels
  double scale_slope = 1.0;      ///< value = slope * stored + intercept (NIfTI scl_*)
  double scale_intercept = 0.0;
};

/// Decodes `bytes` (binary samples) into volume.layers or volume.scalars
/// following `layout`; the geometry must already be set. A sample that is
/// not a finite number throws InputError. Float samples that are all
/// integers become label maps.
void decode_samples(std::string_view bytes, const SampleLayout& layout, LabelVolume& volume,
                    const std::string& what);

/// Same for text samples (NRRD ascii, MetaImage BinaryData = False).
void decode_text_samples(std::string_view text, const SampleLayout& layout, LabelVolume& volume,
                         const std::string& what);

/// Limits on what a volume header may declare (docs/reliability.md): more
/// samples (voxels x layers) than kMaxVoxelSamples are refused before any
/// allocation; spacing outside [kMinSpacingMm, kMaxSpacingMm] and positions
/// (origin, corners) farther than kMaxCoordinateMm from 0 are bad input,
/// since the meshes made from them would not fit single precision.
inline constexpr double kMaxVoxelSamples = 1073741824.0;  // 2^30: 4 GiB of 32-bit labels
inline constexpr double kMinSpacingMm = 1e-6;
inline constexpr double kMaxSpacingMm = 1e5;
inline constexpr double kMaxCoordinateMm = 1e7;

/// Throws InputError unless `layer_count` layers of the volume's voxels are
/// at most kMaxVoxelSamples (computed without overflow).
void check_sample_count(const VolumeGeometry& geometry, std::size_t layer_count,
                        const std::string& what);

/// A segment or label name must be UTF-8 text (it goes into JSON and SVG).
void check_utf8_name(std::string_view name, const std::string& what, const std::string& field);

/// Throws InputError unless the geometry is usable (dims > 0, at most
/// kMaxVoxelSamples voxels, spacing within limits, finite, positions within
/// kMaxCoordinateMm, direction not singular); normalises nothing.
void check_geometry(const VolumeGeometry& geometry, const std::string& what);

std::string lowercase(std::string_view s);
std::string trim(std::string_view s);
/// Parses whitespace-separated doubles; InputError naming `what` and `field`.
std::vector<double> parse_numbers(std::string_view text, const std::string& what,
                                  const std::string& field);

LabelVolume read_nrrd(const std::filesystem::path& path);
LabelVolume read_metaimage(const std::filesystem::path& path);
LabelVolume read_nifti(const std::filesystem::path& path);

}  // namespace fabrica::io::volume_detail
