#include "host/diagnosis/output_bits.h"

#include <cmath>

namespace imuforge::diagnosis {

void OutputBitCounter::add(double y) {
  if (!(step_ > 0) || !std::isfinite(y)) return;
  const double x = y / step_;
  if (!(std::fabs(x) < 4.5e15)) return;  // beyond a double's whole numbers
  const double r = std::nearbyint(x);
  if (std::fabs(x - r) > 1e-3) return;
  const auto code = static_cast<std::int64_t>(r);
  ones_ |= static_cast<std::uint64_t>(code);
  if (rows_ > 0) {
    std::uint64_t changed = static_cast<std::uint64_t>(code) ^ static_cast<std::uint64_t>(prev_);
    const std::int64_t d = code - prev_;
    const std::uint64_t ad = static_cast<std::uint64_t>(d < 0 ? -d : d);
    while (changed) {
      const int b = __builtin_ctzll(changed);
      ++toggles_[static_cast<std::size_t>(b)];
      if (b < 63 && ad < (std::uint64_t{1} << b)) ++near_toggles_[static_cast<std::size_t>(b)];
      changed &= changed - 1;
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
    if (toggles_[static_cast<std::size_t>(b)] >= kMinToggles) lowest = b;
  if (lowest < 0) return out;
  for (int b = lowest + 1; b < 62; ++b) {
    const auto ub = static_cast<std::size_t>(b);
    if (toggles_[ub] != 0 || near_toggles_[ub + 1] < kMinToggles) continue;
    out.mask |= std::uint64_t{1} << b;
    if (out.bit < 0) {
      out.bit = b;
      out.high = (ones_ >> b) & 1u;
      out.below_toggles = toggles_[ub - 1];
      out.above_toggles = near_toggles_[ub + 1];
    }
  }
  return out;
}

}  // namespace imuforge::diagnosis
