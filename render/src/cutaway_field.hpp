// The cutaway on the CPU, for the vector output (docs/algorithms.md §15):
// per pixel the distance to the nearest pixel of the focus's footprint
// (exact Euclidean distance transform) and the focus's front depth there,
// so a context point can be tested as the GPU pass tests a fragment.
#pragma once

#include <vector>

#include "fabrica/core/depth_raster.hpp"
#include "fabrica/core/projector.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::render::detail {

class CutawayField {
 public:
  /// `focus`: the focus structures' depth (render_depth); `scale` converts
  /// the cutaway's reference pixels to the picture's (the line scale).
  CutawayField(const DepthBuffer& focus, const Camera& camera, const Cutaway& cutaway,
               double scale);
  /// The fraction of a context surface kept at `p` (cutaway_keep where `p`
  /// lies in front of the nearest focus pixel's depth, else 1).
  double keep(const Vec3& p) const;

 private:
  int width_ = 0, height_ = 0;
  std::vector<float> distance_;  // pixels to the nearest focus pixel (+inf: none)
  std::vector<float> depth_;     // the focus's linear depth at that pixel
  Projector projector_;
  Cutaway cutaway_;
  double scale_ = 1.0;
};

}  // namespace fabrica::render::detail
