// Isolated single-sample outliers ("glitches") in a log's outputs: a bit error on the bus or in the converter's
// output word sets one sample of one axis far off and leaves its neighbours alone. No catalog effect and no noise
// model of the diagnosis has that shape: spread over a block mean, a glitch of 100 σ moves it by a fifth of its σ
// at 500 samples, so the block-mean residual never names the axis, yet the glitches inflate the white noise and the
// Allan curve and pull whichever block holds them. The filter finds them in one streaming pass and replays the log
// with each replaced by the nearest of those lines; the diagnosis then runs on the replayed log and names an
// axis that held any (docs/diagnosis.md § 1, "Glitches").
//
// What counts as a glitch, per axis, at row i with neighbours i−3 … i+3 evenly spaced in time (no gap) and all
// carrying a reference (the rows the fit reads; a hand-held log's moving rows, where a knock is as sharp, carry none):
//   * y_i stands off each of four lines by more than the bar, on the same side of all four: the line through its
//     direct neighbours, through i−2 and i+2, and each side's two rows extrapolated to i. A line cancels from
//     each (a turning table's ramp), a kink (a rate starting or stopping, where a second difference alone is as
//     isolated as a glitch) lies on one side's extrapolation, a step on one side's line, and a row caught halfway
//     through a step (a pose changing within a sample period: 10 Hz logs of the simulator) between the two sides';
//   * the bar: z_threshold robust σ of the second difference y_i − (y_{i−1} + y_{i+1})/2, the σ being 1.4826 × its
//     median magnitude over the stretch of kStretchRows rows that holds i or over either half of the kLocalRows
//     rows about i, whichever is largest (the bar follows the noise where it changes: a turning table vibrates,
//     and a row where it starts has quiet rows on one side only), and at least 8 output quanta (the smallest
//     non-zero step between neighbouring rows in the stretch: a coarse output flickering by a count is not a
//     glitch);
//   * both direct neighbours, asked the same way, stand off by less than half the bar (one sample alone: a burst
//     over two or more rows is motion or noise and is left as it is).
// Not found: a glitch on the second or third row after a step (or the rows before it): the neighbour between it
// and the step has no line clear of both, so the glitch is not alone (and where the step's first row is caught on
// the way, that neighbour can be read as the glitch in its place); one on a step's first row pointing back across
// it by less than half the step; one within three rows of a gap or of the log's ends.
// Under Gaussian noise the second difference is Gaussian (σ √1.5 of a row's), so z_threshold = 12 puts the false
// alarm below 10^-30 per row; what limits it is the noise's own tails (a real table's vibration), which the local σ
// and the four lines keep out (the five recordings of docs/real-data.md: one, a knock within a static pose that
// jumps all six outputs for a sample).
//
// Cost: one streaming pass at construction, O(kStretchRows) per stretch and O(kLocalRows) per candidate for the
// medians (nth_element), memory O(kStretchRows) plus one entry per glitch; then O(1) per replayed row.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

class GlitchFilterSource : public SampleSource {
 public:
  static constexpr int kStretchRows = 1000;
  static constexpr long long kLocalRows = 51;
  // Reads inner once. z_threshold ≤ 0 turns the filter off (the log replays as it is).
  GlitchFilterSource(SampleSource& inner, double z_threshold);
  void rewind() override;
  bool next(Sample& s) override;
  const std::array<GlitchSummary, kNumAxes>& summary() const { return summary_; }
  long long total() const;

 private:
  struct Fix {
    long long row;
    int axis;
    double value;
  };
  SampleSource& inner_;
  std::vector<Fix> fixes_;  // ascending in (row, axis)
  std::array<GlitchSummary, kNumAxes> summary_{};
  long long row_ = 0;
  std::size_t next_fix_ = 0;
};

}  // namespace imuforge::diagnosis
