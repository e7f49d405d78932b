// cal.json: the calibration result file (format documented in docs/calibration.md).
#pragma once

#include "host/io/utc_time.h"

#include <string>

#include <nlohmann/json.hpp>

#include "host/solver/estimate.h"
#include "host/solver/fixture.h"

namespace imuforge::solver {

constexpr const char* kCalFormat = "imuforge-cal";
constexpr int kCalVersion = 1;

struct CalibrationResult {
  std::string mode = "fixture";      // fixture | fixture+errors | reference-free
  std::string method = "inverse";    // inverse | traditional
  Estimate estimate;                 // covariance empty for the traditional method
  bool has_covariance = true;
  // σ from the sensor noise alone, when estimate.covariance also carries the fixture tolerance
  // (consider.h); empty otherwise. Written as each parameter's "sigma_noise".
  Eigen::VectorXd sigma_noise;
  Observability observability;
  bool has_residuals = true;
  Sigma6 residual_rms{};             // per channel, SI
  Sigma6 noise_sigma{};              // weights used, SI
  std::string noise_source;          // "static" | "model" | "residual" | ...
  double T_ref_C = 25.0;
  nlohmann::json model;              // the model spec as read
  nlohmann::json extra = nlohmann::json::object();  // mode-specific sections, copied to the top level
  std::string log_path, log_sha256;
  long long samples = 0;
};

nlohmann::json calibration_to_json(const CalibrationResult& r);
// Reads back parameters {name: value} (and sigma when present); throws io::InputError naming the key on a
// malformed file.
Estimate calibration_from_json(const nlohmann::json& j);
// Current UTC time as ISO 8601 (provenance).
using io::utc_now_iso8601;  // host/io/utc_time.h

}  // namespace imuforge::solver
