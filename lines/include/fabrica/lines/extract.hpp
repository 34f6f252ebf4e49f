// One extractor per line family (docs/algorithms.md §3–8), each a free function
// returning the family's segment soup (segments.hpp), plus LineExtractor,
// which keeps the view-independent precomputation and the per-view buffers
// and extracts any set of families for one camera.
//
// Thresholds are dimensionless and scaled by the feature size s_f (§2.6):
// curvature thresholds t/s_f, curvature-derivative thresholds t/s_f². The
// defaults are rtsc's (suggestive 0.01, highlight 0.02, ridge/valley 0.1,
// apparent 0.1 on rtsc's squared q1, fade 0.03), so that the same
// parameters give the same lines as the reference implementation.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/lines/precompute.hpp"
#include "fabrica/lines/segments.hpp"
#include "fabrica/lines/view_fields.hpp"

namespace fabrica {

namespace detail {
struct FaceLists;
}

struct ContourOptions {
  /// rtsc's "trim inside contours": keep only where K_r >= 0 (points with
  /// K_r < 0 are locally self-occluded, §3.2).
  bool trim_concave = true;
  /// Mesh-edge contours (§3.1: edges between a front- and a back-facing
  /// face) instead of interpolated ones.
  bool mesh_edges = false;
};

struct CreaseOptions {
  double angle_deg = 60.0;  ///< normal deviation above which an edge is a crease
};

struct SuggestiveOptions {
  double threshold = 0.01;  ///< on tan θ D_w κ_r, times 1/s_f²
  double fade = 0.03;       ///< fade constant, times 1/s_f² (0 = no fade)
  bool cull_backfaces = true;
};

struct HighlightOptions {
  double threshold = 0.02;  ///< on -tan θ D_w κ_r, times 1/s_f²
  double fade = 0.03;
  bool cull_backfaces = true;
};

struct RidgeOptions {
  double threshold = 0.1;  ///< on |k1|, times 1/s_f
  bool cull_backfaces = true;
};

struct ApparentOptions {
  double threshold = 0.1;  ///< on rtsc's q1 (squared view-dependent curvature), times 1/s_f²
  bool maximum_test = true;
  /// With a value m: apparent ridges are looked for only around vertices
  /// where n·v >= m as well as q1 above the threshold (the extractor passes
  /// it to the view fields, ViewFieldsRequest::apparent_min_ndotv). Meant
  /// for a closed, opaque surface seen from outside with hidden lines
  /// omitted: with m < 0 the faces skipped turn away from the eye and are
  /// hidden behind the surface's front, so the visible lines stay and
  /// their hidden part is not computed. nullopt (the default): everywhere.
  std::optional<double> min_ndotv;
};

struct PhoticOptions {
  /// Light direction (towards the light); nullopt = headlight.
  std::optional<Vec3> light_direction;
  /// PELs: |∇(n·l)| at the crossing > threshold / s_f.
  double threshold = 0.2;
  bool cull_backfaces = true;
};

struct LaplacianOptions {
  std::optional<Vec3> light_direction;
  /// |∇(n·l)| > threshold / s_f (removes the weak, minimum crossings).
  double threshold = 0.2;
  bool cull_backfaces = true;
};

struct DemarcatingOptions {
  double threshold = 0.05;  ///< on C(g,g,g), times 1/s_f²
  bool cull_backfaces = true;
};

// --- single families -------------------------------------------------------
SegmentSoup extract_contours(const Surface& surface, const ViewFields& fields,
                             const ContourOptions& options = {});
SegmentSoup extract_boundaries(const Surface& surface);
SegmentSoup extract_creases(const Surface& surface, const CreaseOptions& options = {});
SegmentSoup extract_suggestive_contours(const Surface& surface, const ViewFields& fields,
                                        double feature_size, const SuggestiveOptions& options = {});
SegmentSoup extract_suggestive_highlights(const Surface& surface, const ViewFields& fields,
                                          double feature_size,
                                          const HighlightOptions& options = {});
SegmentSoup extract_ridges(const LinePrecompute& pre, const ViewFields& fields, double feature_size,
                           const RidgeOptions& options = {});
SegmentSoup extract_valleys(const LinePrecompute& pre, const ViewFields& fields,
                            double feature_size, const RidgeOptions& options = {});
SegmentSoup extract_apparent_ridges(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const ApparentOptions& options = {});
/// Needs fields computed with request.light and request.pel.
SegmentSoup extract_pels(const Surface& surface, const ViewFields& fields, double feature_size,
                         const PhoticOptions& options = {});
/// Needs fields computed with request.light.
SegmentSoup extract_laplacian_lines(const Surface& surface, const ViewFields& fields,
                                    double feature_size, const LaplacianOptions& options = {});
SegmentSoup extract_demarcating_curves(const LinePrecompute& pre, const ViewFields& fields,
                                       double feature_size, const DemarcatingOptions& options = {});

// --- several families for one view ----------------------------------------
struct LineOptions {
  /// Families to extract, in output order. Default: contour, boundary,
  /// suggestive (the classic "suggestive contour drawing").
  std::vector<LineFamily> families = {LineFamily::contour, LineFamily::boundary,
                                      LineFamily::suggestive};
  /// Feature size in mm; <= 0 uses the Surface's (rtsc's rule).
  double feature_size = 0.0;
  ContourOptions contour;
  CreaseOptions crease;
  SuggestiveOptions suggestive;
  HighlightOptions highlight;
  RidgeOptions ridge;
  RidgeOptions valley;
  ApparentOptions apparent;
  PhoticOptions pel;
  LaplacianOptions laplacian;
  DemarcatingOptions demarcating;
};

/// The families rtsc computes, in the reference .seg order.
std::vector<LineFamily> reference_families();
/// Every family.
std::vector<LineFamily> all_families();

/// Stateful extractor: keeps LinePrecompute and the ViewFields buffers, so
/// each new camera only recomputes what depends on the view.
class LineExtractor {
 public:
  LineExtractor(const Surface& surface, LineOptions options = {});
  ~LineExtractor();
  const LineOptions& options() const { return options_; }
  void set_options(LineOptions options);
  double feature_size() const { return feature_size_; }
  const LinePrecompute& precompute() const { return *precompute_; }
  /// The fields of the last extract() call.
  const ViewFields& fields() const { return fields_; }
  /// One soup per requested family, in options().families order.
  std::vector<SegmentSoup> extract(const Camera& camera);
  /// The same into `soups`, whose previous segment storage is recycled
  /// (for a redraw loop: no fresh memory per view once warmed up).
  void extract(const Camera& camera, std::vector<SegmentSoup>& soups);
  /// One view only (the one-shot draw_lines): each extract() frees the
  /// precompute's per-view inputs (LinePrecompute::vertex_blocks,
  /// tangent_ring) as soon as its passes are through with them, which
  /// lowers the peak memory; a further extract() would rebuild them.
  void set_one_shot(bool one_shot) { one_shot_ = one_shot; }

 private:
  const Surface* surface_;
  LineOptions options_;
  double feature_size_ = 0.0;
  std::unique_ptr<LinePrecompute> precompute_;
  ViewFields fields_;
  std::unique_ptr<detail::FaceLists> apparent_faces_;  // listed by the contour scan
  bool one_shot_ = false;
};

}  // namespace fabrica
