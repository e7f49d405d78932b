// The deterministic measurement equation of docs/error-model.md, and its regressors.
//
// For one triad, y = u + J(input) · θ, where u is the ideal input (f or ω) and θ the catalog
// parameters: the model is LINEAR in every deterministic parameter. measure() evaluates y directly;
// regressors() gives the 3×n matrix J = ∂y/∂θ for any parameter list. The simulator uses measure(),
// the solver uses regressors(); a test asserts measure() == nominal() + J·θ, so they cannot disagree.
//
// Stochastic effects (white noise, bias instability, rate random walk, quantization, saturation,
// turn-on bias) are NOT here: the simulator realises them (host/sim/noise.h).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "host/model/catalog.h"
#include "host/model/sensor_model.h"

namespace imuforge::model {

using Vec3 = Eigen::Vector3d;

// Everything the deterministic model needs at one sample. All in the IMU nominal frame.
struct MeasureInput {
  Vec3 f = Vec3::Zero();       // specific force at the IMU reference point, m/s²
  Vec3 w = Vec3::Zero();       // angular rate w.r.t. inertial space, rad/s
  Vec3 wdot = Vec3::Zero();    // angular acceleration, rad/s² (size effect; gyro u̇ for timing)
  Vec3 fdot = Vec3::Zero();    // d f/dt, m/s³ (accel u̇ for timing)
  double T_C = 25.0;           // die temperature
  double Tdot_C_s = 0.0;       // die temperature rate
  double d = 0.0;              // hysteresis direction d(t) ∈ {−1, 0, +1}
  double t_s = 0.0;            // time since log start (timing ppm term)
};

// The ideal input u of a triad: f for the accelerometer, ω for the gyro.
inline const Vec3& nominal(Sensor s, const MeasureInput& in) { return s == Sensor::kAccel ? in.f : in.w; }
// Its time derivative u̇ (fdot or wdot).
inline const Vec3& nominal_rate(Sensor s, const MeasureInput& in) { return s == Sensor::kAccel ? in.fdot : in.wdot; }

// Options: the simulator realises timing exactly (by evaluating the input at the shifted time) and
// passes include_timing = false; the solver's linearised model keeps it on.
struct MeasureOptions {
  bool include_timing = true;
};

// Precomputed dense coefficients of one triad, so per-sample evaluation does no lookups.
// Build once per sensor model with compile(); evaluate with measure().
struct CompiledTriad {
  Sensor sensor = Sensor::kAccel;
  double T_ref_C = 25.0;
  double b[3] = {0, 0, 0};
  double bt[3][3] = {};        // [j][p-1]
  double M[3][3] = {};         // scale diagonal + misalign off-diagonal (δ excluded)
  double Mt[3][3][3] = {};     // [j][k][p-1]
  double k2[3] = {}, k3[3] = {}, asym[3] = {};
  double cc[3][3] = {};        // [j][k], k≠j
  double G[3][3] = {};         // gyro only
  double G2[3][6] = {};        // [j][term] 0=xy, 1=yz, 2=zx, 3=xx, 4=yy, 5=zz
  double xn[3][6] = {};        // accel only, cross-axis nonlinearity: [j][term] as G2, terms in f_k f_l (k, l != j)
  double r[3][3] = {};         // size effect lever arm of axis j: r[j][0..2]
  double hyst[3] = {}, trate[3] = {};
  double latency_s = 0.0, ppm = 0.0;
};
// Uses SensorModel::effective_params() (disabled effects contribute zero).
CompiledTriad compile(const SensorModel& m, Sensor s);
CompiledTriad compile(const ParamSet& p, Sensor s, double T_ref_C);

// y in SI (before noise, quantization and saturation). O(1), no allocation.
Vec3 measure(const CompiledTriad& c, const MeasureInput& in, const MeasureOptions& opt = {});
// Convenience (compiles each call; not for per-sample loops).
Vec3 measure(const SensorModel& m, Sensor s, const MeasureInput& in, const MeasureOptions& opt = {});

// Regressors: J.col(i) = ∂y/∂θ_ids[i] for triad s (zero column for parameters of the other sensor or
// stochastic ones). J must be 3 × ids.size(). T_ref_C is the model's reference temperature.
// O(ids.size()), no allocation.
void regressors(Sensor s, const std::vector<ParamId>& ids, const MeasureInput& in, double T_ref_C,
                Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> J, const MeasureOptions& opt = {});

// The regressors of a fixed parameter list, compiled once for a per-sample loop that sums them (the diagnosis's
// block means): accumulate() adds J = ∂y/∂θ to a 3 × ids.size() matrix, bit-identical to adding what
// regressors(s, ids, …) returns (one column kernel serves both). Each column is held in 12 bytes instead of
// read from its ParamInfo, and only its non-zero entries (one, three for timing) are touched: the per-sample
// regressors were a quarter of a 1 h, 1 kHz diagnosis, which the plan takes from 12.8 s to 11.1 s
// (diagnosis_bench). Construction O(ids.size()) (allocates);
// accumulate() O(ids.size()), no allocation. Throws std::invalid_argument when J has the wrong width.
class RegressorPlan {
 public:
  struct Column {
    Effect effect = Effect::kBias;
    std::int8_t j = 0, k = 0, l = 0, power = 0;
    bool latency = false;  // timing: the latency column (else the clock's ppm)
    bool active = false;   // a deterministic parameter of this triad (else the column stays zero)
  };
  static Column column(Sensor s, ParamId id, const MeasureOptions& opt = {});
  RegressorPlan() = default;
  RegressorPlan(Sensor s, const std::vector<ParamId>& ids, const MeasureOptions& opt = {});
  std::size_t size() const { return cols_.size(); }
  void accumulate(const MeasureInput& in, double T_ref_C, Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> J) const;

 private:
  Sensor sensor_ = Sensor::kAccel;
  bool need_size_ = false;
  std::vector<Column> cols_;
};

// Size-effect term alone: s_j = [ω×(ω×r_j) + ω̇×r_j]_j (m/s²). Exposed for the test and the docs.
Vec3 size_effect_term(const double r[3][3], const Vec3& w, const Vec3& wdot);

// ---- thermal-history helpers, shared by simulator (true die temperature) and solver (logged temp_C) ----

// Streaming d(t): +1 after heating, −1 after cooling, 0 before the first significant change.
// A change is significant when T has moved more than threshold_C from the last turning point.
// smooth_tau_s > 0: the turning-point test reads T through a first-order low-pass of that time constant
// (t_s gives the step; a first sample or a time going backwards restarts it at T, a repeated time leaves it).
// A logged temperature carries its sensor's noise, and the test reads the extremes of what it is fed. Raw,
// 0.02 °C of white noise at 100 Hz turned d at 771 s on the simulate source's
// single-accel.temp_hysteresis-automotive (a die that self-heating warms by less than the threshold during a
// soak) and back at 846 s, and every real turn came 5–9 s early: the solver read 0.87 of the true h (14 σ),
// the diagnosis 0.54 (6.6 σ). Through kLoggedTempSmoothing_s (noise 10× down at 100 Hz, a turn delayed by
// about that constant) neither false turn remains: the diagnosis reads h within 1 σ, the solver within 2.3 σ
// (on that sensor without its bias instability, which the solver's σ leaves out). A V-shaped turn at 0.4 °C/s
// (tests: a piecewise-linear temperature) still turns within a second; a die, a minute behind its chamber,
// turns far more slowly than that. The simulator feeds the true die temperature unsmoothed (the physics);
// the estimators feed the logged one.
//
// A caller that runs several thresholds on one temperature (the diagnosis's profile) smooths it once with
// LowPass below and feeds unsmoothed trackers.

// First-order low-pass of a sampled signal on its own time stamps: y += (1 − e^(−Δt/τ))·(x − y). A first sample
// or a time going backwards restarts it at x; a repeated time leaves it. The gain of the last step length is
// reused while the steps repeat (to 1e-9 relative): one exp per sample was 5 % of a diagnosis. O(1).
class LowPass {
 public:
  explicit LowPass(double tau_s) : tau_(tau_s) {}
  double update(double x, double t_s);  // x finite
  void reset() { have_ = false; }

 private:
  double tau_;
  bool have_ = false;
  double y_ = 0.0, t_prev_ = 0.0;
  double dt_gain_ = -1.0, gain_ = 0.0;
};

class HysteresisTracker {
 public:
  explicit HysteresisTracker(double threshold_C = 0.5, double smooth_tau_s = 0.0)
      : thr_(threshold_C), smooth_(smooth_tau_s > 0), lp_(smooth_tau_s) {}
  // Feed samples in time order; returns d for this sample. NaN temperatures keep the current state.
  // O(1). t_s is used only with smoothing.
  double update(double T_C, double t_s = 0.0);
  double direction() const { return d_; }
  void reset() {
    init_ = false;
    d_ = 0.0;
    lp_.reset();
  }

 private:
  double thr_;
  bool smooth_;
  LowPass lp_;
  bool init_ = false;
  double d_ = 0.0;
  double extreme_ = 0.0;  // last turning point candidate (max while heating, min while cooling)
};

// Time constant the estimators (solver, end-of-line tracker, diagnosis) smooth a logged temperature with before
// HysteresisTracker.
inline constexpr double kLoggedTempSmoothing_s = 0.5;

// Ṫ by centred difference over ±window_s (shrunk to one side at the ends): for sample i, the slope
// between the first sample at ≥ t_i−window and the last at ≤ t_i+window. NaN temperatures -> 0.
// O(n), output size n. t must be non-decreasing.
std::vector<double> temp_rate_centered(const std::vector<double>& t_s, const std::vector<double>& T_C,
                                       double window_s);

}  // namespace imuforge::model
