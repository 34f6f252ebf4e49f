// Whether the tests run under the sanitizers, for the few tests that bound
// wall-clock time or peak memory.
#pragma once

namespace fabrica::test {

/// Whether this build runs under AddressSanitizer (build-asan/,
/// scripts/sanitize-test): code is several times slower there and freed
/// memory is held in a quarantine, so wall-clock and peak-memory bounds are
/// scaled or skipped (docs/reliability.md, "Sanitizers").
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif
/// Factor for wall-clock bounds in tests: 1, or 10 under the sanitizers
/// (ASan + UBSan at -O1 run the readers 3-6x slower, on a loaded CI machine).
inline constexpr double kTimeScale = kSanitized ? 10.0 : 1.0;

}  // namespace fabrica::test
