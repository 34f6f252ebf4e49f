// Comparing two sets of 3D line segments (docs/algorithms.md §12, and the scores
// of docs/lines-fidelity.md "How it is measured"): every segment is sampled
// at spacing <= `spacing`; a sample is matched when its exact distance to
// some segment of the other set is <= `tolerance`. Precision = matched
// fraction of the test set's length, recall = matched fraction of the
// reference set's length, F = 2PR/(P+R). Empty sets: P (or R) = 1 when the
// set has no length; F = 1 when both are empty.
#pragma once

#include <vector>

#include "fabrica/lines/seg_io.hpp"

namespace fabrica {

struct LineMatchScore {
  double precision = 1.0, recall = 1.0, f = 1.0;
  double test_length = 0.0, reference_length = 0.0;
};

LineMatchScore compare_segments(const std::vector<Segment3>& test,
                                const std::vector<Segment3>& reference, double tolerance,
                                double spacing);

/// Bounding-box diagonal of all endpoints of the given sets.
double segments_diagonal(const std::vector<const std::vector<Segment3>*>& sets);

}  // namespace fabrica
