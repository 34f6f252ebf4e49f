// fabrica-study's documented randomness and counterbalancing (issue 20):
// the PRNG gives its published reference values (so plans are the same on
// every machine) and Williams' Latin squares are balanced.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "plan.hpp"

namespace fabrica::study {
namespace {

TEST(StudyRng, SplitMix64MatchesReferenceValues) {
  // Vigna's splitmix64.c with seed 1234567: the first outputs.
  std::uint64_t state = 1234567;
  EXPECT_EQ(splitmix64(state), 6457827717110365317ULL);
  EXPECT_EQ(splitmix64(state), 3203168211198807973ULL);
  EXPECT_EQ(splitmix64(state), 9817491932198370423ULL);
}

TEST(StudyRng, BelowIsInRangeAndCoversIt) {
  Rng rng(42);
  std::set<std::uint64_t> seen;
  for (int i = 0; i < 1000; ++i) {
    const auto v = rng.below(7);
    ASSERT_LT(v, 7u);
    seen.insert(v);
  }
  EXPECT_EQ(seen.size(), 7u);
  Rng a(5), b(5), c(6);
  EXPECT_EQ(a.next(), b.next());
  EXPECT_NE(Rng(5).next(), c.next());
  const double u = Rng(9).uniform();
  EXPECT_TRUE(u >= 0.0 && u < 1.0);
}

TEST(StudyLatinSquare, EveryConditionOncePerPositionAndNeighboursBalanced) {
  for (int k = 2; k <= 7; ++k) {
    const int rows = latin_square_rows(k);
    EXPECT_EQ(rows, k % 2 ? 2 * k : k);
    std::vector<std::map<int, int>> per_position(k);
    std::map<std::pair<int, int>, int> neighbours;
    for (int r = 0; r < rows; ++r) {
      const auto row = latin_square_row(k, r);
      ASSERT_EQ(static_cast<int>(std::set<int>(row.begin(), row.end()).size()), k);
      for (int p = 0; p < k; ++p) ++per_position[p][row[p]];
      for (int p = 0; p + 1 < k; ++p) ++neighbours[{row[p], row[p + 1]}];
    }
    for (int p = 0; p < k; ++p)
      for (int c = 0; c < k; ++c) EXPECT_EQ(per_position[p][c], rows / k) << "k=" << k;
    // Each ordered pair of distinct conditions is a neighbour equally often.
    EXPECT_EQ(static_cast<int>(neighbours.size()), k * (k - 1)) << "k=" << k;
    for (const auto& [pair, n] : neighbours) EXPECT_EQ(n, rows / k) << "k=" << k;
  }
}

TEST(StudyLatinSquare, ParticipantRowFromTrailingDigits) {
  EXPECT_EQ(participant_row("P07", 4), 3);
  EXPECT_EQ(participant_row("S12", 6), 0);
  EXPECT_EQ(participant_row("anna", 4), participant_row("anna", 4));
  EXPECT_LT(participant_row("anna", 4), 4);
}

TEST(StudyNames, ParticipantIdsAreValidated) {
  EXPECT_TRUE(valid_name("P01"));
  EXPECT_TRUE(valid_name("site-a_17"));
  EXPECT_FALSE(valid_name(""));
  EXPECT_FALSE(valid_name("../x"));
  EXPECT_FALSE(valid_name("a b"));
  EXPECT_FALSE(valid_name(std::string(65, 'a')));
}

}  // namespace
}  // namespace fabrica::study
