// The .seg text format of the reference rtsc line files
// (docs/formats.md ".seg"): line 1 is "# " followed by one JSON object
// (the header: camera, parameters, counts), then one straight segment per
// line, "type x0 y0 z0 x1 y1 z1", in the mesh's own units, 7 significant
// digits. Types appear grouped, in the order contour, suggestive, apparent,
// ridge, valley (fabrica's other families follow).
#pragma once

#include <array>
#include <filesystem>
#include <istream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fabrica/core/types.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/lines/segments.hpp"

namespace fabrica {

using Segment3 = std::array<Vec3, 2>;

struct SegGroup {
  std::string type;
  std::vector<Segment3> segments;
};

struct SegFile {
  nlohmann::json header;         ///< object; empty when the file has no header line
  std::vector<SegGroup> groups;  ///< in order of first appearance
  const SegGroup* find(const std::string& type) const;
};

/// Parses .seg text; `what` names the source in InputError messages.
SegFile read_seg(std::istream& in, const std::string& what);
/// Reads a plain (uncompressed) .seg file.
SegFile read_seg_file(const std::filesystem::path& path);

/// The order families are written in: reference families first.
std::vector<LineFamily> seg_family_order();

/// Writes header + segments atomically. Each polyline contributes its
/// consecutive vertex pairs; with `visible_only`, only visible edges (an
/// edge takes the visibility of its first vertex).
void write_seg(const std::filesystem::path& path, const nlohmann::json& header,
               const LineSet& lines, bool visible_only);
/// Writes raw segment soups (no chaining).
void write_seg(const std::filesystem::path& path, const nlohmann::json& header,
               const std::vector<SegmentSoup>& soups);

/// Straight segments of a soup (positions only).
std::vector<Segment3> segment_positions(const SegmentSoup& soup);

}  // namespace fabrica
