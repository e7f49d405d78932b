#include "host/navigate/sensitivity.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <stdexcept>
#include <thread>

#include "host/model/measure.h"
#include "host/navigate/aided_run.h"

namespace imuforge::navigate {

using model::Effect;
using model::Sensor;

double SensitivityResult::predicted_rms_m(const solver::Estimate& e) const {
  if (e.covariance.rows() != static_cast<Eigen::Index>(e.names.size())) return NAN;
  double s2 = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const int k = e.index_of(names[i]);
    if (k < 0) continue;
    const double var = e.covariance(k, k);
    if (!std::isfinite(var)) return NAN;
    s2 += var * J[i].squaredNorm();
  }
  return std::sqrt(s2);
}

namespace {

bool is_temp(Effect e) { return e == Effect::kBiasTemp || e == Effect::kScaleTemp || e == Effect::kMisalignTemp; }

// The parameters a calibration ships: bias, scale, misalign, *_temp (powers up to the highest the sensor
// file uses, at least 1), gyro g_sensitivity.
std::vector<model::ParamId> shipped_params(const model::SensorModel& m) {
  const model::ParamSet p = m.effective_params();
  std::vector<model::ParamId> out;
  for (int s = 0; s < 2; ++s)
    for (Effect e : {Effect::kBias, Effect::kScale, Effect::kMisalign, Effect::kBiasTemp, Effect::kScaleTemp,
                     Effect::kMisalignTemp, Effect::kGSensitivity}) {
      const Sensor sn = static_cast<Sensor>(s);
      const auto ids = model::effect_params(sn, e);
      if (ids.empty()) continue;
      int max_pow = 1;
      if (is_temp(e))
        for (auto id : ids)
          if (p[id] != 0) max_pow = std::max(max_pow, model::param_info(id).power);
      for (auto id : ids)
        if (!is_temp(e) || model::param_info(id).power <= max_pow) out.push_back(id);
    }
  return out;
}

model::MeasureInput input_at(const sim::VehicleTruth& truth, std::size_t i) {
  model::MeasureInput in;
  const physics::VehicleState& st = truth.states[i];
  in.f = st.f_b;
  in.w = st.w_b;
  in.wdot = st.wdot_b;
  in.fdot = st.fdot_b;
  in.T_C = truth.temp_C[i];
  in.Tdot_C_s = truth.tdot_C_s[i];
  in.d = truth.hyst_d[i];
  in.t_s = st.t_s;
  return in;
}

}  // namespace

SensitivityResult sensitivity(const sim::VehicleTruth& truth, const model::SensorModel& sensor, const ImpactOptions& opt,
                              double target_m, double at_s, double floor_m) {
  if (!(target_m > 0)) throw std::invalid_argument("--spec-m must be > 0");
  if (!(at_s >= 1 && at_s <= opt.outage_s + 1e-3)) throw std::invalid_argument("the sensitivity time must lie in the outage");
  const double fs = truth.rate_hz;
  const std::size_t i0 = static_cast<std::size_t>(std::lround(opt.outage_start_s * fs));
  const std::size_t iT = i0 + static_cast<std::size_t>(std::lround(at_s * fs));
  if (iT >= truth.states.size()) throw std::invalid_argument("the outage runs past the trajectory");

  SensitivityResult res;
  res.target_m = target_m;
  res.at_s = at_s;
  res.floor_m = floor_m;
  res.budget_m = target_m > floor_m ? std::sqrt(target_m * target_m - floor_m * floor_m) : 0.0;
  const std::vector<model::ParamId> ids = shipped_params(sensor);
  res.J.assign(ids.size(), Eigen::Vector2d::Zero());
  for (auto id : ids) res.names.push_back(model::param_info(id).name);

  // Error at T of the noise-free truth with output perturbation δy = J_col · h (h = 0: the numerical floor).
  auto error_at_T = [&](model::ParamId id, double h) {
    Eigen::Vector2d e = Eigen::Vector2d::Zero();
    const std::vector<model::ParamId> one{id};
    Eigen::Matrix<double, 3, 1> col;
    const Sensor sn = model::param_info(id).sensor;
    aided_run(
        truth, i0, iT, opt.aiding,
        [&](std::size_t i, Eigen::Vector3d& f, Eigen::Vector3d& w) {
          f = truth.states[i].f_b;
          w = truth.states[i].w_b;
          if (h == 0) return;
          model::regressors(sn, one, input_at(truth, i), sensor.T_ref_C, col);
          (sn == Sensor::kAccel ? f : w) += h * col;
        },
        [&](std::size_t i, const nav::NavState& s) {
          if (i == iT) e = nav::horizontal_offset_m(s.pos, truth.states[i].pos);
        });
    return e;
  };
  const Eigen::Vector2d e0 = error_at_T(ids.front(), 0.0);

  std::atomic<std::size_t> next{0};
  auto worker = [&]() {
    Eigen::Matrix<double, 3, 1> col;
    for (std::size_t k = next++; k < ids.size(); k = next++) {
      const model::ParamId id = ids[k];
      const Sensor sn = model::param_info(id).sensor;
      // Step: the output perturbation peaks at 1e-3 m/s² (accel) or 1e-5 rad/s (gyro) along the
      // trajectory, well inside the linear range of the error equations and far above rounding.
      double peak = 0;
      const std::vector<model::ParamId> one{id};
      for (std::size_t i = 0; i <= iT; i += 10) {
        model::regressors(sn, one, input_at(truth, i), sensor.T_ref_C, col);
        peak = std::max(peak, col.cwiseAbs().maxCoeff());
      }
      if (!(peak > 0)) continue;  // not excited on this trajectory: no sensitivity
      const double h = (sn == Sensor::kAccel ? 1e-3 : 1e-5) / peak;
      res.J[k] = (error_at_T(id, h) - e0) / h;
    }
  };
  int nthreads = opt.threads > 0 ? opt.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (int t = 1; t < nthreads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();

  std::map<std::string, std::size_t> index;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const auto& info = model::param_info(ids[k]);
    const std::string g = std::string(model::sensor_name(info.sensor)) + "." + model::effect_info(info.effect).name;
    auto it = index.find(g);
    if (it == index.end()) {
      it = index.emplace(g, res.groups.size()).first;
      GroupSensitivity gs;
      gs.group = g;
      gs.units = model::effect_info(info.effect).units;
      res.groups.push_back(gs);
    }
    GroupSensitivity& gs = res.groups[it->second];
    gs.n_params += 1;
    gs.m_per_unit += res.J[k].squaredNorm();
  }
  const double G = static_cast<double>(res.groups.size());
  for (auto& gs : res.groups) {
    gs.m_per_unit = std::sqrt(gs.m_per_unit);
    gs.sigma_alone = gs.m_per_unit > 0 ? res.budget_m / gs.m_per_unit : INFINITY;
    gs.sigma_share = gs.m_per_unit > 0 ? res.budget_m / (gs.m_per_unit * std::sqrt(G)) : INFINITY;
  }
  return res;
}

}  // namespace imuforge::navigate
