// Private: deterministic chunked parallel loops that produce variable-size
// output (segments): each fixed chunk of the index range writes its own
// vector, and the chunks are concatenated in order, so the result is the
// same at any thread count.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <vector>

namespace fabrica::detail {

inline constexpr std::size_t kFaceChunk = 4096;

/// Process-wide free list of chunk output buffers: the chunks of one call
/// reuse the capacity (already-touched memory) left by earlier calls instead
/// of growing fresh vectors every view. Keeps at most kMaxBytes of capacity.
template <class T>
class ChunkBufferPool {
 public:
  static ChunkBufferPool& instance() {
    static ChunkBufferPool pool;
    return pool;
  }
  std::vector<T> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) return {};
    std::vector<T> v = std::move(free_.back());
    free_.pop_back();
    bytes_ -= v.capacity() * sizeof(T);
    return v;
  }
  void give(std::vector<T>&& v) {
    if (v.capacity() == 0) return;
    v.clear();
    std::lock_guard<std::mutex> lock(mutex_);
    if (bytes_ + v.capacity() * sizeof(T) > kMaxBytes) return;
    bytes_ += v.capacity() * sizeof(T);
    free_.push_back(std::move(v));
  }

 private:
  static constexpr std::size_t kMaxBytes = std::size_t{64} << 20;
  std::mutex mutex_;
  std::vector<std::vector<T>> free_;
  std::size_t bytes_ = 0;
};

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
  std::vector<std::vector<T>> parts(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        parts[c] = pool.take();
                        fn(c * chunk, std::min(n, (c + 1) * chunk), parts[c]);
                      }
                    });
  std::size_t total = out.size();
  for (const auto& p : parts) total += p.size();
  out.reserve(total);
  for (auto& p : parts) {
    out.insert(out.end(), p.begin(), p.end());
    pool.give(std::move(p));
  }
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
