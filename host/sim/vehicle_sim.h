// The vehicle simulator: true motion along a trajectory file (host/physics/vehicle.h) and the raw counts a
// sensor model gives for it, every effect of the catalog and every noise process included, through the same
// output chain as the bench campaigns (sensor_chain.h).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/vehicle.h"
#include "host/sim/trajectory_file.h"

namespace imuforge::sim {

// Everything that does not depend on the noise realisation: truth states and the die temperature.
// Computed once, shared by every Monte Carlo run. ~0.3 KB per sample.
struct VehicleTruth {
  double rate_hz = 0;
  std::vector<physics::VehicleState> states;  // t = i / rate_hz
  std::vector<double> temp_C;                  // die temperature (the IMU's temperature channel)
  std::vector<double> tdot_C_s;                // its rate
  std::vector<double> hyst_d;                  // hysteresis direction d(t)
  // Linear interpolation of f, ω, ω̇, ḟ at any t (used for the timing shift).
  void motion_at(double t_s, Eigen::Vector3d& f, Eigen::Vector3d& w, Eigen::Vector3d& wdot, Eigen::Vector3d& fdot) const;
};

// Die temperature: starts at ambient at power-up (t = 0), lags ambient + self-heating by the sensor's
// die time constant (the same first-order model as the campaign simulator).
VehicleTruth vehicle_truth(const TrajectoryFile& tf, const model::SensorModel& m);

using RawSample = std::array<std::int32_t, 6>;  // ax ay az gx gy gz counts

// Raw counts of one sensor realisation for samples [0, n). Deterministic in seed.
// O(n); fills `out` (resized to n). realised (optional): the turn-on biases drawn.
void vehicle_raw(const VehicleTruth& truth, const model::SensorModel& m, std::uint64_t seed, std::size_t n,
                 std::vector<RawSample>& out, nlohmann::json* realised = nullptr);

// `imuforge simulate --trajectory`: the whole trajectory as log v1 (docs/formats.md § trajectory file):
// segment −1 throughout (no fixture dwells), f_ref/w_ref = the true specific force and rate, temp_C = die,
// chamber_C = ambient. Returns the truth JSON (path at 1 Hz, realised turn-on biases).
io::LogMeta vehicle_log_meta(const TrajectoryFile& tf, const model::SensorModel& m, std::uint64_t seed,
                             const std::string& serial);
nlohmann::json simulate_vehicle_log(const TrajectoryFile& tf, const model::SensorModel& m, std::uint64_t seed,
                                    io::LogWriter& out);

}  // namespace imuforge::sim
