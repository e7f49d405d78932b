// A synthetic channel of dwell means for the drift tests (tests/estimator/drift_test.cpp,
// drift_coverage_test.cpp).
#pragma once

#include <cmath>
#include <random>

#include "host/estimator/drift.h"

namespace estimator_drift_series {

using imuforge::estimator::DwellSeries;

// S dwells, one every 90 s on average (jittered), a bias and a slow "temperature" column; the wander at each
// dwell's time.
inline DwellSeries drift_series(int S, unsigned seed, double gm_var, double tau_s, double offset_var, double white_var) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u(60.0, 120.0);
  DwellSeries s;
  s.t_s.resize(static_cast<size_t>(S));
  s.y.resize(S);
  s.X.resize(S, 2);
  s.white_var = Eigen::VectorXd::Constant(S, white_var);
  double t = 0, g = std::sqrt(gm_var) * n01(rng);
  for (int i = 0; i < S; ++i) {
    const double dt = u(rng);
    t += dt;
    if (gm_var > 0) {
      const double phi = std::exp(-dt / tau_s);
      g = phi * g + std::sqrt(gm_var * (1 - phi * phi)) * n01(rng);
    }
    s.t_s[static_cast<size_t>(i)] = t;
    s.X(i, 0) = 1.0;
    s.X(i, 1) = std::sin(2 * M_PI * t / (S * 90.0));  // one thermal cycle over the log
    s.y[i] = 0.3 + 0.1 * s.X(i, 1) + g + std::sqrt(offset_var) * n01(rng) + std::sqrt(white_var) * n01(rng);
  }
  return s;
}


}  // namespace estimator_drift_series
