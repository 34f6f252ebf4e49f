// Private per-triangle kernels shared by the Surface cache and the public
// free functions (geometry.cpp, curvature.cpp, laplacian.cpp). Not installed.
//
// Corner/edge convention used everywhere: corner k of a face is vertex
// face[k]; edge k is the edge opposite corner k, as a vector
// e[k] = p[(k+2)%3] - p[(k+1)%3] (counter-clockwise). At corner k the two
// edges leaving the corner are e[(k+2)%3] (to corner k+1) and -e[(k+1)%3]
// (to corner k+2).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>
#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/core/types.hpp"

/// Hot per-face loops are compiled twice, for x86-64-v3 (AVX2) and the
/// portable baseline, and the best is picked at load time (GCC function
/// multiversioning). The sources are compiled with -ffp-contract=off
/// (core/geometry.cmake), so both versions give the same bits.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(FABRICA_NO_MULTIVERSION)
#define FABRICA_MULTIVERSION __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define FABRICA_MULTIVERSION
#endif

namespace fabrica::detail {

/// Sets v to n copies of `value`. For large arrays (>= 4 MiB) the storage is
/// first reserved and marked for transparent huge pages (Linux), so filling
/// it takes a few hundred page faults instead of thousands: on the 2-core
/// build machines that is ~20 ms of a ~40 ms precompute on a 270k-face mesh.
/// Only the memory's paging changes, never its contents.
template <class T>
void assign_large(std::vector<T>& v, std::size_t n, const T& value) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::size_t kHuge = std::size_t(2) << 20;
  const std::size_t bytes = n * sizeof(T);
  if (bytes >= 2 * kHuge && v.capacity() < n) {
    std::vector<T>().swap(v);
    v.reserve(n);
    const auto begin = reinterpret_cast<std::uintptr_t>(v.data());
    const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t last = (begin + bytes) & ~(kHuge - 1);
    if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
  }
#endif
  v.assign(n, value);
}

/// A scratch array whose elements are NOT initialised (every pass that uses
/// one writes each element before anything reads it), so the first touch of
/// its pages happens inside the parallel pass that fills it, and large ones
/// use transparent huge pages as in assign_large. Large ones (>= 4 MiB, on
/// Linux) are mapped directly, so freeing one returns its memory to the
/// system at once and leaves the allocator's thresholds alone (a large
/// block freed through malloc raises glibc's mmap threshold, and the
/// arrays allocated after it then stay in the heap).
template <class T>
class ScratchArray {
  static_assert(std::is_trivially_default_constructible_v<T> &&
                std::is_trivially_destructible_v<T>);

 public:
  ScratchArray() = default;
  ScratchArray(const ScratchArray&) = delete;
  ScratchArray& operator=(const ScratchArray&) = delete;
  ScratchArray(ScratchArray&& o) noexcept { swap(o); }
  ScratchArray& operator=(ScratchArray&& o) noexcept {
    ScratchArray tmp(std::move(o));
    swap(tmp);
    return *this;
  }
  ~ScratchArray() { release(); }

  void resize(std::size_t n) {
    if (n > capacity_) {
      release();
      allocate(n);
    }
    size_ = n;
  }
  std::size_t size() const { return size_; }
  /// Frees the storage.
  void release() {
#if defined(__linux__)
    if (mapped_) munmap(data_, capacity_ * sizeof(T));
#endif
    if (!mapped_) delete[] data_;
    data_ = nullptr;
    mapped_ = false;
    size_ = capacity_ = 0;
  }
  T* data() { return data_; }
  const T* data() const { return data_; }
  T& operator[](std::size_t i) {
    return data_[i];
  }
  const T& operator[](std::size_t i) const {
    return data_[i];
  }

 private:
  void swap(ScratchArray& o) noexcept {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
    std::swap(mapped_, o.mapped_);
  }
  void allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
#if defined(__linux__)
    constexpr std::size_t kHuge = std::size_t(2) << 20;
    if (bytes >= 2 * kHuge) {
      void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (p == MAP_FAILED) throw std::bad_alloc();
#if defined(MADV_HUGEPAGE)
      const auto begin = reinterpret_cast<std::uintptr_t>(p);
      const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
      const std::uintptr_t last = (begin + bytes) & ~(kHuge - 1);
      if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#endif
      data_ = static_cast<T*>(p);
      mapped_ = true;
      capacity_ = n;
      return;
    }
#endif
    data_ = new T[n];
    capacity_ = n;
  }

  T* data_ = nullptr;
  std::size_t size_ = 0, capacity_ = 0;
  bool mapped_ = false;
};

/// A face is degenerate when twice its area is below this fraction of its
/// longest squared edge (the sine of its largest angle is ~1e-12 or less),
/// or when it has a repeated vertex.
constexpr double kDegenerateSine = 1e-12;

/// Everything a per-face pass needs about one triangle's shape.
struct TriangleShape {
  Vec3 p[3];
  Vec3 e[3];     ///< e[k] = p[k+2] - p[k+1]
  double l2[3];  ///< |e[k]|^2
  Vec3 cross;    ///< e[2] x (-e[1]) = (p1 - p0) x (p2 - p0); |cross| = 2A
  double twice_area;
  bool degenerate;
};

inline TriangleShape triangle_shape(const TriangleMesh& mesh, const Face& f) {
  TriangleShape t;
  for (int k = 0; k < 3; ++k) t.p[k] = mesh.positions[f[k]];
  t.e[0] = t.p[2] - t.p[1];
  t.e[1] = t.p[0] - t.p[2];
  t.e[2] = t.p[1] - t.p[0];
  for (int k = 0; k < 3; ++k) t.l2[k] = t.e[k].squaredNorm();
  t.cross = t.e[2].cross(-t.e[1]);
  t.twice_area = t.cross.norm();
  const double lmax = std::max({t.l2[0], t.l2[1], t.l2[2]});
  t.degenerate =
      f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || !(t.twice_area > kDegenerateSine * lmax);
  return t;
}

/// Corner areas of a triangle (sum = area); see MixedAreaScheme. Degenerate
/// triangles split their (tiny) area equally.
inline Vec3 corner_areas(const TriangleShape& t, MixedAreaScheme scheme) {
  const double area = 0.5 * t.twice_area;
  if (t.degenerate) return Vec3::Constant(area / 3.0);
  const double* l2 = t.l2;
  // a . b at corner k, from the edge vectors (accurate also for slivers,
  // unlike the law of cosines); < 0 iff corner k is obtuse.
  double dot[3];
  for (int k = 0; k < 3; ++k) dot[k] = -t.e[(k + 1) % 3].dot(t.e[(k + 2) % 3]);
  for (int k = 0; k < 3; ++k) {
    if (dot[k] >= 0.0) continue;
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    Vec3 c;
    if (scheme == MixedAreaScheme::meyer) {
      c[k] = 0.5 * area;
      c[k1] = c[k2] = 0.25 * area;
    } else {
      // Right triangle cut off at corner k1 by the bisector of edge (k, k1),
      // whose length^2 is l2[k2]: area = l^2 A / (4 a.b). Clamped so that
      // rounding on slivers can never give negative or non-finite areas.
      c[k1] = dot[k1] > 0.0 ? std::min(area, l2[k2] * area / (4.0 * dot[k1])) : 0.0;
      c[k2] = dot[k2] > 0.0 ? std::min(area - c[k1], l2[k1] * area / (4.0 * dot[k2])) : 0.0;
      c[k] = area - c[k1] - c[k2];
    }
    return c;
  }
  Vec3 c;
  if (scheme == MixedAreaScheme::meyer) {
    // cot at corner k = (a . b) / |a x b|.
    double cot[3];
    for (int k = 0; k < 3; ++k) cot[k] = dot[k] / t.twice_area;
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      c[k] = 0.125 * (l2[k2] * cot[k2] + l2[k1] * cot[k1]);
    }
  } else {
    // Circumcentre barycentric weights beta_k = l2[k] (l2[k+1] + l2[k+2] - l2[k])
    // = 2 l2[k] (a . b)_k, all >= 0 here.
    const double b0 = l2[0] * dot[0], b1 = l2[1] * dot[1], b2 = l2[2] * dot[2];
    const double s = 0.5 * area / (b0 + b1 + b2);
    c = Vec3(s * (b1 + b2), s * (b0 + b2), s * (b0 + b1));
  }
  return c;
}

/// Weight of the unit face normal in the vertex normal of each corner.
inline Vec3 normal_corner_weights(const TriangleShape& t, NormalWeighting weighting) {
  if (t.degenerate) return Vec3::Zero();
  switch (weighting) {
    case NormalWeighting::area:
      return Vec3::Constant(0.5 * t.twice_area);
    case NormalWeighting::angle: {
      Vec3 w;
      for (int k = 0; k < 3; ++k) {
        const double d = -t.e[(k + 1) % 3].dot(t.e[(k + 2) % 3]);
        w[k] = std::atan2(t.twice_area, d);
      }
      return w;
    }
    case NormalWeighting::max:
      break;
  }
  // Max (1999): cross product / (|e_a|^2 |e_b|^2) per corner.
  return Vec3(t.twice_area / (t.l2[1] * t.l2[2]), t.twice_area / (t.l2[2] * t.l2[0]),
              t.twice_area / (t.l2[0] * t.l2[1]));
}

/// Minimal rotation (about from x to) of a vector x tangent to the plane with
/// unit normal `from` into the plane with unit normal `to`. Exact for x
/// perpendicular to `from`; when the normals are (nearly) opposite the
/// rotation is undefined and x is projected onto the new plane instead.
inline Vec3 rotate_tangent(const Vec3& x, const Vec3& from, const Vec3& to) {
  const double c = from.dot(to);
  if (c > -1.0 + 1e-12) return x - (to.dot(x) / (1.0 + c)) * (from + to);
  return x - to.dot(x) * to;
}

}  // namespace fabrica::detail
