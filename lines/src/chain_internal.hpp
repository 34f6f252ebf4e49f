// Private to fabrica::lines (and its tests): the end pairing of chaining.
#pragma once

#include <cstdint>
#include <vector>

#include "fabrica/lines/segments.hpp"

namespace fabrica::detail {

/// partner[2 * segment + side] = the end joined to that end (the only other
/// end of another segment with the same kind and element), else -1. A flat
/// table indexed by element when the ids are small, else a sort of the
/// keys (`force_sorted`: always the sort; both give the same pairs).
std::vector<std::int32_t> pair_ends(const std::vector<LineSegment>& segs,
                                    bool force_sorted = false);
/// The same pairs, the table sized by the soup's mesh instead of a pass
/// over the ends: `bound[kind]` = the number of edges, vertices and faces
/// (an id at or past its bound falls back to pair_ends(segs)).
std::vector<std::int32_t> pair_ends(const std::vector<LineSegment>& segs,
                                    const std::int64_t bound[3]);

}  // namespace fabrica::detail
