// Shared by the diagnosis tests: campaigns and sensors built in code, simulated in-process.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "host/io/campaign_file.h"
#include "host/diagnosis/diagnose.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/sim/simulator.h"

namespace diagtest {

using nlohmann::json;
namespace dg = imuforge::diagnosis;

inline json pos(double a, double b, double c, double dwell, const std::string& label = "") {
  return {{"type", "position"}, {"label", label}, {"position_deg", {a, b, c}}, {"dwell_s", dwell}};
}
inline json rate(double outer_dps, double dwell) {
  return {{"type", "rate"}, {"label", "rate"}, {"rate_dps", {0.0, 0.0, outer_dps}}, {"dwell_s", dwell}};
}

// The rich campaign: faces, a 45° tumble, rate runs about body and diagonal axes at two magnitudes, sines.
inline json rich_campaign(const std::vector<double>& plateaus_C, double fs_hz) {
  json steps = json::array();
  const double faces[6][3] = {{0, 0, 0}, {0, 180, 0}, {0, 90, 0}, {180, 90, 0}, {90, 90, 0}, {270, 90, 0}};
  for (auto& f : faces) steps.push_back(pos(f[0], f[1], f[2], 3));
  for (double mid : {45.0, 135.0})
    for (double inner : {0.0, 90.0, 180.0, 270.0}) steps.push_back(pos(inner, mid, 0, 3));
  for (double inner : {45.0, 135.0, 225.0, 315.0}) steps.push_back(pos(inner, 90, 0, 3));
  // 30° / 60° tilts: more input levels separate u², |u| (asymmetry) and u³.
  for (double mid : {30.0, 60.0, 120.0, 150.0})
    for (double inner : {0.0, 90.0}) steps.push_back(pos(inner, mid, 0, 3));
  const double rate_pos[6][2] = {{0, 0}, {90, 90}, {0, 90}, {0, 45}, {90, 45}, {45, 90}};
  for (auto& rp : rate_pos) {
    steps.push_back(pos(rp[0], rp[1], 0, 1));
    for (double r : {60.0, -60.0, 200.0, -200.0}) steps.push_back(rate(r, 3));
    steps.push_back(rate(0.0, 1));
  }
  steps.push_back(pos(0, 45, 0, 1));
  steps.push_back({{"type", "sine"}, {"label", "sine inner"}, {"amplitude_deg", {30.0, 0.0, 0.0}}, {"frequency_hz", {0.5, 0.0, 0.0}}, {"dwell_s", 6}});
  steps.push_back({{"type", "sine"}, {"label", "sine middle"}, {"amplitude_deg", {0.0, 20.0, 0.0}}, {"frequency_hz", {0.0, 0.7, 0.0}}, {"dwell_s", 6}});
  json phases = json::array();
  for (double T : plateaus_C) phases.push_back({{"type", "plateau"}, {"label", "p"}, {"setpoint_C", T}, {"soak_s", 15}, {"steps", steps}});
  return {{"format", "imuforge-campaign"}, {"version", 1}, {"name", "rich"}, {"site", {{"latitude_deg", 45.0}, {"height_m", 100.0}}},
          {"sample_rate_hz", fs_hz},
          {"table", {{"axes", {{{"name", "inner"}, {"axis", "z"}, {"max_rate_dps", 400}, {"max_accel_dps2", 600}},
                               {{"name", "middle"}, {"axis", "x"}, {"max_rate_dps", 300}, {"max_accel_dps2", 600}},
                               {{"name", "outer"}, {"axis", "z"}, {"max_rate_dps", 400}, {"max_accel_dps2", 600}}}},
                     {"settle_s", 0.3},
                     {"mount", {{"rotation_deg", {0, 0, 0}}, {"lever_arm_m", {0.0, 0.0, 0.0}}}}}},
          {"chamber", {{"initial_C", plateaus_C.front()}, {"ramp_limit_C_per_min", 60}, {"tau_s", 5}}},
          {"phases", phases},
          {"simulation", {{"encoder_noise_deg", 0.0}, {"rate_noise_dps", 0.0}, {"temp_noise_C", 0.0}, {"chamber_noise_C", 0.0}}}};
}

// The thermal campaign: plateaus with faces and rates, joined by chamber ramps of different rates.
inline json thermal_campaign(double fs_hz) {
  json steps = json::array();
  const double faces[6][3] = {{0, 0, 0}, {0, 180, 0}, {0, 90, 0}, {180, 90, 0}, {90, 90, 0}, {270, 90, 0}};
  for (auto& f : faces) steps.push_back(pos(f[0], f[1], f[2], 4));
  steps.push_back(pos(0, 0, 0, 1));
  for (double r : {90.0, -90.0}) steps.push_back(rate(r, 4));
  steps.push_back(rate(0.0, 1));
  json phases = json::array();
  auto plateau = [&](double T) { phases.push_back({{"type", "plateau"}, {"label", "p"}, {"setpoint_C", T}, {"soak_s", 60}, {"steps", steps}}); };
  auto ramp = [&](double T, double r) { phases.push_back({{"type", "ramp"}, {"label", "r"}, {"setpoint_C", T}, {"rate_C_per_min", r}}); };
  plateau(25);
  ramp(37, 3.0);
  plateau(37);
  ramp(17, 4.0);
  plateau(17);
  ramp(30, 1.5);
  plateau(30);
  ramp(22, 2.0);
  plateau(22);
  return {{"format", "imuforge-campaign"}, {"version", 1}, {"name", "thermal"}, {"site", {{"latitude_deg", 45.0}, {"height_m", 100.0}}},
          {"sample_rate_hz", fs_hz},
          {"table", {{"axes", {{{"name", "inner"}, {"axis", "z"}, {"max_rate_dps", 400}, {"max_accel_dps2", 600}},
                               {{"name", "middle"}, {"axis", "x"}, {"max_rate_dps", 300}, {"max_accel_dps2", 600}},
                               {{"name", "outer"}, {"axis", "z"}, {"max_rate_dps", 400}, {"max_accel_dps2", 600}}}},
                     {"settle_s", 0.3},
                     {"mount", {{"rotation_deg", {0, 0, 0}}, {"lever_arm_m", {0.0, 0.0, 0.0}}}}}},
          {"chamber", {{"initial_C", 25}, {"ramp_limit_C_per_min", 6}, {"tau_s", 10}}},
          {"phases", phases},
          {"simulation", {{"encoder_noise_deg", 0.0}, {"rate_noise_dps", 0.0}, {"temp_noise_C", 0.0}, {"chamber_noise_C", 0.0}}}};
}

// A sensor with the basic effects, bias_temp (optional) and white noise; `extra` adds/overrides effects.
inline json base_sensor(bool with_bias_temp, const json& extra = json::object()) {
  json eff = {
      {"accel.bias", {{"x", 0.05}, {"y", -0.03}, {"z", 0.08}}},
      {"accel.scale", {{"x", 0.002}, {"y", -0.001}, {"z", 0.0015}}},
      {"accel.misalign", {{"xy", 0.001}, {"xz", -0.0005}, {"yx", 0.0007}, {"yz", 0.0012}, {"zx", -0.0009}, {"zy", 0.0004}}},
      {"gyro.bias", {{"x", 0.003}, {"y", -0.002}, {"z", 0.001}}},
      {"gyro.scale", {{"x", 0.001}, {"y", -0.002}, {"z", 0.0012}}},
      {"gyro.misalign", {{"xy", 0.0008}, {"xz", -0.0006}, {"yx", 0.0004}, {"yz", 0.001}, {"zx", -0.0007}, {"zy", 0.0005}}},
      {"accel.white_noise", {{"x", 0.002}, {"y", 0.002}, {"z", 0.002}}},
      {"gyro.white_noise", {{"x", 2e-4}, {"y", 2e-4}, {"z", 2e-4}}}};
  if (with_bias_temp) {
    eff["accel.bias_temp"] = {{"x.t1", 0.002}, {"y.t1", -0.001}, {"z.t1", 0.0015}};
    eff["gyro.bias_temp"] = {{"x.t1", 1e-4}, {"y.t1", -5e-5}, {"z.t1", 8e-5}};
  }
  for (auto it = extra.begin(); it != extra.end(); ++it) {
    if (!eff.contains(it.key())) eff[it.key()] = json::object();
    for (auto c = it.value().begin(); c != it.value().end(); ++c) eff[it.key()][c.key()] = c.value();
  }
  return {{"format", "imuforge-sensor"}, {"version", 1}, {"name", "battery"}, {"T_ref_C", 25},
          {"accel", {{"lsb", 1e-4}, {"bits", 24}}}, {"gyro", {{"lsb", 1e-5}, {"bits", 24}}},
          {"thermal", {{"die_tau_s", 8}, {"self_heating_C", 0}, {"self_heating_tau_s", 30}, {"hysteresis_threshold_C", 0.5}, {"dTdt_window_s", 10}}},
          {"effects", eff}};
}

// Simulates in-process and converts to diagnosis samples (SI outputs). with_table: the reported table angles and
// rates too (what a log carries; the diagnosis's unexplained signature and its table-error estimate read them).
inline std::vector<dg::Sample> simulate(const json& campaign, const json& sensor, std::uint64_t seed, bool with_table = false) {
  const auto c = imuforge::io::campaign_from_json(campaign);
  const auto m = imuforge::model::sensor_model_from_json(sensor);
  imuforge::sim::SimOptions o;
  o.seed = seed;
  std::vector<dg::Sample> out;
  const double la = m.triad(imuforge::model::Sensor::kAccel).lsb, lg = m.triad(imuforge::model::Sensor::kGyro).lsb;
  imuforge::sim::simulate(c, m, o, [&](const imuforge::io::LogRow& r) {
    dg::Sample s;
    s.t_s = r.t_s;
    s.segment = r.segment;
    s.temp_C = r.temp_C;
    s.has_ref = r.has_ref;
    for (int k = 0; k < 3; ++k) {
      s.f[k] = r.f_ref[k];
      s.w[k] = r.w_ref[k];
      s.y[k] = r.raw[k] * la;
      s.y[k + 3] = r.raw[k + 3] * lg;
      if (with_table) {
        s.table_angle_rad[k] = r.table_angle_rad[k];
        s.table_rate_rad_s[k] = r.table_rate_rad_s[k];
      }
    }
    out.push_back(s);
  });
  return out;
}

inline dg::BaseModel thermal_base() {
  using namespace imuforge::model;
  dg::BaseModel b = dg::basic_model();
  for (Sensor s : {Sensor::kAccel, Sensor::kGyro}) {
    for (ParamId id : effect_params(s, Effect::kBiasTemp)) {
      const auto& c = param_info(id).component;
      if (c.size() > 3 && (c.substr(c.size() - 2) == "t1" || c.substr(c.size() - 2) == "t2")) b.params.push_back(id);
    }
    b.effect_names.push_back(std::string(sensor_name(s)) + ".bias_temp");
  }
  return b;
}

}  // namespace diagtest
