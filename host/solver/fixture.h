// Fixture mode: the reference columns (f_ref, w_ref) are trusted, so the calibration is LINEAR least
// squares in the model parameters (docs/error-model.md: y = u + J(u, T)·θ). One streaming pass over
// the log builds per-channel sufficient statistics (moments.h); the solve is then O(n_params³),
// independent of the number of samples.
//
//   FixtureAccumulator acc(spec, log.meta());
//   while (log.next(row)) acc.add(row);
//   acc.finish();
//   FixtureSolution sol = solve_fixture(acc, acc.static_noise_sigma());
#pragma once

#include <array>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "host/io/log.h"
#include "host/model/catalog.h"
#include "host/model/measure.h"
#include "host/model/sensor_model.h"
#include "host/solver/estimate.h"
#include "host/solver/moments.h"

namespace imuforge::solver {

using Sigma6 = std::array<double, kNumChannels>;  // per-sample noise σ per channel, SI
const char* channel_name(int c);                   // "accel.x" … "gyro.z"

// Normal-equation blocks of one channel in the sensor's local parameter space (the model parameters of
// that sensor, in spec order), unweighted: A = Σ φφᵀ, b = Σ φ z, zz = Σ z², z = y − u.
struct ChannelStats {
  Eigen::MatrixXd a;
  Eigen::VectorXd b;
  double zz = 0.0;
  long long n = 0;
  void reset(int n_local);
  ChannelStats& operator+=(const ChannelStats& o);
};
using ChannelSet = std::array<ChannelStats, kNumChannels>;

// What the log says about one segment (a dwell), for the traditional method and for reports.
struct SegmentSummary {
  int segment = -1;
  long long n = 0;
  Eigen::Vector3d f_ref = Eigen::Vector3d::Zero();  // means
  Eigen::Vector3d w_ref = Eigen::Vector3d::Zero();
  double T_C = 0.0;
  std::array<double, kNumChannels> y{};             // mean output, SI
  std::array<double, kNumChannels> var{};           // within-segment variance, SI²
  int plateau = -1;
};

struct PlateauInfo {
  double T_C = 0.0;      // mean temperature of its samples
  long long samples = 0;
};

class FixtureAccumulator {
 public:
  FixtureAccumulator(const model::ModelSpec& spec, const io::LogMeta& meta);

  // Streams one row. Rows without a reference or outside a dwell (segment −1) only feed the hysteresis
  // tracker: in motion, ω̇ and ḟ are not in the log, so those rows cannot be modelled exactly.
  void add(const io::LogRow& row);
  // Flushes the last block and segment. Must be called before the results below.
  void finish();

  // Called after every completed segment with its statistics (in local space, unweighted), in log order.
  std::function<void(const SegmentSummary&, const ChannelSet&)> on_segment;

  // Parameter slots: spec parameters, with per-plateau ones expanded to one slot per plateau
  // (named "<name>@plateau<k>", plateaus sorted by temperature).
  std::vector<std::string> names() const;
  const std::vector<PlateauInfo>& plateaus() const { return plateaus_sorted_; }
  bool has_per_plateau() const { return any_per_plateau_; }
  // Weighted normal equations in slot space.
  NormalEquations normal_equations(const Sigma6& sigma) const;
  // Weighted information of one segment's statistics (no per-plateau parameters allowed).
  NormalEquations segment_normal_equations(const ChannelSet& seg, const Sigma6& sigma) const;
  // Pooled within-block standard deviation per channel (static-segment noise estimate).
  Sigma6 static_noise_sigma() const;
  // RMS of y − (u + Jθ) per channel at the slot-space estimate theta.
  Sigma6 residual_rms(const Eigen::VectorXd& theta) const;
  const std::map<int, SegmentSummary>& segments() const { return segments_; }
  long long samples_used() const { return samples_used_; }
  const model::ModelSpec& spec() const { return spec_; }
  // Local parameter ids of a sensor (catalog ids, spec order).
  const std::vector<model::ParamId>& sensor_ids(model::Sensor s) const { return ids_[static_cast<int>(s)]; }

 private:
  void flush_block();
  void flush_segment();
  int plateau_of(double T_C);
  int slot(int sensor, int local, int plateau_sorted) const;

  model::ModelSpec spec_;
  double lsb_[2];
  std::array<std::vector<model::ParamId>, 2> ids_;
  std::array<std::vector<bool>, 2> per_plateau_;
  std::array<std::vector<int>, 2> spec_pos_;  // position of each local parameter in spec order
  bool any_per_plateau_ = false;
  bool needs_temp_ = false;
  model::HysteresisTracker hyst_;

  // Current block and segment.
  bool in_block_ = false;
  double key_[7] = {};
  int block_segment_ = -1;
  BlockMoments block_;
  Eigen::Matrix<double, 6, 1> block_u_ = Eigen::Matrix<double, 6, 1>::Zero();  // Σ f_ref, Σ w_ref
  bool in_segment_ = false;
  int seg_id_ = -1;
  ChannelSet seg_stats_;
  SegmentSummary seg_sum_;
  Eigen::Matrix<double, 6, 1> seg_y_sum_, seg_y_sq_;

  std::vector<ChannelSet> plateau_stats_;  // by discovery order
  std::vector<double> plateau_T_sum_;
  std::vector<long long> plateau_n_;
  std::vector<PlateauInfo> plateaus_sorted_;
  std::vector<int> discovery_to_sorted_;
  std::map<int, SegmentSummary> segments_;
  double var_num_[kNumChannels] = {};
  long long var_den_ = 0;
  long long samples_used_ = 0;
  bool finished_ = false;
};

struct FixtureSolution {
  Estimate estimate;
  Observability observability;
  Sigma6 noise_sigma{};   // σ used as weights
  Sigma6 residual_rms{};
  double chi2 = 0.0;      // weighted residual sum of squares
  long long samples = 0;
};

// Solves; throws SolverError naming unobservable combinations on rank deficiency.
FixtureSolution solve_fixture(const FixtureAccumulator& acc, const Sigma6& sigma);

}  // namespace imuforge::solver
