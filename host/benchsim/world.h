// The simulated lab behind bench-sim: one rate table, one thermal chamber, one IMU on the table, one
// clock. The Modbus server and the virtual IMU both read this world, so the fixture's registers and the
// IMU's samples describe the same motion and temperature at the same simulated time.
//
// World is the seam: the Modbus side only sees this interface. SimWorld implements it with the
// simulator's physics (host/sim: table kinematics, Earth/gravity, chamber and die thermal model).
//
// Units: SI inside the world (rad, rad/s, degC, s); the register bank converts to the map's units.
// Not thread-safe: the Bench (bench.h) serialises access with its mutex.
#pragma once

#include <cstdint>
#include <array>
#include <memory>
#include <string>

#include <Eigen/Core>

namespace imuforge::benchsim {

enum class AxisMode : int { kIdle = 0, kPosition = 1, kRate = 2 };

struct AxisReport {
  AxisMode mode = AxisMode::kIdle;
  double command = 0.0;     // rad (position) or rad/s (rate)
  double angle_rad = 0.0;   // reported (encoder) angle, unwrapped
  double rate_rad_s = 0.0;  // reported rate
  bool in_position = false; // position mode: within the in-position window of the target
  bool settled = false;     // the motion has been steady for the settle time
  bool moving = false;
  bool fault = false;
  uint16_t fault_code = 0;
};

struct ChamberReport {
  double setpoint_C = 25.0;
  double air_C = 25.0;          // measured air temperature
  double ramp_C_per_min = 3.0;  // ramp-rate limit in use
  bool running = true;
  bool at_setpoint = false;
  bool fault = false;
  uint16_t fault_code = 0;
};

// The IMU's true inputs at the world's current time (IMU nominal frame).
struct ImuTruth {
  double t_s = 0.0;
  Eigen::Vector3d f_mps2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d w_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d wdot_rad_s2 = Eigen::Vector3d::Zero();
  double die_C = 25.0;
  double die_rate_C_s = 0.0;
};

class World {
 public:
  virtual ~World() = default;
  virtual double time_s() const = 0;
  // Advance the simulation to t_s (no-op if t_s <= time_s()). Steps internally at a fixed dt.
  virtual void advance_to(double t_s) = 0;

  virtual int axes() const = 0;
  virtual void command_axis(int axis, AxisMode mode, double value) = 0;
  virtual AxisReport axis(int axis) const = 0;

  virtual void set_setpoint(double temp_C) = 0;
  virtual void set_ramp(double C_per_min) = 0;
  virtual void set_running(bool on) = 0;
  virtual ChamberReport chamber() const = 0;

  virtual ImuTruth imu_truth() const = 0;
};

// Configuration of the simulated lab (bench-sim flags and --world JSON).
struct WorldConfig {
  int axes = 3;
  double max_rate_rad_s = 500.0 * 3.14159265358979323846 / 180.0;
  double max_accel_rad_s2 = 300.0 * 3.14159265358979323846 / 180.0;
  // Per-axis limits, innermost first; 0 means "use max_rate_rad_s / max_accel_rad_s2". Real tables
  // have a slow, heavy gimbal and a fast inner axis, so one limit for all would refuse valid runs.
  std::array<double, 3> axis_max_rate_rad_s{};
  std::array<double, 3> axis_max_accel_rad_s2{};
  double in_position_rad = 0.001 * 3.14159265358979323846 / 180.0;  // window around the target
  double settle_s = 1.0;                                             // steady for this long -> settled
  double initial_C = 25.0;
  double ramp_C_per_min = 3.0;        // chamber default ramp limit
  double max_ramp_C_per_min = 10.0;   // the chamber's own hardware limit
  double chamber_tau_s = 120.0;       // first-order air response to the ramped setpoint
  double at_setpoint_band_C = 0.5;
  std::array<std::string, 3> axis_names{"z", "y", "x"};  // nominal axis in the parent frame, innermost first
  std::array<double, 3> mount_ypr_deg{};  // IMU on the platform, ZYX yaw, pitch, roll
  std::array<double, 3> lever_arm_m{};    // IMU reference point from the rotation centre, platform frame
  double die_tau_s = 60.0;                // die lag behind the air (the sensor model overrides)
  double self_heating_C = 0.0;
  double self_heating_tau_s = 30.0;
  double latitude_deg = 45.0;
  double height_m = 0.0;
  double dt_s = 0.001;                // integration step (simulated time)
  uint64_t seed = 1;
};

// The world with the simulator's physics.
std::unique_ptr<World> make_sim_world(const WorldConfig& cfg);

}  // namespace imuforge::benchsim
