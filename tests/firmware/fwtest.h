// Tiny test harness for firmware unit tests: the same program runs on the host and under
// qemu-system-arm with semihosting. No heap use of its own, no exceptions, no iostream; printf only.
//
//   int main() { FW_RUN(test_a); FW_RUN(test_b); return fwtest::summary("crc32"); }
//   static void test_a() { FW_EXPECT(x == 1); FW_EXPECT_EQ_INT(rc, -106); FW_EXPECT_NEAR(a, b, 1e-6); }
//
// Exit code 0 iff every expectation held.
#pragma once
#include <cstdint>
#include <cstdio>

namespace fwtest {

struct State {
  long checks = 0;
  long failures = 0;
};
inline State& state() {
  static State s;
  return s;
}
inline void fail(const char* file, int line, const char* what) {
  ++state().failures;
  if (state().failures <= 50) std::printf("FAIL %s:%d: %s\n", file, line, what);
}
inline int summary(const char* suite) {
  std::printf("%s: %ld checks, %ld failures\n", suite, state().checks, state().failures);
  return state().failures == 0 ? 0 : 1;
}

// Deterministic PRNG (xorshift64*), identical on every target, so a failing case reproduces.
struct Rng {
  std::uint64_t s;
  explicit Rng(std::uint64_t seed) : s(seed ? seed : 0x9E3779B97F4A7C15ull) {}
  std::uint64_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return s * 0x2545F4914F6CDD1Dull;
  }
  // Uniform in [lo, hi].
  double uniform(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);
  }
  std::int32_t range_i32(std::int32_t lo, std::int32_t hi) {
    const std::uint64_t span = static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - lo) + 1u;
    return static_cast<std::int32_t>(lo + static_cast<std::int64_t>(next() % span));
  }
};

}  // namespace fwtest

#define FW_EXPECT(cond)                                   \
  do {                                                    \
    ++fwtest::state().checks;                             \
    if (!(cond)) fwtest::fail(__FILE__, __LINE__, #cond); \
  } while (0)

#define FW_EXPECT_EQ_INT(a, b)                                                                   \
  do {                                                                                           \
    ++fwtest::state().checks;                                                                    \
    const long long fw_a_ = static_cast<long long>(a), fw_b_ = static_cast<long long>(b);        \
    if (fw_a_ != fw_b_) {                                                                        \
      std::printf("  %s = %lld, %s = %lld\n", #a, fw_a_, #b, fw_b_);                             \
      fwtest::fail(__FILE__, __LINE__, #a " == " #b);                                            \
    }                                                                                            \
  } while (0)

#define FW_RUN(fn)                       \
  do {                                   \
    const long fw_f0_ = fwtest::state().failures; \
    fn();                                \
    std::printf("[%s] %s\n", fwtest::state().failures == fw_f0_ ? " ok " : "FAIL", #fn); \
  } while (0)
