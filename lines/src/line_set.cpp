#include "fabrica/lines/line_set.hpp"

#include <array>

#include "fabrica/lines/segments.hpp"

namespace fabrica {

namespace {
constexpr std::array<const char*, kLineFamilyCount> kNames = {
    "contour", "boundary", "crease", "suggestive", "highlight",  "ridge",
    "valley",  "apparent", "pel",    "laplacian",  "demarcating"};
}  // namespace

const char* family_name(LineFamily family) {
  const auto i = static_cast<std::size_t>(family);
  return i < kNames.size() ? kNames[i] : "unknown";
}

std::optional<LineFamily> parse_family(std::string_view name) {
  for (std::size_t i = 0; i < kNames.size(); ++i)
    if (name == kNames[i]) return static_cast<LineFamily>(i);
  // Common long forms.
  if (name == "contours" || name == "silhouette") return LineFamily::contour;
  if (name == "suggestive-contour" || name == "suggestive_contour") return LineFamily::suggestive;
  if (name == "suggestive-highlight" || name == "suggestive_highlight")
    return LineFamily::highlight;
  if (name == "apparent-ridge" || name == "apparent_ridge") return LineFamily::apparent;
  if (name == "ridges") return LineFamily::ridge;
  if (name == "valleys") return LineFamily::valley;
  if (name == "boundaries") return LineFamily::boundary;
  if (name == "creases") return LineFamily::crease;
  if (name == "pels" || name == "photic") return LineFamily::pel;
  return std::nullopt;
}

}  // namespace fabrica

namespace fabrica {

double Polyline::length() const {
  double sum = 0.0;
  const std::size_t n = vertices.size();
  for (std::size_t i = 0; i + 1 < n; ++i)
    sum += (vertices[i + 1].position - vertices[i].position).norm();
  if (closed && n > 2) sum += (vertices.front().position - vertices.back().position).norm();
  return sum;
}

}  // namespace fabrica
