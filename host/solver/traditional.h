// The traditional baseline, what calibration labs do today (no covariance, no temperature model):
//   accelerometer: six-position averages. For static dwells with the reference along ±e_k,
//     (I+M)_jk = (ȳ_j(+k) − ȳ_j(−k)) / (f(+k) − f(−k)),   b_j = mean over the six positions of ȳ_j − ((I+M) f̄)_j
//   gyro: CW/CCW rate-table averages. For constant-rate dwells about ±e_k,
//     (I+M)_jk = (ȳ_j(+) − ȳ_j(−)) / (ω_k(+) − ω_k(−)),     b_j = mean over axes of (ȳ_j(+)+ȳ_j(−))/2 − ((I+M) ω̄)_j
// Only the dwells of one plateau are used (a lab calibrates at room temperature): the one nearest T_ref
// that holds all six positions and both rate directions per axis.
// Several dwells with the same direction (a 24-position tumble has four per face) are averaged.
#pragma once

#include <map>

#include "host/solver/estimate.h"
#include "host/solver/fixture.h"

namespace imuforge::solver {

struct TraditionalResult {
  Estimate estimate;       // bias/scale/misalign of both sensors; covariance is empty
  double plateau_T_C = 0;  // temperature of the dwells used
  int accel_dwells = 0, gyro_dwells = 0;
};

// Throws SolverError naming what is missing (e.g. "no static dwell with the reference along -y").
TraditionalResult solve_traditional(const std::map<int, SegmentSummary>& segments, double T_ref_C);

}  // namespace imuforge::solver
