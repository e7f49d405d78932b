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
// Cost: O(1) per row and axis (an exclusive or, and a count per bit that changed); memory O(64).
#pragma once

#include <array>
#include <cstdint>

#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

class OutputBitCounter {
 public:
  static constexpr long long kMinToggles = 50;
  // step: the output's step (SI); ≤ 0 counts nothing (a continuous output).
  explicit OutputBitCounter(double step = 0) : step_(step) {}
  // One row's output, in time order. A value that is not a whole number of steps (within 1e-3 of one; a glitch's
  // fix, a non-finite value) is skipped. O(bits changed).
  void add(double y);
  // What the rows show. O(64).
  StuckBits finish() const;

 private:
  double step_;
  long long rows_ = 0;
  std::int64_t prev_ = 0;
  std::uint64_t ones_ = 0;                 // bits that were 1 in some row
  std::array<long long, 64> toggles_{};     // bit b changed between neighbouring rows
  std::array<long long, 64> near_toggles_{};  // ... with |Δ| < 2^b
};

}  // namespace imuforge::diagnosis
