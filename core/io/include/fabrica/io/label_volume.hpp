// Label volumes (segmentations) and scalar volumes (level sets) -> triangle
// surfaces.
//
// Reading: NRRD (.nrrd, .nhdr, 3D Slicer .seg.nrrd with 3D or 4D layered
// label maps), MetaImage (.mha, .mhd) and NIfTI-1/2 (.nii, .nii.gz). Headers
// are parsed by fabrica itself so that the orientation is always applied (the
// VTK readers drop it). Every volume is returned in LPS patient millimetres:
//
//     p(i,j,k) = origin + direction * (spacing .* (i,j,k))
//
// with `direction` a 3x3 matrix whose columns are the unit directions of the
// index axes in LPS. NIfTI (RAS by definition) and NRRD files with a RAS/LAS
// space are converted to LPS by negating the first two rows of the affine.
// Details and formulas: docs/volumes.md.
//
// Extraction: one closed surface per label (discrete flying edges on the
// voxel label map, padded so labels touching the border still close),
// windowed-sinc smoothing (Taubin et al. 1996, "Optimal surface smoothing
// as filter design"), optional quadric decimation (Garland and Heckbert
// 1997), or one iso-surface of a scalar volume (flying edges, Schroeder et
// al. 2015). Vertices are mapped through the full index->patient transform,
// and faces are oriented outward (positive signed volume).
//
// Errors: every unreadable, truncated or malformed file throws
// fabrica::InputError naming the file and what is wrong.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica::io {

/// A named label (segment) of a label volume.
struct LabelInfo {
  int value = 0;  ///< voxel value of the label in its layer
  int layer = 0;  ///< layer (label map) it lives in; 0 unless a 4D layered .seg.nrrd
  std::string name;
  std::optional<std::array<double, 3>> color;  ///< RGB in [0, 1] when the file has one
};

/// Where voxels are in patient space (LPS millimetres once read).
struct VolumeGeometry {
  std::array<int, 3> dims{0, 0, 0};   ///< voxels along i, j, k (i fastest in memory)
  Vec3 spacing = Vec3::Ones();        ///< mm between voxel centres along i, j, k (> 0)
  Vec3 origin = Vec3::Zero();         ///< patient position of voxel (0,0,0)'s centre
  Mat3 direction = Mat3::Identity();  ///< columns: unit direction of the i, j, k axes
  Space space = Space::lps;           ///< always LPS after read_label_volume

  std::size_t voxel_count() const {
    return static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
           static_cast<std::size_t>(dims[2]);
  }
  /// Patient position of (fractional) voxel index (i, j, k).
  Vec3 index_to_patient(const Vec3& ijk) const {
    return origin + direction * spacing.cwiseProduct(ijk);
  }
};

/// A volume as read: either integer label maps or one float scalar field.
struct LabelVolume {
  VolumeGeometry geometry;
  /// true: `layers` holds integer label maps; false: `scalars` holds values
  /// that are not all integers (a level set, an intensity image).
  bool integer_labels = true;
  /// One label map per layer (usually one), geometry.voxel_count() values
  /// each, index i + dims[0] * (j + dims[1] * k).
  std::vector<std::vector<std::int32_t>> layers;
  /// Scalar values (same indexing) when !integer_labels.
  std::vector<float> scalars;
  /// Labels named by the file (seg.nrrd segments, NIfTI label-table
  /// extension); may be empty or list only some of the labels present.
  std::vector<LabelInfo> labels;
  std::string path;
  std::string format;              ///< "nrrd", "seg.nrrd", "metaimage", "nifti"
  std::string orientation_source;  ///< how the orientation was decided (for reports)
  std::vector<std::string> notes;  ///< harmless oddities worth telling the user
};

/// Reads a volume; the format is chosen by extension (.nrrd .nhdr .seg.nrrd
/// .mha .mhd .nii .nii.gz, case-insensitive), else by sniffing the header.
/// Throws InputError naming the file on any problem (missing, unknown
/// format, malformed header, truncated or undecodable data, non-finite
/// values, unsupported element type or dimension).
LabelVolume read_label_volume(const std::filesystem::path& path);

/// Reads a label-name table: one label per line, `VALUE NAME [R G B [A]]`
/// (3D Slicer colour tables and ITK-SNAP label descriptions both fit; colour
/// components > 1 are taken as 0..255). '#' starts a comment. Throws
/// InputError on a malformed line.
std::vector<LabelInfo> read_label_names(const std::filesystem::path& path);

struct ExtractOptions {
  /// Label values to extract (in every layer); empty = every nonzero label.
  std::vector<int> labels;
  /// Windowed-sinc smoothing iterations; 0 = none. Unset: 60 for label maps
  /// (removes the voxel staircase, docs/segmentation.md), 0 for iso-surfaces
  /// (a level set is already smooth).
  std::optional<int> smoothing_iterations;
  /// Windowed-sinc pass band in (0, 2): smaller smooths more.
  double smoothing_passband = 0.1;
  /// Fraction of faces to remove with quadric decimation, in [0, 1); 0 = none.
  double decimate = 0.0;
  /// Extract the iso-surface at this value instead of labels (scalar volumes
  /// such as level sets; also allowed on label maps, e.g. 0.5 for a mask).
  /// A scalar (non-integer) volume requires it.
  std::optional<double> iso_value;
  /// Drop the pieces of a label (6-connected voxels) with fewer voxels than
  /// this before contouring (islands that would become ink dots); 0 = keep all.
  std::size_t min_island_voxels = 0;
  /// Keep only the largest piece (6-connected voxels) of each label.
  bool largest_component = false;
  /// A volume with more distinct values than this is not a label map (a CT
  /// or MR image): extract_surfaces refuses it unless `labels` names the
  /// values to extract. 0 = no limit.
  std::size_t max_labels = 1000;
  /// Optional progress report, called after each label is done with
  /// (labels done, labels in total); calls never overlap but may come from
  /// worker threads. Return false to cancel: labels not started yet come
  /// back with an empty mesh and problem "cancelled".
  std::function<bool(std::size_t done, std::size_t total)> progress;
};

/// One extracted surface. `mesh` is empty when the label yielded no surface;
/// then `problem` says why (no voxels, extraction failed, ...).
struct ExtractedSurface {
  int label = 0;  ///< label value (0 for an iso-surface)
  int layer = 0;
  std::string name;  ///< from the file, else "label_<N>" (or "label_<N>_layer<L>"), "isosurface"
  std::optional<std::array<double, 3>> color;
  std::size_t voxel_count = 0;            ///< voxels carrying the label (0 for an iso-surface)
  std::size_t islands_removed = 0;        ///< pieces dropped (min_island_voxels, largest_component)
  std::size_t island_voxels_removed = 0;  ///< their voxels
  TriangleMesh mesh;                      ///< LPS mm, closed, faces outward
  std::string problem;
};

/// Extracts one surface per label (sorted by layer, then value) or one
/// iso-surface. Labels asked for but absent come back with an empty mesh
/// and a `problem`; an exception while extracting one label is caught and
/// reported the same way, so one bad label never stops the others.
/// Throws InputError for invalid options (pass band, decimation, iso value
/// missing for a scalar volume) and for a volume that is not a label map
/// (non-integer values without an iso value; more than max_labels distinct
/// values without `labels`).
std::vector<ExtractedSurface> extract_surfaces(const LabelVolume& volume,
                                               const ExtractOptions& options = {});

/// Volume-preserving windowed-sinc smoothing of any surface (the filter
/// extraction uses; `fabrica info --repair --smooth N`): moves vertices only,
/// vertex i stays vertex i, faces unchanged. Boundary vertices are smoothed
/// too. Throws InputError for iterations outside [0, 10000], a pass band
/// outside (0, 2) or a malformed mesh.
void smooth_surface(TriangleMesh& mesh, int iterations, double passband = 0.1);

/// Every distinct nonzero label value with its voxel count, per layer:
/// result[layer][value] = count.
std::vector<std::map<int, std::size_t>> label_voxel_counts(const LabelVolume& volume);

}  // namespace fabrica::io
