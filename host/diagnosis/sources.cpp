#include <limits>
#include "host/diagnosis/sources.h"

#include <Eigen/Dense>
#include <algorithm>
#include <deque>
#include <set>

#include "host/diagnosis/step_lag.h"
#include "host/poses/gravity_fit.h"
#include <cmath>

namespace imuforge::diagnosis {

LogSource::LogSource(const std::string& path) : r_(path) {
  const auto& m = r_.meta();
  if (!(m.accel_lsb_mps2 > 0) || !(m.gyro_lsb_rad_s > 0))
    throw DiagnosisError(path + ": metadata lacks a positive accel/gyro LSB (accel_lsb, gyro_lsb)");
}

bool LogSource::next(Sample& s) {
  io::LogRow row;
  if (!r_.next(row)) return false;
  const auto& m = r_.meta();
  s.t_s = row.t_s;
  s.segment = row.segment;
  s.temp_C = row.temp_C;
  s.has_ref = row.has_ref;
  for (int k = 0; k < 3; ++k) {
    s.f[k] = row.f_ref[k];
    s.w[k] = row.w_ref[k];
    s.y[k] = row.raw[k] * m.accel_lsb_mps2;
    s.y[k + 3] = row.raw[k + 3] * m.gyro_lsb_rad_s;
    s.table_angle_rad[k] = k < m.table_axes ? row.table_angle_rad[k] : std::numeric_limits<double>::quiet_NaN();
    s.table_rate_rad_s[k] = k < m.table_axes ? row.table_rate_rad_s[k] : std::numeric_limits<double>::quiet_NaN();
  }
  return true;
}

bool PairedSource::next(Sample& s) {
  Sample q;
  const bool a = real_.next(s), b = sim_.next(q);
  if (a != b)
    throw DiagnosisError("--sim log and real log differ in length (one ends at row " + std::to_string(row_) + ")");
  if (!a) return false;
  ++row_;
  if (!s.has_ref && q.has_ref) {
    s.has_ref = true;
    for (int k = 0; k < 3; ++k) {
      s.f[k] = q.f[k];
      s.w[k] = q.w[k];
    }
    s.segment = q.segment;
  }
  if (!std::isfinite(s.temp_C)) s.temp_C = q.temp_C;
  return true;
}

ReferenceSegmentSource::ReferenceSegmentSource(SampleSource& inner) : inner_(inner) {
  struct Row {
    double f[3], w[3];
    long long row;  // row index in the log
    int segment;    // as logged
  };
  std::vector<int> cut_segment;  // the logged segment at each cut
  std::set<int> ids;
  std::deque<Row> win;  // the last rows of the current run of reference rows (at most 6)
  long long run_n = 0;  // rows in the current run
  long long done = 0;   // pairs (i, i+1) of the run already tested, i < done
  bool any_ref = false;
  // Tests the pair whose first row is run row i (in the window), with up to two rows on each side.
  auto test = [&](long long i) {
    const long long first = run_n - static_cast<long long>(win.size());  // run index of win.front()
    auto at = [&](long long j) -> const Row* {
      return j >= first && j < run_n ? &win[static_cast<std::size_t>(j - first)] : nullptr;
    };
    const Row* a = at(i);
    const Row* b = at(i + 1);
    if (!a || !b) return;
    if (!(reference_step(at(i - 1), *a, *b, at(i + 2)) || reference_kink(at(i - 2), at(i - 1), *a, *b, at(i + 2), at(i + 3))))
      return;
    // One change can flag two neighbouring row pairs (a step into a tumble: the step, then the slope it starts);
    // the first is where the new dwell begins, and a segment of one or two rows is no dwell.
    if (!cuts_.empty() && b->row - cuts_.back() <= 2) return;
    cuts_.push_back(b->row);
    cut_segment.push_back(b->segment);
  };
  auto flush = [&]() {
    for (; done + 1 < run_n; ++done) test(done);
    win.clear();
    run_n = done = 0;
  };
  inner_.rewind();
  Sample s;
  long long row = 0;
  std::vector<long long> bounds;  // rows where the logged segment changes
  int last = -2;
  for (; inner_.next(s); ++row) {
    if (s.segment >= 0 && ids.size() < 3) ids.insert(s.segment);
    max_id_ = std::max(max_id_, s.segment);
    if (s.segment != last) bounds.push_back(row);
    last = s.segment;
    if (!s.has_ref) {  // the diagnosis starts a new unit after rows without a reference itself
      flush();
      continue;
    }
    any_ref = true;
    Row r;
    for (int k = 0; k < 3; ++k) {
      r.f[k] = s.f[k];
      r.w[k] = s.w[k];
    }
    r.row = row;
    r.segment = s.segment;
    win.push_back(r);
    if (win.size() > 6) win.pop_front();
    ++run_n;
    // The pair (i, i+1) is tested once its two rows after b are in: i + 3 = newest.
    for (; done + 3 < run_n; ++done) test(done);
  }
  flush();
  logged_ = static_cast<int>(ids.size());
  derived_ = any_ref && logged_ < 3;
  if (!derived_) {
    // A cut within two rows of a logged boundary is that boundary (a sine's last row before its segment ends
    // bends the same change a row early on blindgen's logs), not a dwell of its own. Any other cut inside a
    // logged dwell (not a −1 stretch) splits it.
    std::size_t kept = 0;
    for (std::size_t i = 0; i < cuts_.size(); ++i) {
      const long long c = cuts_[i];
      const auto it = std::lower_bound(bounds.begin(), bounds.end(), c - 2);
      if (it != bounds.end() && *it <= c + 2) continue;
      cuts_[kept++] = c;
      split_ += cut_segment[i] >= 0 ? 1 : 0;
    }
    cuts_.resize(kept);
  }
  rewind();
}

void ReferenceSegmentSource::rewind() {
  inner_.rewind();
  row_ = 0;
  next_cut_ = 0;
  seg_ = 0;
  last_logged_ = -2;
  out_ = -1;
  new_id_ = max_id_ + 1;
}

bool ReferenceSegmentSource::next(Sample& s) {
  if (!inner_.next(s)) return false;
  bool cut = false;
  while (next_cut_ < cuts_.size() && cuts_[next_cut_] <= row_) {
    cut = cut || cuts_[next_cut_] == row_;
    ++next_cut_;
  }
  if (derived_) {
    seg_ += cut ? 1 : 0;
    s.segment = seg_;
  } else {
    const int logged = s.segment;
    if (logged != last_logged_) out_ = logged;
    else if (cut && logged >= 0) out_ = new_id_++;
    last_logged_ = logged;
    s.segment = logged >= 0 ? out_ : logged;
  }
  ++row_;
  return true;
}

ReferenceFreeSource::ReferenceFreeSource(SampleSource& inner, double g, const poses::DetectOptions& detect,
                                         double accel_lsb, double gyro_lsb, double rate_hz)
    : inner_(inner) {
  info_.gravity_mps2 = std::isfinite(g) && g > 0 ? g : 9.80665;
  // The shared reference-free front end (host/poses): the whole recording in memory, the one static-pose
  // detector, the one gravity-magnitude fit.
  poses::Recording rec;
  rec.gravity_mps2 = info_.gravity_mps2;
  rec.accel_lsb = accel_lsb;
  rec.gyro_lsb = gyro_lsb;
  inner_.rewind();
  Sample s;
  while (inner_.next(s)) {
    rec.t_s.push_back(s.t_s);
    rec.y.push_back({s.y[0], s.y[1], s.y[2], s.y[3], s.y[4], s.y[5]});
  }
  if (rec.t_s.size() < 3) throw DiagnosisError("reference-free: empty log");
  rec.rate_hz = rate_hz > 0 ? rate_hz : static_cast<double>(rec.t_s.size() - 1) / (rec.t_s.back() - rec.t_s.front());
  detection_ = poses::detect_poses(rec, detect);
  const auto& ps = detection_.poses;
  info_.poses = static_cast<int>(ps.size());
  info_.static_s = detection_.still_s;
  if (info_.poses < 1) throw DiagnosisError("reference-free: no static interval detected");
  sample_pose_.assign(rec.t_s.size(), -1);
  for (std::size_t k = 0; k < ps.size(); ++k)
    for (const auto& [b, e] : ps[k].parts)
      for (std::size_t i = b; i < e; ++i) sample_pose_[i] = static_cast<int>(k);
  // 9 parameters need clearly more poses than that; with 7..11 poses only bias and the three scales are
  // fitted (the off-diagonal terms stay 0); with fewer the raw directions are used as they are.
  const bool full = ps.size() >= 12, diag_only = !full && ps.size() >= 7;
  info_.calibrated_params = full ? 9 : diag_only ? 6 : 0;
  std::array<bool, 9> active{};
  for (int k = 0; k < 9; ++k) active[static_cast<std::size_t>(k)] = full || (diag_only && k < 6);
  poses::GravityFit fit;
  if (full) {
    // The same term selection as `imuforge solve --mode reference-free` (leave-poses-out CV over the
    // catalog's accelerometer terms), so one log gets one accelerometer answer from both commands.
    poses::TermSelection ts = poses::select_gravity_terms(ps, info_.gravity_mps2, active);
    fit = std::move(ts.fit);
    for (model::ParamId id : ts.added) info_.terms_added.push_back(model::param_info(id).name);
    info_.terms_note = ts.note;
    info_.calibrated_params += static_cast<int>(ts.added.size());
    info_.accel_rms_before = fit.rms_before;
    info_.accel_rms_after = fit.rms_after;
  } else if (diag_only) {
    fit = poses::fit_gravity(ps, info_.gravity_mps2, active);
    info_.terms_note = "not tried: fewer than 12 poses";
    info_.accel_rms_before = fit.rms_before;
    info_.accel_rms_after = fit.rms_after;
  } else {
    info_.accel_rms_before = info_.accel_rms_after =
        poses::gravity_rms(ps, info_.gravity_mps2, [](const Eigen::Vector3d& y) { return y; });
  }
  for (const auto& p : ps) {
    Eigen::Vector3d d = fit.apply(p.acc);
    d *= info_.gravity_mps2 / d.norm();
    dir_.push_back({d[0], d[1], d[2]});
  }
}

void ReferenceFreeSource::rewind() {
  inner_.rewind();
  row_ = 0;
}

bool ReferenceFreeSource::next(Sample& s) {
  if (!inner_.next(s)) return false;
  const std::size_t i = row_++;
  const int pose = i < sample_pose_.size() ? sample_pose_[i] : -1;
  if (pose < 0) {
    s.has_ref = false;
    s.segment = -1;
    return true;
  }
  s.has_ref = true;
  s.segment = pose;
  for (int k = 0; k < 3; ++k) {
    s.f[k] = dir_[static_cast<std::size_t>(pose)][static_cast<std::size_t>(k)];
    s.w[k] = 0.0;
  }
  return true;
}

}  // namespace imuforge::diagnosis
