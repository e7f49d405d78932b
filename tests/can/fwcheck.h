// Minimal check macros for the CAN firmware tests (host and qemu): no heap, no exceptions, no iostream.
// A failed CHECK prints file:line and the expression and counts a failure; FW_TEST_MAIN_END returns
// non-zero if any check failed, which ctest (host) and qemu semihosting (MCU) turn into a failed test.
#pragma once
#include <cstdio>

namespace fwcheck {
inline int& failures() {
  static int n = 0;
  return n;
}
inline int& checks() {
  static int n = 0;
  return n;
}
}  // namespace fwcheck

#define CHECK(expr)                                                              \
  do {                                                                           \
    ++fwcheck::checks();                                                         \
    if (!(expr)) {                                                               \
      ++fwcheck::failures();                                                     \
      std::printf("%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #expr);       \
    }                                                                            \
  } while (0)

#define CHECK_EQ(a, b)                                                                                  \
  do {                                                                                                  \
    ++fwcheck::checks();                                                                                \
    const long long va_ = static_cast<long long>(a), vb_ = static_cast<long long>(b);                   \
    if (va_ != vb_) {                                                                                   \
      ++fwcheck::failures();                                                                            \
      std::printf("%s:%d: CHECK_EQ failed: %s == %s (%lld vs %lld)\n", __FILE__, __LINE__, #a, #b, va_, vb_); \
    }                                                                                                   \
  } while (0)

#define FW_TEST_RESULT(name)                                                                     \
  (std::printf("%s: %d checks, %d failed\n", name, fwcheck::checks(), fwcheck::failures()),      \
   fwcheck::failures() == 0 ? 0 : 1)
