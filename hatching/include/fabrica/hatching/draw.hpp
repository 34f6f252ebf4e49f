// One call for a hatching (issue 16): the light given as `fabrica hatch
// --light` spells it, the options checked with the CLI's messages, then
// hatching::hatch (method shading, the default) or hatching::confis (method
// confis, issue 21: ConFIS streamlines, docs/confis.md). `fabrica hatch`, the viewer, the batch
// runner and the Python module hatch through this. Feature lines over the strokes come from
// fabrica::draw_lines (lines/draw.hpp); the PNG from render/draw.hpp.
#pragma once

#include <string>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/confis.hpp"
#include "fabrica/hatching/hatching.hpp"
#include "fabrica/hatching/stroke_set.hpp"

namespace fabrica {

/// `fabrica hatch --method`: shading strokes (Singh & Schaefer 2010) or
/// ConFIS streamlines (Lawonn, Moench & Preim 2013).
enum class HatchingMethod { shading, confis };
const char* to_string(HatchingMethod method);
/// "shading" or "confis" (any case); InputError with a did-you-mean otherwise.
HatchingMethod parse_hatching_method(const std::string& text);

struct DrawHatchingOptions {
  HatchingMethod method = HatchingMethod::shading;
  /// Method shading: everything but the light (which depends on the camera
  /// for "view:").
  hatching::HatchingOptions hatching;
  /// Method confis (the light is not used).
  hatching::ConfisOptions confis;
  /// eye | dir:X,Y,Z (world, towards the light) | view:X,Y,Z (camera frame:
  /// x right, y up, z towards the viewer) | point:X,Y,Z (world, mm).
  std::string light = "eye";
};

/// The light `text` names for `camera` (InputError with the CLI's message).
hatching::Light parse_light(const std::string& text, const Camera& camera);

/// Throws InputError with the CLI's one-line message for an option out of
/// range (ridge angle, stroke width, lengths, threshold, depths).
void validate(const DrawHatchingOptions& options);

/// Validates, resolves the light for `camera` and hatches with the method.
hatching::StrokeSet draw_hatching(const Surface& surface, const Camera& camera,
                                  const DrawHatchingOptions& options = {});

}  // namespace fabrica
