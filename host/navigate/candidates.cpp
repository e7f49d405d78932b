#include "host/navigate/candidates.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <stdexcept>

#include "host/solver/calfile.h"
#include "host/solver/table_out.h"
#include "host/table/table_writer.h"

namespace imuforge::navigate {

RawFormat raw_format(const model::SensorModel& m) {
  RawFormat f;
  const auto& a = m.triad(model::Sensor::kAccel);
  const auto& g = m.triad(model::Sensor::kGyro);
  f.accel_shift = std::max(0, a.bits - 24);
  f.gyro_shift = std::max(0, g.bits - 24);
  f.accel_bits = std::max(8, a.bits - f.accel_shift);
  f.gyro_bits = std::max(8, g.bits - f.gyro_shift);
  f.accel_lsb_mps2 = std::ldexp(a.lsb, f.accel_shift);
  f.gyro_lsb_rad_s = std::ldexp(g.lsb, f.gyro_shift);
  return f;
}

namespace {

fw::Table finish(table::TableSpec spec, const RawFormat& fmt, const std::string& what) {
  spec.device_serial = 1;
  spec.table_sequence = 1;
  spec.created_unix_s = 1;  // fixed: the comparison must not depend on the clock
  spec.accel_lsb_mps2 = fmt.accel_lsb_mps2;
  spec.gyro_lsb_rad_s = fmt.gyro_lsb_rad_s;
  spec.accel_raw_bits = fmt.accel_bits;
  spec.gyro_raw_bits = fmt.gyro_bits;
  try {
    return table::build_table(spec);
  } catch (const table::TableError& e) {
    throw std::invalid_argument(what + ": the firmware table rejects this calibration: " + e.what());
  }
}

std::vector<double> breakpoints(const std::vector<double>& temps_C) {
  double lo = INFINITY, hi = -INFINITY;
  for (double t : temps_C)
    if (std::isfinite(t)) {
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
  if (!std::isfinite(lo)) return {25.0};
  if (hi - lo < 0.5) return {0.5 * (lo + hi)};
  std::vector<double> b;
  for (int i = 0; i < 16; ++i) b.push_back(lo + (hi - lo) * i / 15.0);
  return b;
}

}  // namespace

Candidate estimate_candidate(const std::string& name, const std::string& kind, const solver::Estimate& e, double T_ref_C,
                             const std::vector<double>& plateau_T_C, const RawFormat& fmt,
                             const std::vector<double>& temps_C) {
  Candidate c;
  c.name = name;
  c.kind = kind;
  bool per_plateau = false;
  std::set<std::string> dropped_effects;
  for (const auto& n : e.names) {
    per_plateau = per_plateau || n.find("@plateau") != std::string::npos;
    if (n.rfind("fixture.", 0) == 0) continue;  // fixture nuisances are not sensor terms
    if (!solver::table_expressible(n)) {
      const std::string base = n.substr(0, n.find('@'));
      const auto d1 = base.find('.'), d2 = base.find('.', d1 + 1);
      dropped_effects.insert(base.substr(0, d2));
    }
  }
  c.dropped.assign(dropped_effects.begin(), dropped_effects.end());
  std::vector<double> bps;
  std::vector<int> bp_plateau;
  if (per_plateau) {
    if (plateau_T_C.empty()) throw std::invalid_argument(name + ": per-plateau estimate without plateau temperatures");
    if (plateau_T_C.size() > 16) throw std::invalid_argument(name + ": more than 16 plateaus (table v1 holds 16 breakpoints)");
    bps = plateau_T_C;
    for (std::size_t i = 0; i < bps.size(); ++i) bp_plateau.push_back(static_cast<int>(i));
  } else {
    bps = breakpoints(temps_C);
    bp_plateau.assign(bps.size(), -1);
  }
  c.table = finish(solver::table_spec_from_estimate(e, T_ref_C, bps, bp_plateau), fmt, name);
  return c;
}

Candidate calibration_candidate(const std::string& path, const RawFormat& fmt, const std::vector<double>& temps_C) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open calibration file");
  nlohmann::json j;
  solver::Estimate e;
  try {
    j = nlohmann::json::parse(in);
    e = solver::calibration_from_json(j);
  } catch (const std::exception& ex) {
    throw std::invalid_argument(path + ": " + ex.what());
  }
  const double T_ref = j.contains("T_ref_C") && j["T_ref_C"].is_number() ? j["T_ref_C"].get<double>() : 25.0;
  std::vector<double> plateaus;
  if (auto it = j.find("plateaus"); it != j.end() && it->is_array())
    for (const auto& p : *it)
      if (p.is_object() && p.contains("T_C") && p["T_C"].is_number()) plateaus.push_back(p["T_C"].get<double>());
  std::string name = path.substr(path.find_last_of('/') + 1);
  if (name.size() > 5 && name.substr(name.size() - 5) == ".json") name.resize(name.size() - 5);
  Candidate c = estimate_candidate(name, "calibration", e, T_ref, plateaus, fmt, temps_C);
  c.source = path;
  return c;
}

Candidate oracle_candidate(const model::SensorModel& m, const RawFormat& fmt, const std::vector<double>& temps_C) {
  const model::ParamSet p = m.effective_params();
  solver::Estimate e;
  std::vector<double> vals;
  std::set<std::string> dropped;
  for (const auto& info : model::params()) {
    if (!info.deterministic || !m.on(info.sensor, info.effect)) continue;
    if (solver::table_expressible(info.name)) {
      e.names.push_back(info.name);
      vals.push_back(p[info.id]);
    } else {
      dropped.insert(std::string(model::sensor_name(info.sensor)) + "." + model::effect_info(info.effect).name);
    }
  }
  e.value = Eigen::Map<Eigen::VectorXd>(vals.data(), static_cast<Eigen::Index>(vals.size()));
  e.covariance = Eigen::MatrixXd::Zero(e.value.size(), e.value.size());
  Candidate c = estimate_candidate("oracle", "oracle", e, m.T_ref_C, {}, fmt, temps_C);
  c.dropped.assign(dropped.begin(), dropped.end());
  c.source = "true parameters of the sensor file (table-expressible terms)";
  return c;
}

Candidate uncompensated_candidate(const RawFormat& fmt) {
  table::TableSpec spec;
  spec.kind = table::SpecKind::kSensorModel;
  spec.breakpoints.push_back(table::BreakpointSpec{});
  Candidate c;
  c.name = "uncompensated";
  c.kind = "uncompensated";
  c.source = "raw counts x nominal LSB";
  c.table = finish(spec, fmt, "uncompensated");
  return c;
}

}  // namespace imuforge::navigate
