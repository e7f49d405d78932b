// Trajectory file (JSON, docs/formats.md § trajectory file): a vehicle's path as a chain of segments, the
// sample rate and the ambient temperature. Parsed into host/physics's VehicleTrajectory.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "host/physics/vehicle.h"

namespace imuforge::sim {

struct TrajectoryFile {
  std::string name;
  double sample_rate_hz = 200.0;
  double ambient_C = 25.0;         // air around the IMU; the die follows it (sensor's thermal constants)
  physics::VehicleTrajectory trajectory;
};

// Throws std::invalid_argument naming the key ("segments[3].radius_m: must be > 0").
TrajectoryFile trajectory_from_json(const nlohmann::json& j);
// Prefixes errors with the path.
TrajectoryFile load_trajectory(const std::string& path);

// Start and duration (s) of the first run of consecutive segments labelled `label`; throws if there is none.
void labelled_span(const physics::VehicleTrajectory& tr, const std::string& label, double& start_s, double& duration_s);

}  // namespace imuforge::sim
