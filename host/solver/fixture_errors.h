// Fixture+errors mode: the rate table's axis tilts, encoder zero offsets and the IMU mount rotation are
// estimated as nuisance parameters together with the model, so an imprecise fixture still calibrates.
#pragma once

#include <string>
#include <vector>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"

namespace imuforge::solver {

struct FixtureErrorsResult {
  Estimate estimate;                       // model parameters, then nuisance parameters
  Observability observability;
  Sigma6 residual_rms{}, noise_sigma{};
  long long samples = 0;
  std::vector<std::string> nuisance_names;  // fixture.axis<i>.tilt_a|tilt_b|zero, fixture.mount.rx|ry|rz
  int iterations = 0;
};

FixtureErrorsResult solve_fixture_errors(io::LogReader& log, const model::ModelSpec& spec, const std::string& campaign_path);

}  // namespace imuforge::solver
