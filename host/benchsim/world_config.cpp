#include "host/io/campaign_file.h"
#include "host/benchsim/world_config.h"
#include "host/physics/units.h"

#include <algorithm>
#include <fstream>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"

namespace imuforge::benchsim {

namespace {
using physics::kDeg;  // host/physics/units.h
}

void apply_world_json(WorldConfig& wc, const nlohmann::json& j, const std::string& origin) {
  if (!j.is_object()) throw std::runtime_error(origin + ": the world file must be a JSON object");
  static const std::set<std::string> keys = {
      "axes", "axis_names", "max_rate_dps", "max_accel_dps2", "in_position_deg", "settle_s", "initial_C",
      "ramp_C_per_min", "max_ramp_C_per_min", "chamber_tau_s", "at_setpoint_band_C", "die_tau_s",
      "self_heating_C", "self_heating_tau_s", "latitude_deg", "height_m", "dt_s", "mount_ypr_deg", "lever_arm_m"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!keys.count(it.key())) throw std::runtime_error(origin + ": unknown key '" + it.key() + "'");
  try {
    wc.axes = j.value("axes", wc.axes);
    if (j.contains("axis_names"))
      for (size_t i = 0; i < 3 && i < j["axis_names"].size(); ++i) wc.axis_names[i] = j["axis_names"][i].get<std::string>();
    if (j.contains("max_rate_dps")) wc.max_rate_rad_s = j["max_rate_dps"].get<double>() * kDeg;
    if (j.contains("max_accel_dps2")) wc.max_accel_rad_s2 = j["max_accel_dps2"].get<double>() * kDeg;
    if (j.contains("in_position_deg")) wc.in_position_rad = j["in_position_deg"].get<double>() * kDeg;
    wc.settle_s = j.value("settle_s", wc.settle_s);
    wc.initial_C = j.value("initial_C", wc.initial_C);
    wc.ramp_C_per_min = j.value("ramp_C_per_min", wc.ramp_C_per_min);
    wc.max_ramp_C_per_min = j.value("max_ramp_C_per_min", wc.max_ramp_C_per_min);
    wc.chamber_tau_s = j.value("chamber_tau_s", wc.chamber_tau_s);
    wc.at_setpoint_band_C = j.value("at_setpoint_band_C", wc.at_setpoint_band_C);
    wc.die_tau_s = j.value("die_tau_s", wc.die_tau_s);
    wc.self_heating_C = j.value("self_heating_C", wc.self_heating_C);
    wc.self_heating_tau_s = j.value("self_heating_tau_s", wc.self_heating_tau_s);
    wc.latitude_deg = j.value("latitude_deg", wc.latitude_deg);
    wc.height_m = j.value("height_m", wc.height_m);
    wc.dt_s = j.value("dt_s", wc.dt_s);
    if (j.contains("mount_ypr_deg")) wc.mount_ypr_deg = j["mount_ypr_deg"].get<std::array<double, 3>>();
    if (j.contains("lever_arm_m")) wc.lever_arm_m = j["lever_arm_m"].get<std::array<double, 3>>();
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(origin + ": a field has the wrong type: " + e.what());
  }
  if (wc.axes < 1 || wc.axes > 3) throw std::runtime_error(origin + ": 'axes' must be 1..3");
  if (!(wc.dt_s > 0 && wc.dt_s <= 0.01)) throw std::runtime_error(origin + ": 'dt_s' must be in (0, 0.01]");
}

WorldConfig world_config(const std::string& campaign_path, const std::string& world_json_path,
                         const std::string& sensor_path, uint64_t seed) {
  WorldConfig wc;
  wc.seed = seed;
  if (!campaign_path.empty()) {
    physics::Campaign c;
    try {
      c = io::load_campaign(campaign_path);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string("campaign: ") + e.what());
    }
    wc.axes = static_cast<int>(c.axes.size());
    for (size_t i = 0; i < c.axes.size() && i < 3; ++i) {
      wc.axis_names[i] = c.axes[i].axis;
      wc.axis_max_rate_rad_s[i] = c.axes[i].max_rate_dps * kDeg;
      wc.axis_max_accel_rad_s2[i] = c.axes[i].max_accel_dps2 * kDeg;
    }
    wc.mount_ypr_deg = c.mount_rotation_deg;
    wc.lever_arm_m = c.lever_arm_m;
    wc.settle_s = c.settle_s;
    wc.initial_C = c.initial_C;
    wc.ramp_C_per_min = c.ramp_limit_C_per_min;
    wc.max_ramp_C_per_min = std::max(wc.max_ramp_C_per_min, c.ramp_limit_C_per_min);
    wc.chamber_tau_s = c.chamber_tau_s;
    wc.latitude_deg = c.latitude_deg;
    wc.height_m = c.height_m;
  }
  if (!sensor_path.empty()) {
    model::SensorModel m;
    try {
      m = model::load_sensor_model(sensor_path);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string("sensor: ") + e.what());
    }
    wc.die_tau_s = m.thermal.die_tau_s;
    wc.self_heating_C = m.thermal.self_heating_C;
    wc.self_heating_tau_s = m.thermal.self_heating_tau_s;
  }
  if (!world_json_path.empty()) {
    std::ifstream in(world_json_path);
    if (!in) throw std::runtime_error(world_json_path + ": cannot open");
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw std::runtime_error(world_json_path + ": not valid JSON: " + e.what());
    }
    apply_world_json(wc, j, world_json_path);
  }
  return wc;
}

}  // namespace imuforge::benchsim
