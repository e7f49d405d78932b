#include "host/solver/online.h"

#include <cmath>
#include <fstream>
#include <limits>

namespace imuforge::solver {

double SigmaSpec::limit_for(const std::string& name) const {
  double best = std::numeric_limits<double>::infinity();
  size_t best_len = 0;
  for (const auto& [key, v] : limits) {
    const bool match = name == key || (name.size() > key.size() && name.compare(0, key.size(), key) == 0 &&
                                       (name[key.size()] == '.' || name[key.size()] == '@'));
    if (match && key.size() >= best_len) {
      best = v;
      best_len = key.size();
    }
  }
  return best;
}

SigmaSpec sigma_spec_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw SolverError("sigma spec: expected a JSON object");
  const auto it = j.find("sigma");
  if (it == j.end() || !it->is_object()) throw SolverError("sigma spec: missing object \"sigma\" {name: limit}");
  SigmaSpec s;
  for (auto e = it->begin(); e != it->end(); ++e) {
    if (!e->is_number()) throw SolverError("sigma spec: \"sigma." + e.key() + "\" must be a number");
    const double v = e->get<double>();
    if (!(v > 0) || !std::isfinite(v)) throw SolverError("sigma spec: \"sigma." + e.key() + "\" must be positive");
    s.limits.emplace_back(e.key(), v);
  }
  if (s.limits.empty()) throw SolverError("sigma spec: \"sigma\" is empty");
  return s;
}

SigmaSpec load_sigma_spec(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw SolverError("cannot open sigma spec '" + path + "'");
  try {
    return sigma_spec_from_json(nlohmann::json::parse(f));
  } catch (const nlohmann::json::exception& e) {
    throw SolverError("sigma spec '" + path + "': " + e.what());
  } catch (const SolverError& e) {
    throw SolverError("'" + path + "': " + e.what());
  }
}

SigmaCheck check_sigma(const Estimate& e, const SigmaSpec& spec) {
  SigmaCheck c;
  const Eigen::VectorXd s = e.sigma();
  for (size_t i = 0; i < e.names.size(); ++i) {
    const double lim = spec.limit_for(e.names[i]);
    if (!std::isfinite(lim)) continue;
    ++c.n_limited;
    const double r = s[static_cast<long>(i)] / lim;
    c.worst_ratio = std::max(c.worst_ratio, std::isfinite(r) ? r : std::numeric_limits<double>::infinity());
    if (r <= 1.0)
      ++c.n_met;
    else
      c.unmet.push_back(e.names[i]);
  }
  c.all_met = c.n_limited > 0 && c.unmet.empty();
  return c;
}

OnlineCalibrator::OnlineCalibrator(const model::ModelSpec& spec, const io::LogMeta& meta, const Sigma6& noise_sigma)
    : acc_(spec, meta), sigma_(noise_sigma), srif_({}) {
  if (acc_.has_per_plateau())
    throw SolverError("online mode: per-plateau parameters are only defined once all plateaus are known; "
                      "use a polynomial temperature model");
  for (int c = 0; c < kNumChannels; ++c)
    if (!(noise_sigma[static_cast<size_t>(c)] > 0))
      throw SolverError(std::string("online mode: noise sigma of ") + channel_name(c) + " must be positive");
  srif_ = SquareRootInformationFilter(acc_.names());
  acc_.on_segment = [this](const SegmentSummary& s, const ChannelSet& cs) {
    const NormalEquations ne = acc_.segment_normal_equations(cs, sigma_);
    srif_.add_information(ne.info, ne.rhs);
    ++n_segments_;
    if (on_update) on_update(s, srif_.estimate());
  };
}

void OnlineCalibrator::add(const io::LogRow& row) { acc_.add(row); }
void OnlineCalibrator::finish() { acc_.finish(); }
Estimate OnlineCalibrator::estimate() const { return srif_.estimate(); }

}  // namespace imuforge::solver
