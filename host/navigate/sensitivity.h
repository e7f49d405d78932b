// Which calibration σ meets a navigation requirement "horizontal error ≤ X m after T s of outage"
// (docs/navigation.md § sensitivity). Linear error budget:
//   e(T) ≈ Σ_i J_i δθ_i,  J_i = ∂(horizontal position error at T)/∂θ_i  (2-vector, m per parameter unit)
// found by navigating the noise-free truth with one residual parameter error at a time (the sensor's
// output perturbed through model::regressors(), the same regressors the solver fits). With independent
// residual errors of σ_g for every parameter of group g, E|e|² = Σ_g σ_g² S_g², S_g² = Σ_{i∈g} |J_i|².
// The error budget left to calibration is X_cal² = X² − floor², floor = the oracle's RMS (noise and the
// terms the table cannot hold).
#pragma once

#include <string>
#include <vector>

#include "host/model/sensor_model.h"
#include "host/navigate/impact.h"
#include "host/solver/estimate.h"

namespace imuforge::navigate {

struct GroupSensitivity {
  std::string group;         // "gyro.bias"
  std::string units;         // catalog units of the group's parameters
  int n_params = 0;
  double m_per_unit = 0;     // S_g: RMS horizontal error at T per unit σ on every parameter of the group
  double sigma_alone = 0;    // σ_g meeting X_cal with every other group perfect
  double sigma_share = 0;    // σ_g meeting X_cal when all groups take an equal share of X_cal²
};

struct SensitivityResult {
  double target_m = 0, at_s = 0, floor_m = 0, budget_m = 0;
  std::vector<GroupSensitivity> groups;
  std::vector<std::string> names;   // parameters, in the order of J
  std::vector<Eigen::Vector2d> J;   // m per unit
  // RMS horizontal error at T predicted from a calibration's σ (names not in `names` contribute nothing).
  double predicted_rms_m(const solver::Estimate& e) const;
};

// Groups: bias, scale, misalign, their *_temp polynomials (up to the sensor file's order, at least 1) and
// gyro g_sensitivity, both triads: what a calibration ships in table v1. floor_m: from the Monte Carlo.
SensitivityResult sensitivity(const sim::VehicleTruth& truth, const model::SensorModel& sensor, const ImpactOptions& opt,
                              double target_m, double at_s, double floor_m);

}  // namespace imuforge::navigate
