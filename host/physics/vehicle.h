// Vehicle trajectory kinematics: a land or air vehicle following a chain of segments (stand still,
// accelerate, cruise, turn with a radius, climb) over the WGS-84 ellipsoid, and the specific force and
// angular rate an IMU fixed to it senses, Earth rate and transport rate included.
//
// Frames: navigation frame NED at the vehicle; body frame FRD (x forward, y right, z down), the IMU
// frame (mount identity, no lever arm). Attitude: yaw = heading ψ (from north, clockwise), pitch = the
// flight-path angle θ = asin(v_up / s), roll 0 (no bank): C_nb = Rz(ψ) Ry(θ).
//   v_n   = (s_h cos ψ, s_h sin ψ, −v_up),  s_h = √(s² − v_up²)
//   f_b   = C_bn (v̇_n − g_n + (2 ω_ie + ω_en) × v_n)          (the navigator's velocity equation, inverted)
//   ω_ib  = C_bn (ω_ie + ω_en) + ω_nb,  ω_nb = (−ψ̇ sin θ, θ̇, ψ̇ cos θ)
// Every profile has a continuous acceleration (raised-cosine shapes), so specific force and rate are
// continuous too: a sampled IMU sees no steps the real vehicle could not make.
// Position is integrated (RK4 on the sample grid) from the analytic velocity; everything else is analytic.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "host/physics/earth.h"

namespace imuforge::physics {

struct VehicleSegment {
  enum class Kind { kStand, kAccelerate, kCruise, kTurn, kClimb };
  Kind kind = Kind::kStand;
  std::string label;            // free text; a label is how a report names the segment ("tunnel")
  double duration_s = 0.0;      // stand, accelerate, cruise, climb; turn: derived from radius and angle
  double speed_to_mps = 0.0;    // accelerate: end speed (≥ 0)
  double radius_m = 0.0;        // turn: radius of the constant-rate part (> 0)
  double angle_rad = 0.0;       // turn: heading change, + = to the right (clockwise seen from above)
  double transition_s = 1.0;    // turn: raised-cosine ramp of the turn rate at each end (≥ 0)
  double height_change_m = 0.0; // climb: height gained (negative: descent) at constant path speed
};

struct VehicleStart {
  double latitude_deg = 45.0;
  double longitude_deg = 0.0;
  double height_m = 0.0;
  double heading_deg = 0.0;
};

// Along-path state at one time (no Earth position needed).
struct PathState {
  double speed_mps = 0, speed_dot = 0;          // path speed s and ṡ
  double heading_rad = 0, heading_rate = 0;     // ψ, ψ̇
  double vup_mps = 0, vup_dot = 0;              // vertical speed (up) and its rate
  int segment = -1;
};

// One sample of the true motion.
struct VehicleState {
  double t_s = 0;
  Geodetic pos;
  Eigen::Vector3d v_ned = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_nb = Eigen::Quaterniond::Identity();  // body → NED
  Eigen::Vector3d f_b = Eigen::Vector3d::Zero();      // specific force, m/s², body
  Eigen::Vector3d w_b = Eigen::Vector3d::Zero();      // ω_ib, rad/s, body
  Eigen::Vector3d wdot_b = Eigen::Vector3d::Zero();   // dω_ib/dt, rad/s²
  Eigen::Vector3d fdot_b = Eigen::Vector3d::Zero();   // df/dt, m/s³
  int segment = -1;
};

class VehicleTrajectory {
 public:
  // Validates the chain (throws std::invalid_argument naming "segments[i]": a stand at non-zero speed,
  // a turn or climb at zero speed, a climb steeper than the speed allows, a turn too tight for its ramps...).
  VehicleTrajectory(const VehicleStart& start, std::vector<VehicleSegment> segments);

  double duration_s() const { return t_end_.empty() ? 0.0 : t_end_.back(); }
  const std::vector<VehicleSegment>& segments() const { return seg_; }
  const VehicleStart& start() const { return start_; }
  double segment_start_s(std::size_t i) const { return i == 0 ? 0.0 : t_end_[i - 1]; }
  double segment_end_s(std::size_t i) const { return t_end_[i]; }
  // t clamped to [0, duration]. O(log segments).
  PathState path(double t_s) const;

 private:
  VehicleStart start_;
  std::vector<VehicleSegment> seg_;
  std::vector<double> t_end_, s0_, psi0_;
};

// Velocity, attitude, specific force and rate at time t for a vehicle at position pos (the caller's
// integrated position). wdot_b and fdot_b by central difference over ±0.5 ms of the analytic profiles.
VehicleState vehicle_kinematics(const VehicleTrajectory& tr, double t_s, const Geodetic& pos);

// The whole trajectory on a grid of rate_hz (t = i/rate_hz, i = 0..floor(duration·rate)): position by
// RK4 from the analytic velocity, the rest analytic. O(duration·rate).
std::vector<VehicleState> sample_vehicle(const VehicleTrajectory& tr, double rate_hz);

// d(lat, lon, h)/dt for a velocity in NED at pos (meridian and normal radii of curvature).
Eigen::Vector3d geodetic_rate(const Geodetic& pos, const Eigen::Vector3d& v_ned);

}  // namespace imuforge::physics
