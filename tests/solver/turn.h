// A synthetic rotation-check recording shared by the reference-free tests: 5 s still, a 90° turn about x
// at 45 °/s, 5 s still, at 100 Hz, gyro outputs from the catalog's measurement function for `truth`,
// accelerometer reading +9.8 m/s² on z; white noise σ_a, σ_g on every sample.
#pragma once

#include <cmath>
#include <random>

#include <Eigen/Core>

#include "host/model/measure.h"
#include "host/solver/reference_free.h"

namespace turn {

inline imuforge::solver::RawRecording quarter_turn_about_x(const imuforge::model::ParamSet& truth, double sigma_a,
                                                           double sigma_g, unsigned seed) {
  namespace model = imuforge::model;
  const auto cg = model::compile(truth, model::Sensor::kGyro, 25.0);
  imuforge::solver::RawRecording rec;
  rec.rate_hz = 100;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  double t = 0;
  auto emit = [&](const Eigen::Vector3d& w) {
    model::MeasureInput in;
    in.w = w;
    const Eigen::Vector3d y = model::measure(cg, in);
    rec.t_s.push_back(t);
    rec.y.push_back({sigma_a * n01(rng), sigma_a * n01(rng), 9.8 + sigma_a * n01(rng), y[0] + sigma_g * n01(rng),
                     y[1] + sigma_g * n01(rng), y[2] + sigma_g * n01(rng)});
    t += 0.01;
  };
  for (int i = 0; i < 500; ++i) emit(Eigen::Vector3d::Zero());
  for (int i = 0; i < 200; ++i) emit(Eigen::Vector3d(M_PI / 4, 0, 0));
  for (int i = 0; i < 500; ++i) emit(Eigen::Vector3d::Zero());
  return rec;
}

}  // namespace turn
