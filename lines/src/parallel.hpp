// Private: deterministic chunked parallel loops that produce variable-size
// output (segments): each fixed chunk of the index range writes its own
// vector, and the chunks are concatenated in order, so the result is the
// same at any thread count.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <map>
#include <mutex>
#include <type_traits>
#include <utility>
#include <vector>

namespace fabrica::detail {

inline constexpr std::size_t kFaceChunk = 4096;

/// Process-wide free lists of output buffers, so that the chunks of a call
/// reuse the capacity (already-touched memory) left by earlier calls instead
/// of growing fresh vectors every view. Chunk buffers are filed under their
/// call site and chunk index (a chunk gets back a buffer sized by the same
/// chunk of an earlier call); whole outputs (handed back through
/// LineExtractor::extract(camera, soups)) under kOutputKey, taken best-fit.
/// Keeps at most kMaxBytes of capacity. Buffers never affect the results.
template <class T>
class ChunkBufferPool {
 public:
  using Key = std::pair<const void*, std::size_t>;
  static ChunkBufferPool& instance() {
    static ChunkBufferPool pool;
    return pool;
  }
  /// The largest free buffer filed under `key`, or an empty vector.
  std::vector<T> take(const Key& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = free_.find(key);
    if (it == free_.end() || it->second.empty()) return {};
    auto& list = it->second;
    std::size_t best = 0;
    for (std::size_t k = 1; k < list.size(); ++k)
      if (list[k].capacity() > list[best].capacity()) best = k;
    return pop(list, best);
  }
  /// The smallest free buffer under `key` with capacity >= n, or empty.
  std::vector<T> take_at_least(const Key& key, std::size_t n) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = free_.find(key);
    if (it == free_.end()) return {};
    auto& list = it->second;
    std::size_t best = list.size();
    for (std::size_t k = 0; k < list.size(); ++k)
      if (list[k].capacity() >= n &&
          (best == list.size() || list[k].capacity() < list[best].capacity()))
        best = k;
    if (best == list.size()) return {};
    return pop(list, best);
  }
  /// With `keep_size` (whole outputs under kOutputKey only, for a
  /// trivially destructible T) the elements stay constructed, so the next
  /// output that takes the buffer and resizes it to about the same length
  /// does not value-initialise them all again (concatenate_chunks
  /// overwrites every element it keeps).
  void give(const Key& key, std::vector<T>&& v, bool keep_size = false) {
    if (v.capacity() == 0) return;
    if (!keep_size) v.clear();
    std::lock_guard<std::mutex> lock(mutex_);
    if (bytes_ + v.capacity() * sizeof(T) > kMaxBytes) return;
    bytes_ += v.capacity() * sizeof(T);
    free_[key].push_back(std::move(v));
  }

 private:
  std::vector<T> pop(std::vector<std::vector<T>>& list, std::size_t k) {
    std::vector<T> v = std::move(list[k]);
    list[k] = std::move(list.back());
    list.pop_back();
    bytes_ -= v.capacity() * sizeof(T);
    return v;
  }
  static constexpr std::size_t kMaxBytes = std::size_t{128} << 20;
  std::mutex mutex_;
  std::map<Key, std::vector<std::vector<T>>> free_;
  std::size_t bytes_ = 0;
};

/// Key of the whole-output buffers in ChunkBufferPool.
inline constexpr std::pair<const void*, std::size_t> kOutputKey{nullptr, 0};

/// Appends parts[0], parts[1], ... to `out` and hands each part back to the
/// pool under {site, key_base + c}. The output grows once (from a recycled
/// whole output when `out` is empty: its kept elements are overwritten, not
/// value-initialised again), then the parts are copied into their places in
/// parallel (a serial copy of ~10 MB per view would not scale).
template <class T>
void concatenate_chunks(std::vector<std::vector<T>>& parts, std::vector<T>& out, const void* site,
                        std::size_t key_base) {
  static_assert(std::is_trivially_destructible_v<T>);
  auto& pool = ChunkBufferPool<T>::instance();
  const std::size_t chunks = parts.size();
  std::vector<std::size_t> offset(chunks + 1);
  offset[0] = out.size();
  for (std::size_t c = 0; c < chunks; ++c) offset[c + 1] = offset[c] + parts[c].size();
  const std::size_t total = offset[chunks];
  if (out.empty() && out.capacity() < total) {
    std::vector<T> v = pool.take_at_least(kOutputKey, total);
    if (v.capacity() >= total) out.swap(v);
  }
  out.resize(total);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        std::copy(parts[c].begin(), parts[c].end(), out.begin() + offset[c]);
                        pool.give({site, key_base + c}, std::move(parts[c]));
                      }
                    });
}

/// fn(begin, end, std::vector<T>& out) for fixed chunks of [0, n); the
/// outputs are appended to `out` in chunk order.
template <class T, class Fn>
void parallel_chunks(std::size_t n, Fn&& fn, std::vector<T>& out, std::size_t chunk = kFaceChunk) {
  if (n == 0) return;
  const std::size_t chunks = (n + chunk - 1) / chunk;
  if (chunks == 1) {
    fn(std::size_t{0}, n, out);
    return;
  }
  auto& pool = ChunkBufferPool<T>::instance();
  static const char site = 0;  // one per instantiation, i.e. per call site
  std::vector<std::vector<T>> parts(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        parts[c] = pool.take({&site, c + 1});
                        fn(c * chunk, std::min(n, (c + 1) * chunk), parts[c]);
                      }
                    });
  concatenate_chunks(parts, out, &site, 1);
}

/// Plain parallel loop over [0, n) in blocks (no output).
template <class Fn>
void parallel_range(std::size_t n, Fn&& fn, std::size_t grain = 2048) {
  if (n == 0) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) fn(i);
                    });
}

}  // namespace fabrica::detail
