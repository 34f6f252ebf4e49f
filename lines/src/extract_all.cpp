#include <algorithm>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"

namespace fabrica {

std::vector<LineFamily> reference_families() {
  return {LineFamily::contour, LineFamily::suggestive, LineFamily::apparent, LineFamily::ridge,
          LineFamily::valley};
}

std::vector<LineFamily> all_families() {
  std::vector<LineFamily> out;
  for (int i = 0; i < kLineFamilyCount; ++i) out.push_back(static_cast<LineFamily>(i));
  return out;
}

LineExtractor::LineExtractor(const Surface& surface, LineOptions options)
    : surface_(&surface), precompute_(std::make_unique<LinePrecompute>(surface)) {
  set_options(std::move(options));
}

LineExtractor::~LineExtractor() = default;

void LineExtractor::set_options(LineOptions options) {
  options_ = std::move(options);
  feature_size_ = options_.feature_size > 0.0 ? options_.feature_size : surface_->feature_size();
  if (!(feature_size_ > 0.0) || !std::isfinite(feature_size_))
    throw InputError("feature size must be a positive number (got " +
                     std::to_string(feature_size_) + "); pass --feature-size");
}

std::vector<SegmentSoup> LineExtractor::extract(const Camera& camera) {
  const auto has = [&](LineFamily f) {
    return std::find(options_.families.begin(), options_.families.end(), f) !=
           options_.families.end();
  };
  ViewFieldsRequest req;
  req.radial = true;
  req.sc_test = has(LineFamily::suggestive) || has(LineFamily::highlight);
  req.apparent = has(LineFamily::apparent);
  req.light = has(LineFamily::laplacian) || has(LineFamily::pel);
  req.pel = has(LineFamily::pel);
  if (has(LineFamily::pel) && has(LineFamily::laplacian) &&
      options_.pel.light_direction != options_.laplacian.light_direction)
    throw InputError("PELs and Laplacian lines must use the same light in one extraction");
  req.light_direction =
      has(LineFamily::pel) ? options_.pel.light_direction : options_.laplacian.light_direction;
  update_view_fields(fields_, *surface_, camera, req, precompute_.get());

  const double fs = feature_size_;
  std::vector<SegmentSoup> out;
  out.reserve(options_.families.size());
  for (LineFamily f : options_.families) {
    switch (f) {
      case LineFamily::contour:
        out.push_back(extract_contours(*surface_, fields_, options_.contour));
        break;
      case LineFamily::boundary:
        out.push_back(extract_boundaries(*surface_));
        break;
      case LineFamily::crease:
        out.push_back(extract_creases(*surface_, options_.crease));
        break;
      case LineFamily::suggestive:
        out.push_back(extract_suggestive_contours(*surface_, fields_, fs, options_.suggestive));
        break;
      case LineFamily::highlight:
        out.push_back(extract_suggestive_highlights(*surface_, fields_, fs, options_.highlight));
        break;
      case LineFamily::ridge:
        out.push_back(extract_ridges(*precompute_, fields_, fs, options_.ridge));
        break;
      case LineFamily::valley:
        out.push_back(extract_valleys(*precompute_, fields_, fs, options_.valley));
        break;
      case LineFamily::apparent:
        out.push_back(extract_apparent_ridges(*surface_, fields_, fs, options_.apparent));
        break;
      case LineFamily::pel:
        out.push_back(extract_pels(*surface_, fields_, fs, options_.pel));
        break;
      case LineFamily::laplacian:
        out.push_back(extract_laplacian_lines(*surface_, fields_, fs, options_.laplacian));
        break;
      case LineFamily::demarcating:
        out.push_back(extract_demarcating_curves(*precompute_, fields_, fs, options_.demarcating));
        break;
    }
  }
  return out;
}

}  // namespace fabrica
