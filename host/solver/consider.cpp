#include "host/solver/consider.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "host/solver/fixture_errors.h"

namespace imuforge::solver {

namespace {

constexpr double kRadPerDeg = M_PI / 180.0;

double sigma_deg(const nlohmann::json& v, const std::string& key) {
  if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0)
    throw SolverError(key + " must be a finite number >= 0 (1 sigma, degrees)");
  return v.get<double>();
}

std::array<double, 3> axis_from_json(const nlohmann::json& a, const std::string& key) {
  if (!a.is_object()) throw SolverError(key + " must be an object {\"tilt_sigma_deg\": .., \"zero_sigma_deg\": ..}");
  std::array<double, 3> out{};
  for (auto kv = a.begin(); kv != a.end(); ++kv) {
    if (kv.key() == "tilt_sigma_deg") {
      out[0] = out[1] = sigma_deg(kv.value(), key + ".tilt_sigma_deg") * kRadPerDeg;
    } else if (kv.key() == "zero_sigma_deg") {
      out[2] = sigma_deg(kv.value(), key + ".zero_sigma_deg") * kRadPerDeg;
    } else if (kv.key().empty() || kv.key()[0] != '_') {
      throw SolverError(key + ": unknown key '" + kv.key() + "' (expected tilt_sigma_deg, zero_sigma_deg)");
    }
  }
  return out;
}

}  // namespace

double FixtureTolerance::sigma_of(const std::string& name) const {
  static const std::string kAxis = "fixture.axis", kMount = "fixture.mount.r";
  if (name.compare(0, kMount.size(), kMount) == 0 && name.size() == kMount.size() + 1) {
    const char c = name.back();
    return c >= 'x' && c <= 'z' ? mount_sigma_rad[static_cast<std::size_t>(c - 'x')] : 0.0;
  }
  if (name.compare(0, kAxis.size(), kAxis) != 0) return 0.0;
  const std::size_t dot = name.find('.', kAxis.size());
  if (dot == std::string::npos) return 0.0;
  const std::size_t a = static_cast<std::size_t>(std::atoi(name.substr(kAxis.size(), dot - kAxis.size()).c_str()));
  if (a >= axis_sigma_rad.size()) return 0.0;
  const std::string what = name.substr(dot + 1);
  return what == "tilt_a" ? axis_sigma_rad[a][0] : what == "tilt_b" ? axis_sigma_rad[a][1] : what == "zero" ? axis_sigma_rad[a][2] : 0.0;
}

nlohmann::json FixtureTolerance::to_json() const {
  nlohmann::json axes = nlohmann::json::array();
  for (const auto& a : axis_sigma_rad)
    axes.push_back({{"tilt_sigma_deg", a[0] / kRadPerDeg}, {"zero_sigma_deg", a[2] / kRadPerDeg}});
  return {{"axes", axes},
          {"mount_sigma_deg", {mount_sigma_rad[0] / kRadPerDeg, mount_sigma_rad[1] / kRadPerDeg, mount_sigma_rad[2] / kRadPerDeg}}};
}

FixtureTolerance fixture_tolerance_from_json(const nlohmann::json& j, int n_axes, const std::string& where) {
  const std::string key = where + ": fixture_tolerance";
  if (!j.is_object()) throw SolverError(key + " must be an object {\"axes\": .., \"mount_sigma_deg\": ..}");
  FixtureTolerance t;
  t.axis_sigma_rad.assign(static_cast<std::size_t>(n_axes), {0.0, 0.0, 0.0});
  for (auto kv = j.begin(); kv != j.end(); ++kv) {
    if (kv.key() == "axes") {
      if (kv.value().is_array()) {
        if (kv.value().size() != static_cast<std::size_t>(n_axes))
          throw SolverError(key + ".axes lists " + std::to_string(kv.value().size()) + " axes but the table has " +
                            std::to_string(n_axes));
        for (int a = 0; a < n_axes; ++a)
          t.axis_sigma_rad[static_cast<std::size_t>(a)] =
              axis_from_json(kv.value()[static_cast<std::size_t>(a)], key + ".axes[" + std::to_string(a) + "]");
      } else {
        const auto one = axis_from_json(kv.value(), key + ".axes");
        for (auto& a : t.axis_sigma_rad) a = one;
      }
    } else if (kv.key() == "mount_sigma_deg") {
      const auto& v = kv.value();
      if (v.is_array()) {
        if (v.size() != 3) throw SolverError(key + ".mount_sigma_deg must be a number or [x, y, z]");
        for (std::size_t k = 0; k < 3; ++k)
          t.mount_sigma_rad[k] = sigma_deg(v[k], key + ".mount_sigma_deg[" + std::to_string(k) + "]") * kRadPerDeg;
      } else {
        const double s = sigma_deg(v, key + ".mount_sigma_deg") * kRadPerDeg;
        t.mount_sigma_rad = {s, s, s};
      }
    } else if (kv.key().empty() || kv.key()[0] != '_') {
      throw SolverError(key + ": unknown key '" + kv.key() + "' (expected axes, mount_sigma_deg)");
    }
  }
  return t;
}

std::optional<FixtureTolerance> fixture_tolerance_of(const model::ModelSpec& spec, int n_axes, const std::string& where) {
  const auto it = spec.extra.find("fixture_tolerance");
  if (it == spec.extra.end()) return std::nullopt;
  return fixture_tolerance_from_json(*it, n_axes, where);
}

ConsiderResult consider_fixture_tolerance(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& campaign,
                                          const Estimate& est, const Sigma6& sigma, const FixtureTolerance& tol) {
  const int nm = static_cast<int>(spec.parameters().size());
  const int ne = static_cast<int>(est.names.size());
  if (ne < nm || est.covariance.rows() != ne) throw SolverError("consider: the estimate does not hold the model's parameters");
  // Nuisance parameters of the joint linearisation: the estimated ones (their current values), then the
  // considered ones (at nominal, 0).
  std::vector<std::string> nuisance(est.names.begin() + nm, est.names.end());
  ConsiderResult r;
  for (const std::string& name : fixture_nuisance_names(static_cast<int>(campaign.axes.size()))) {
    if (std::find(nuisance.begin(), nuisance.end(), name) != nuisance.end()) continue;
    if (tol.sigma_of(name) > 0) r.considered.push_back(name);
  }
  const int nc = static_cast<int>(r.considered.size());
  r.covariance = est.covariance;
  r.sensitivity = Eigen::MatrixXd::Zero(ne, nc);
  r.considered_sigma.resize(nc);
  r.dominant.assign(static_cast<std::size_t>(ne), "");
  if (nc == 0) return r;
  nuisance.insert(nuisance.end(), r.considered.begin(), r.considered.end());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(ne + nc);
  x.head(ne) = est.value;
  log.rewind();
  const Eigen::MatrixXd h = fixture_joint_information(log, spec, campaign, nuisance, x, sigma);
  log.rewind();
  // The estimator's response to a fixture error δη: the data move by J_η δη, which the solve (η held at
  // nominal) fits with δθ = P J_θᵀ W J_η δη = P H_EC δη.
  r.sensitivity = est.covariance * h.block(0, ne, ne, nc);
  for (int k = 0; k < nc; ++k) r.considered_sigma[k] = tol.sigma_of(r.considered[static_cast<std::size_t>(k)]);
  const Eigen::MatrixXd ss = r.sensitivity * r.considered_sigma.asDiagonal();
  r.covariance += ss * ss.transpose();
  for (int i = 0; i < ne; ++i) {
    Eigen::Index k = 0;
    if (ss.row(i).cwiseAbs().maxCoeff(&k) > 0) r.dominant[static_cast<std::size_t>(i)] = r.considered[static_cast<std::size_t>(k)];
  }
  return r;
}

nlohmann::json apply_consider(Estimate& est, const ConsiderResult& r, const FixtureTolerance& tol, Eigen::VectorXd* sigma_noise) {
  if (sigma_noise) *sigma_noise = est.sigma();
  est.covariance = r.covariance;
  nlohmann::json dom = nlohmann::json::object();
  for (std::size_t i = 0; i < est.names.size() && i < r.dominant.size(); ++i)
    if (!r.dominant[i].empty()) dom[est.names[i]] = r.dominant[i];
  return {{"stated", true},
          {"tolerance", tol.to_json()},
          {"considered", r.considered},
          {"dominant", dom},
          {"sigma_covers", "sensor noise and the fixture tolerance (consider analysis, docs/calibration.md)"}};
}

nlohmann::json fixture_tolerance_not_stated() {
  return {{"stated", false},
          {"sigma_covers", "sensor noise only: no fixture_tolerance stated, so errors of the fixture (axis tilts, "
                           "encoder zeros, the mount in the nest) are not in sigma"}};
}

}  // namespace imuforge::solver
