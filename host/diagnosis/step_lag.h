// Instantaneous steps of the reference and what they say about a sensor's timing (docs/diagnosis.md
// § timing, "Steps" and "Lag probe at steps"): the step criterion shared by the reference re-evaluation
// (diagnose.cpp, ShiftedReference) and the probe, and the probe itself; and, where the reference has no step,
// the lag probe on the motion (motion_lag.cpp, "Lag probe on the motion").
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

// A step in the reference between rows a and b (p before a, n after b; null at the ends of the data): the
// change between a and b exceeds the change between the neighbouring rows by more than any real table could
// add in one row interval (0.5 m/s², 0.2 rad/s), or it is a tenth of that and ten times the neighbouring
// changes (a smooth motion changes by about as much from one row to the next: ratio ≈ 1, while a
// discontinuity stands alone; a 0.1 rad/s rate step read a few samples late by a drifting clock is an offset of
// ~1e-3 rad/s on a 4 s segment). The test is on the second difference, not on the change alone: a step into
// or out of a motion (a tumble or a sine starting from rest, the reference moving on one side) is still a step,
// while a fast smooth motion whose rows are far apart at a low log rate (gravity turning 0.5 m/s² per row at
// 300 °/s and 100 Hz) is not, and is interpolated.
template <class R>
bool reference_step(const R* p, const R& a, const R& b, const R* n) {
  auto is_step = [](double d, double dp, double dn, double thr) {
    const double m = std::max(std::fabs(dp), std::fabs(dn));
    return std::fabs(d) - m > thr || (std::fabs(d) > 0.1 * thr && std::fabs(d) > 10.0 * m);
  };
  for (int k = 0; k < 3; ++k) {
    const double fp = p ? a.f[k] - p->f[k] : 0.0, fn = n ? n->f[k] - b.f[k] : 0.0;
    const double wp = p ? a.w[k] - p->w[k] : 0.0, wn = n ? n->w[k] - b.w[k] : 0.0;
    if (is_step(b.f[k] - a.f[k], fp, fn, 0.5) || is_step(b.w[k] - a.w[k], wp, wn, 0.2)) return true;
  }
  return false;
}

// A kink in the reference within rows a..b: its slope changes there, or it steps by less than the rows around
// it move. A rate table that starts or stops accelerating does both: ω̇ jumps (a kink in the rate) and, for a
// sensor off the axis, the tangential specific force ω̇ × r steps, while gravity turning in the body moves the
// neighbouring rows by as much (0.34 m/s² per row at 200 °/s and 100 Hz), so reference_step does not see it.
// Interpolated at a shifted time, the reference reads across it: off by δ/h of a step, |Δ²|·δ/h at a kink. On
// the simulate source's random-19 (0.5 ms latency and a clock drifting to 12 ms) that left the accelerometer at
// held-out χ²/dof 11–13, "unexplained", with per-axis latencies 0.508–0.540 ms for a true 0.517.
// Either way the second difference falls on the two rows around it (+J, −J for a step; split by where in the
// interval a kink lies), so the test sums |Δ²| at a and at b and compares that with |Δ²| one row further out on
// each side (pp, p, a and b, n, nn): smooth motion (a sine, gravity turning) changes Δ² little from row to row
// (ratio about 2), a kink or a step stands alone. Thresholds: 0.02 rad/s or 0.05 m/s², and four times the
// neighbours. Null pointers at the ends of the data: no kink there.
template <class R>
bool reference_kink(const R* pp, const R* p, const R& a, const R& b, const R* n, const R* nn) {
  if (!p || !n) return false;
  for (int k = 0; k < 3; ++k) {
    auto second = [k](const R& x, const R& y, const R& z, bool rate) {
      return rate ? (z.w[k] - y.w[k]) - (y.w[k] - x.w[k]) : (z.f[k] - y.f[k]) - (y.f[k] - x.f[k]);
    };
    for (const bool rate : {true, false}) {
      const double thr = rate ? 0.02 : 0.05;
      const double s = std::fabs(second(*p, a, b, rate)) + std::fabs(second(a, b, *n, rate));
      const double out = std::max(pp ? std::fabs(second(*pp, *p, a, rate)) : 0.0, nn ? std::fabs(second(b, *n, *nn, rate)) : 0.0);
      if (s > thr && s > 4.0 * out) return true;
    }
  }
  return false;
}

// Lag probe at instantaneous steps of the reference (docs/diagnosis.md § timing). Once a clock error has
// accumulated to more than a sample interval, the first samples after a step read the old pose, and a
// linearised timing term cannot see it: the derivative is zero on both sides of a step and the samples next
// to it are left out. Each large step is then a direct observation of the lag: the number n of output
// samples after it that still show the old input (or before it that already show the new one) brackets the
// lag to one sample interval h, δ ∈ ((n−1)h, nh] when the pose changes at the row that shows the new pose (the
// convention of ShiftedReference), or gives δ = E[n]·h when the change falls anywhere within the row interval
// (blind logs whose segments are not whole samples); which of the two, the steps themselves say (step_lag.cpp).
// A line latency + ppm·t through these brackets (steps misread by more than a sample off it left out) is a
// starting point for the re-evaluation, which then refines it on the motion (sines) with the linear term; the
// ±h exclusion around each shifted step absorbs what is left of the bracket.
// Below a sample interval the probe still tells the sign: with no lag, the output sample stamped at the row
// that first shows the new pose reads the new pose whatever the step's place in the row interval (and the
// one before reads the old), so a step read late (n_old ≥ 1) or early (n_new ≥ 1) is a direct observation
// of a lag. A full-step misreading cannot come from noise (the thresholds below), so kStepLagDecisiveCount steps
// read late and none read early (or the reverse) is decisive (`sign`), where the sines alone may leave a latency
// of a fraction of a sample below significance (step_lag.cpp says why 4). O(n_samples + n_steps · W) time (each step scans its window of
// W samples), O(W + n_steps) memory.
// A change a probe reads a lag from must stand clear of the uncalibrated output's bias, scale and misalignment
// errors by a wide margin (per sensor {accel m/s², gyro rad/s}): a step's largest component, a window's range.
inline constexpr double kLagProbeMinChange[2] = {2.0, 0.3};
// One-sided misreadings that name a lag below one sample (StepLag::sign).
inline constexpr int kStepLagDecisiveCount = 4;

struct StepLag {
  bool valid = false;
  double latency_s = 0, ppm = 0, max_abs_s = 0, rms_s = 0;
  // σ of the line's latency and ppm: least squares with the brackets' scatter (at least a uniform ±h/2, h²/12),
  // plus what the steps may share (the place of the change within a row interval: step_lag.cpp).
  double sigma_latency_s = 0, sigma_ppm = 0;
  int n_steps = 0, n_late = 0, n_early = 0, sign = 0;
  int n_outliers = 0;  // steps left out of the line: misread by more than a sample off it (step_lag.cpp)
  int max_n = 0;  // the most samples any one step was read late or early: how far its misreading reaches
};

// Reads every step of the log (one streaming pass, memory bounded by the 1.5 s window), per sensor
// {0: accel, 1: gyro}. fs: sample rate; duration_s: log duration (for the largest shift the line reaches).
std::array<StepLag, 2> probe_step_lag(SampleSource& src, double fs, double duration_s);

// Lag probe on the motion (motion_lag.cpp; docs/diagnosis.md § timing, "Lag probe on the motion"): for a log
// whose reference moves smoothly (a table that accelerates into and out of each move, no instantaneous step),
// the step probe has nothing to read, and a linearised timing term cannot start from a shift of many samples:
// u̇·δ describes a shift only while it is small next to the time the motion takes to change (a 0.2 s
// acceleration phase), and a clock drifting by 1.8 s over the log drove the linear iteration to a wrong
// latency/ppm pair (−0.38 s, +64 ppm for a true 0, −420 ppm). Here every stretch of output that moves (a window
// of 4 s whose output range is ≥ 2 m/s² or 0.3 rad/s) is matched against the reference shifted by −2.5..+2.5 s:
// the shift that minimises the squared difference (each axis's mean removed: bias), refined by a parabola
// through its neighbours, is a local lag, kept when it is unique (no other local minimum within 5× its residual)
// and sharp (a twentieth of the median over the shifts). A line latency + ppm·t through the local lags (the most
// lags within max(1.5 bins, 10 ms) of a line through two of them, then least squares with a 3-robust-σ trim) is
// the result, with the fields of StepLag (n_steps: local lags; n_late/n_early/sign/max_n unused). Valid with at
// least 8 lags on the line and 60 % of them. Works on the log averaged to about 100 Hz (bins of round(fs/100)
// samples, more beyond 2e6 bins): O(n_samples + n_windows · n_shifts · window) time, O(n_bins) memory.
std::array<StepLag, 2> probe_motion_lag(SampleSource& src, double fs, double duration_s);

}  // namespace imuforge::diagnosis
