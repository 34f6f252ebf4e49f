// Per-label voxel statistics of label maps (label_volume_stats.hpp) and the
// public label_voxel_counts; no VTK, so built in every configuration.
#include "label_volume_stats.hpp"

#include <algorithm>
#include <cstdint>

namespace fabrica::io {

namespace detail {

std::map<int, LabelStats> label_stats(const LabelVolume& volume, int layer) {
  std::map<int, LabelStats> stats;
  const auto& dims = volume.geometry.dims;
  const std::int32_t* v = volume.layers[static_cast<std::size_t>(layer)].data();
  LabelStats* last = nullptr;
  std::size_t index = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i, ++index) {
        const std::int32_t label = v[index];
        if (label == 0) continue;
        if (last == nullptr || last->value != label) {
          last = &stats[label];
          last->value = label;
          last->layer = layer;
        }
        ++last->count;
        last->lo[0] = std::min(last->lo[0], i);
        last->hi[0] = std::max(last->hi[0], i);
        last->lo[1] = std::min(last->lo[1], j);
        last->hi[1] = std::max(last->hi[1], j);
        last->lo[2] = std::min(last->lo[2], k);
        last->hi[2] = std::max(last->hi[2], k);
      }
  return stats;
}

}  // namespace detail

std::vector<std::map<int, std::size_t>> label_voxel_counts(const LabelVolume& volume) {
  std::vector<std::map<int, std::size_t>> out;
  if (!volume.integer_labels) return out;
  for (std::size_t l = 0; l < volume.layers.size(); ++l) {
    std::map<int, std::size_t>& counts = out.emplace_back();
    for (const auto& [value, s] : detail::label_stats(volume, static_cast<int>(l)))
      counts[value] = s.count;
  }
  return out;
}

}  // namespace fabrica::io
