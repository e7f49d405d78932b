#include "host/solver/online.h"

#include "host/io/input_error.h"

#include <algorithm>
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
  const nlohmann::json j = io::read_json_file(path);
  try {
    return sigma_spec_from_json(j);
  } catch (const nlohmann::json::exception& e) {
    throw io::InputError(path + ": " + e.what());
  } catch (const SolverError& e) {
    throw io::InputError(path + ": " + e.what());
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
  for (int c = 0; c < kNumChannels; ++c)
    if (!(noise_sigma[static_cast<size_t>(c)] > 0))
      throw SolverError(std::string("online mode: noise sigma of ") + channel_name(c) + " must be positive");
  srif_ = SquareRootInformationFilter(acc_.names());
  acc_.on_segment = [this](const SegmentSummary& s, const ChannelSet& cs) {
    grow_for_new_plateaus();
    const NormalEquations ne = acc_.segment_normal_equations(cs, sigma_, s.plateau);
    srif_.add_information(ne.info, ne.rhs);
    ++n_segments_;
    if (on_update) on_update(s, srif_.estimate());
  };
}

void OnlineCalibrator::grow_for_new_plateaus() {
  const int np = acc_.plateaus_discovered();
  const int known = static_cast<int>(plateau_order_.size());
  if (np == known) return;
  const std::vector<int> rank = acc_.plateau_ranks();
  std::vector<int> order(static_cast<size_t>(np));
  for (int p = 0; p < np; ++p) order[static_cast<size_t>(rank[static_cast<size_t>(p)])] = p;
  // The plateaus known before keep their relative order (means cannot cross, fixture.h): only then do
  // the existing slots stay valid when new ones are inserted between them.
  std::vector<int> old_order;
  for (int p : order)
    if (p < known) old_order.push_back(p);
  if (old_order != plateau_order_) throw SolverError("internal: plateau temperature order changed during the run");
  if (acc_.has_per_plateau()) {
    // Insert the new plateaus' slots in ascending final position: each lands where the batch puts it.
    std::vector<int> pos;
    for (int p = known; p < np; ++p) {
      const std::vector<int> sl = acc_.plateau_slots(rank[static_cast<size_t>(p)], np);
      pos.insert(pos.end(), sl.begin(), sl.end());
    }
    std::sort(pos.begin(), pos.end());
    const std::vector<std::string> names = acc_.slot_names(np);
    for (int k : pos) srif_.insert_parameter(k, names[static_cast<size_t>(k)]);
    srif_.rename(names);
  }
  plateau_order_ = order;
}

void OnlineCalibrator::add(const io::LogRow& row) { acc_.add(row); }
void OnlineCalibrator::finish() { acc_.finish(); }
Estimate OnlineCalibrator::estimate() const { return srif_.estimate(); }

}  // namespace imuforge::solver
