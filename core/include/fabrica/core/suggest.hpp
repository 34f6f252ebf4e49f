// "Did you mean": the closest known name to a misspelt one (edit distance
// with swaps, case-insensitive), for option values, scene keys, views
// and line families.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace fabrica {

/// Edit distance (insertions, deletions, substitutions and swaps of two
/// neighbouring letters, each 1: optimal string alignment), ASCII
/// case-insensitive.
std::size_t edit_distance(std::string_view a, std::string_view b);

/// The candidate closest to `word` when it is close enough to be a typo
/// (distance <= max(1, |word| / 3), or `word` is a prefix of it), else "".
/// Ties go to the earlier candidate.
std::string closest_name(std::string_view word, const std::vector<std::string>& candidates);

/// " (did you mean 'NAME'?)" for closest_name, or "" when nothing is close.
std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates);

}  // namespace fabrica
