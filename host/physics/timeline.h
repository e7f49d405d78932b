// The campaign expanded into a continuous-time schedule: table motion, free (hand-held) motion,
// segments, and the chamber setpoint. The simulator samples it; the bench simulator can too.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "host/physics/campaign.h"
#include "host/physics/table.h"

namespace imuforge::physics {

// Motion of one table axis over one entry, τ = t − t0 (rad, rad/s, rad/s²).
struct AxisProfile {
  enum class Kind : unsigned char { kHold, kMove, kRateChange, kConstRate, kRateRamp, kSine };
  Kind kind = Kind::kHold;
  double a0 = 0, r0 = 0, r1 = 0;  // start angle, start rate, end rate
  double acc = 0;                 // signed acceleration (move: of the first phase)
  double t_acc = 0, t_const = 0;  // move: accel duration, cruise duration; rate change: ramp duration
  double amp = 0, omega = 0;      // sine
  void eval(double tau, double& ang, double& rate, double& accel) const;
};

struct TimelineEntry {
  double t0 = 0, t1 = 0;       // [t0, t1)
  int segment = -1;            // dwell index or −1 (moving)
  bool has_ref = true;         // false for hand-held poses
  bool free = false;           // hand-held: attitude from C0 rotated about axis n by φ·s(τ)
  std::array<AxisProfile, kMaxTableAxes> axis{};
  // free motion: C_ned_imu(τ) = C0 · Exp(φ s(τ) [n×]), s = smoothstep over move_s
  Eigen::Matrix3d C0_ned_imu = Eigen::Matrix3d::Identity();
  Eigen::Vector3d n = Eigen::Vector3d::UnitX();
  double phi = 0, move_s = 0;
  int phase = 0;               // campaign phase index
  std::string label;
};

struct SegmentInfo {
  int id;
  double t0, t1;
  int phase;
  std::string kind;   // "position", "rate", "soak", "ramp", "plateau_soak", "sine", "ramp_rate", "pose"
  std::string label;
  bool has_ref;
};

// Chamber setpoint program: from t0 the slewed setpoint moves towards target at slew_C_s.
struct SetpointEvent {
  double t0;
  double target_C;
  double slew_C_s;
};

struct Timeline {
  std::vector<TimelineEntry> entries;
  std::vector<SegmentInfo> segments;
  std::vector<SetpointEvent> setpoints;
  double duration_s = 0;
};

// Nominal (error-free) table geometry and mount of a campaign. Mount rotation_deg = ZYX yaw, pitch, roll of
// the IMU case w.r.t. the platform (C_plat←imu = Rz Ry Rx).
TableGeometry geometry_from_campaign(const Campaign& c);

Timeline build_timeline(const Campaign& c);

// Motion sample: table state (commanded = encoder frame) or free attitude.
struct MotionSample {
  const TimelineEntry* entry;
  TableState table;
  bool free;
  Eigen::Matrix3d C_imu_ned;     // free only
  Eigen::Vector3d w_nb_imu, wdot_nb_imu;  // free only
};

// Evaluates the timeline at t; `cursor` is an entry index hint updated in place (amortised O(1) for
// monotone or nearly monotone t). t is clamped to [0, duration].
MotionSample sample_motion(const Timeline& tl, double t, std::size_t& cursor);

}  // namespace imuforge::physics
