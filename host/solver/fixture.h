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
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "host/estimator/drift.h"
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

// Streaming Ṫ (°C/s) from the logged temp_C, with exactly the definition of docs/error-model.md and
// model::temp_rate_centered(): for the row at t_i, the slope between the first row at ≥ t_i − window and
// the last row at ≤ t_i + window (one-sided at the log's ends); 0 when either end has no temperature.
// Every row is delayed until the first row later than t_i + window arrives (or close() is called), so
// memory is bounded by the rows in one ±window span, never by the log length.
//   feed(row, use) for every row, then finish(use); use(row, Tdot) sees each row once, in time order.
class CenteredTempRate {
 public:
  explicit CenteredTempRate(double window_s);
  // Throws SolverError if t is not finite or goes backwards, or the window holds more than kMaxRows rows.
  // Amortised O(1).
  void push(const io::LogRow& row);
  // End of the log: every pending row's Ṫ becomes final.
  void close();
  // Next row (time order) whose Ṫ is final; false if none yet.
  bool pop(io::LogRow& row, double& Tdot_C_s);
  // push(row), then use(row, Ṫ) for every row that became final.
  template <class F>
  void feed(const io::LogRow& row, F&& use) {
    push(row);
    drain(use);
  }
  // close(), then use(row, Ṫ) for every pending row.
  template <class F>
  void finish(F&& use) {
    close();
    drain(use);
  }
  double window_s() const { return window_s_; }
  std::size_t pending() const { return rows_.size(); }
  // 20 s at 200 kHz: far above any IMU log; beyond it timestamps are stuck or the window is absurd.
  static constexpr std::size_t kMaxRows = 4000000;

 private:
  void release(std::size_t i, double t_hi, double T_hi);
  template <class F>
  void drain(F& use) {
    io::LogRow r;
    double q = 0.0;
    while (pop(r, q)) use(r, q);
  }
  double window_s_;
  std::deque<io::LogRow> rows_;               // pending rows; the first n_ready_ have a final Ṫ
  std::deque<double> tdot_;                   // Ṫ of the ready rows
  std::size_t n_ready_ = 0;
  std::deque<std::pair<double, double>> hist_;  // (t, T) of rows from the oldest pending one's t − window
  double last_t_ = -std::numeric_limits<double>::infinity();
  bool closed_ = false;
};

// Dwell guard. A sample stamped late (transport latency, a slow clock) or early reads the table's
// motion into the first or last moments of a dwell. A `rate` step has no settle (docs/formats.md), so
// without a guard a 20 ppm clock, 0.19 s late by the end of campaign-eol, puts the end of each
// acceleration into the rate dwells, and the fixture solve reads the deficit as gyro scale (1.7–2e-3,
// 30–50σ, on the automotive example). A dwell row is left out when some row within guard_s of it, before
// or after, lies outside its dwell (another segment, segment −1 or no reference) and has a different
// reference (beyond the block tolerances, 2e-3 m/s² and 2e-4 rad/s):
//  - a position dwell after a settle at its own pose loses nothing at its start;
//  - a rate dwell loses guard_s at its start, and any dwell loses guard_s before the motion after it;
//  - a log with instantaneous pose changes (no settle) loses guard_s on each side of every change.
// So any timing shift of either sign up to guard_s leaves the dwell means clean. A shift the guard does
// not cover is what `imuforge diagnose` reports as timing. Rows are released guard_s late, in time
// order; use(row, Ṫ, keep) sees each row once, keep = false for a guarded dwell row.
class DwellGuard {
 public:
  // guard_s ≥ 0 and finite (SolverError otherwise); 0 passes every row through at once with keep = true.
  explicit DwellGuard(double guard_s);
  // Throws SolverError if t is not finite or goes backwards, or guard_s holds more than kMaxRows rows.
  // Amortised O(1); at the first row of a dwell O(rows in the preceding guard_s).
  void push(const io::LogRow& row, double Tdot_C_s);
  // End of the log: every pending row is final (the last dwell keeps its end).
  void close();
  // Next row (time order) whose fate is final; false if none yet.
  bool pop(io::LogRow& row, double& Tdot_C_s, bool& keep);
  template <class F>
  void feed(const io::LogRow& row, double Tdot_C_s, F&& use) {
    push(row, Tdot_C_s);
    drain(use);
  }
  template <class F>
  void finish(F&& use) {
    close();
    drain(use);
  }
  double guard_s() const { return guard_s_; }
  long long dropped() const { return dropped_; }  // rows released with keep = false so far
  static constexpr std::size_t kMaxRows = CenteredTempRate::kMaxRows;

 private:
  struct Ref {
    bool has = false;
    double u[6] = {};  // f_ref, w_ref
  };
  static Ref ref_of(const io::LogRow& row);
  static bool differs(const Ref& a, const Ref& b);
  // One contiguous run of rows of one segment. t_lb: latest differing outside row before it (within
  // guard_s of its first row); t_la: first differing outside row after it (within guard_s of its last).
  struct Run {
    long long id = 0;
    int segment = -1;
    double t_lb = -std::numeric_limits<double>::infinity();
    double t_la = std::numeric_limits<double>::infinity();
    double t_last = 0.0;
    Ref last;
    bool open = true;
    bool resolved = false;
  };
  struct Pending {
    io::LogRow row;
    double q = 0.0;
    long long run = -1;  // −1: outside every dwell
  };
  template <class F>
  void drain(F& use) {
    io::LogRow r;
    double q = 0.0;
    bool keep = true;
    while (pop(r, q, keep)) use(r, q, keep);
  }
  double guard_s_;
  std::deque<Pending> pending_;
  std::deque<Run> runs_;                      // runs with pending rows (and the open one)
  std::deque<std::pair<double, Ref>> hist_;   // (t, reference) of the rows in the last guard_s
  long long next_run_ = 0;
  long long dropped_ = 0;
  double last_t_ = -std::numeric_limits<double>::infinity();
  bool closed_ = false;
};

// The dwell guard of a model: its "dwell_guard_s" (s, ≥ 0; 0 turns the guard off), else
// kDefaultDwellGuard_s. Throws SolverError unless finite and ≥ 0.
constexpr double kDefaultDwellGuard_s = 0.5;
double dwell_guard_of(const model::ModelSpec& spec);

// The Ṫ window of a model: its "dTdt_window_s" (s), else ThermalConstants' default. Throws SolverError
// unless positive and finite.
double dTdt_window_of(const model::ModelSpec& spec);
// The hysteresis tracker of a model, on the logged temperature: its hysteresis_threshold_C (what `imuforge
// diagnose --emit-model` writes when it chose one), else ThermalConstants' default, read through
// model::kLoggedTempSmoothing_s.
model::HysteresisTracker logged_hysteresis_tracker(const model::ModelSpec& spec);

class FixtureAccumulator {
 public:
  FixtureAccumulator(const model::ModelSpec& spec, const io::LogMeta& meta);

  // Streams one row. Rows without a reference or outside a dwell (segment −1) only feed the hysteresis
  // tracker and the Ṫ estimate: in motion, ω̇ and ḟ are not in the log, so those rows cannot be
  // modelled exactly. Dwell rows next to a reference change are left out (DwellGuard), so every row is
  // processed dwell_guard_s late; with temp_rate in the model dTdt_window_s later still (its Ṫ needs the
  // temperatures up to t + window). on_segment fires that much later.
  void add(const io::LogRow& row);
  // Flushes the last block and segment. Must be called before the results below.
  void finish();

  // Called after every completed segment with its statistics (in local space, unweighted), in log order.
  // Before finish(), SegmentSummary::plateau is the plateau's DISCOVERY index (see plateau_ranks()).
  std::function<void(const SegmentSummary&, const ChannelSet&)> on_segment;

  // Parameter slots: spec parameters, with per-plateau ones expanded to one slot per plateau
  // (named "<name>@plateau<k>", plateaus sorted by temperature). Before finish(): over the plateaus
  // discovered so far (k then ranks them by their current mean temperature).
  std::vector<std::string> names() const;
  const std::vector<PlateauInfo>& plateaus() const { return plateaus_sorted_; }
  bool has_per_plateau() const { return any_per_plateau_; }
  bool has_temp_rate() const { return tdot_.has_value(); }
  // Half window of the centred difference for Ṫ (model file "dTdt_window_s", default 10 s).
  double dTdt_window_s() const { return dTdt_window_s_; }
  // Plateaus discovered so far, and for each (by discovery index) its rank by mean temperature. Ranks of
  // existing plateaus never swap (a segment joins the nearest plateau, so means cannot cross); a new
  // plateau shifts the ranks above it by one.
  int plateaus_discovered() const { return static_cast<int>(plateau_n_.size()); }
  std::vector<int> plateau_ranks() const;
  // Slot names / slot index with `np` plateaus (rank in 0..np−1). names() == slot_names(plateaus so far).
  std::vector<std::string> slot_names(int np) const;
  int slot(int sensor, int local, int plateau_rank, int np) const;
  // Adds one channel set's statistics, weighted by 1/σ², to ne at the slots of plateau_rank of np.
  void add_weighted(const ChannelSet& set, const Sigma6& sigma, int plateau_rank, int np, NormalEquations& ne) const;
  // Slots (ascending) of the per-plateau parameters of the plateau with this rank, among np plateaus.
  std::vector<int> plateau_slots(int plateau_rank, int np) const;
  // Weighted normal equations in slot space.
  NormalEquations normal_equations(const Sigma6& sigma) const;
  // Weighted information of one segment's statistics, in the slot space of the plateaus discovered so
  // far (slot_names(plateaus_discovered())); `plateau` is the segment's discovery index
  // (SegmentSummary::plateau in on_segment). The overload without it refuses per-plateau models.
  NormalEquations segment_normal_equations(const ChannelSet& seg, const Sigma6& sigma, int plateau) const;
  NormalEquations segment_normal_equations(const ChannelSet& seg, const Sigma6& sigma) const;
  // Pooled within-block standard deviation per channel (static-segment noise estimate).
  Sigma6 static_noise_sigma() const;
  // RMS of y − (u + Jθ) per channel at the slot-space estimate theta.
  Sigma6 residual_rms(const Eigen::VectorXd& theta) const;
  const std::map<int, SegmentSummary>& segments() const { return segments_; }
  long long samples_used() const { return samples_used_; }
  // Per dwell (segment) and channel: samples, Σφ and Σz, where φ is the channel's regressor row in the
  // sensor's local space. Σφ is the bias column of the segment's A (the bias regressor is 1), so it costs
  // nothing to keep; sphi[c] is empty when the model has no (shared) bias on that channel. Transit segments of
  // a per-plateau model are not kept. `plateau` is the sorted rank after finish().
  struct SegmentMeans {
    int plateau = -1;
    long long n = 0;
    double t_mid_s = 0.0;  // mean time of its kept rows (the dwell-drift model's dwell time)
    std::array<Eigen::VectorXd, kNumChannels> sphi;
    std::array<double, kNumChannels> sz{};
  };
  const std::vector<SegmentMeans>& segment_means() const { return seg_means_; }
  // Dwell rows left out by the dwell guard (DwellGuard, model "dwell_guard_s"), and that guard.
  long long guarded_samples() const { return guard_.dropped(); }
  double dwell_guard_s() const { return guard_.guard_s(); }
  // Per-plateau models only: samples of segments whose die temperature moved by more than the plateau
  // tolerance (3 °C). They belong to no plateau (SegmentSummary::plateau = −1, no on_segment call) and
  // inform no parameter.
  long long transit_samples() const { return transit_samples_; }
  const model::ModelSpec& spec() const { return spec_; }
  // Local parameter ids of a sensor (catalog ids, spec order).
  const std::vector<model::ParamId>& sensor_ids(model::Sensor s) const { return ids_[static_cast<int>(s)]; }

 private:
  void process(const io::LogRow& row, double Tdot_C_s, bool keep);
  void flush_block();
  void flush_segment();
  int plateau_of(double T_C);
  int num_plateaus() const { return finished_ ? static_cast<int>(plateaus_sorted_.size()) : plateaus_discovered(); }

  model::ModelSpec spec_;
  double lsb_[2];
  std::array<std::vector<model::ParamId>, 2> ids_;
  std::array<std::vector<bool>, 2> per_plateau_;
  std::array<std::vector<int>, 2> spec_pos_;  // position of each local parameter in spec order
  bool any_per_plateau_ = false;
  bool needs_temp_ = false;
  model::HysteresisTracker hyst_;  // logged_hysteresis_tracker(spec)
  double dTdt_window_s_ = 10.0;
  std::optional<CenteredTempRate> tdot_;  // only when the model has temp_rate
  DwellGuard guard_;                      // after tdot_: rows reach process() guard_s later still

  // Ṫ moments of the current block, q = Ṫ: Σ q s^k (k ≤ 3), Σ q², per channel Σ q z. With them the
  // temp_rate regressor (q on its axis) joins the block compression exactly: φ(s, q) = B m(s) + e q.
  struct RateMoments {
    double qs[4] = {};
    double qq = 0.0;
    double qz[kNumChannels] = {};
  } block_q_;

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
  double seg_t_sum_s_ = 0.0;

  std::vector<ChannelSet> plateau_stats_;  // by discovery order
  std::vector<double> plateau_T_sum_;
  std::vector<long long> plateau_n_;
  std::vector<PlateauInfo> plateaus_sorted_;
  std::vector<int> discovery_to_sorted_;
  std::map<int, SegmentSummary> segments_;
  std::vector<SegmentMeans> seg_means_;
  std::array<std::array<int, 3>, 2> bias_local_{{{-1, -1, -1}, {-1, -1, -1}}};  // local index of bias.<axis>, −1: none
  // Within-block variance pools: [0] blocks whose die temperature spans ≤ kNoiseBlockSpan_C (dwells),
  // [1] all blocks. A linear trend in T removes a dwell's drift, not the curvature of a ramp across tens
  // of °C, so ramps and soaks after a step only count when there are too few dwells.
  double var_num_[2][kNumChannels] = {};
  long long var_den_[2] = {};
  double block_T_min_ = 0.0, block_T_max_ = 0.0;
  long long samples_used_ = 0;
  long long transit_samples_ = 0;
  double seg_T_min_C_ = 0.0, seg_T_max_C_ = 0.0;
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

// How the dwell means scatter about the fit, per channel: Σ_s n_s r̄_s² / σ² over the dwells, divided by its
// degrees of freedom (dwells − the parameters that act on the channel), r̄_s the dwell's mean residual at the
// slot-space estimate theta. 1 for white noise; above 1 when the noise wanders between dwells (bias
// instability, random walk) or the model misses a dwell-to-dwell effect, by the factor the dwell means'
// variance exceeds σ²/n. NaN for a channel without a bias term or without dwells to spare. acc finished;
// O(dwells × parameters).
struct SegmentScatter {
  std::array<double, kNumChannels> ratio{};
  std::array<int, kNumChannels> dof{};
};
SegmentScatter segment_scatter(const FixtureAccumulator& acc, const Eigen::VectorXd& theta, const Sigma6& sigma);
// Whether a ratio is past white noise's spread: > 1 + 3·sqrt(2/dof) (the χ² test at about 3σ).
bool scatter_significant(double ratio, int dof);
// The dwell-to-dwell drift (estimator/drift.h, docs/calibration.md "Dwell drift"). Per channel, the dwells' sums
// over their kept rows in one parameter space (slot space in fixture mode, model + nuisance in fixture+errors):
// Σ z (or the residual at the estimate: REML does not tell them apart), Σ φ (the channel's Jacobian rows), n and
// the mean time.
struct DwellSums {
  double t_mid_s = 0.0;
  long long n = 0;
  double sz = 0.0;
  Eigen::VectorXd sphi;
};
// A channel's dwells as the drift fit and the covariance take them: the series on the parameters that act on the
// channel (`cols`, the non-zero entries of any Σ φ), and G = Σ φ/σ². Throws on a dwell without samples.
// O(dwells · parameters).
struct DwellDriftInput {
  estimator::DwellSeries series;
  Eigen::MatrixXd G;
  std::vector<int> cols;
};
DwellDriftInput dwell_drift_input(const std::vector<DwellSums>& dwells, double sigma);
using ChannelDrifts = std::array<estimator::DwellDrift, kNumChannels>;
// Fits each channel's drift (none where the channel has no dwells). O(channels · grid · dwells · p²).
ChannelDrifts fit_drifts(const std::array<DwellDriftInput, kNumChannels>& in);
// The covariance of a weighted least-squares estimate whose white-σ covariance is C0 under those drifts
// (estimator::drift_covariance): C0 + C0 Gᵀ C G C0 per channel with an adopted drift, per parameter the largest
// over the drifts the dwell means do not reject.
Eigen::MatrixXd drift_widened_covariance(const std::array<DwellDriftInput, kNumChannels>& in, const Eigen::MatrixXd& C0,
                                         const ChannelDrifts& drifts);
// Whether the model lets the drift widen σ: its "dwell_scatter" (default true; false keeps the white σ).
bool dwell_scatter_of(const model::ModelSpec& spec);
// solve_fixture, then, unless the model says "dwell_scatter": false, the covariance widened by the channels'
// adopted drifts (the estimate unchanged). The solution's noise_sigma stays `sigma`. `scatter` (optional) receives
// the dwell-mean χ² ratios, `drifts` the fitted drifts. Every fixture-mode solve that reports σ goes through here
// (`imuforge solve`, the end-of-line batch, the Python module).
FixtureSolution solve_fixture_widened(const FixtureAccumulator& acc, const Sigma6& sigma, SegmentScatter* scatter = nullptr,
                                      ChannelDrifts* drifts = nullptr);
// cal.json's "dwell_scatter": {"widened": bool, "<channel>": {ratio, dof, significant, drift: {adopted, gain,
// offset_sigma, gm_sigma, gm_tau_s, flicker_sigma, plausible}}, …}. The same section from `imuforge solve` and the end-of-line
// runner.
// sc may be null (fixture+errors: no ratio, the drift only).
nlohmann::json dwell_scatter_json(const SegmentScatter* sc, bool widen, const ChannelDrifts& drifts);

// Solves; throws SolverError naming unobservable combinations on rank deficiency.
FixtureSolution solve_fixture(const FixtureAccumulator& acc, const Sigma6& sigma);

}  // namespace imuforge::solver
