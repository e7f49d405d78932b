#include "host/eol/settle.h"

#include <cmath>

namespace imuforge::eol {

void SlopeSettleDetector::add(double t_s, double value) {
  if (!std::isfinite(t_s) || !std::isfinite(value)) return;
  if (!have_t0_) {
    t0_ = t_s;
    have_t0_ = true;
  }
  double t = t_s - t0_;
  buf_.push_back({t, value});
  n_ += 1;
  st_ += t;
  sv_ += value;
  stt_ += t * t;
  stv_ += t * value;
  while (!buf_.empty() && buf_.back().t - buf_.front().t > window_s_) {
    const S& o = buf_.front();
    n_ -= 1;
    st_ -= o.t;
    sv_ -= o.v;
    stt_ -= o.t * o.t;
    stv_ -= o.t * o.v;
    buf_.pop_front();
  }
}

double SlopeSettleDetector::slope_per_s() const {
  if (buf_.size() < 2) return 0.0;
  // Recomputed from the buffer when the running sums may have lost precision is not needed here:
  // the times are relative to t0 and windows hold at most a few 10^5 samples.
  double den = n_ * stt_ - st_ * st_;
  if (!(std::fabs(den) > 0)) return 0.0;
  return (n_ * stv_ - st_ * sv_) / den;
}

double SlopeSettleDetector::mean() const { return buf_.empty() ? NAN : sv_ / n_; }

bool SlopeSettleDetector::settled() const {
  return buf_.size() >= 3 && span_s() >= 0.95 * window_s_ && std::fabs(slope_per_s()) <= max_slope_;
}

void SlopeSettleDetector::reset() {
  buf_.clear();
  have_t0_ = false;
  n_ = st_ = sv_ = stt_ = stv_ = 0;
}

}  // namespace imuforge::eol
