// Private: deterministic chunked parallel loops that produce variable-size
// output (segments): each fixed chunk of the index range writes its own
// vector, and the chunks are appended in order, so the result is the same
// at any thread count.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace fabrica::detail {

inline constexpr std::size_t kFaceChunk = 4096;

/// Process-wide free lists of output buffers, so that the chunks of a call
/// reuse the capacity (already-touched memory) left by earlier calls instead
/// of growing fresh vectors every view. Chunk buffers are filed under their
/// call site and taken back most recent first (likely still in cache);
/// whole outputs (handed back through LineExtractor::extract(camera,
/// soups)) under kOutputKey, taken best-fit.
/// Keeps at most kMaxBytes of capacity. Buffers never affect the results.
template <class T>
class ChunkBufferPool {
 public:
  using Key = std::pair<const void*, std::size_t>;
  static ChunkBufferPool& instance() {
    static ChunkBufferPool pool;
    return pool;
  }
  /// The buffer given back last under `key` (likely still in cache), or
  /// an empty vector.
  std::vector<T> take_recent(const Key& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = free_.find(key);
    if (it == free_.end() || it->second.empty()) return {};
    return pop(it->second, it->second.size() - 1);
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
  /// Files `v` (emptied) under `key`.
  void give(const Key& key, std::vector<T>&& v) {
    if (v.capacity() == 0) return;
    v.clear();
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

/// fn(begin, end, part_0, ..., part_{N-1}) for fixed chunks of [0, n), each
/// chunk writing N fresh parts; part k of every chunk is appended to
/// *outs[k] in chunk order, so the result is the same at any thread count.
/// A chunk taken when every chunk before it has been appended writes
/// straight into the outputs (nothing else touches them until it is done,
/// and its segments are not copied: a copy of a view's ~10 MB of segments
/// is ~0.8 ms of a ~12 ms view at one thread). So the chunks are taken from
/// both ends: the next chunk from the front when that holds (always on one
/// thread), otherwise the last one left, into parts; each finished run of
/// consecutive chunks is appended by the thread that completes it, and the
/// part buffers are recycled most-recent-first. On two threads sharing a
/// loop, one works forward in place and the other backward into parts,
/// so about half of it is copied (taking chunks in turn, nearly all was).
template <std::size_t N, class T, class Fn>
void ordered_chunks(std::size_t n, Fn&& fn, const std::array<std::vector<T>*, N>& outs,
                    const void* site, std::size_t chunk = kFaceChunk) {
  static_assert(std::is_trivially_destructible_v<T>);
  if (n == 0) return;
  const std::size_t chunks = (n + chunk - 1) / chunk;
  auto& pool = ChunkBufferPool<T>::instance();
  // Each empty output starts from the smallest recycled whole output that
  // holds what this call site's output held last time (instantiations
  // differ by call site: Fn is a lambda).
  static std::array<std::atomic<std::size_t>, N> last_size{};
  std::array<std::size_t, N> start{};
  for (std::size_t k = 0; k < N; ++k) {
    std::vector<T>* o = outs[k];
    if (o->empty() && o->capacity() == 0) {
      const std::size_t want = last_size[k].load(std::memory_order_relaxed);
      if (want > 0) {
        // Room for a little more than last time, so that buffers settle at
        // a capacity later views fit in (no growth while appending).
        *o = pool.take_at_least(kOutputKey, want);
        o->clear();
        o->reserve(want + want / 8);
      }
    }
    start[k] = o->size();
  }
  struct Slot {
    std::array<std::vector<T>, N> part;
    std::atomic<bool> done{false};
  };
  std::unique_ptr<Slot[]> slot(new Slot[chunks]);
  std::mutex claim;
  std::size_t front = 0, back = chunks;  // unclaimed: [front, back); guarded by `claim`
  std::mutex append;
  // Chunks before `appended` are in the outputs; written with `append`
  // held (release), read without it (acquire) to find a chunk that can
  // write straight into them.
  std::atomic<std::size_t> appended{0};
  auto drain = [&] {  // with `append` held
    std::size_t a = appended.load(std::memory_order_relaxed);
    while (a < chunks && slot[a].done.load(std::memory_order_acquire)) {
      for (std::size_t k = 0; k < N; ++k) {
        std::vector<T>& p = slot[a].part[k];
        outs[k]->insert(outs[k]->end(), p.begin(), p.end());
        pool.give({site, 0}, std::move(p));
      }
      appended.store(++a, std::memory_order_release);
    }
  };
  auto run = [&] {
    std::size_t c;
    bool direct;
    {
      std::lock_guard<std::mutex> lock(claim);
      direct = appended.load(std::memory_order_acquire) == front;
      c = direct ? front++ : --back;
    }
    Slot& s = slot[c];
    const std::size_t b = c * chunk, e = std::min(n, (c + 1) * chunk);
    if (direct) {
      // Every earlier chunk is in the outputs, and no later one is
      // appended before this one is done: append in place.
      std::array<std::vector<T>*, N> o = outs;
      std::apply([&](auto*... direct) { fn(b, e, *direct...); }, o);
    } else {
      for (auto& p : s.part) p = pool.take_recent({site, 0});
      std::apply([&](auto&... parts) { fn(b, e, parts...); }, s.part);
    }
    s.done.store(true, std::memory_order_release);
    // Whoever finds the lock free appends what is ready (RAII: an append
    // that throws still releases it).
    std::unique_lock<std::mutex> lock(append, std::try_to_lock);
    if (lock.owns_lock()) drain();
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t t = r.begin(); t != r.end(); ++t) run();
                    });
  std::lock_guard<std::mutex> lock(append);
  drain();
  for (std::size_t k = 0; k < N; ++k)
    last_size[k].store(outs[k]->size() - start[k], std::memory_order_relaxed);
}

/// fn(begin, end, std::vector<T>& out) for fixed chunks of [0, n); the
/// outputs are appended to `out` in chunk order (ordered_chunks).
template <class T, class Fn>
void parallel_chunks(std::size_t n, Fn&& fn, std::vector<T>& out, std::size_t chunk = kFaceChunk) {
  if (n == 0) return;
  if (n <= chunk) {
    fn(std::size_t{0}, n, out);
    return;
  }
  static const char site = 0;  // one per instantiation, i.e. per call site
  ordered_chunks<1, T>(n, fn, std::array<std::vector<T>*, 1>{&out}, &site, chunk);
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
