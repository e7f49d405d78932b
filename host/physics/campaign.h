// The campaign: the fixture schedule run by BOTH the simulator and the real end-of-line runner, and
// read by the solver's fixture+errors mode (docs/formats.md § campaign). Plain data and the schedule's
// nominal duration; the JSON file is read and written by host/io/campaign_file.h. This part
// (host/physics) depends on nothing but Eigen and the standard library.
//
// A campaign is a list of phases in time order:
//   plateau  chamber setpoint jumps to setpoint_C (the chamber ramps at its limit); the table holds
//            while the air settles for soak_s (recorded as one static segment), then the steps run.
//   ramp     chamber setpoint ramps to setpoint_C at rate_C_per_min (≤ the chamber limit); the table
//            holds still; the whole ramp is one static segment (excites temp_rate / hysteresis).
// A step is one dwell (one segment in the log) preceded by the motion that reaches it (segment −1):
//   position  move every axis to position_deg (trapezoidal, rate/accel limited), settle, dwell.
//   rate      accelerate to rate_dps per axis, dwell at constant rate (segment), rate stays until the
//             next step changes it.
//   ramp_rate rate changes linearly from `from` to `to` over dwell_s (one segment).
//   sine      oscillation amplitude_deg·sin(2π f t) about the current position, for dwell_s.
//   soak      static at the current position for dwell_s (long static record for Allan/noise).
//   pose      hand-held style: the IMU is turned (no fixture) to attitude_deg [roll, pitch, yaw] over
//             move_s, then rests for dwell_s; logged WITHOUT reference (has_ref = false).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace imuforge::physics {

struct CampaignAxis {
  std::string name;            // "inner", "outer", ...
  std::string axis = "z";      // nominal axis in the parent frame: x, y, z, -x, -y, -z
  double max_rate_dps = 300.0;
  double max_accel_dps2 = 100.0;
};

struct CampaignStep {
  enum class Kind { kPosition, kRate, kRampRate, kSine, kSoak, kPose };
  Kind kind = Kind::kPosition;
  std::string label;                             // free text, e.g. "tumble 7", "+z CW"
  std::array<double, 3> position_deg{};          // kPosition (per table axis; unused axes 0)
  std::array<double, 3> rate_dps{};              // kRate; kRampRate: the final rate
  std::array<double, 3> rate_from_dps{};         // kRampRate
  std::array<double, 3> amplitude_deg{};         // kSine
  std::array<double, 3> frequency_hz{};          // kSine
  std::array<double, 3> attitude_deg{};          // kPose: roll, pitch, yaw of IMU in NED
  double move_s = 3.0;                           // kPose: duration of the hand rotation
  double dwell_s = 0.0;                          // time logged as this step's segment
  double settle_s = -1.0;                        // kPosition: after the move; <0 = campaign default
};

struct CampaignPhase {
  enum class Kind { kPlateau, kRamp };
  Kind kind = Kind::kPlateau;
  std::string label;
  double setpoint_C = 25.0;
  double soak_s = 0.0;          // kPlateau: wait (static segment) before the steps
  double rate_C_per_min = 1.0;  // kRamp
  std::vector<CampaignStep> steps;  // kPlateau only (sequences expanded)
};

struct Campaign {
  std::string name;
  std::string description;
  double latitude_deg = 45.0;
  double height_m = 0.0;
  double sample_rate_hz = 100.0;

  // Table
  std::vector<CampaignAxis> axes;               // innermost first, 1..3
  std::array<double, 3> mount_rotation_deg{};   // ZYX yaw, pitch, roll of IMU w.r.t. platform
  std::array<double, 3> lever_arm_m{};          // IMU reference point from rotation centre, platform frame
  double settle_s = 1.0;                        // default settle after a position move

  // Chamber
  double initial_C = 25.0;
  double ramp_limit_C_per_min = 3.0;            // chamber setpoint slew limit
  double chamber_tau_s = 120.0;                 // first-order air response to the slewed setpoint

  std::vector<CampaignPhase> phases;
  // The optional "simulation" block (fixture errors, encoder noise) as compact JSON text, "" when absent.
  // Only the simulator reads it (host/sim); the runner and the solver ignore it.
  std::string simulation_json;

  // Nominal duration (s) of the whole schedule including moves and chamber slews, from the limits.
  // Mirrors the simulator's timeline (within 1 % on the examples; sine steps are approximate).
  // For progress/ETA displays; physics::build_timeline() is authoritative.
  double nominal_duration_s() const;
  // Number of steps over all phases (segments = steps + plateau soaks + ramps).
  std::size_t num_steps() const;
};

}  // namespace imuforge::physics
