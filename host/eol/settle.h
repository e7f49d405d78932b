// Settling from data, not from fixed waits. The IMU temperature is settled when the least-squares slope
// of its last window_s of samples is below a threshold (and the window is full). O(1) per sample
// (running sums over a ring of samples), memory O(samples in one window).
#pragma once
#include <cstddef>
#include <deque>

namespace imuforge::eol {

class SlopeSettleDetector {
 public:
  SlopeSettleDetector(double window_s, double max_slope_per_s) : window_s_(window_s), max_slope_(max_slope_per_s) {}
  void add(double t_s, double value);
  // Least-squares slope (units per second) over the current window; 0 with fewer than 2 samples.
  double slope_per_s() const;
  double mean() const;
  double span_s() const { return buf_.size() < 2 ? 0.0 : buf_.back().t - buf_.front().t; }
  // Window full (span ≥ 95 % of window_s: sample timing jitter) and |slope| ≤ threshold.
  bool settled() const;
  void reset();

 private:
  struct S {
    double t, v;
  };
  double window_s_, max_slope_;
  std::deque<S> buf_;
  // Sums relative to t0_ (the first sample ever) so they stay well conditioned over hours.
  double t0_ = 0.0;
  bool have_t0_ = false;
  double n_ = 0, st_ = 0, sv_ = 0, stt_ = 0, stv_ = 0;
};

}  // namespace imuforge::eol
