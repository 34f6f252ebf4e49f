// LineSet: feature lines as polylines anchored on the surface.
//
// Every polyline vertex is a SurfacePoint (face + barycentric coordinates)
// with its 3D position, a strength (how far past its threshold, in [0,1]
// after fading: used for width/opacity) and a visibility flag. Each polyline
// carries its family. Because lines stay anchored on the surface they can be
// smoothed on it, re-projected for any camera, hidden-line tested, styled and
// written as vector paths.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "fabrica/core/surface_point.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica {

/// Line families; names (family_name) are those of the reference .seg format
/// plus fabrica's own.
enum class LineFamily : std::uint8_t {
  contour,      ///< "contour": interpolated occluding contours (n·v = 0)
  boundary,     ///< "boundary": mesh boundary edges
  crease,       ///< "crease": sharp edges (dihedral threshold)
  suggestive,   ///< "suggestive": suggestive contours
  highlight,    ///< "highlight": suggestive highlights
  ridge,        ///< "ridge"
  valley,       ///< "valley"
  apparent,     ///< "apparent": apparent ridges (Judd et al.)
  pel,          ///< "pel": photic extremum lines
  laplacian,    ///< "laplacian": Laplacian lines
  demarcating,  ///< "demarcating": demarcating curves
};
inline constexpr int kLineFamilyCount = 11;

const char* family_name(LineFamily family);
std::optional<LineFamily> parse_family(std::string_view name);

struct LineVertex {
  SurfacePoint anchor;
  Vec3 position = Vec3::Zero();
  float strength = 1.0f;  ///< in [0,1]: fade/width factor
  /// Visibility of this vertex and of the polyline edge that starts here.
  bool visible = true;
};

struct Polyline {
  LineFamily family = LineFamily::contour;
  bool closed = false;  ///< last vertex joins the first
  std::vector<LineVertex> vertices;
  /// Optional: the mesh face each polyline edge (vertex i to i+1, and the
  /// closing edge of a loop) lies in; empty when unknown.
  std::vector<std::int32_t> edge_faces;
  /// Length in space (mm), including the closing edge of a loop.
  double length() const;
};

struct LineSet {
  std::vector<Polyline> polylines;
};

}  // namespace fabrica
