// Dropouts: short runs of rows where one axis reads the word a failed read returns (0, or all bits set: −1 LSB)
// while the rows either side of the run stand far from it. A data register read while the converter rewrote it,
// an I²C or SPI transfer that returned a cleared or floating bus, a frame the logger filled with zeros: each leaves a
// few rows at exactly that value. No catalog effect and no noise has that shape. Spread over a block mean, a run
// of ten rows at 1 g moves a five-second mean by 0.2 m/s², so the fit takes the runs for steps between segments,
// and the noise model for drift (blindgen's `zero_burst`, written at stop 65: all three axes named on their held-out
// χ², "steps from segment to segment", with a Gauss-Markov drift of 34 ms the sensor does not have). The filter finds
// them in the first pass, bridges each with the line between its neighbours, and the diagnosis runs on the bridged
// log and names an axis that held any (docs/diagnosis.md § 1, "Dropouts").
//
// What counts as a dropout, per axis: a maximal run of 1 to kMaxRun rows reading exactly the failed word's value v
// (0; −LSB as well where the log's LSB is known), with two rows before it and two after it (i−2, i−1 and j+1, j+2)
// that all stand on the same side of v, at least kMinZ row σ away from it (z, the nearest of the four), and whose
// run a healthy output would read with a probability under e^−kEvidence. Under Gaussian noise of σ about a level z σ
// from v, a row reads exactly v with probability q/σ · φ(z) (q the output quantum, where σ > q), so the run's
// evidence is L · (z²/2 + ln √(2π) + ln(σ/q)) nats: a run of rows holding one exact value on a noisy axis is itself
// improbable, and a single row needs z ≥ 8.6. σ of a row is the robust σ of the step between neighbouring rows
// over the last kSteps rows outside runs (estimator::robust_sigma_of_magnitudes, over √2), at least the larger step within each
// pair of neighbours (over √2) and two output quanta (the smallest non-zero step between neighbouring rows so far);
// until kSteps steps and one quantum are seen nothing is judged. Two neighbouring pairs alone as the spread took a
// consumer accelerometer's 0.04 m/s² of noise reading 0 at 2.5 σ for a failed read 15 times in a 2.5 h log
// (`unseen14` ooc-temp_knee-0); a 3-row run at 4.7 σ on an axis 70 quanta noisy is 49 nats. An axis near
// v reads v often and honestly (a gyro at rest, a level accelerometer): its neighbours are not far, and nothing is
// found. A run that crosses v (a sine, a pose change through zero) has neighbours on both sides of it. A run longer
// than kMaxRun rows is an outage, not bridged (the log's gaps are the place to show one).
// A single row reading v far from its neighbours is a dropout too: this filter runs before the glitch filter
// (glitches.h), which would otherwise take it for a glitch of another value.
//
// Streaming: while a run is open on some axis its rows wait (at most kMaxRun + 2 rows); every other row is handed
// on as read. The first pass that reaches the end keeps what it found; every later pass replays the bridges. A
// rewind before the end starts the search again.
//
// Cost: O(1) per row and axis, and O(kSteps) per run judged; memory: kMaxRun + 3 samples, and one entry per bridged
// row.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "host/diagnosis/diagnose.h"
#include "host/diagnosis/row_fixes.h"

namespace imuforge::diagnosis {

class DropoutFilterSource : public SampleSource {
 public:
  static constexpr int kMaxRun = 256;   // rows
  static constexpr double kMinZ = 4.0;        // the neighbours' distance from v, in σ of a row
  static constexpr double kEvidence = 40.0;   // nats (a healthy output reads such a run with probability < 4e-18)
  static constexpr int kSteps = 32;     // the steps the spread is taken over
  // lsb: per sensor (accel, gyro), the log's output LSB in SI, ≤ 0 unknown (then only 0 is asked). enabled false: the
  // log replays as it is.
  DropoutFilterSource(SampleSource& inner, std::array<double, 2> lsb, bool enabled = true);
  void rewind() override;
  bool next(Sample& s) override;
  // What was found. Complete once a pass has reached the end; called before that, it reads the rest of the pass
  // (or a whole pass, if none has started) first.
  const std::array<DropoutSummary, kNumAxes>& summary();

 private:
  // One axis' search state. Row indices count from the pass's first row.
  struct Axis {
    double before[2] = {0, 0};     // the last two rows' values before the open run (before[1] the later)
    int n_before = 0;              // how many of them there are (0–2)
    long long run_start = -1;      // first row of the open run (−1: none)
    long long run_end = -1;        // its last row, once a row differing from v has ended it (−1: still open)
    double v = 0;                  // the value the run reads
    double after[2] = {0, 0};      // the rows after it
    int n_after = 0;
    bool skip = false;             // a run past kMaxRun: left alone until the value changes
    double quantum = 0;            // smallest non-zero step between neighbouring rows so far (0: none yet)
    double last = 0;               // the previous row's value
    bool have_last = false;
    std::array<double, kSteps> steps{};  // |Δy| of the last kSteps steps outside runs (a ring)
    int n_steps = 0;
  };

  void reset_search();
  void scan(long long row, Sample& s);     // one row read from inner, already in the look-ahead
  void push_before(Axis& x, double y);     // a row outside any run: the last two, and the step to it
  void close_run(int a, bool at_end);      // judge axis a's ended run (at_end: the log ended first)
  bool is_failed_word(int a, double y) const;
  long long blocked_from() const;          // the first row some axis still has to judge

  SampleSource& inner_;
  std::array<double, 2> lsb_;
  bool searched_ = false;
  bool trace_ = false;
  std::vector<double> scratch_;            // a run's steps, for their robust σ
  // The search (first pass).
  std::array<Axis, kNumAxes> ax_{};
  std::vector<Sample> ahead_;              // a ring of the rows read, not yet handed on: ahead_n_ from ahead_head_
  std::size_t ahead_head_ = 0, ahead_n_ = 0;
  long long rows_read_ = 0, emitted_ = 0;
  bool inner_done_ = false;
  Sample& ahead_row(long long row) { return ahead_[(ahead_head_ + static_cast<std::size_t>(row - emitted_)) % ahead_.size()]; }
  // The result, and the replay.
  RowFixes fixes_;  // ascending in (row, axis) once searched_
  std::array<DropoutSummary, kNumAxes> summary_{};
};

}  // namespace imuforge::diagnosis
