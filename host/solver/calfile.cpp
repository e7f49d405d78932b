#include "host/solver/calfile.h"

#include <cmath>
#include <ctime>

namespace imuforge::solver {

namespace {
// JSON has no infinity: unobservable or absent σ is written as null.
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
}  // namespace

nlohmann::json calibration_to_json(const CalibrationResult& r) {
  using nlohmann::json;
  json j;
  j["format"] = kCalFormat;
  j["version"] = kCalVersion;
  j["mode"] = r.mode;
  j["method"] = r.method;
  j["T_ref_C"] = r.T_ref_C;
  const auto& e = r.estimate;
  const long n = static_cast<long>(e.names.size());
  const Eigen::VectorXd sig = r.has_covariance ? e.sigma() : Eigen::VectorXd::Constant(n, NAN);
  json params = json::array();
  const bool with_noise = r.has_covariance && r.sigma_noise.size() == n;
  for (long i = 0; i < n; ++i) {
    json p = {{"name", e.names[static_cast<size_t>(i)]}, {"value", e.value[i]}, {"sigma", num(sig[i])}};
    if (with_noise) p["sigma_noise"] = num(r.sigma_noise[i]);
    params.push_back(p);
  }
  j["parameters"] = params;
  if (r.has_covariance) {
    json cov = json::array(), cor = json::array();
    const Eigen::MatrixXd c = e.correlation();
    for (long i = 0; i < n; ++i) {
      json rc = json::array(), rr = json::array();
      for (long k = 0; k < n; ++k) {
        rc.push_back(num(e.covariance(i, k)));
        rr.push_back(num(c(i, k)));
      }
      cov.push_back(rc);
      cor.push_back(rr);
    }
    j["covariance"] = cov;
    j["correlation"] = cor;
    j["observability"] = {{"rank", r.observability.rank},
                          {"n_params", r.observability.n_params},
                          {"condition_number", num(r.observability.condition_number)},
                          {"unobservable", r.observability.unobservable}};
  } else {
    j["covariance"] = nullptr;
    j["correlation"] = nullptr;
    j["observability"] = nullptr;
  }
  if (r.has_residuals) {
    json rms = json::object(), ns = json::object();
    for (int c = 0; c < kNumChannels; ++c) {
      rms[channel_name(c)] = num(r.residual_rms[static_cast<size_t>(c)]);
      ns[channel_name(c)] = num(r.noise_sigma[static_cast<size_t>(c)]);
    }
    j["residual_rms"] = rms;
    j["noise_sigma"] = ns;
    j["noise_source"] = r.noise_source;
  }
  j["model"] = r.model;
  j["provenance"] = {{"log", r.log_path},
                     {"log_sha256", r.log_sha256},
                     {"software", std::string("imuforge ") + IMUFORGE_VERSION},
                     {"time_utc", utc_now_iso8601()},
                     {"samples_used", r.samples}};
  for (auto it = r.extra.begin(); it != r.extra.end(); ++it) j[it.key()] = it.value();
  return j;
}

}  // namespace imuforge::solver
