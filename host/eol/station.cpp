#include "host/eol/station.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "host/can/bus_budget.h"
#include "host/io/input_error.h"

namespace imuforge::eol {

namespace {
template <typename T>
T get_or(const nlohmann::json& j, const char* key, T def, const std::string& where) {
  if (!j.contains(key)) return def;
  try {
    return j.at(key).get<T>();
  } catch (const std::exception& e) {
    throw StationError("station: " + where + key + ": " + e.what());
  }
}

std::array<double, 3> vec3(const nlohmann::json& j, const std::string& where) {
  std::array<double, 3> v{};
  if (!j.is_array() || j.size() > 3) throw StationError("station: " + where + ": expected an array of up to 3 numbers");
  for (std::size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number()) throw StationError("station: " + where + ": expected numbers");
    v[i] = j[i].get<double>();
  }
  return v;
}
}  // namespace

const ParamLimit* StationConfig::limit_for(const std::string& param) const {
  // Exact name first; else the longest pattern that is a prefix: "accel.bias" (at a '.' boundary, as in
  // the solver's sigma spec) or "accel.bias*" (any continuation).
  const ParamLimit* best = nullptr;
  std::size_t best_len = 0;
  for (const auto& l : limits) {
    if (l.pattern == param) return &l;
    std::string prefix = l.pattern;
    bool star = !prefix.empty() && prefix.back() == '*';
    if (star) prefix.pop_back();
    bool match = param.compare(0, prefix.size(), prefix) == 0 && param.size() > prefix.size() &&
                 (star || param[prefix.size()] == '.');
    if (match && (best == nullptr || prefix.size() > best_len)) {
      best = &l;
      best_len = prefix.size();
    }
  }
  return best;
}

const StationSlot* StationConfig::slot(const std::string& n) const {
  for (const auto& s : slots)
    if (s.name == n) return &s;
  return nullptr;
}

namespace {
void parse_slots(const nlohmann::json& j, StationConfig& s) {
  if (!j.is_array() || j.empty()) throw StationError("station: slots must be a non-empty array of objects");
  std::map<std::string, std::set<int>> nodes;
  std::set<std::string> names;
  for (std::size_t k = 0; k < j.size(); ++k) {
    const auto& o = j[k];
    const std::string w = "slots[" + std::to_string(k) + "].";
    if (!o.is_object()) throw StationError("station: " + w + ": expected an object");
    for (auto it = o.begin(); it != o.end(); ++it)
      if (it.key() != "name" && it.key() != "node_id" && it.key() != "bus" && it.key() != "mount_rotation_deg" &&
          it.key() != "lever_arm_m" && it.key() != "mount_sigma_deg" && it.key()[0] != '_')
        throw StationError("station: " + w + it.key() + ": unknown key (expected name, node_id, bus, "
                           "mount_rotation_deg, lever_arm_m, mount_sigma_deg)");
    StationSlot sl;
    char def[16];
    std::snprintf(def, sizeof def, "slot%02zu", k + 1);
    sl.name = get_or<std::string>(o, "name", def, w);
    sl.node_id = get_or<int>(o, "node_id", static_cast<int>(k) + 1, w);
    sl.bus = get_or<std::string>(o, "bus", s.can_bus, w);
    if (sl.node_id < 1 || sl.node_id > 127) throw StationError("station: " + w + "node_id must be in 1..127");
    if (!names.insert(sl.name).second) throw StationError("station: " + w + "name: '" + sl.name + "' is used twice");
    if (!nodes[sl.bus].insert(sl.node_id).second)
      throw StationError("station: " + w + "node_id: node " + std::to_string(sl.node_id) + " is used twice on " + sl.bus);
    if (o.contains("mount_rotation_deg")) sl.mount_rotation_deg = vec3(o["mount_rotation_deg"], w + "mount_rotation_deg");
    if (o.contains("lever_arm_m")) sl.lever_arm_m = vec3(o["lever_arm_m"], w + "lever_arm_m");
    sl.has_geometry = o.contains("mount_rotation_deg") || o.contains("lever_arm_m");
    if (o.contains("mount_sigma_deg")) {
      const auto& m = o["mount_sigma_deg"];
      if (m.is_number()) sl.mount_sigma_deg = {m.get<double>(), m.get<double>(), m.get<double>()};
      else sl.mount_sigma_deg = vec3(m, w + "mount_sigma_deg");
      for (double v : sl.mount_sigma_deg)
        if (!(v >= 0)) throw StationError("station: " + w + "mount_sigma_deg must be >= 0");
    }
    s.slots.push_back(sl);
  }
  // The bus budget, before anything moves.
  std::map<std::string, int> per_bus;
  for (const auto& sl : s.slots) ++per_bus[sl.bus];
  std::vector<can::BusPlan> plan;
  for (const auto& [bus, n] : per_bus) plan.push_back({bus, n});
  can::BusTiming t;
  t.fd = s.can_fd;
  t.nominal_bit_s = s.can_bitrate;
  t.data_bit_s = s.can_data_bitrate;
  const can::BudgetVerdict v = can::check_budget(t, plan, s.stream_rate_hz, s.bus_load_limit);
  if (!v.ok) throw StationError("station: " + v.message);
}
}  // namespace

StationConfig station_from_json(const nlohmann::json& j, const std::string& dir) {
  if (!j.is_object()) throw StationError("station: the file must hold a JSON object");
  StationConfig s;
  s.dir = dir;
  s.name = get_or<std::string>(j, "name", s.name, "");
  if (j.contains("fixtures")) s.fixtures = j["fixtures"];
  if (j.contains("can")) {
    const auto& c = j["can"];
    s.can_bus = get_or<std::string>(c, "bus", s.can_bus, "can.");
    s.can_node_id = get_or<int>(c, "node_id", s.can_node_id, "can.");
    s.stream_rate_hz = get_or<double>(c, "stream_rate_hz", s.stream_rate_hz, "can.");
    s.hmac_key_hex = get_or<std::string>(c, "hmac_key_hex", s.hmac_key_hex, "can.");
    s.can_fd = get_or<bool>(c, "fd", s.can_fd, "can.");
    s.can_bitrate = get_or<double>(c, "bitrate", s.can_bitrate, "can.");
    s.can_data_bitrate = get_or<double>(c, "data_bitrate", s.can_data_bitrate, "can.");
    s.bus_load_limit = get_or<double>(c, "load_limit", s.bus_load_limit, "can.");
    if (!(s.can_bitrate > 0) || !(s.can_data_bitrate > 0)) throw StationError("station: can.bitrate and can.data_bitrate must be > 0");
    if (!(s.bus_load_limit > 0) || s.bus_load_limit > 1) throw StationError("station: can.load_limit must be in (0, 1]");
  }
  if (j.contains("records")) s.db = get_or<std::string>(j["records"], "db", s.db, "records.");
  s.model_path = get_or<std::string>(j, "model", s.model_path, "");
  s.time_scale = get_or<double>(j, "time_scale", s.time_scale, "");
  if (!(s.time_scale > 0)) throw StationError("station: time_scale must be > 0");
  if (j.contains("imu")) {
    s.accel_lsb_mps2 = get_or<double>(j["imu"], "accel_lsb_mps2", 0.0, "imu.");
    s.gyro_lsb_rad_s = get_or<double>(j["imu"], "gyro_lsb_rad_s", 0.0, "imu.");
  }
  s.sensor_hint = get_or<std::string>(j, "sensor", s.sensor_hint, "");
  if (j.contains("noise")) {
    s.accel_noise_mps2 = get_or<double>(j["noise"], "accel_mps2", 0.0, "noise.");
    s.gyro_noise_rad_s = get_or<double>(j["noise"], "gyro_rad_s", 0.0, "noise.");
  }
  if (j.contains("settle")) {
    const auto& t = j["settle"];
    s.settle_window_s = get_or<double>(t, "temp_window_s", s.settle_window_s, "settle.");
    s.settle_slope_C_per_min = get_or<double>(t, "temp_slope_C_per_min", s.settle_slope_C_per_min, "settle.");
    s.settle_band_C = get_or<double>(t, "temp_band_C", s.settle_band_C, "settle.");
    s.settle_timeout_s = get_or<double>(t, "temp_timeout_s", s.settle_timeout_s, "settle.");
    s.table_timeout_s = get_or<double>(t, "table_timeout_s", s.table_timeout_s, "settle.");
  }
  if (j.contains("slots")) parse_slots(j["slots"], s);
  if (j.contains("fixture_tolerance")) {
    if (!j["fixture_tolerance"].is_object())
      throw StationError("station: fixture_tolerance must be an object {\"axes\": .., \"mount_sigma_deg\": ..}");
    s.fixture_tolerance = j["fixture_tolerance"];
  }
  s.early_stop = get_or<bool>(j, "early_stop", s.early_stop, "");
  s.early_stop_sigma_fraction = get_or<double>(j, "early_stop_sigma_fraction", s.early_stop_sigma_fraction, "");
  if (!(s.early_stop_sigma_fraction > 0) || s.early_stop_sigma_fraction > 1)
    throw StationError("station: early_stop_sigma_fraction must be in (0, 1]");
  if (j.contains("limits")) {
    const auto& l = j["limits"];
    if (l.contains("parameters")) {
      if (!l["parameters"].is_object()) throw StationError("station: limits.parameters must be an object");
      for (auto it = l["parameters"].begin(); it != l["parameters"].end(); ++it) {
        std::string w = "limits.parameters[\"" + it.key() + "\"].";
        ParamLimit pl;
        pl.pattern = it.key();
        pl.abs_max = get_or<double>(it.value(), "abs", 0.0, w);
        pl.sigma_max = get_or<double>(it.value(), "sigma", 0.0, w);
        if (pl.abs_max < 0 || pl.sigma_max < 0) throw StationError("station: " + w + " limits must be >= 0");
        s.limits.push_back(pl);
      }
    }
    if (l.contains("verification")) {
      s.verify_accel_mps2 = get_or<double>(l["verification"], "accel_mps2", 0.0, "limits.verification.");
      s.verify_gyro_rad_s = get_or<double>(l["verification"], "gyro_rad_s", 0.0, "limits.verification.");
    }
  }
  if (j.contains("verification")) {
    const auto& v = j["verification"];
    if (!v.is_array()) throw StationError("station: verification must be an array of poses");
    for (std::size_t i = 0; i < v.size(); ++i) {
      std::string w = "verification[" + std::to_string(i) + "]";
      VerificationPose p;
      p.label = get_or<std::string>(v[i], "label", "ver" + std::to_string(i), w + ".");
      if (v[i].contains("position_deg")) p.position_deg = vec3(v[i]["position_deg"], w + ".position_deg");
      if (v[i].contains("rate_dps")) p.rate_dps = vec3(v[i]["rate_dps"], w + ".rate_dps");
      p.dwell_s = get_or<double>(v[i], "dwell_s", p.dwell_s, w + ".");
      if (!(p.dwell_s > 0)) throw StationError("station: " + w + ".dwell_s must be > 0");
      s.verification.push_back(p);
    }
  }
  if (!(s.stream_rate_hz > 0) || s.stream_rate_hz > 4000) throw StationError("station: can.stream_rate_hz out of range");
  if (!(s.settle_window_s > 0) || !(s.settle_slope_C_per_min > 0))
    throw StationError("station: settle.temp_window_s and settle.temp_slope_C_per_min must be > 0");
  return s;
}

StationConfig load_station(const std::string& path) {
  nlohmann::json j;
  try {
    j = io::read_json_file(path);
  } catch (const io::InputError& e) {
    throw StationError(e.what());  // every station problem is a StationError (and an input error)
  }
  auto dir = std::filesystem::absolute(path).parent_path().string();
  try {
    return station_from_json(j, dir);
  } catch (const StationError& e) {
    throw StationError(path + ": " + e.what());
  }
}

}  // namespace imuforge::eol
