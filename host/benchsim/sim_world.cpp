// SimWorld: the World on the simulator's physics.
//
// From host/sim: the table geometry and rigid-body kinematics (table_kinematics: Earth rate, plumb-bob
// gravity, mount, lever arm), the site's gravity and Earth rate. The table's servo behaviour (rate and
// acceleration limited moves, in-position window, settle timer) and the chamber controller (setpoint
// ramp limit, first-order air response, die lag and self-heating) are stepped here because the
// simulator exposes them only inside its batch campaign run; see the request to "sim" in
// /work/notes/requests.md. They follow the same laws and parameters as the campaign file
// (max_rate_dps, max_accel_dps2, settle_s, ramp_limit_C_per_min, chamber_tau_s, die_tau_s).
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/benchsim/world.h"
#include "host/physics/earth.h"
#include "host/physics/table.h"

namespace imuforge::benchsim {

namespace {
constexpr double kPi = 3.14159265358979323846;

struct Axis {
  AxisMode mode = AxisMode::kIdle;
  double command = 0.0;
  double angle = 0.0, rate = 0.0, accel = 0.0;
  double steady_s = 0.0;  // how long the axis has met its goal
  bool fault = false;
  uint16_t fault_code = 0;
};

class SimWorld final : public World {
 public:
  explicit SimWorld(const WorldConfig& c) : cfg_(c) {
    if (c.axes < 1 || c.axes > 3) throw std::runtime_error("bench-sim: the table must have 1 to 3 axes");
    if (!(c.dt_s > 0) || !(c.max_rate_rad_s > 0) || !(c.max_accel_rad_s2 > 0) || !(c.chamber_tau_s > 0))
      throw std::runtime_error("bench-sim: world time step, limits and time constants must be positive");
    geom_.n_axes = c.axes;
    for (int i = 0; i < c.axes; ++i) {
      geom_.axes[static_cast<size_t>(i)].name = "axis" + std::to_string(i);
      geom_.axes[static_cast<size_t>(i)].axis_nominal = physics::axis_from_name(c.axis_names[static_cast<size_t>(i)]);
    }
    geom_.mount.C_imu_plat = physics::rotation_zyx_deg(c.mount_ypr_deg[0], c.mount_ypr_deg[1], c.mount_ypr_deg[2]).transpose();
    geom_.mount.lever_arm_m = Eigen::Vector3d(c.lever_arm_m[0], c.lever_arm_m[1], c.lever_arm_m[2]);
    physics::Site site;
    site.latitude_deg = c.latitude_deg;
    site.height_m = c.height_m;
    g_ned_ = physics::gravity_ned(site);
    wie_ned_ = physics::earth_rate_ned(site);
    setpoint_ = ramped_ = air_ = die_ = c.initial_C;
    ramp_ = std::min(c.ramp_C_per_min, c.max_ramp_C_per_min);
    axes_.resize(static_cast<size_t>(c.axes));
    // Exact first-order discretisation for the fixed step (computed once: the world may take a million
    // steps per wall second at a high time scale).
    k_air_ = 1.0 - std::exp(-c.dt_s / c.chamber_tau_s);
    k_die_ = 1.0 - std::exp(-c.dt_s / std::max(c.die_tau_s, 1e-9));
    k_self_ = 1.0 - std::exp(-c.dt_s / std::max(c.self_heating_tau_s, 1e-9));
  }

  double time_s() const override { return t_; }

  void advance_to(double t_s) override {
    while (t_ + cfg_.dt_s <= t_s) step(cfg_.dt_s);
  }

  int axes() const override { return cfg_.axes; }

  void command_axis(int a, AxisMode mode, double value) override {
    Axis& x = axes_.at(static_cast<size_t>(a));
    x.fault = false;
    x.fault_code = 0;
    if (mode == AxisMode::kRate && std::fabs(value) > max_rate(static_cast<size_t>(a))) {
      // The table's own protection: refuse and stop, flagged as a fault the host can read.
      x.mode = AxisMode::kIdle;
      x.command = 0;
      x.fault = true;
      x.fault_code = 1;
      return;
    }
    x.mode = mode;
    x.command = value;
    x.steady_s = 0;
  }

  AxisReport axis(int a) const override {
    const Axis& x = axes_.at(static_cast<size_t>(a));
    AxisReport r;
    r.mode = x.mode;
    r.command = x.command;
    r.angle_rad = x.angle;
    r.rate_rad_s = x.rate;
    r.in_position = x.mode == AxisMode::kPosition ? std::fabs(position_error(x)) <= cfg_.in_position_rad
                    : x.mode == AxisMode::kRate   ? std::fabs(x.command - x.rate) <= 1e-9
                                                  : std::fabs(x.rate) <= 1e-9;
    r.settled = r.in_position && x.steady_s >= cfg_.settle_s;
    r.moving = std::fabs(x.rate) > 1e-9;
    r.fault = x.fault;
    r.fault_code = x.fault_code;
    return r;
  }

  void set_setpoint(double c) override { setpoint_ = c; }
  void set_ramp(double c_per_min) override { ramp_ = std::clamp(c_per_min, 1e-6, cfg_.max_ramp_C_per_min); }
  void set_running(bool on) override { running_ = on; }

  ChamberReport chamber() const override {
    ChamberReport r;
    r.setpoint_C = setpoint_;
    r.air_C = air_;
    r.ramp_C_per_min = ramp_;
    r.running = running_;
    r.at_setpoint = running_ && std::fabs(air_ - setpoint_) <= cfg_.at_setpoint_band_C;
    return r;
  }

  ImuTruth imu_truth() const override {
    physics::TableState st;
    for (int i = 0; i < cfg_.axes; ++i) {
      st.angle_rad[static_cast<size_t>(i)] = axes_[static_cast<size_t>(i)].angle;
      st.rate_rad_s[static_cast<size_t>(i)] = axes_[static_cast<size_t>(i)].rate;
      st.accel_rad_s2[static_cast<size_t>(i)] = axes_[static_cast<size_t>(i)].accel;
    }
    const physics::ImuKinematics k = physics::table_kinematics(geom_, st, g_ned_, wie_ned_);
    ImuTruth t;
    t.t_s = t_;
    t.f_mps2 = k.f_mps2;
    t.w_rad_s = k.w_rad_s;
    t.wdot_rad_s2 = k.wdot_rad_s2;
    t.die_C = die_ + self_heat_;
    t.die_rate_C_s = die_rate_;
    return t;
  }

 private:
  // The axes turn without end stops: after rate runs the integrated angle holds many turns, and a
  // position command must take the shortest way to the commanded angle modulo one turn, not unwind.
  static double position_error(const Axis& x) { return std::remainder(x.command - x.angle, 2.0 * kPi); }

  double max_rate(size_t i) const {
    return cfg_.axis_max_rate_rad_s[i] > 0 ? cfg_.axis_max_rate_rad_s[i] : cfg_.max_rate_rad_s;
  }
  double max_accel(size_t i) const {
    return cfg_.axis_max_accel_rad_s2[i] > 0 ? cfg_.axis_max_accel_rad_s2[i] : cfg_.max_accel_rad_s2;
  }

  void step_axis(size_t i, double dt) {
    Axis& x = axes_[i];
    const double amax = max_accel(i), vmax = max_rate(i);
    double v_goal = 0;
    if (x.mode == AxisMode::kRate) {
      v_goal = x.command;
    } else if (x.mode == AxisMode::kPosition) {
      // Time-optimal approach under rate and acceleration limits: the fastest rate from which the axis
      // can still stop at the target.
      // The last term lands exactly on the target in one step once the acceleration limit allows it.
      const double e = position_error(x);
      v_goal = std::copysign(std::min({vmax, std::sqrt(2.0 * amax * std::fabs(e)), std::fabs(e) / dt}), e);
    }
    const double dv = std::clamp(v_goal - x.rate, -amax * dt, amax * dt);
    x.rate += dv;
    x.accel = dv / dt;
    x.angle += x.rate * dt;  // semi-implicit Euler: a commanded stop lands exactly
  }

  void step(double dt) {
    for (size_t i = 0; i < axes_.size(); ++i) {
      step_axis(i, dt);
      Axis& x = axes_[i];
      // Settling: the goal must hold continuously for settle_s.
      const bool goal = x.mode == AxisMode::kPosition ? std::fabs(position_error(x)) <= cfg_.in_position_rad
                        : x.mode == AxisMode::kRate   ? std::fabs(x.command - x.rate) <= 1e-9
                                                      : std::fabs(x.rate) <= 1e-9;
      x.steady_s = goal ? x.steady_s + dt : 0.0;
    }
    // Chamber: the controller slews its internal setpoint at the ramp limit; the air follows it with a
    // first-order lag. Stopped, the air relaxes towards the room (initial) temperature.
    const double target = running_ ? setpoint_ : cfg_.initial_C;
    const double max_step = ramp_ / 60.0 * dt;
    ramped_ += std::clamp(target - ramped_, -max_step, max_step);
    air_ += (ramped_ - air_) * k_air_;
    // Die: lags the air; self-heating rises after power-up.
    const double die0 = die_ + self_heat_;
    die_ += (air_ - die_) * k_die_;
    self_heat_ += (cfg_.self_heating_C - self_heat_) * k_self_;
    die_rate_ = (die_ + self_heat_ - die0) / dt;
    t_ += dt;
  }

  WorldConfig cfg_;
  physics::TableGeometry geom_;
  Eigen::Vector3d g_ned_, wie_ned_;
  std::vector<Axis> axes_;
  double t_ = 0.0;
  double setpoint_, ramped_, air_, die_, ramp_;
  double self_heat_ = 0.0, die_rate_ = 0.0;
  double k_air_ = 0.0, k_die_ = 0.0, k_self_ = 0.0;
  bool running_ = true;
};

}  // namespace

std::unique_ptr<World> make_sim_world(const WorldConfig& cfg) { return std::make_unique<SimWorld>(cfg); }

}  // namespace imuforge::benchsim
