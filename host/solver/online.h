// Recursive calibration during collection, for `imuforge solve --online` and the end-of-line runner.
//
//   OnlineCalibrator oc(spec, log_meta, noise_sigma);     // noise σ fixed up front (model or first dwell)
//   for each row as it arrives: oc.add(row);              // O(1) per row; O(n³) at each segment end
//   oc.finish();                                          // flushes the last segment
//   Estimate e = oc.estimate();                           // any time: σ = +inf where not yet observable
//   SigmaCheck c = check_sigma(e, spec_sigma);            // does every σ meet the spec?
// After finish(), estimate() equals the batch solve_fixture() of the same rows within 1e-6 σ.
// Per-plateau models: each newly discovered plateau adds its slots (zero prior information) to the
// filter, placed and named as the batch does ("<name>@plateau<k>", k by mean temperature among the
// plateaus seen so far), so names() can change between segments; at the end they equal the batch's.
// temp_rate models: rows are processed dTdt_window_s late (Ṫ needs the temperatures after them).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/solver/fixture.h"
#include "host/solver/srif.h"

namespace imuforge::solver {

// Largest acceptable σ per parameter: keys are full names or prefixes ("accel.bias" covers
// "accel.bias.x"); the longest matching key wins. Format: docs/calibration.md (spec-sigma.json).
struct SigmaSpec {
  std::vector<std::pair<std::string, double>> limits;
  // Limit for a parameter name, or +inf if no key matches.
  double limit_for(const std::string& name) const;
};
SigmaSpec sigma_spec_from_json(const nlohmann::json& j);
SigmaSpec load_sigma_spec(const std::string& path);

struct SigmaCheck {
  bool all_met = false;
  int n_met = 0;
  int n_limited = 0;                 // parameters that have a limit
  std::vector<std::string> unmet;    // names whose σ exceeds the limit (or is not yet observable)
  double worst_ratio = 0.0;          // max σ/limit
};
SigmaCheck check_sigma(const Estimate& e, const SigmaSpec& spec);

class OnlineCalibrator {
 public:
  OnlineCalibrator(const model::ModelSpec& spec, const io::LogMeta& meta, const Sigma6& noise_sigma);
  OnlineCalibrator(const OnlineCalibrator&) = delete;  // the accumulator's hook points at this object
  OnlineCalibrator& operator=(const OnlineCalibrator&) = delete;
  void add(const io::LogRow& row);
  void finish();
  // Called after each completed segment with the estimate so far.
  std::function<void(const SegmentSummary&, const Estimate&)> on_update;

  Estimate estimate() const;
  bool complete() const { return srif_.complete(); }
  int segments() const { return n_segments_; }
  const std::vector<std::string>& names() const { return srif_.names(); }
  const FixtureAccumulator& accumulator() const { return acc_; }

 private:
  void grow_for_new_plateaus();

  FixtureAccumulator acc_;
  Sigma6 sigma_;
  SquareRootInformationFilter srif_;
  int n_segments_ = 0;
  std::vector<int> plateau_order_;  // discovery indices sorted by temperature, as last seen
};

}  // namespace imuforge::solver
