// Per-label voxel statistics of a label map (no VTK): shared by the surface
// extraction (label_volume_extract.cpp) and label_voxel_counts. Private.
#pragma once

#include <array>
#include <cstddef>
#include <limits>
#include <map>

#include "fabrica/io/label_volume.hpp"

namespace fabrica::io::detail {

struct LabelStats {
  int value = 0;
  int layer = 0;
  std::size_t count = 0;
  std::array<int, 3> lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                        std::numeric_limits<int>::max()};
  std::array<int, 3> hi{-1, -1, -1};
};

/// One pass over a label map: voxel count and index bounding box per label.
std::map<int, LabelStats> label_stats(const LabelVolume& volume, int layer);

}  // namespace fabrica::io::detail
