// Navigation impact of a calibration: Monte Carlo over sensor realisations along a vehicle trajectory,
// each realisation's raw counts compensated by the firmware kernel with each candidate's coefficient table
// and navigated by the strapdown navigator through a GNSS outage (docs/navigation.md).
//
// Aiding before the outage is a RESET, not a Kalman filter: at every IMU sample before the outage start,
// position and velocity are set to the truth (attitude too with Aiding::kPosVelAtt); attitude is aligned
// to the truth once at t = 0. From the outage start the navigator runs free; errors are taken against
// the truth at every second of the outage.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware/table/table.h"
#include "host/model/sensor_model.h"
#include "host/sim/vehicle_sim.h"

namespace imuforge::navigate {

// One way of compensating the raw counts: a coefficient table run by the firmware kernel.
struct Candidate {
  std::string name;         // "uncompensated", "oracle", or the cal file's name
  std::string kind;         // "uncompensated" | "oracle" | "calibration"
  std::string source;       // file path for calibrations
  fw::Table table;
  std::vector<std::string> dropped;  // estimated parameters the table v1 cannot hold (not shipped)
};

enum class Aiding { kPosVel, kPosVelAtt };

struct ImpactOptions {
  double outage_start_s = 0;
  double outage_s = 60;
  int runs = 100;
  std::uint64_t seed = 1;        // run r uses seed + r
  int threads = 0;               // 0: hardware concurrency
  Aiding aiding = Aiding::kPosVel;
  // Raw words wider than the table's 24 bits are read through their top bits (candidates.h RawFormat).
  int accel_shift = 0, gyro_shift = 0;
  std::vector<double> checkpoints_s{10, 30, 60};  // into the outage; those beyond its end are dropped
};

struct Stats {
  double mean = 0, median = 0, p95 = 0, max = 0;
};
Stats stats_of(std::vector<double> v);

struct CandidateResult {
  std::string name, kind, source;
  std::vector<std::string> dropped;
  // [run][second of outage 1..D]: horizontal position error (m), horizontal velocity error (m/s), heading error (rad)
  std::vector<std::vector<float>> hpos_m, hvel_mps, heading_rad;
  // per checkpoint
  std::vector<Stats> hpos, hvel, heading_deg;
  // per second: median and 95th percentile of the horizontal position error (for the plot)
  std::vector<double> hpos_median_m, hpos_p95_m;
};

struct ImpactResult {
  std::vector<double> checkpoints_s;
  int outage_seconds = 0;
  std::vector<CandidateResult> candidates;
  double cpu_s = 0, wall_s = 0;
  std::uint64_t nav_steps = 0;   // navigator updates in total (all runs, all candidates)
};

// Throws std::invalid_argument when the outage does not fit the trajectory or options are out of range.
ImpactResult run_impact(const sim::VehicleTruth& truth, const model::SensorModel& sensor,
                        const std::vector<Candidate>& candidates, const ImpactOptions& opt);

}  // namespace imuforge::navigate
