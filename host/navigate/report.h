// nav.json and report.html of `imuforge navigate` (docs/navigation.md § outputs).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/navigate/impact.h"
#include "host/navigate/sensitivity.h"
#include "host/sim/vehicle_sim.h"

namespace imuforge::navigate {

struct NavReport {
  std::string trajectory_path, trajectory_name, sensor_path, sensor_name;
  double ambient_C = 0, distance_m = 0;
  std::string outage_label;             // segment label when --outage named one
  ImpactOptions opt;
  ImpactResult result;
  std::optional<SensitivityResult> sens;
  std::vector<double> predicted_rms_m;  // per candidate, from its σ (NaN without covariance)
  const sim::VehicleTruth* truth = nullptr;
};

nlohmann::json nav_json(const NavReport& r);
std::string nav_html(const NavReport& r);
// Writes nav.json and report.html into dir (created if missing) through temporary files renamed at the
// end: either both appear complete or neither changes. Throws std::runtime_error naming the path.
void write_nav_outputs(const std::string& dir, const NavReport& r);

}  // namespace imuforge::navigate
