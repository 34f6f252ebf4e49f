// Surfaces from label maps (discrete flying edges per label, on the label's
// bounding box padded with one background voxel so every surface closes)
// and iso-surfaces of scalar volumes (flying edges), smoothed with the
// windowed-sinc filter and optionally decimated, then mapped voxel index ->
// LPS patient mm and oriented outward.
#include <tbb/parallel_for.h>
#include <vtkCellArray.h>
#include <vtkCellArrayIterator.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <tuple>

#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "label_volume_stats.hpp"
#include "vtk_module.hpp"

namespace fabrica::io {
namespace {

using detail::label_stats;
using detail::LabelStats;

// Windowed-sinc iterations for label maps when none are given: with the
// default pass band (0.1) they take the voxel staircase off the bundled
// TotalSegmentator aorta (ridge and valley ink per mm^2 less than half the
// unsmoothed mesh's, test_segmentation) and keep its volume within 1%.
constexpr int kDefaultLabelSmoothing = 60;

vtkSmartPointer<vtkPolyData> smooth_and_decimate(vtkSmartPointer<vtkPolyData> surface,
                                                 int iterations, double passband, double decimate) {
  if (iterations > 0 && surface->GetNumberOfPolys() > 0) {
    vtkNew<vtkWindowedSincPolyDataFilter> smoother;
    smoother->SetInputData(surface);
    smoother->SetNumberOfIterations(iterations);
    smoother->SetPassBand(passband);
    smoother->NormalizeCoordinatesOn();
    smoother->BoundarySmoothingOff();
    smoother->FeatureEdgeSmoothingOff();
    smoother->NonManifoldSmoothingOn();
    smoother->Update();
    surface = smoother->GetOutput();
  }
  if (decimate > 0.0 && surface->GetNumberOfPolys() > 0) {
    vtkNew<vtkQuadricDecimation> decimator;
    decimator->SetInputData(surface);
    decimator->SetTargetReduction(decimate);
    decimator->VolumePreservationOn();
    decimator->Update();
    surface = decimator->GetOutput();
  }
  return surface;
}

/// A smoothed label enclosing less than this fraction of its voxels' volume
/// has collapsed (a label of one or a few voxels).
constexpr double kCollapsedFraction = 0.02;

double enclosed_volume(const TriangleMesh& mesh) {
  if (mesh.faces.empty()) return 0.0;
  const Vec3 c = bounding_box(mesh.positions).center();
  double volume6 = 0.0;
  for (const Face& f : mesh.faces)
    volume6 +=
        (mesh.positions[f[0]] - c).dot((mesh.positions[f[1]] - c).cross(mesh.positions[f[2]] - c));
  return volume6 / 6.0;
}

/// Maps the filter output (points in spacing-scaled index space) to LPS mm,
/// drops degenerate triangles and unused points, orients faces outward.
TriangleMesh to_patient_mesh(vtkPolyData* surface, const VolumeGeometry& g) {
  TriangleMesh mesh;
  mesh.space = Space::lps;
  mesh.space_source = SpaceSource::file_tag;
  vtkPoints* points = surface->GetPoints();
  vtkCellArray* polys = surface->GetPolys();
  if (points == nullptr || polys == nullptr) return mesh;
  const vtkIdType n = points->GetNumberOfPoints();
  std::vector<std::int32_t> remap(static_cast<std::size_t>(n), -1);
  auto iter = vtk::TakeSmartPointer(polys->NewIterator());
  for (iter->GoToFirstCell(); !iter->IsDoneWithTraversal(); iter->GoToNextCell()) {
    vtkIdType count = 0;
    const vtkIdType* ids = nullptr;
    iter->GetCurrentCell(count, ids);
    if (count != 3) continue;
    if (ids[0] == ids[1] || ids[1] == ids[2] || ids[0] == ids[2]) continue;
    Face f{};
    for (int k = 0; k < 3; ++k) {
      std::int32_t& r = remap[static_cast<std::size_t>(ids[k])];
      if (r < 0) {
        double q[3];
        points->GetPoint(ids[k], q);
        r = static_cast<std::int32_t>(mesh.positions.size());
        mesh.positions.push_back(g.origin + g.direction * Vec3(q[0], q[1], q[2]));
      }
      f[k] = r;
    }
    mesh.faces.push_back(f);
  }
  // Outward: the enclosed (signed) volume must be positive. The mapping flips
  // orientation when det(direction) < 0; the sum over all components keeps
  // cavities (inner walls of hollow labels) facing into the cavity.
  if (enclosed_volume(mesh) < 0.0)
    for (Face& f : mesh.faces) std::swap(f[1], f[2]);
  return mesh;
}

/// Drops the 6-connected pieces of a padded binary mask that are smaller
/// than options.min_island_voxels, or all but the largest with
/// options.largest_component. Returns (pieces dropped, voxels dropped).
std::pair<std::size_t, std::size_t> drop_islands(unsigned char* mask, const std::array<int, 3>& n,
                                                 const ExtractOptions& options) {
  if (options.min_island_voxels == 0 && !options.largest_component) return {0, 0};
  const std::size_t total = static_cast<std::size_t>(n[0]) * n[1] * n[2];
  const std::ptrdiff_t step[6] = {1,
                                  -1,
                                  n[0],
                                  -n[0],
                                  static_cast<std::ptrdiff_t>(n[0]) * n[1],
                                  -static_cast<std::ptrdiff_t>(n[0]) * n[1]};
  std::vector<std::int32_t> piece(total, -1);
  std::vector<std::size_t> sizes;
  std::vector<std::size_t> stack;
  for (std::size_t seed = 0; seed < total; ++seed) {
    if (mask[seed] == 0 || piece[seed] >= 0) continue;
    const auto id = static_cast<std::int32_t>(sizes.size());
    std::size_t size = 0;
    piece[seed] = id;
    stack.push_back(seed);
    while (!stack.empty()) {
      const std::size_t v = stack.back();
      stack.pop_back();
      ++size;
      // The mask has a background border, so a set voxel's neighbours exist.
      for (const std::ptrdiff_t d : step) {
        const auto w = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(v) + d);
        if (mask[w] != 0 && piece[w] < 0) {
          piece[w] = id;
          stack.push_back(w);
        }
      }
    }
    sizes.push_back(size);
  }
  // The largest piece (the first of equal ones, in voxel order: deterministic).
  const std::size_t largest =
      static_cast<std::size_t>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  std::vector<std::uint8_t> drop(sizes.size(), 0);
  std::size_t pieces = 0, voxels = 0;
  for (std::size_t p = 0; p < sizes.size(); ++p) {
    drop[p] = (options.largest_component && p != largest) || sizes[p] < options.min_island_voxels;
    if (drop[p]) {
      ++pieces;
      voxels += sizes[p];
    }
  }
  if (pieces > 0)
    for (std::size_t v = 0; v < total; ++v)
      if (mask[v] != 0 && drop[piece[v]]) mask[v] = 0;
  return {pieces, voxels};
}

TriangleMesh extract_label(const LabelVolume& volume, const LabelStats& s,
                           const ExtractOptions& options, int iterations, ExtractedSurface& out) {
  const VolumeGeometry& g = volume.geometry;
  const std::vector<std::int32_t>& labels = volume.layers[static_cast<std::size_t>(s.layer)];
  // Crop to the bounding box plus one background voxel on every side.
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = s.hi[a] - s.lo[a] + 3;
  vtkNew<vtkImageData> image;
  image->SetDimensions(n[0], n[1], n[2]);
  image->SetSpacing(g.spacing[0], g.spacing[1], g.spacing[2]);
  image->SetOrigin(g.spacing[0] * (s.lo[0] - 1), g.spacing[1] * (s.lo[1] - 1),
                   g.spacing[2] * (s.lo[2] - 1));
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* mask = static_cast<unsigned char*>(image->GetScalarPointer());
  std::fill(mask, mask + static_cast<std::size_t>(n[0]) * n[1] * n[2], 0);
  const std::size_t row = static_cast<std::size_t>(g.dims[0]);
  const std::size_t slice = row * static_cast<std::size_t>(g.dims[1]);
  for (int k = s.lo[2]; k <= s.hi[2]; ++k)
    for (int j = s.lo[1]; j <= s.hi[1]; ++j) {
      const std::int32_t* src = labels.data() + k * slice + j * row;
      unsigned char* dst =
          mask + (static_cast<std::size_t>(k - s.lo[2] + 1) * n[1] + (j - s.lo[1] + 1)) * n[0] + 1;
      for (int i = s.lo[0]; i <= s.hi[0]; ++i) dst[i - s.lo[0]] = src[i] == s.value ? 1 : 0;
    }
  std::tie(out.islands_removed, out.island_voxels_removed) = drop_islands(mask, n, options);
  if (out.island_voxels_removed == s.count) return {};
  vtkNew<vtkDiscreteFlyingEdges3D> contour;
  contour->SetInputData(image);
  contour->SetValue(0, 1.0);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  contour->Update();
  vtkSmartPointer<vtkPolyData> contoured = contour->GetOutput();
  TriangleMesh mesh = to_patient_mesh(
      smooth_and_decimate(contoured, iterations, options.smoothing_passband, options.decimate), g);
  // Smoothing shrinks a piece of a few voxels towards a point; such a label
  // keeps its unsmoothed contour (a blob, not a speck of nothing).
  const double voxel = g.spacing.prod();
  if (iterations > 0 && enclosed_volume(mesh) < kCollapsedFraction * voxel * s.count)
    mesh = to_patient_mesh(smooth_and_decimate(contoured, 0, 1.0, options.decimate), g);
  return mesh;
}

TriangleMesh extract_iso(const LabelVolume& volume, double iso, const ExtractOptions& options,
                         int iterations, std::string& problem) {
  const VolumeGeometry& g = volume.geometry;
  const std::size_t count = g.voxel_count();
  auto value = [&](std::size_t index) -> float {
    return volume.integer_labels ? static_cast<float>(volume.layers[0][index])
                                 : volume.scalars[index];
  };
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  for (std::size_t v = 0; v < count; ++v) {
    lo = std::min(lo, value(v));
    hi = std::max(hi, value(v));
  }
  if (!(lo < iso && hi > iso)) {
    problem = "no voxel crosses the iso value " + std::to_string(iso) + " (values range " +
              std::to_string(lo) + " .. " + std::to_string(hi) + ")";
    return {};
  }
  // The side of the iso value most border voxels are on is "outside"; pad
  // the volume with one voxel of it so surfaces cut by the border close.
  const auto& d = g.dims;
  std::size_t above = 0, below = 0;
  std::size_t index = 0;
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i, ++index) {
        const bool border =
            i == 0 || j == 0 || k == 0 || i == d[0] - 1 || j == d[1] - 1 || k == d[2] - 1;
        if (!border) continue;
        (value(index) > iso ? above : below) += 1;
      }
  const float pad = above > below ? std::max(hi, static_cast<float>(iso)) + 1.0f
                                  : std::min(lo, static_cast<float>(iso)) - 1.0f;
  std::array<int, 3> n{d[0] + 2, d[1] + 2, d[2] + 2};
  vtkNew<vtkImageData> image;
  image->SetDimensions(n[0], n[1], n[2]);
  image->SetSpacing(g.spacing[0], g.spacing[1], g.spacing[2]);
  image->SetOrigin(-g.spacing[0], -g.spacing[1], -g.spacing[2]);
  image->AllocateScalars(VTK_FLOAT, 1);
  auto* out = static_cast<float*>(image->GetScalarPointer());
  std::fill(out, out + static_cast<std::size_t>(n[0]) * n[1] * n[2], pad);
  index = 0;
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j) {
      float* dst = out + (static_cast<std::size_t>(k + 1) * n[1] + (j + 1)) * n[0] + 1;
      for (int i = 0; i < d[0]; ++i, ++index) dst[i] = value(index);
    }
  vtkNew<vtkFlyingEdges3D> contour;
  contour->SetInputData(image);
  contour->SetValue(0, iso);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  contour->InterpolateAttributesOff();
  contour->Update();
  vtkSmartPointer<vtkPolyData> surface = contour->GetOutput();
  surface = smooth_and_decimate(surface, iterations, options.smoothing_passband, options.decimate);
  TriangleMesh mesh = to_patient_mesh(surface, g);
  if (mesh.faces.empty()) problem = "the iso-surface at " + std::to_string(iso) + " is empty";
  return mesh;
}

}  // namespace

void detail::smooth_surface_with_vtk(TriangleMesh& mesh, int iterations, double passband) {
  ExtractOptions check;
  check.smoothing_iterations = iterations;
  check.smoothing_passband = passband;
  check_extract_options(check);
  check_mesh_indices_and_values(mesh, "mesh");
  if (iterations == 0 || mesh.faces.empty()) return;
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(mesh.positions.size()));
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), mesh.positions[i].data());
  vtkNew<vtkCellArray> polys;
  for (const Face& f : mesh.faces) {
    const vtkIdType ids[3] = {f[0], f[1], f[2]};
    polys->InsertNextCell(3, ids);
  }
  auto surface = vtkSmartPointer<vtkPolyData>::New();
  surface->SetPoints(points);
  surface->SetPolys(polys);
  surface = smooth_and_decimate(surface, iterations, passband, 0.0);
  vtkPoints* out = surface->GetPoints();
  if (out == nullptr || out->GetNumberOfPoints() != static_cast<vtkIdType>(mesh.positions.size()))
    throw Error(ErrorKind::internal, "smoothing changed the number of vertices");
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    double q[3];
    out->GetPoint(static_cast<vtkIdType>(i), q);
    mesh.positions[i] = Vec3(q[0], q[1], q[2]);
  }
}

std::vector<ExtractedSurface> detail::extract_surfaces_with_vtk(const LabelVolume& volume,
                                                                const ExtractOptions& options) {
  check_extract_options(options);
  const std::string what = "volume '" + volume.path + "'";
  const std::size_t voxels = volume.geometry.voxel_count();
  if (volume.integer_labels) {
    if (volume.layers.empty()) throw InputError(what + ": holds no voxel data");
    for (const auto& layer : volume.layers)
      if (layer.size() != voxels)
        throw InputError(what + ": label map size does not match its dimensions");
  } else if (volume.scalars.size() != voxels) {
    throw InputError(what + ": scalar data size does not match its dimensions");
  }

  if (options.iso_value) {
    if (volume.integer_labels && volume.layers.size() > 1)
      throw InputError(what +
                       ": an iso-surface of a layered segmentation is not defined; "
                       "extract labels instead");
    ExtractedSurface result;
    result.name = "isosurface";
    result.mesh = extract_iso(volume, *options.iso_value, options,
                              options.smoothing_iterations.value_or(0), result.problem);
    return {std::move(result)};
  }
  if (!volume.integer_labels)
    throw InputError(what +
                     " holds non-integer (float) values - a level set or an intensity image, "
                     "not a label map: give --iso VALUE for an isosurface (e.g. --iso 0 for "
                     "a level set)");

  // Which (layer, value) pairs to extract.
  std::vector<std::map<int, LabelStats>> stats(volume.layers.size());
  tbb::parallel_for(std::size_t{0}, volume.layers.size(),
                    [&](std::size_t l) { stats[l] = label_stats(volume, static_cast<int>(l)); });
  struct Target {
    int layer;
    int value;
    const LabelStats* stats;
  };
  std::size_t distinct = 0;
  bool negative = false;
  for (const auto& layer : stats) {
    distinct += layer.size();
    negative = negative || (!layer.empty() && layer.begin()->first < 0);
  }
  if (options.labels.empty() && options.max_labels > 0 && distinct > options.max_labels)
    throw InputError(what + " holds " + std::to_string(distinct) + " distinct nonzero values" +
                     (negative ? " (some negative)" : "") +
                     ": an intensity image (CT, MR), not a label map of at most " +
                     std::to_string(options.max_labels) +
                     " labels; give --iso VALUE for an isosurface (e.g. --iso 300 for bone in CT), "
                     "or --labels to extract chosen values anyway");
  std::vector<Target> targets;
  for (std::size_t l = 0; l < stats.size(); ++l)
    for (const auto& [value, s] : stats[l])
      if (options.labels.empty() ||
          std::find(options.labels.begin(), options.labels.end(), value) != options.labels.end())
        targets.push_back({static_cast<int>(l), value, &s});
  for (int wanted : options.labels) {
    const bool listed = std::any_of(targets.begin(), targets.end(),
                                    [&](const Target& t) { return t.value == wanted; });
    if (!listed) targets.push_back({0, wanted, nullptr});  // absent: reported, not extracted
  }
  std::sort(targets.begin(), targets.end(), [](const Target& a, const Target& b) {
    return std::tie(a.layer, a.value) < std::tie(b.layer, b.value);
  });

  const bool layered = volume.layers.size() > 1;
  const int iterations = options.smoothing_iterations.value_or(kDefaultLabelSmoothing);
  std::vector<ExtractedSurface> results(targets.size());
  std::mutex progress_mutex;
  std::size_t done = 0;
  std::atomic<bool> cancelled{false};
  auto report = [&] {
    if (!options.progress) return;
    const std::lock_guard<std::mutex> lock(progress_mutex);
    ++done;
    if (!options.progress(done, targets.size())) cancelled = true;
  };
  tbb::parallel_for(std::size_t{0}, targets.size(), [&](std::size_t t) {
    const Target& target = targets[t];
    ExtractedSurface& r = results[t];
    r.label = target.value;
    r.layer = target.layer;
    r.name = "label_" + std::to_string(target.value) +
             (layered ? "_layer" + std::to_string(target.layer) : std::string());
    for (const LabelInfo& info : volume.labels)
      if (info.value == target.value && info.layer == target.layer) {
        if (!info.name.empty()) r.name = info.name;
        r.color = info.color;
        break;
      }
    if (target.stats == nullptr) {
      r.problem = "label " + std::to_string(target.value) + " has no voxels in this volume";
      report();
      return;
    }
    r.voxel_count = target.stats->count;
    if (cancelled) {
      r.problem = "cancelled";
      return;
    }
    try {
      r.mesh = extract_label(volume, *target.stats, options, iterations, r);
      if (r.mesh.faces.empty())
        r.problem = r.island_voxels_removed == r.voxel_count
                        ? "every piece of the label is an island below --min-island"
                        : "the label's surface is empty";
    } catch (const std::exception& e) {
      r.mesh = {};
      r.problem = std::string("extraction failed: ") + e.what();
    }
    report();
  });
  return results;
}

}  // namespace fabrica::io
