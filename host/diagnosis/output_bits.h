// Stuck bits of an output word (DiagnosisResult::stuck_bits, docs/diagnosis.md § 1, "Stuck bits"), from the codes
// y / step of a quantised output, counted in one streaming pass.
//
// Why a healthy output cannot show one. Between two neighbouring rows the code moves by Δ. Bit b+1 changes where the
// codes straddle a multiple B of 2^(b+1); if it changes with |Δ| < 2^(b+1) and bit b does not, both codes have bit b
// equal, which with one below B and one at or above it means bit b = 0 on both (x < B − 2^b, y ≥ B: Δ > 2^b). Such
// steps, between 2^b and 2^(b+1), cross multiples of 2^b on the way and change bit b nearly every time. So a bit that
// never changes over a log whose bit above it changes across neighbouring codes (|Δ| < 2^(b+1)) kMinToggles times
// or more is not the output's: it is stuck. Bits under the lowest that changes (a left-justified converter's word,
// an output coarser than its LSB) are not asked, nor bits over the codes' range (the bit above never changes across
// neighbouring codes there), nor a log whose codes sit in clusters far apart (a pose change is not a neighbouring
// code). A stuck bit b makes the codes either side of it 2^b + 1 apart, under 2^(b+1): the bit above changes across
// them wherever the noise carries the output past a multiple of 2^(b+1).
//
// Cost: O(1) per row and axis: the bits that changed and those that changed across a neighbouring code are two masks,
// each added to a bit-sliced counter (16 planes of 64 one-bit counters: a ripple carry, about two planes per add;
// flushed into the per-bit counts every 65535 rows). Counting each changed bit in a loop cost 6 % of
// diagnosis_bench at stop 64, most of it in the first pass; memory O(64).
#pragma once

#include <array>
#include <cstdint>

#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

class OutputBitCounter {
 public:
  static constexpr long long kMinToggles = 50;
  // step: the output's step (SI); ≤ 0 counts nothing (a continuous output).
  explicit OutputBitCounter(double step = 0) : step_(step), inv_step_(step > 0 ? 1.0 / step : 0.0) {}
  // One row's output, in time order. A value that is not a whole number of steps (within 1e-3 of one; a glitch's
  // fix, a non-finite value) is skipped. O(1) (a ripple carry through at most 16 planes, about two on average).
  void add(double y);
  // What the rows show. O(64 · 16).
  StuckBits finish() const;
  // How often bit b changed between neighbouring rows so far, and how often across a neighbouring code (|Δ| < 2^b).
  // O(16).
  long long toggles(int b) const;
  long long near_toggles(int b) const;

 private:
  static constexpr int kPlanes = 16;
  static constexpr long long kFlushRows = (1LL << kPlanes) - 1;
  using Planes = std::array<std::uint64_t, kPlanes>;
  static void add_mask(Planes& p, std::uint64_t m);
  static long long plane_count(const Planes& p, int b);
  void flush();

  double step_;
  double inv_step_;
  long long rows_ = 0;
  long long pending_ = 0;                  // masks added to the planes since the last flush
  Planes tog_planes_{}, near_planes_{};
  std::int64_t prev_ = 0;
  std::uint64_t ones_ = 0;                 // bits that were 1 in some row
  std::array<long long, 64> toggles_{};     // bit b changed between neighbouring rows
  std::array<long long, 64> near_toggles_{};  // ... with |Δ| < 2^b
};

}  // namespace imuforge::diagnosis
