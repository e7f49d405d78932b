#include "host/sim/vehicle_sim.h"

#include <algorithm>
#include <cmath>

#include "host/model/measure.h"
#include "host/sim/sensor_chain.h"

namespace imuforge::sim {

using model::Sensor;

void VehicleTruth::motion_at(double t_s, Eigen::Vector3d& f, Eigen::Vector3d& w, Eigen::Vector3d& wdot,
                             Eigen::Vector3d& fdot) const {
  const double x = std::clamp(t_s * rate_hz, 0.0, static_cast<double>(states.size() - 1));
  const std::size_t i = std::min(static_cast<std::size_t>(x), states.size() - 2);
  const double u = x - static_cast<double>(i);
  const physics::VehicleState &a = states[i], &b = states[i + 1];
  f = a.f_b + u * (b.f_b - a.f_b);
  w = a.w_b + u * (b.w_b - a.w_b);
  wdot = a.wdot_b + u * (b.wdot_b - a.wdot_b);
  fdot = a.fdot_b + u * (b.fdot_b - a.fdot_b);
}

VehicleTruth vehicle_truth(const TrajectoryFile& tf, const model::SensorModel& m) {
  VehicleTruth vt;
  vt.rate_hz = tf.sample_rate_hz;
  vt.states = physics::sample_vehicle(tf.trajectory, tf.sample_rate_hz);
  const std::size_t n = vt.states.size();
  vt.temp_C.resize(n);
  vt.tdot_C_s.resize(n);
  vt.hyst_d.resize(n);
  const auto& th = m.thermal;
  const double dt = 1.0 / tf.sample_rate_hz;
  const double a_die = 1.0 - std::exp(-dt / th.die_tau_s);
  double die = tf.ambient_C;
  model::HysteresisTracker hyst(th.hysteresis_threshold_C);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    const double target = tf.ambient_C + th.self_heating_C * (1.0 - std::exp(-t / th.self_heating_tau_s));
    vt.temp_C[i] = die;
    vt.tdot_C_s[i] = (target - die) / th.die_tau_s;
    vt.hyst_d[i] = hyst.update(die);
    die += (target - die) * a_die;
  }
  return vt;
}

void vehicle_raw(const VehicleTruth& truth, const model::SensorModel& m, std::uint64_t seed, std::size_t n,
                 std::vector<RawSample>& out) {
  n = std::min(n, truth.states.size());
  out.resize(n);
  const double dt = 1.0 / truth.rate_hz;
  SensorChain chain(m, dt, seed);
  const model::MeasureOptions mopt{false};  // timing realised exactly by the time shift
  model::MeasureInput in;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    in.T_C = truth.temp_C[i];
    in.Tdot_C_s = truth.tdot_C_s[i];
    in.d = truth.hyst_d[i];
    in.t_s = t;
    for (int s = 0; s < 2; ++s) {
      const Sensor sn = static_cast<Sensor>(s);
      if (chain.has_timing(sn)) {
        truth.motion_at(chain.shifted_time(sn, t), in.f, in.w, in.wdot, in.fdot);
      } else {
        const physics::VehicleState& st = truth.states[i];
        in.f = st.f_b;
        in.w = st.w_b;
        in.wdot = st.wdot_b;
        in.fdot = st.fdot_b;
      }
      chain.counts(sn, model::measure(chain.triad(sn), in, mopt), out[i].data() + 3 * s);
    }
  }
}

}  // namespace imuforge::sim
