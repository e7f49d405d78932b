#include "host/diagnosis/dropouts.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "host/estimator/robust.h"

namespace imuforge::diagnosis {

DropoutFilterSource::DropoutFilterSource(SampleSource& inner, std::array<double, 2> lsb, bool enabled)
    : inner_(inner), lsb_(lsb), ahead_(static_cast<std::size_t>(kMaxRun) + 8) {
  searched_ = !enabled;  // off: nothing to search, every pass replays the log as it is
  trace_ = std::getenv("IMUFORGE_DIAG_TRACE") != nullptr;
  scratch_.reserve(kSteps);
}

void DropoutFilterSource::reset_search() {
  ax_ = {};
  ahead_head_ = ahead_n_ = 0;
  rows_read_ = emitted_ = 0;
  inner_done_ = false;
  fixes_.clear();
  summary_ = {};
}

bool DropoutFilterSource::is_failed_word(int a, double y) const {
  const double lsb = lsb_[static_cast<std::size_t>(a / 3)];
  return y == 0.0 || (lsb > 0 && y == -lsb);
}

long long DropoutFilterSource::blocked_from() const {
  long long b = rows_read_;
  for (const Axis& x : ax_)
    if (x.run_start >= 0) b = std::min(b, x.run_start);
  return b;
}

void DropoutFilterSource::close_run(int a, bool at_end) {
  Axis& x = ax_[static_cast<std::size_t>(a)];
  bool drop = !at_end && x.n_before == 2 && x.n_after == 2 && x.quantum > 0 && x.n_steps >= kSteps;
  double z = 0, evidence = 0;
  if (drop) {
    const double d[4] = {x.before[0] - x.v, x.before[1] - x.v, x.after[0] - x.v, x.after[1] - x.v};
    const bool above = d[0] > 0 && d[1] > 0 && d[2] > 0 && d[3] > 0, below = d[0] < 0 && d[1] < 0 && d[2] < 0 && d[3] < 0;
    const double m = std::min(std::min(std::fabs(d[0]), std::fabs(d[1])), std::min(std::fabs(d[2]), std::fabs(d[3])));
    scratch_.assign(x.steps.begin(), x.steps.end());
    const double sigma_step = estimator::robust_sigma_of_magnitudes(scratch_);
    const double sigma_row =
        std::max({sigma_step / std::sqrt(2.0), std::fabs(x.before[1] - x.before[0]) / std::sqrt(2.0),
                  std::fabs(x.after[1] - x.after[0]) / std::sqrt(2.0), 2.0 * x.quantum});
    z = m / sigma_row;
    const double len = static_cast<double>(x.run_end - x.run_start + 1);
    evidence = len * (0.5 * z * z + 0.5 * std::log(2.0 * M_PI) + std::log(sigma_row / x.quantum));
    drop = (above || below) && z >= kMinZ && evidence >= kEvidence;
  }
  if (drop) {
    const long long len = x.run_end - x.run_start + 1;
    for (long long r = x.run_start; r <= x.run_end; ++r) {
      const double frac = static_cast<double>(r - x.run_start + 1) / static_cast<double>(len + 1);
      const double value = x.before[1] + frac * (x.after[0] - x.before[1]);
      ahead_row(r).y[a] = value;
      fixes_.push(r, a, value);
    }
    DropoutSummary& S = summary_[static_cast<std::size_t>(a)];
    const double t = ahead_row(x.run_start).t_s;
    if (S.runs == 0) {
      S.first_t_s = t;
      S.value = x.v;
      S.min_z = z;
    }
    if (x.v != S.value) {
      ++S.other_runs;
      S.other_value = x.v;
    }
    S.last_t_s = t;
    S.min_z = std::min(S.min_z, z);
    ++S.runs;
    S.rows += len;
    S.longest = std::max(S.longest, static_cast<int>(len));
    if (S.t_s.size() < DropoutSummary::kListed) S.t_s.push_back(t);
    if (trace_)
      std::fprintf(stderr, "dropout %s: %lld rows from %.3f s read %.6g, neighbours %.6g %.6g | %.6g %.6g, %.1f sigma away, %.0f nats\n",
                   axis_name(a), len, t, x.v, x.before[0], x.before[1], x.after[0], x.after[1], z, evidence);
  }
  // The rows after the run are the next run's rows before.
  x.n_before = 0;
  const int n_after = x.n_after;
  x.run_start = x.run_end = -1;
  x.n_after = 0;
  for (int k = 0; k < n_after; ++k) push_before(x, x.after[k]);
}

void DropoutFilterSource::push_before(Axis& x, double y) {
  if (x.n_before > 0 && std::isfinite(y) && std::isfinite(x.before[1])) {
    x.steps[static_cast<std::size_t>(x.n_steps % kSteps)] = std::fabs(y - x.before[1]);
    ++x.n_steps;
  }
  x.before[0] = x.before[1];
  x.before[1] = y;
  x.n_before = std::min(2, x.n_before + 1);
}

void DropoutFilterSource::scan(long long row, Sample& s) {
  for (int a = 0; a < kNumAxes; ++a) {
    Axis& x = ax_[static_cast<std::size_t>(a)];
    const double y = s.y[a];
    if (x.have_last) {
      const double d = std::fabs(y - x.last);
      if (d > 0 && (x.quantum == 0 || d < x.quantum)) x.quantum = d;
    }
    x.last = y;
    x.have_last = true;
    if (x.run_start >= 0 && x.run_end < 0) {  // an open run
      if (y == x.v) {
        if (row - x.run_start + 1 > kMaxRun) {  // an outage, not a dropout: left alone while it lasts
          x.run_start = -1;
          x.n_before = 0;
          x.skip = true;
        }
        continue;
      }
      x.run_end = row - 1;
      x.after[0] = y;
      x.n_after = 1;
      continue;
    }
    if (x.run_end >= 0) {  // the second row after the run: judge it
      x.after[1] = y;
      x.n_after = 2;
      close_run(a, false);
      continue;
    }
    if (x.skip) {
      if (y == x.v) continue;
      x.skip = false;
    }
    if (x.n_before == 2 && is_failed_word(a, y)) {
      x.run_start = row;
      x.v = y;
      x.n_after = 0;
      continue;
    }
    push_before(x, y);
  }
}

void DropoutFilterSource::rewind() {
  inner_.rewind();
  fixes_.rewind();
  if (!searched_) reset_search();  // a pass left before the end: search again from the start
}

bool DropoutFilterSource::next(Sample& s) {
  if (searched_) {  // replay
    if (!inner_.next(s)) return false;
    fixes_.apply(s);
    return true;
  }
  // Search: read on while the oldest row read waits for an axis' open run to be judged.
  while (emitted_ >= blocked_from()) {
    if (inner_done_) {  // the end, and every row handed on
      fixes_.sort();
      searched_ = true;
      return false;
    }
    Sample in;
    if (!inner_.next(in)) {
      inner_done_ = true;
      for (int a = 0; a < kNumAxes; ++a)
        if (ax_[static_cast<std::size_t>(a)].run_start >= 0) close_run(a, true);
      continue;
    }
    // At most kMaxRun + 3 rows wait (a run past kMaxRun is let go), within the ring's kMaxRun + 8.
    ahead_[(ahead_head_ + ahead_n_) % ahead_.size()] = in;
    ++ahead_n_;
    scan(rows_read_, ahead_row(rows_read_));
    ++rows_read_;
  }
  s = ahead_[ahead_head_];
  ahead_head_ = (ahead_head_ + 1) % ahead_.size();
  --ahead_n_;
  ++emitted_;
  return true;
}

const std::array<DropoutSummary, kNumAxes>& DropoutFilterSource::summary() {
  if (!searched_) {
    if (emitted_ == 0 && ahead_n_ == 0) rewind();
    Sample s;
    while (next(s)) {
    }
  }
  return summary_;
}

}  // namespace imuforge::diagnosis
