// Private to fabrica::lines: what the per-view AVX2 passes share. The build
// is portable (x86-64 baseline): each AVX2 pass is a function compiled for
// AVX2 (target attribute) and called only when the CPU has it
// (cpu_has_avx2). The passes use the same IEEE operations in the same order
// as the portable code (no fused multiply-adds: target("avx2") does not
// enable FMA), so they give the same bits.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(FABRICA_NO_MULTIVERSION)
#include <immintrin.h>

#include <atomic>
#include <cstdlib>
#include <cstring>

#include "fabrica/core/camera.hpp"
#define FABRICA_LINES_AVX2 1
// The AVX-512 kernels (zero_crossing_avx512.cpp): compiled for these
// extensions by target attributes, called only when cpu_has_avx512().
#define FABRICA_LINES_AVX512 1
#define FABRICA_AVX512_ISA "avx512f,avx512vl,avx512dq,avx512bw"

namespace fabrica::detail {

/// The widest SIMD passes the environment allows: FABRICA_LINES_SIMD=portable
/// (none), avx2 (no AVX-512) or avx512; unset or anything else: no cap
/// (A/B timings of one binary; the CPU still decides what it has).
inline int lines_simd_cap() {
  const char* s = std::getenv("FABRICA_LINES_SIMD");
  if (s && std::strcmp(s, "portable") == 0) return 0;
  if (s && std::strcmp(s, "avx2") == 0) return 1;
  return 2;
}

/// Whether the AVX2 passes run: whether the CPU has AVX2, unless set to
/// false (tests compare the AVX2 passes with the portable ones this way).
inline std::atomic<bool>& avx2_enabled() {
  static std::atomic<bool> on{__builtin_cpu_supports("avx2") != 0 && lines_simd_cap() >= 1};
  return on;
}
inline bool cpu_has_avx2() {
  return avx2_enabled().load(std::memory_order_relaxed);
}

/// Whether the AVX-512 kernels run (with the AVX2 passes: cpu_has_avx512()
/// needs both): whether the CPU has AVX-512 F, VL, DQ and BW (libgcc's
/// check includes the OS's saving of the zmm and mask state, XCR0), unless
/// set to false (tests compare them with the AVX2 and portable ones).
inline std::atomic<bool>& avx512_enabled() {
  static std::atomic<bool> on{__builtin_cpu_supports("avx512f") != 0 &&
                              __builtin_cpu_supports("avx512vl") != 0 &&
                              __builtin_cpu_supports("avx512dq") != 0 &&
                              __builtin_cpu_supports("avx512bw") != 0 && lines_simd_cap() >= 2};
  return on;
}
inline bool cpu_has_avx512() {
  return avx512_enabled().load(std::memory_order_relaxed) && cpu_has_avx2();
}

/// Eigen's Vec3 dot, (x x' + y y') + z z', for four vertices.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d dot4(__m256d ax, __m256d ay, __m256d az,
                                                                __m256d bx, __m256d by,
                                                                __m256d bz) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ax, bx), _mm256_mul_pd(ay, by)),
                       _mm256_mul_pd(az, bz));
}

/// mask ? x : y per lane.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d pick4(__m256d mask, __m256d x,
                                                                 __m256d y) {
  return _mm256_blendv_pd(y, x, mask);
}

/// Camera::view_vector for four positions (x, y, z): (eye - p).normalized()
/// for a perspective camera (unchanged where |eye - p| = 0), else `view`.
struct ViewVector4 {
  bool perspective;
  double eye[3], view[3];
  explicit ViewVector4(const Camera& c) : perspective(c.projection == Projection::perspective) {
    const Vec3 v = c.view_vector(Vec3::Zero());
    for (int k = 0; k < 3; ++k) {
      eye[k] = c.eye[k];
      view[k] = v[k];
    }
  }
  [[gnu::target("avx2"), gnu::always_inline]] inline void operator()(__m256d px, __m256d py,
                                                                     __m256d pz, __m256d& vx,
                                                                     __m256d& vy,
                                                                     __m256d& vz) const {
    if (!perspective) {
      vx = _mm256_set1_pd(view[0]);
      vy = _mm256_set1_pd(view[1]);
      vz = _mm256_set1_pd(view[2]);
      return;
    }
    const __m256d dx = _mm256_sub_pd(_mm256_set1_pd(eye[0]), px);
    const __m256d dy = _mm256_sub_pd(_mm256_set1_pd(eye[1]), py);
    const __m256d dz = _mm256_sub_pd(_mm256_set1_pd(eye[2]), pz);
    const __m256d z = dot4(dx, dy, dz, dx, dy, dz);
    const __m256d sz = _mm256_sqrt_pd(z);
    const __m256d ok = _mm256_cmp_pd(z, _mm256_setzero_pd(), _CMP_GT_OQ);
    vx = pick4(ok, _mm256_div_pd(dx, sz), dx);
    vy = pick4(ok, _mm256_div_pd(dy, sz), dy);
    vz = pick4(ok, _mm256_div_pd(dz, sz), dz);
  }
};

/// `value` in the lanes where `mask` is set, 0 elsewhere (64-bit lanes).
[[gnu::target("avx2"), gnu::always_inline]] inline __m256i mask_bits4(__m256d mask, int value) {
  return _mm256_and_si256(_mm256_castpd_si256(mask), _mm256_set1_epi64x(value));
}

/// Four AoS Vec3 (x y z x y z ...) as three vectors of x, y and z.
[[gnu::target("avx2"), gnu::always_inline]] inline void load_vec3x4(const double* p, __m256d& x,
                                                                    __m256d& y, __m256d& z) {
  x = _mm256_set_pd(p[9], p[6], p[3], p[0]);
  y = _mm256_set_pd(p[10], p[7], p[4], p[1]);
  z = _mm256_set_pd(p[11], p[8], p[5], p[2]);
}

}  // namespace fabrica::detail
#endif
