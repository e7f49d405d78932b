// Sample sources for the diagnosis: a log file (CSV or binary, host/io/log.h), a real log whose missing
// references come from a simulation of the same campaign, and the reference-free wrapper for hand-held
// recordings (static poses of unknown orientation).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "host/diagnosis/diagnose.h"
#include "host/io/log.h"
#include "host/poses/detect.h"

namespace imuforge::diagnosis {

// Reads a log v1; outputs are raw counts × the LSBs of the metadata. Throws io::LogError / DiagnosisError.
class LogSource : public SampleSource {
 public:
  explicit LogSource(const std::string& path);
  void rewind() override { r_.rewind(); }
  bool next(Sample& s) override;
  const io::LogMeta& meta() const { return r_.meta(); }

 private:
  io::LogReader r_;
};

// Real samples with the reference, segment and temperature taken from a simulation log of the same
// campaign when the real row has none (rows are paired in order; a length mismatch is an error).
class PairedSource : public SampleSource {
 public:
  PairedSource(SampleSource& real, SampleSource& sim) : real_(real), sim_(sim) {}
  void rewind() override { real_.rewind(); sim_.rewind(); row_ = 0; }
  bool next(Sample& s) override;

 private:
  SampleSource& real_;
  SampleSource& sim_;
  long long row_ = 0;
};

// Segments from the reference where the log's schedule is missing or coarse. The diagnosis withholds whole
// segments, so a log whose segment column carries no schedule (every row −1, what the format writes when none
// is known, or fewer than three distinct dwell indices) could not be scored at all ("too short to tell"), and
// one whose segments are coarser than its dwells (a generator numbering plateaus, or a whole tumble as one
// segment) withholds far fewer, larger pieces than it holds dwells. Cuts are where the reference itself ends a
// dwell: at each step or kink of the reference (step_lag.h, the criteria the timing path uses for an
// instantaneous pose or rate change and for a table starting or stopping its acceleration).
//   * no schedule: segments numbered from 0 at those cuts (derived());
//   * a schedule: a segment that holds a cut after its first row continues under a new number (above every
//     logged one) from that row on (split_segments() counts them); rows at −1 (the table moving) stay −1.
// On logs whose segments already end at every step (blindgen's, imuforge simulate's) nothing changes. Rows without
// a reference and gaps in time start a new unit in the diagnosis already.
// Cost: one streaming pass at construction (six rows held), then O(1) per row. Memory: one index per cut, and
// during construction one per logged segment boundary.
class ReferenceSegmentSource : public SampleSource {
 public:
  explicit ReferenceSegmentSource(SampleSource& inner);
  void rewind() override;
  bool next(Sample& s) override;
  bool derived() const { return derived_; }
  bool changes() const { return derived_ || split_ > 0; }
  int logged_segments() const { return logged_; }  // distinct dwell indices ≥ 0 in the log (counted up to 3)
  int derived_segments() const { return derived_ ? static_cast<int>(cuts_.size()) + 1 : 0; }
  int split_segments() const { return split_; }    // logged segments split at a step or kink within them

 private:
  SampleSource& inner_;
  bool derived_ = false;
  int logged_ = 0, max_id_ = -1, split_ = 0;
  std::vector<long long> cuts_;  // rows that start a new dwell (ascending)
  // replay state
  long long row_ = 0;
  std::size_t next_cut_ = 0;
  int seg_ = 0, last_logged_ = -2, out_ = -1, new_id_ = 0;
};

// Reference-free mode (Tedaldi et al., ICRA 2014 style), on the shared front end of host/poses: the one
// static-pose detector (the poses `imuforge solve --mode reference-free` finds), and the one
// gravity-magnitude fit of the accelerometer on the pose means (bias, 3 scales, 3 non-orthogonalities;
// lower-triangular gauge); each static sample then
// gets the pseudo-reference f = g·unit(calibrated pose mean), ω = 0, segment = pose index. Moving samples
// carry no reference. What this cannot see: any error along the pose direction orthogonal to |f|.
struct ReferenceFreeInfo {
  int poses = 0;
  int calibrated_params = 0;  // 9 + terms_added (≥12 poses), 6 (bias + scales, 7..11 poses) or 0 (raw directions)
  double static_s = 0;
  double gravity_mps2 = 9.80665;
  double accel_rms_before = 0, accel_rms_after = 0;  // RMS of |f| − g over pose means, raw vs calibrated
  // With ≥ 12 poses the fit is poses::select_gravity_terms's, as in `imuforge solve --mode reference-free`
  // (cal.json reference_free.term_selection): catalog terms added by leave-poses-out CV, and why it stopped.
  std::vector<std::string> terms_added;
  std::string terms_note;
};
class ReferenceFreeSource : public SampleSource {
 public:
  // lsb: one count of each triad in SI (0 = unknown), the detector's floor for quantised sensors;
  // rate_hz: the log's nominal rate (0 = from the timestamps), as `imuforge solve` takes it.
  ReferenceFreeSource(SampleSource& inner, double gravity_mps2, const poses::DetectOptions& detect = {},
                      double accel_lsb = 0, double gyro_lsb = 0, double rate_hz = 0);
  void rewind() override;
  bool next(Sample& s) override;
  const ReferenceFreeInfo& info() const { return info_; }
  const poses::Detection& detection() const { return detection_; }

 private:
  SampleSource& inner_;
  ReferenceFreeInfo info_;
  poses::Detection detection_;
  std::size_t row_ = 0;
  std::vector<int> sample_pose_;            // pose index per sample, −1 = not in a pose
  std::vector<std::array<double, 3>> dir_;  // pseudo-reference per pose
};

}  // namespace imuforge::diagnosis
