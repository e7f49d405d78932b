#include "host/diagnosis/output_bits.h"

#include <cmath>

namespace imuforge::diagnosis {

void OutputBitCounter::add_mask(Planes& p, std::uint64_t m) {
  for (int k = 0; k < kPlanes && m != 0; ++k) {
    const std::uint64_t carry = p[static_cast<std::size_t>(k)] & m;
    p[static_cast<std::size_t>(k)] ^= m;
    m = carry;
  }
}

long long OutputBitCounter::plane_count(const Planes& p, int b) {
  long long n = 0;
  for (int k = 0; k < kPlanes; ++k) n |= static_cast<long long>((p[static_cast<std::size_t>(k)] >> b) & 1u) << k;
  return n;
}

void OutputBitCounter::flush() {
  for (int b = 0; b < 64; ++b) {
    toggles_[static_cast<std::size_t>(b)] += plane_count(tog_planes_, b);
    near_toggles_[static_cast<std::size_t>(b)] += plane_count(near_planes_, b);
  }
  tog_planes_ = {};
  near_planes_ = {};
  pending_ = 0;
}

long long OutputBitCounter::toggles(int b) const { return toggles_[static_cast<std::size_t>(b)] + plane_count(tog_planes_, b); }
long long OutputBitCounter::near_toggles(int b) const {
  return near_toggles_[static_cast<std::size_t>(b)] + plane_count(near_planes_, b);
}

void OutputBitCounter::add(double y) {
  if (!(step_ > 0) || !std::isfinite(y)) return;
  const double x = y * inv_step_;  // within an ulp of y / step: the lattice test below allows 1e-3
  if (!(std::fabs(x) < 4.5e15)) return;  // beyond a double's whole numbers
  const double r = std::nearbyint(x);
  if (std::fabs(x - r) > 1e-3) return;
  const auto code = static_cast<std::int64_t>(r);
  ones_ |= static_cast<std::uint64_t>(code);
  if (rows_ > 0) {
    const std::uint64_t changed = static_cast<std::uint64_t>(code) ^ static_cast<std::uint64_t>(prev_);
    if (changed != 0) {
      const std::int64_t d = code - prev_;
      const std::uint64_t ad = static_cast<std::uint64_t>(d < 0 ? -d : d);
      // The bits b < 63 with |Δ| < 2^b: b ≥ 64 − clz(|Δ|) (|Δ| > 0 where a bit changed).
      const int lo = 64 - __builtin_clzll(ad);
      const std::uint64_t near = lo >= 63 ? 0 : changed & (~std::uint64_t{0} << lo) & ~(std::uint64_t{1} << 63);
      add_mask(tog_planes_, changed);
      add_mask(near_planes_, near);
      if (++pending_ == kFlushRows) flush();
    }
  }
  prev_ = code;
  ++rows_;
}

StuckBits OutputBitCounter::finish() const {
  StuckBits out;
  out.step = step_;
  out.rows = rows_;
  if (!(step_ > 0)) return out;
  // The lowest bit that changes: the ones under it are the word's, not stuck (an output coarser than its step).
  int lowest = -1;
  for (int b = 0; b < 64 && lowest < 0; ++b)
    if (toggles(b) >= kMinToggles) lowest = b;
  if (lowest < 0) return out;
  for (int b = lowest + 1; b < 62; ++b) {
    if (toggles(b) != 0 || near_toggles(b + 1) < kMinToggles) continue;
    out.mask |= std::uint64_t{1} << b;
    if (out.bit < 0) {
      out.bit = b;
      out.high = (ones_ >> b) & 1u;
      out.below_toggles = toggles(b - 1);
      out.above_toggles = near_toggles(b + 1);
    }
  }
  return out;
}

}  // namespace imuforge::diagnosis
