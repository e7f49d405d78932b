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
                 std::vector<RawSample>& out, nlohmann::json* realised) {
  n = std::min(n, truth.states.size());
  out.resize(n);
  const double dt = 1.0 / truth.rate_hz;
  SensorChain chain(m, dt, seed);
  if (realised) *realised = chain.realised();
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

io::LogMeta vehicle_log_meta(const TrajectoryFile& tf, const model::SensorModel& m, std::uint64_t seed,
                             const std::string& serial) {
  io::LogMeta meta;
  meta.serial = serial;
  meta.sample_rate_hz = tf.sample_rate_hz;
  meta.accel_lsb_mps2 = m.triad(Sensor::kAccel).lsb;
  meta.gyro_lsb_rad_s = m.triad(Sensor::kGyro).lsb;
  meta.accel_bits = m.triad(Sensor::kAccel).bits;  // the word the output stage clamps to
  meta.gyro_bits = m.triad(Sensor::kGyro).bits;
  meta.latitude_deg = tf.trajectory.start().latitude_deg;
  meta.height_m = tf.trajectory.start().height_m;
  meta.gravity_mps2 = physics::normal_gravity_mps2(physics::Site{meta.latitude_deg, meta.height_m});
  meta.table_axes = 0;
  meta.set("source", "imuforge-simulate");
  meta.set("trajectory", tf.name);
  meta.set("sensor", m.name);
  meta.set("seed", std::to_string(seed));
  meta.set("T_ref_C", std::to_string(m.T_ref_C));
  meta.set("frame", "FRD body (f_ref, w_ref: the true specific force and rate)");
  return meta;
}

nlohmann::json simulate_vehicle_log(const TrajectoryFile& tf, const model::SensorModel& m, std::uint64_t seed,
                                    io::LogWriter& out) {
  const VehicleTruth truth = vehicle_truth(tf, m);
  std::vector<RawSample> raw;
  nlohmann::json realised;
  vehicle_raw(truth, m, seed, truth.states.size(), raw, &realised);
  io::LogRow row;
  nlohmann::json path = nlohmann::json::array();
  const std::size_t per_s = static_cast<std::size_t>(std::max(1.0, std::round(truth.rate_hz)));
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const physics::VehicleState& st = truth.states[i];
    row.t_s = st.t_s;
    row.segment = -1;
    row.temp_C = truth.temp_C[i];
    row.chamber_C = tf.ambient_C;
    row.has_ref = true;
    for (int j = 0; j < 3; ++j) {
      row.f_ref[j] = st.f_b[j];
      row.w_ref[j] = st.w_b[j];
    }
    for (int c = 0; c < 6; ++c) row.raw[c] = raw[i][static_cast<std::size_t>(c)];
    out.write(row);
    if (i % per_s == 0) {
      const Eigen::Matrix3d C = st.q_nb.toRotationMatrix();
      path.push_back({{"t_s", st.t_s}, {"lat_deg", st.pos.lat_rad * 180 / M_PI}, {"lon_deg", st.pos.lon_rad * 180 / M_PI},
                      {"h_m", st.pos.h_m}, {"v_ned_mps", {st.v_ned.x(), st.v_ned.y(), st.v_ned.z()}},
                      {"heading_deg", std::atan2(C(1, 0), C(0, 0)) * 180 / M_PI}, {"segment", st.segment}});
    }
  }
  nlohmann::json segs = nlohmann::json::array();
  for (std::size_t k = 0; k < tf.trajectory.segments().size(); ++k)
    segs.push_back({{"id", k}, {"t0_s", tf.trajectory.segment_start_s(k)}, {"t1_s", tf.trajectory.segment_end_s(k)},
                    {"label", tf.trajectory.segments()[k].label}});
  return {{"format", "imuforge-truth"}, {"version", 1}, {"sensor", m.name}, {"trajectory", tf.name}, {"seed", seed},
          {"sample_rate_hz", truth.rate_hz}, {"T_ref_C", m.T_ref_C}, {"realised", realised}, {"segments", segs},
          {"path_1hz", path}, {"rows", raw.size()}};
}

}  // namespace imuforge::sim
