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
// Streaming: the filter finds glitches while it hands the log on, on the first pass its consumer makes (the
// diagnosis's pass 0), so it costs no read of its own. A row is handed on once every axis has judged it: rows wait
// in a look-ahead of about a stretch (kStretchRows + kLocalRows/2 rows with a reference), more where an axis' rows
// with a reference are sparse (a hand-held log's moving rows carry none). Past max_buffered_rows rows waiting, each
// axis judges the rows it holds at once, as at the log's end (so memory stays bounded on any log). Once a pass has
// reached the end, every later pass replays the fixes it found. A rewind before the end starts the search again.
//
// Cost: O(1) per row and axis for the four lines, O(kStretchRows) per stretch for its median (nth_element) and
// O(kLocalRows) per candidate; memory: the look-ahead (≤ max_buffered_rows samples) plus one entry per glitch; a
// replayed pass is O(1) per row.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "host/diagnosis/diagnose.h"
#include "host/diagnosis/row_fixes.h"

namespace imuforge::diagnosis {

class GlitchFilterSource : public SampleSource {
 public:
  static constexpr int kStretchRows = 1000;
  static constexpr long long kLocalRows = 51;
  static constexpr std::size_t kMaxBufferedRows = 1u << 17;  // 131072 samples waiting (≈ 20 MB)
  // Reads nothing until the first next(). z_threshold ≤ 0 turns the filter off (the log replays as it is).
  GlitchFilterSource(SampleSource& inner, double z_threshold, std::size_t max_buffered_rows = kMaxBufferedRows);
  void rewind() override;
  bool next(Sample& s) override;
  // What was found. Complete once a pass has reached the end; called before that, it reads the rest of the pass
  // (or a whole pass, if none has started) first.
  const std::array<GlitchSummary, kNumAxes>& summary();
  long long total();

 private:
  struct Row {
    long long row = 0;
    bool has_ref = false;
    double t_s = 0;
    double y[kNumAxes] = {};
  };
  // One centre row of a stretch: its residual against the four lines and its direct neighbours', and its fix.
  struct Entry {
    long long row;
    double t_s, d, e_prev, e_next, fix;
    double r1;  // against its direct neighbours alone: what σ is measured on (√1.5 σ under white noise; |d| ≤ |r1|)
  };
  static constexpr int kRing = 7;

  void reset_search();
  void scan(const Sample& s);        // one row read from inner: into the ring and each axis' stretch
  void judge(int a, bool all);       // judge axis a's stretch (all: every row it holds, as at the end)
  void finish_search();              // at the end of the first pass: the rest, sorted fixes, shared, medians
  long long ready_before() const;    // rows below this are judged on every axis

  SampleSource& inner_;
  double z_;
  std::size_t max_buffered_;
  bool searched_ = false;  // a pass reached the end: fixes_ and summary_ are complete, later passes replay
  // The search (first pass).
  Row ring_[kRing];
  int ring_head_ = 0, filled_ = 0;
  long long rows_read_ = 0;
  std::array<std::vector<Entry>, kNumAxes> stretch_;
  std::array<long long, kNumAxes> first_new_{};  // entries before this index were judged already
  std::array<double, kNumAxes> quantum_{};      // smallest non-zero step between neighbouring rows in the stretch
  std::array<double, kNumAxes> last_sigma_{};   // the previous stretch's σ, for a last stretch too short for its own
  std::array<std::vector<double>, kNumAxes> sizes_;  // every glitch's size in σ (for the median)
  std::vector<double> scratch_;
  // Read from inner, not yet handed on: a ring of ahead_n_ samples from ahead_head_, the first being row emitted_
  // (a ring, not a deque: a sample is larger than a deque block holds a few of, and the pass allocates nothing per
  // row once the ring has grown to the look-ahead).
  std::vector<Sample> ahead_;
  std::size_t ahead_head_ = 0, ahead_n_ = 0;
  Sample& ahead_at(std::size_t i) { return ahead_[(ahead_head_ + i) % ahead_.size()]; }
  void ahead_push(const Sample& s);
  // Each axis' last residuals (residual() of glitches.cpp) by their centre row: consecutive windows share two of
  // the three each needs, so one is computed per row and axis.
  std::array<long long, kNumAxes> res_row_{{-1, -1, -1, -1, -1, -1}};  // centre row of res_[a][2]; −1 none
  std::array<std::array<double, 3>, kNumAxes> res_{};  // centres res_row_ − 2, − 1, res_row_
  long long emitted_ = 0;
  bool inner_done_ = false;
  bool trace_ = false;
  // The result, and the replay.
  RowFixes fixes_;  // ascending in (row, axis) once searched_
  std::array<GlitchSummary, kNumAxes> summary_{};
};

}  // namespace imuforge::diagnosis
