// The deterministic chunked loop behind every segment extractor
// (lines/src/parallel.hpp, ordered_chunks): whatever the thread count and
// whichever chunks write straight into the outputs (those taken when every
// earlier chunk is appended) or into parts appended later, the outputs are
// the sequential loop's, after what they held before.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <vector>

#include "parallel.hpp"

namespace {

// Element i of [0, n) gives 0..2 entries to the first output and 0..1 to
// the second, by a hash; chunks take uneven, index-dependent time so the
// threads overtake each other.
std::uint32_t mix(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  return x ^ (x >> 16);
}

void body(std::size_t b, std::size_t e, std::vector<std::int64_t>& a,
          std::vector<std::int64_t>& c) {
  const auto until =
      std::chrono::steady_clock::now() + std::chrono::microseconds(mix(std::uint32_t(b)) % 200);
  for (std::size_t i = b; i < e; ++i) {
    const std::uint32_t h = mix(std::uint32_t(i) * 2654435761U);
    for (std::uint32_t k = 0; k < h % 3; ++k) a.push_back(std::int64_t(i) * 4 + k);
    if (h & 8) c.push_back(-std::int64_t(i));
  }
  while (std::chrono::steady_clock::now() < until) {
  }
}

}  // namespace

TEST(OrderedChunks, OutputsAreTheSequentialLoopsAtAnyThreadCountAfterWhatTheyHeld) {
  const std::size_t n = 50'000, chunk = 700;  // the last chunk is short
  std::vector<std::int64_t> want_a{7, 8}, want_c{9};
  body(0, n, want_a, want_c);
  ASSERT_GT(want_a.size(), n / 2);
  ASSERT_GT(want_c.size(), n / 4);
  static const char site = 0;
  for (int threads : {1, 2}) {
    tbb::task_arena arena(threads);
    for (int round = 0; round < 12; ++round) {
      std::vector<std::int64_t> a{7, 8}, c{9};
      arena.execute([&] {
        fabrica::detail::ordered_chunks<2, std::int64_t>(
            n, body, std::array<std::vector<std::int64_t>*, 2>{&a, &c}, &site, chunk);
      });
      ASSERT_EQ(a, want_a) << threads << " threads, round " << round;
      ASSERT_EQ(c, want_c) << threads << " threads, round " << round;
    }
  }
}

TEST(OrderedChunks, EmptyOutputsStartFromRecycledBuffersAndStayCorrect) {
  // Empty outputs without capacity take a recycled whole output sized from
  // the previous call at this site; the contents must not leak in.
  const std::size_t n = 20'000;
  std::vector<std::int64_t> want_a, want_c;
  body(0, n, want_a, want_c);
  static const char site = 0;
  tbb::task_arena arena(2);
  for (int round = 0; round < 6; ++round) {
    std::vector<std::int64_t> a, c;
    arena.execute([&] {
      fabrica::detail::ordered_chunks<2, std::int64_t>(
          n, body, std::array<std::vector<std::int64_t>*, 2>{&a, &c}, &site, 1000);
    });
    ASSERT_EQ(a, want_a) << "round " << round;
    ASSERT_EQ(c, want_c) << "round " << round;
    auto& pool = fabrica::detail::ChunkBufferPool<std::int64_t>::instance();
    pool.give(fabrica::detail::kOutputKey, std::move(a));
    pool.give(fabrica::detail::kOutputKey, std::move(c));
  }
}
