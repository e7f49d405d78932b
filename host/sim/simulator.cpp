#include "host/sim/simulator.h"

#include <cmath>
#include <stdexcept>

#include "host/model/measure.h"
#include "host/physics/earth.h"
#include "host/physics/units.h"
#include "host/sim/noise.h"
#include "host/sim/sensor_chain.h"
#include "host/physics/timeline.h"

namespace imuforge::sim {

using namespace physics;  // the simulator samples the physics part throughout

using model::Effect;
using model::Sensor;
using nlohmann::json;

namespace {

using physics::kDeg;  // host/physics/units.h

struct SimExtras {
  double encoder_noise_rad = 0, rate_noise_rad_s = 0, temp_noise_C = 0, chamber_noise_C = 0;
  std::array<AxisError, kMaxTableAxes> axis_err{};
  Eigen::Vector3d mount_err = Eigen::Vector3d::Zero();
};

double jnum(const json& o, const char* k, const std::string& where) {
  auto it = o.find(k);
  if (it == o.end()) return 0.0;
  if (!it->is_number()) throw std::invalid_argument(where + "." + k + ": expected a number");
  return it->get<double>();
}

SimExtras parse_extras(const Campaign& c, bool use_errors) {
  SimExtras x;
  if (c.simulation_json.empty()) return x;
  const json s = json::parse(c.simulation_json);
  if (!s.is_object()) throw std::invalid_argument("simulation: expected an object");
  for (auto it = s.begin(); it != s.end(); ++it) {
    const std::string& k = it.key();
    if (!k.empty() && k[0] == '_') continue;
    if (k != "encoder_noise_deg" && k != "rate_noise_dps" && k != "temp_noise_C" && k != "chamber_noise_C" &&
        k != "fixture_errors")
      throw std::invalid_argument("simulation: unknown key '" + k + "'");
  }
  x.encoder_noise_rad = jnum(s, "encoder_noise_deg", "simulation") * kDeg;
  x.rate_noise_rad_s = jnum(s, "rate_noise_dps", "simulation") * kDeg;
  x.temp_noise_C = jnum(s, "temp_noise_C", "simulation");
  x.chamber_noise_C = jnum(s, "chamber_noise_C", "simulation");
  if (x.encoder_noise_rad < 0 || x.rate_noise_rad_s < 0 || x.temp_noise_C < 0 || x.chamber_noise_C < 0)
    throw std::invalid_argument("simulation: noise levels must be >= 0");
  if (use_errors && s.contains("fixture_errors")) {
    const json& fe = s["fixture_errors"];
    if (fe.contains("axes")) {
      const json& ax = fe["axes"];
      if (!ax.is_array() || ax.size() > c.axes.size())
        throw std::invalid_argument("simulation.fixture_errors.axes: at most one entry per table axis");
      for (std::size_t i = 0; i < ax.size(); ++i) {
        std::string w = "simulation.fixture_errors.axes[" + std::to_string(i) + "]";
        x.axis_err[i].tilt_a_rad = jnum(ax[i], "tilt_a_deg", w) * kDeg;
        x.axis_err[i].tilt_b_rad = jnum(ax[i], "tilt_b_deg", w) * kDeg;
        x.axis_err[i].zero_rad = jnum(ax[i], "zero_deg", w) * kDeg;
      }
    }
    if (fe.contains("mount_error_deg")) {
      const json& me = fe["mount_error_deg"];
      if (!me.is_array() || me.size() != 3 || !me[0].is_number() || !me[1].is_number() || !me[2].is_number())
        throw std::invalid_argument("simulation.fixture_errors.mount_error_deg: expected 3 numbers");
      for (int i = 0; i < 3; ++i) x.mount_err[i] = me[static_cast<std::size_t>(i)].get<double>() * kDeg;
    }
  }
  return x;
}

}  // namespace

io::LogMeta make_log_meta(const Campaign& c, const model::SensorModel& m, const SimOptions& opt) {
  io::LogMeta meta;
  meta.serial = opt.serial;
  meta.sample_rate_hz = opt.sample_rate_hz > 0 ? opt.sample_rate_hz : c.sample_rate_hz;
  meta.accel_lsb_mps2 = m.triad(Sensor::kAccel).lsb;
  meta.gyro_lsb_rad_s = m.triad(Sensor::kGyro).lsb;
  meta.accel_bits = m.triad(Sensor::kAccel).bits;  // the output stage clamps to this word (to_counts)
  meta.gyro_bits = m.triad(Sensor::kGyro).bits;
  meta.latitude_deg = c.latitude_deg;
  meta.height_m = c.height_m;
  meta.gravity_mps2 = normal_gravity_mps2(Site{c.latitude_deg, c.height_m});
  meta.table_axes = static_cast<int>(c.axes.size());
  meta.set("source", "imuforge-simulate");
  meta.set("campaign", c.name);
  meta.set("sensor", m.name);
  meta.set("seed", std::to_string(opt.seed));
  meta.set("T_ref_C", std::to_string(m.T_ref_C));
  meta.set("frame", "NED");
  return meta;
}

SimSummary simulate(const Campaign& c, const model::SensorModel& m, const SimOptions& opt, io::LogWriter& out) {
  return simulate(c, m, opt, [&out](const io::LogRow& r) { out.write(r); });
}

SimSummary simulate(const Campaign& c, const model::SensorModel& m, const SimOptions& opt,
                    const std::function<void(const io::LogRow&)>& sink) {
  const double fs = opt.sample_rate_hz > 0 ? opt.sample_rate_hz : c.sample_rate_hz;
  if (!(fs > 0) || fs > 1e6) throw std::invalid_argument("sample rate must be in (0, 1e6] Hz");
  const double dt = 1.0 / fs;
  const Timeline tl = build_timeline(c);
  const SimExtras ex = parse_extras(c, opt.use_campaign_fixture_errors);

  TableGeometry geom_true = geometry_from_campaign(c);
  for (std::size_t i = 0; i < kMaxTableAxes; ++i) geom_true.axes[i].error = ex.axis_err[i];
  geom_true.mount.rot_error_rad = ex.mount_err;
  const TableGeometry geom_nom_g = geom_true.nominal();
  const PreparedTable geom_nom(geom_nom_g), geom_tru(geom_true);
  const Site site{c.latitude_deg, c.height_m};
  const Eigen::Vector3d g_ned = gravity_ned(site), wie_ned = earth_rate_ned(site);

  // Turn-on bias and noise streams live in the sensor chain (shared with the vehicle simulator); the
  // fixture's encoder and temperature noise have a stream of their own.
  Rng rng_fix(opt.seed * 0x9E3779B97F4A7C15ULL + 2);
  SensorChain chain(m, dt, opt.seed);
  const model::ParamSet P = m.effective_params();
  const model::CompiledTriad tri[2] = {chain.triad(Sensor::kAccel), chain.triad(Sensor::kGyro)};
  json realised = chain.realised();
  const double lat_s[2] = {tri[0].latency_s, tri[1].latency_s};
  const double ppm[2] = {tri[0].ppm * 1e-6, tri[1].ppm * 1e-6};
  const bool shifted[2] = {lat_s[0] != 0 || ppm[0] != 0, lat_s[1] != 0 || ppm[1] != 0};
  // Accelerometer and gyro usually share one sample clock: evaluate the shifted motion once.
  const bool same_shift = shifted[0] && shifted[1] && lat_s[0] == lat_s[1] && ppm[0] == ppm[1];
  const model::MeasureOptions mopt{false};  // timing realised exactly by the time shift below

  // Thermal state.
  const auto& th = m.thermal;
  const double a_ch = 1.0 - std::exp(-dt / c.chamber_tau_s);
  const double a_die = 1.0 - std::exp(-dt / th.die_tau_s);
  double sp = c.initial_C, air = c.initial_C, die = c.initial_C;
  std::size_t sp_idx = 0;
  double sp_target = c.initial_C, sp_slew = 0;
  model::HysteresisTracker hyst(th.hysteresis_threshold_C);

  double sim_s = tl.duration_s;
  if (opt.max_duration_s > 0) sim_s = std::min(sim_s, opt.max_duration_s);
  const std::uint64_t n_rows = static_cast<std::uint64_t>(std::floor(sim_s * fs + 1e-9));
  std::size_t cur_true = 0, cur_a = 0, cur_g = 0;
  io::LogRow row;
  model::MeasureInput in;
  const int n_axes = static_cast<int>(c.axes.size());

  auto kin_at = [&](double t, std::size_t& cur, MotionSample* ms_out) {
    MotionSample ms = sample_motion(tl, t, cur);
    // Hand-held poses: the IMU is off the table, so lever arm and mount do not apply.
    ImuKinematics k = ms.free ? free_kinematics(ms.C_imu_ned, ms.w_nb_imu, ms.wdot_nb_imu, g_ned, wie_ned)
                              : table_kinematics(geom_tru, ms.table, g_ned, wie_ned);
    if (ms_out) *ms_out = ms;
    return k;
  };

  for (std::uint64_t i = 0; i < n_rows; ++i) {
    const double t = static_cast<double>(i) * dt;
    // --- thermal: values at t, then advance to t + dt
    while (sp_idx < tl.setpoints.size() && tl.setpoints[sp_idx].t0 <= t) {
      sp_target = tl.setpoints[sp_idx].target_C;
      sp_slew = tl.setpoints[sp_idx].slew_C_s;
      ++sp_idx;
    }
    const double self = th.self_heating_C * (1.0 - std::exp(-t / th.self_heating_tau_s));
    const double die_target = air + self;
    const double Tdot = (die_target - die) / th.die_tau_s;
    const double d = hyst.update(die);

    // --- motion: true kinematics (per sensor at its shifted time), reference from reported table
    MotionSample ms;
    ImuKinematics k0 = kin_at(t, cur_true, &ms);
    ImuKinematics ks;
    for (int s = 0; s < 2; ++s) {
      if (shifted[s] && !(s == 1 && same_shift)) ks = kin_at(t - lat_s[s] - ppm[s] * t, s ? cur_g : cur_a, nullptr);
      const ImuKinematics& k = shifted[s] ? ks : k0;
      in.f = k.f_mps2;
      in.w = k.w_rad_s;
      in.wdot = k.wdot_rad_s2;
      in.T_C = die;
      in.Tdot_C_s = Tdot;
      in.d = d;
      in.t_s = t;
      chain.counts(static_cast<Sensor>(s), model::measure(tri[s], in, mopt), row.raw + 3 * s);
    }
    row.t_s = t;
    row.segment = ms.entry->segment;
    row.has_ref = ms.entry->has_ref && !ms.free;
    for (int a = 0; a < 3; ++a) {
      row.table_angle_rad[a] = std::nan("");
      row.table_rate_rad_s[a] = std::nan("");
    }
    if (!ms.free && n_axes > 0) {
      TableState rep = ms.table;
      for (int a = 0; a < n_axes; ++a) {
        if (ex.encoder_noise_rad > 0) rep.angle_rad[static_cast<std::size_t>(a)] += ex.encoder_noise_rad * rng_fix.normal();
        if (ex.rate_noise_rad_s > 0) rep.rate_rad_s[static_cast<std::size_t>(a)] += ex.rate_noise_rad_s * rng_fix.normal();
        row.table_angle_rad[a] = rep.angle_rad[static_cast<std::size_t>(a)];
        row.table_rate_rad_s[a] = rep.rate_rad_s[static_cast<std::size_t>(a)];
      }
      if (row.has_ref) {
        const ImuKinematics kr = table_kinematics(geom_nom, rep, g_ned, wie_ned);
        for (int j = 0; j < 3; ++j) {
          row.f_ref[j] = kr.f_mps2[j];
          row.w_ref[j] = kr.w_rad_s[j];
        }
      }
    }
    if (!row.has_ref)
      for (int j = 0; j < 3; ++j) row.f_ref[j] = row.w_ref[j] = 0.0;
    row.temp_C = die + (ex.temp_noise_C > 0 ? ex.temp_noise_C * rng_fix.normal() : 0.0);
    row.chamber_C = air + (ex.chamber_noise_C > 0 ? ex.chamber_noise_C * rng_fix.normal() : 0.0);
    sink(row);

    // advance thermal state
    if (sp < sp_target) sp = std::min(sp_target, sp + sp_slew * dt);
    else if (sp > sp_target) sp = std::max(sp_target, sp - sp_slew * dt);
    die += (die_target - die) * a_die;
    air += (sp - air) * a_ch;
  }

  SimSummary sum;
  sum.rows = n_rows;
  sum.duration_s = static_cast<double>(n_rows) / fs;
  sum.segments = static_cast<int>(tl.segments.size());
  json params = json::object();
  for (const auto& p : model::params()) params[p.name] = P[p.id];
  json enabled = json::array();
  for (int s = 0; s < 2; ++s)
    for (int e = 0; e < model::kNumEffects; ++e)
      if (m.enabled[static_cast<std::size_t>(s)][static_cast<std::size_t>(e)])
        enabled.push_back(std::string(model::sensor_name(static_cast<Sensor>(s))) + "." +
                          model::effect_info(static_cast<Effect>(e)).name);
  json fixture = json::object();
  for (int a = 0; a < n_axes; ++a)
    for (int part = 0; part < 3; ++part)
      fixture[physics::axis_error_name(a, part)] = geom_true.axes[static_cast<std::size_t>(a)].error.part(part);
  fixture["fixture.mount.rx"] = ex.mount_err.x();
  fixture["fixture.mount.ry"] = ex.mount_err.y();
  fixture["fixture.mount.rz"] = ex.mount_err.z();
  json segs = json::array();
  for (const auto& s : tl.segments)
    segs.push_back({{"id", s.id}, {"t0_s", s.t0}, {"t1_s", s.t1}, {"phase", s.phase}, {"kind", s.kind},
                    {"label", s.label}, {"has_ref", s.has_ref}});
  sum.truth = {{"format", "imuforge-truth"},
               {"version", 1},
               {"sensor", m.name},
               {"campaign", c.name},
               {"seed", opt.seed},
               {"sample_rate_hz", fs},
               {"T_ref_C", m.T_ref_C},
               {"enabled", enabled},
               {"parameters", params},
               {"realised", realised},
               {"fixture", fixture},
               {"thermal", {{"die_tau_s", th.die_tau_s},
                            {"self_heating_C", th.self_heating_C},
                            {"self_heating_tau_s", th.self_heating_tau_s},
                            {"hysteresis_threshold_C", th.hysteresis_threshold_C}}},
               {"segments", segs},
               {"rows", n_rows},
               {"duration_s", sum.duration_s}};
  return sum;
}

}  // namespace imuforge::sim
