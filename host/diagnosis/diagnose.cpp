// The diagnosis pipeline (docs/diagnosis.md): pass 0 (noise, reference), pass 1 (block means at the
// possibly shifted time), the whitened per-axis design, folds, forward–backward selection, the
// unexplained verdict, the final joint fit, cells and plot data. One piece, ~5,400 lines, because every
// stage reads the same per-axis design and fold statistics (AxisData) and the time-shift iteration
// re-runs the whole chain; splitting it would pass that state through a dozen signatures. The fits and
// held-out scores themselves live in host/estimator (shared with the solver); the noise model in
// noise_model.*, the Allan and signature statistics in stats.*, the reference-step test and lag probe in
// step_lag.*, the rate table's axis errors in table_errors.*. What runs on more than one thread (the log read
// ahead, the regressors' block sums, the wander search's lines) gives the one-thread answer to the last bit:
// concurrency.h, prefetch.*, regressor_sums.*.
#include "host/diagnosis/diagnose.h"
#include "host/diagnosis/dropouts.h"
#include "host/diagnosis/glitches.h"
#include "host/diagnosis/concurrency.h"
#include "host/diagnosis/prefetch.h"
#include "host/diagnosis/regressor_sums.h"
#include "host/diagnosis/output_bits.h"
#include "host/diagnosis/step_lag.h"
#include "host/diagnosis/table_errors.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>

#include "host/estimator/kfold.h"
#include "host/model/measure.h"
#include "host/model/sensor_model.h"

namespace imuforge::diagnosis {

using model::Effect;
using model::ParamId;
using model::Sensor;

std::string ambiguity_reason(const DiagnosisResult::Ambiguity& a) {
  char buf[160];
  if (a.nested)
    std::snprintf(buf, sizeof buf, "nested in the other, with %s components the data need (%d against %d)%s",
                  a.components_chosen < a.components_alternative ? "fewer" : "as many", a.components_chosen, a.components_alternative,
                  a.components_chosen < a.components_alternative ? "" : " and fewer in the catalog");
  else
    std::snprintf(buf, sizeof buf, "larger AIC gain, on the components the data need, by %.1f", a.delta_aic);
  return buf;
}

const char* axis_name(int a) {
  static const char* kNames[kNumAxes] = {"accel.x", "accel.y", "accel.z", "gyro.x", "gyro.y", "gyro.z"};
  return (a >= 0 && a < kNumAxes) ? kNames[a] : "?";
}

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();
// Whether an `ambiguous` entry is the pair of effects a and b, whichever of the two was chosen.
bool same_pair(const DiagnosisResult::Ambiguity& x, const std::string& a, const std::string& b) {
  return (x.chosen == a && x.alternative == b) || (x.chosen == b && x.alternative == a);
}
// Whether axis a of gap g is over the unexplained threshold: its held-out χ²/dof above it, and not within it in the
// GLS fit under an adopted whole-log wander (Gap::chi2_dof_wander, NaN where none is adopted).
bool over_threshold(const Gap& g, int a, double chi2_dof_max) {
  const auto ua = static_cast<std::size_t>(a);
  return g.chi2_dof[ua] > chi2_dof_max && !(std::isfinite(g.chi2_dof_wander[ua]) && g.chi2_dof_wander[ua] <= chi2_dof_max);
}
// The mount rotation's corrections (diagnose(), "Mount rotation"): χ² of 3 dof a first one must pass (p 1e-3), and
// a further one (p 0.01).
const double kMountFirstChi2 = 16.27, kMountNextChi2 = 11.34;
const double kFormLr = 23.0;  // χ²(2 dof) at p = 1e-5: the functional-form (RESET) check of a selected effect
// ... and the size its remainder must have against the effect's own signal (norms over the blocks) to say the form
// is wrong. A true gyro scale_nonlinearity of 2.6 rad/s at the table's top rate (varied8 random-10, snr 6e4) left
// 5.5e-5 of it, a second-order detail of an effect that size, at LR 130, and was withdrawn for it at no floor. Over
// the trace of every case of the nineteen blind suites (stop 49), the true effects that fail the LR tests leave at
// most 2.4e-4 (varied10 random-12 gyro cross_coupling) and the stand-ins at least 9.0e-3 (varied19 ooc-w_cubed-0:
// a gyro g2_sensitivity's isotropic squares, identified by the centripetal acceleration of a 975 °/s rate, took
// a |ω|³ bias and left 0.009, under the 0.01 floor this was until then). The floor sits between, a factor of
// about 5 from each.
const double kFormShare = 0.002;

// Deterministic catalog parameters of one sensor, in catalog order.
std::vector<ParamId> sensor_params(Sensor s) {
  std::vector<ParamId> ids;
  for (const auto& p : model::params())
    if (p.sensor == s && p.deterministic) ids.push_back(p.id);
  return ids;
}

std::string effect_key(Sensor s, Effect e) {
  return std::string(model::sensor_name(s)) + "." + model::effect_info(e).name;
}

// The parameters a candidate effect enters the model with: those the model file loader gives
// `"sensor.effect": {}` (model_spec_from_json, then ModelSpec::parameters; one table, built once and
// thread-safely), so that what the diagnosis tests and selects is what its user then adds. A
// temperature polynomial (bias_temp, scale_temp, misalign_temp) enters at the file's default order, 1. Scored
// with all three powers, misalign_temp took 18 columns per sensor where its six slopes were the signal: the
// fold fits of the cubic extrapolate, so a real one often lost its held-out gain, and once selected it spoiled
// the held-out score of later candidates (varied12 random-8: a true accel k2 at held-out gain −745 beside the
// cubic, +21.7 beside the slopes; stop 42).
const std::vector<ParamId>& candidate_params(Sensor s, Effect e) {
  static const std::map<std::pair<int, int>, std::vector<ParamId>> table = [] {
    std::map<std::pair<int, int>, std::vector<ParamId>> t;
    for (const auto& ei : model::effects()) {
      if (ei.kind != model::EffectKind::kDeterministic) continue;
      for (Sensor sn : {Sensor::kAccel, Sensor::kGyro}) {
        if (!(ei.sensors & (sn == Sensor::kAccel ? model::kMaskAccel : model::kMaskGyro))) continue;
        const nlohmann::json j = {{"effects", {{effect_key(sn, ei.effect), nlohmann::json::object()}}}};
        t[{static_cast<int>(sn), static_cast<int>(ei.effect)}] = model::model_spec_from_json(j).parameters();
      }
    }
    return t;
  }();
  static const std::vector<ParamId> none;
  const auto it = table.find({static_cast<int>(s), static_cast<int>(e)});
  return it == table.end() ? none : it->second;
}

// The nominal input u of output axis a (0…5): specific force for accel.x…z, rate for gyro.x…z.
// Keep it a branch on two plain subscripts. The shorter `(a < 3 ? f : w)[a % 3]` is miscompiled by GCC 12
// under -fsanitize=undefined (the instrumented index is computed in the first arm only and the second arm
// reads a stale one), so the sanitizer build subtracted w[2] from every gyro axis. Guarded by the test
// DiagnosisPipeline.NominalInputPerAxis, which runs in the host-sanitize preset.
double nominal_input(const double (&f)[3], const double (&w)[3], int a) {
  if (a < 3) return f[a];
  return w[a - 3];
}

// ---------------------------------------------------------------------------------------------------
// Pass 0: duration, rate, and a 0.1 s binned temperature series for Ṫ.
struct Pass0 {
  long long n = 0, n_ref = 0;
  double t_first = 0, t_last = 0, fs = 0;
  double bin_s = 0.1;
  std::vector<double> Tbin;  // NaN where no temperature
  std::vector<double> Tdot;  // °C/s per bin
  std::array<double, kNumAxes> out_step{};  // output step of a quantised axis (0: continuous), noise_model.h
  // Output limits (saturation) per axis: the extreme value an output sticks at while its reference lies beyond
  // it; NaN = none found. Samples reading exactly that value are left out (run_pass1).
  std::array<double, kNumAxes> clamp_hi, clamp_lo;
  std::array<long long, kNumAxes> n_clamped{};
  bool clamped(const Sample& s) const {
    for (int a = 0; a < kNumAxes; ++a)
      if (s.y[a] == clamp_hi[static_cast<std::size_t>(a)] || s.y[a] == clamp_lo[static_cast<std::size_t>(a)]) return true;
    return false;
  }
  double tdot_at(double t) const {
    if (Tdot.empty()) return 0.0;
    // Clamp in floating point: converting an out-of-range double to an integer is undefined.
    const double x = std::floor((t - t_first) / bin_s);
    if (!(x > 0.0)) return Tdot.front();
    if (x >= static_cast<double>(Tdot.size() - 1)) return Tdot.back();
    return Tdot[static_cast<std::size_t>(x)];
  }
};

Pass0 run_pass0(SampleSource& src, const Options& opt) {
  Pass0 p;
  src.rewind();
  Sample s;
  std::vector<double> sum, cnt;
  bool first = true;
  double prev_t = 0;
  // Output steps: the first kStepDiffs sample-to-sample differences per axis are plenty to see a lattice.
  const std::size_t kStepDiffs = 400000;
  std::array<std::vector<double>, kNumAxes> diffs;
  std::array<double, kNumAxes> y_prev{}, y_max{};
  // Saturation: the running extreme of each output and the samples that read exactly it (their count and the
  // largest / smallest reference among them), and a straight line y = s·u + b through every other sample with a
  // reference. A clamped output sits at its limit for whole dwells while the line puts the input past it; an
  // unclamped one reaches its extreme a few times, and a coarse quantiser that repeats its top level at the
  // highest rate dwell has the line at that level (a consumer gyro 2 % low in scale read 3.420 rad/s at a
  // reference of 3.491 on the blind stoch-consumer-3: the reference alone cannot tell).
  std::array<double, kNumAxes> hi, lo, hi_umax, lo_umin;
  std::array<long long, kNumAxes> hi_n{}, lo_n{};
  std::array<std::array<double, 5>, kNumAxes> line{}, line_hi{}, line_lo{};  // Σ1, Σu, Σy, Σuu, Σuy
  hi.fill(-std::numeric_limits<double>::infinity());
  lo.fill(std::numeric_limits<double>::infinity());
  hi_umax.fill(-std::numeric_limits<double>::infinity());
  lo_umin.fill(std::numeric_limits<double>::infinity());
  while (src.next(s)) {
    if (!std::isfinite(s.t_s)) throw DiagnosisError("sample " + std::to_string(p.n) + ": time is not finite");
    if (first) {
      p.t_first = s.t_s;
      first = false;
    } else if (s.t_s < prev_t) {
      throw DiagnosisError("sample " + std::to_string(p.n) + ": time goes backwards (" + std::to_string(s.t_s) +
                           " s after " + std::to_string(prev_t) + " s)");
    }
    prev_t = s.t_s;
    for (int a = 0; a < kNumAxes; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      if (p.n > 0 && diffs[ua].size() < kStepDiffs) diffs[ua].push_back(std::fabs(s.y[a] - y_prev[ua]));
      y_prev[ua] = s.y[a];
      if (!std::isfinite(s.y[a])) continue;
      y_max[ua] = std::max(y_max[ua], std::fabs(s.y[a]));
      if (!s.has_ref) continue;
      const double u = a < 3 ? s.f[a] : s.w[a - 3];
      const std::array<double, 5> term{1.0, u, s.y[a], u * u, u * s.y[a]};
      for (int k = 0; k < 5; ++k) line[ua][static_cast<std::size_t>(k)] += term[static_cast<std::size_t>(k)];
      if (s.y[a] > hi[ua]) hi[ua] = s.y[a], hi_n[ua] = 0, hi_umax[ua] = -std::numeric_limits<double>::infinity(), line_hi[ua] = {};
      if (s.y[a] == hi[ua]) {
        ++hi_n[ua];
        hi_umax[ua] = std::max(hi_umax[ua], u);
        for (int k = 0; k < 5; ++k) line_hi[ua][static_cast<std::size_t>(k)] += term[static_cast<std::size_t>(k)];
      }
      if (s.y[a] < lo[ua]) lo[ua] = s.y[a], lo_n[ua] = 0, lo_umin[ua] = std::numeric_limits<double>::infinity(), line_lo[ua] = {};
      if (s.y[a] == lo[ua]) {
        ++lo_n[ua];
        lo_umin[ua] = std::min(lo_umin[ua], u);
        for (int k = 0; k < 5; ++k) line_lo[ua][static_cast<std::size_t>(k)] += term[static_cast<std::size_t>(k)];
      }
    }
    ++p.n;
    if (s.has_ref) ++p.n_ref;
    if (std::isfinite(s.temp_C)) {
      const double bin = (s.t_s - p.t_first) / p.bin_s;  // ≥ 0: time never goes backwards here
      if (!(bin < 1e8 + 1.0)) throw DiagnosisError("log spans an implausible time range");
      const std::size_t i = static_cast<std::size_t>(bin);
      if (i >= sum.size()) {
        sum.resize(i + 1, 0.0);
        cnt.resize(i + 1, 0.0);
      }
      sum[i] += s.temp_C;
      cnt[i] += 1.0;
    }
  }
  if (p.n < 2) throw DiagnosisError("log has fewer than 2 samples");
  p.t_last = prev_t;
  const double dur = p.t_last - p.t_first;
  if (!(dur > 0)) throw DiagnosisError("log has zero duration");
  p.fs = static_cast<double>(p.n - 1) / dur;
  // Below 4e-7 of the largest value a difference is float resolution (f32 logs), not a step.
  for (int a = 0; a < kNumAxes; ++a)
    p.out_step[static_cast<std::size_t>(a)] = output_step(std::move(diffs[static_cast<std::size_t>(a)]), 4e-7 * y_max[static_cast<std::size_t>(a)]);
  p.clamp_hi.fill(kNaN);
  p.clamp_lo.fill(kNaN);
  for (std::size_t a = 0; a < static_cast<std::size_t>(kNumAxes); ++a) {
    std::array<double, 5> L = line[a];
    for (int k = 0; k < 5; ++k) L[static_cast<std::size_t>(k)] -= line_hi[a][static_cast<std::size_t>(k)] + line_lo[a][static_cast<std::size_t>(k)];
    const double det = L[0] * L[3] - L[1] * L[1];
    if (!(L[0] > 100) || !(det > 0)) continue;
    const double sc = (L[0] * L[4] - L[1] * L[2]) / det, b = (L[2] - sc * L[1]) / L[0];
    // Past the limit by more than 1 % of it: the line's output at the most extreme reference that read it.
    // An output range is symmetric (to an LSB or two: int16 ends at −32768 and +32767): when the two extremes
    // are one limit, the samples of both sides count together, so a composite rate that crosses the limit
    // briefly on one side (7 samples on the simulate source's null-consumer-3, each 40σ off) is left out with
    // the side that sat there longer; and once one side is a limit by that test, the other side's extreme is
    // the same limit wherever the line puts its reference past it at all (null-consumer-6: a gyro 0.3 % low in
    // scale clamped 17 samples at −4.363 rad/s for a line output of −4.378, 17σ each, under the 1 % margin).
    // A coarse quantiser's top level stays unflagged: the line lands within its noise of it (stoch-consumer-3:
    // 1.1σ of the line's scatter), and its two extremes are not one limit.
    const double tol = 2.0 * std::max(p.out_step[a], 1e-9 * std::max(std::fabs(hi[a]), std::fabs(lo[a])));
    const bool symmetric = hi[a] > 0 && lo[a] < 0 && std::fabs(hi[a] + lo[a]) <= tol;
    const long long n_hi = symmetric ? hi_n[a] + lo_n[a] : hi_n[a], n_lo = symmetric ? hi_n[a] + lo_n[a] : lo_n[a];
    const double past_hi = hi_n[a] > 0 ? sc * hi_umax[a] + b - hi[a] : 0.0, past_lo = lo_n[a] > 0 ? lo[a] - (sc * lo_umin[a] + b) : 0.0;
    const bool strong_hi = n_hi >= 10 && hi[a] > 0 && past_hi > 0.01 * hi[a];
    const bool strong_lo = n_lo >= 10 && lo[a] < 0 && past_lo > -0.01 * lo[a];
    if (strong_hi || (symmetric && strong_lo && past_hi > 0)) p.clamp_hi[a] = hi[a], p.n_clamped[a] += hi_n[a];
    if (strong_lo || (symmetric && strong_hi && past_lo > 0)) p.clamp_lo[a] = lo[a], p.n_clamped[a] += lo_n[a];
  }
  if (!sum.empty()) {
    p.Tbin.assign(sum.size(), kNaN);
    for (std::size_t i = 0; i < sum.size(); ++i)
      if (cnt[i] > 0) p.Tbin[i] = sum[i] / cnt[i];
    // Centred difference over ±window (docs/error-model.md, "Temperature Ṫ"), one-sided at the ends.
    const long w = std::max<long>(1, std::lround(opt.dTdt_window_s / p.bin_s));
    const long nb = static_cast<long>(p.Tbin.size());
    p.Tdot.assign(p.Tbin.size(), 0.0);
    for (long i = 0; i < nb; ++i) {
      long a = std::max<long>(0, i - w), b = std::min<long>(nb - 1, i + w);
      while (a < i && !std::isfinite(p.Tbin[static_cast<std::size_t>(a)])) ++a;
      while (b > i && !std::isfinite(p.Tbin[static_cast<std::size_t>(b)])) --b;
      if (b > a && std::isfinite(p.Tbin[static_cast<std::size_t>(a)]) && std::isfinite(p.Tbin[static_cast<std::size_t>(b)]))
        p.Tdot[static_cast<std::size_t>(i)] =
            (p.Tbin[static_cast<std::size_t>(b)] - p.Tbin[static_cast<std::size_t>(a)]) / (static_cast<double>(b - a) * p.bin_s);
    }
  }
  return p;
}

// ---------------------------------------------------------------------------------------------------
// Pass 1: blocks.
// Thresholds (°C) the temperature history d(t) of temp_hysteresis is built at (docs/diagnosis.md § 5,
// "temp_hysteresis's threshold"): the threshold is the effect's nonlinear parameter, and a sensor's is not the
// catalog's default (blindgen's tactical sensor: 0.3 °C, the examples' others 0.5 °C). diagnose_core profiles it.
constexpr int kHysteresisGrid = 6;
constexpr std::array<double, kHysteresisGrid> kHysteresisGrid_C = {0.1, 0.2, 0.3, 0.5, 0.8, 1.2};
// Another threshold replaces the catalog's default only when its likelihood ratio is larger by this much (its
// likelihood e² ≈ 7× higher). Near-ties are common where the thresholds' turns fall in the same blocks, and there
// the pick was noise: `varied2` mixed-rate_memory (a 0.5 °C sensor) read 0.3 °C at 31.6 against 29.5, and
// `varied4` random-7 read 0.8 °C at 33 against 30 (a 0.3 °C sensor, profile flat at 21–33). Every threshold
// other than 0.5 °C that the blind suites' profiles picked correctly won by 5 or more (`holdout`
// mixed-w_cubed-0: 81 against 76).
constexpr double kHysteresisDefaultMargin = 4.0;
// A candidate counts as nested in a model (the nested equivalent in diagnose_core) when the model's span leaves less
// than this share of the signal the candidate fits in its place on the components it needs (norm against spread).
// Measured at stop 55 (`varied` suites): a k2 in the model with the cross-axis squares 0.0009, 0.002 and 0.037
// (varied25 random-28, mixed-w_cubed; varied24 random-11, where neither is significant beside the other, p 0.73
// and 0.69); scale_asymmetry's |u| in the model with scale_nonlinearity 0.067 and 0.087 (varied25 random-20, 17,
// whose k2 are true); a k2 beside the cross-axis squares where the rate table's centripetal term tells them apart
// 0.096 (varied26 random-6). A threshold from six pairs, between 0.037 and 0.067.
constexpr double kNestedShare = 0.05;
// The two cross-axis squares of an accel axis count as equal (scale_nonlinearity's k2 signature) when a Wald test
// of their difference reads p above kEqualSquaresP, and the in-sample cost of one k2 column in their place does
// not reject it (p above kSquaresSwapP; it also carries the centripetal term, where the two columns differ, and
// read p 0.013 on a true k2 whose squares' Wald test read 0.59: `varied29` random-22's accel.x). The
// k2-within-the-squares step of diagnose_core.
constexpr double kEqualSquaresP = 0.05;
constexpr double kSquaresSwapP = 1e-3;

struct Block {
  int segment = -1, unit = 0, fold = 0;
  double t0 = 0, t1 = 0;
  long n = 0;
  Eigen::MatrixXd J[2];  // mean regressors, 3 × n_params(sensor)
  double z[kNumAxes] = {};
  // mean features
  double t = 0, T = kNaN, Tdot = 0, d = 0, f[3] = {}, w[3] = {}, absw = 0;
  double absTdot = 0;  // block mean of |Ṫ| (signatures: what heating and cooling alike do)
  // The inputs through first-order lags of kMemoryTaus_s (signatures: an output that remembers what the input was,
  // as a suspension that creeps after each pose change does). Filled over the blocks in time order
  // (fill_input_memory).
  double f_mem[3][4] = {}, w_mem[3][4] = {};
  // Whether the table turns (|ω| > kMotionRate_rad_s), through first-order lags of kTurnLagTaus_s (signatures: an
  // output that follows the table motor's heat, rising through each run of rotations and decaying after it, which
  // the die's temperature sensor does not see). fill_input_memory.
  double turn_mem[3] = {};
  // The die's temperature minus itself through first-order lags of kGradTaus_s (signatures: a bias in the gradient
  // between the die and a board or case that follows it by minutes, which bends the package while the temperature
  // moves and relaxes after it holds). Ṫ is its limit for a lag far shorter than the ramps, T minus a constant for
  // one far longer. 0 where the log has no temperature. fill_input_memory.
  double T_grad[2] = {};
  // Block mean of the rotation wound up about the specific force since the log's start (rad, signed): the turns a
  // table without a slip ring has twisted its cable by, which strain the mount. Integrated sample by sample while
  // the table turns (|ω| > kMotionRate_rad_s, so the Earth's rate in the dwells adds no slow trend); zero where the
  // log has no rotation. A history, as no function of the present inputs is: the same pose reads differently after
  // turns one way and the other.
  double wound_rad = 0;
  // Block mean of e^{−s/τ} for each τ of kSettleTaus_s, s the time since the last motion ended: [0] a rotation,
  // [1] a rotation or a pose change between two static blocks (where the log's poses change instantaneously, the
  // turn between them is not in it). 0 on moving blocks and before the first motion (signatures: an output that
  // settles after every motion, as a drive ringing down or a motor's heat does). fill_motion_settling.
  double settle[2][3] = {};
  std::array<double, kHysteresisGrid> d_grid{};  // block mean of d at each threshold of kHysteresisGrid_C
  double ww[3] = {}, ff[3][3] = {};          // block means of ω_k² and f_k f_l (signatures)
  double wq[3][3] = {};                      // block means of ω_k ω_l of the gyro's reference as evaluated (mount)
  double wc[3][3] = {};                      // block means of ω_k² ω_l, likewise (mount: the cubic's cross terms)
  double sin_a[3] = {}, cos_a[3] = {};       // block means of sin/cos of the reported table angles
  long n_a[3] = {};
  bool is_static = false;
  double v[kNumAxes] = {};  // variance of the block mean per axis
  // Block means of the reference's derivative by the table's axis errors (Options::table known; else zero), per
  // output axis at the time each sensor reads its input.
  TableErrors::Jac D = TableErrors::Jac::Zero();
};

// Block mean of the table errors' derivative (Block::D) by the midpoint rule over groups of up to kDerivGroup
// consecutive samples: one evaluation at each group's middle sample, weighted by the group's size. The
// derivative is a smooth function of the table's angles (sines of them), so the rule's error is second order in
// a group's turn: at 1 kHz a group of 10 samples turns 0.05 rad at 300 °/s, and the mean moves by ~1e-4 of
// itself (Δ²/24), far below the 1e-3 at which the derivative is held anyway (TableErrors). An evaluation per
// moving sample (ten kinematics each) put diagnosis_bench's 1 h, 1 kHz case with --campaign at 36.2 s; once
// per group it is 28.7 s, the estimates moving by < 0.03 σ. The states are buffered per sensor (each reads at
// its own time); no allocation.
constexpr int kDerivGroup = 16;
struct DerivativeGroup {
  int n_group = 1;  // samples per group (≥ 1, ≤ kDerivGroup)
  int n = 0;        // buffered
  std::array<std::array<physics::TableState, kDerivGroup>, 2> st{};
  std::array<std::array<bool, kDerivGroup>, 2> ok{};
  void add(const physics::TableState st_s[2], const bool ok_s[2]) {
    for (int s = 0; s < 2; ++s) {
      st[static_cast<std::size_t>(s)][static_cast<std::size_t>(n)] = st_s[s];
      ok[static_cast<std::size_t>(s)][static_cast<std::size_t>(n)] = ok_s[s];
    }
    ++n;
  }
  bool full() const { return n >= n_group; }
  // Adds the group's n samples to D (sum; close_block divides by the block's samples). shared: both sensors read
  // at one time (one evaluation serves both).
  void flush(TableErrors te[2], bool shared, TableErrors::Jac& D) {
    if (n == 0) return;
    const auto m = static_cast<std::size_t>(n / 2);
    int cnt[2] = {0, 0};
    for (int s = 0; s < 2; ++s)
      for (int i = 0; i < n; ++i) cnt[s] += ok[static_cast<std::size_t>(s)][static_cast<std::size_t>(i)] ? 1 : 0;
    // The samples without table angles (none in a log that carries them) add nothing, as before the grouping.
    if (shared) {
      if (ok[0][m]) D += static_cast<double>(cnt[0]) * te[0].derivative(st[0][m]);
    } else {
      for (int s = 0; s < 2; ++s)
        if (ok[static_cast<std::size_t>(s)][m])
          D.middleRows<3>(3 * s) += static_cast<double>(cnt[s]) * te[s].derivative(st[static_cast<std::size_t>(s)][m]).middleRows<3>(3 * s);
    }
    n = 0;
  }
};

struct BlockAcc {
  bool open = false;
  Block b;
  long nT = 0;
  double sT = 0;
  double f0[3] = {}, w0[3] = {}, T0 = kNaN;
  double maxw = 0, fmin[3] = {}, fmax[3] = {}, Tmin = 1e300, Tmax = -1e300;
  std::array<std::vector<double>, kNumAxes> series;
  std::array<double, kNumAxes> bin_sum{};
  std::array<double, kNumAxes> dz2{};
  long long ndz = 0;
  std::vector<double> Tseries;   // bin means of the temperature (NaN without one), aligned with `series`
  // Bin means of the hysteresis state d: the tracked one, then each threshold of kHysteresisGrid_C.
  std::vector<std::array<double, kHysteresisGrid + 1>> Dseries;
  std::array<double, kHysteresisGrid + 1> binD_sum{};
  double binT_sum = 0;
  long binT_n = 0;
  long bin_n = 0;
};

// Re-evaluation of the reference at a shifted time (docs/diagnosis.md § timing): a sensor whose output at t
// reads its input at t − δ(t), δ = latency + ppm·1e-6·(t − t_first), is compared with the reference
// interpolated at t − δ(t), not with a first-order correction, so an accumulated clock error of a second
// is as exact as a latency of a millisecond.
struct TimeShift {
  double latency_s = 0, ppm = 0;
  // Samples this far beyond one sample interval from a reference step are left out too: the sensor reads the
  // steps late or early by more than its shift accounts for, and its timing cannot be refined (diagnose()).
  double step_margin_s = 0;
  bool active() const { return latency_s != 0.0 || ppm != 0.0; }
  double at(double t_rel_s) const { return latency_s + ppm * 1e-6 * t_rel_s; }
};

// The reference rows of a sliding time window, fed by a read-ahead wrapper around the source.
class ShiftedReference {
 public:
  ShiftedReference(SampleSource& src, double lookahead_s, double history_s, double fs)
      : src_(src), ahead_(lookahead_s), hist_(history_s), h_(1.0 / fs), gap_(5.0 / fs) {}
  void rewind() {
    src_.rewind();
    q_.clear();
    ref_.clear();
    eof_ = false;
  }
  bool next(Sample& s) {
    while (!eof_ && (q_.empty() || q_.back().t_s <= q_.front().t_s + ahead_)) {
      Sample r;
      if (!src_.next(r)) {
        eof_ = true;
        break;
      }
      if (r.has_ref) ref_.push_back(Ref{r.t_s, {r.f[0], r.f[1], r.f[2]}, {r.w[0], r.w[1], r.w[2]}});
      q_.push_back(r);
    }
    if (q_.empty()) return false;
    s = q_.front();
    q_.pop_front();
    while (ref_.size() > 2 && ref_[1].t_s < s.t_s - hist_) ref_.pop_front();
    return true;
  }
  // Reference (f, w) and its derivatives at time tq, from the rows in the window (clamped at its ends).
  void eval(double tq, model::MeasureInput& in) const {
    double f0[3], w0[3], f1[3], w1[3];
    at(tq - h_, f0, w0);
    at(tq + h_, f1, w1);
    double f[3], w[3];
    at(tq, f, w);
    for (int k = 0; k < 3; ++k) {
      in.f[k] = f[k];
      in.w[k] = w[k];
      in.fdot[k] = (f1[k] - f0[k]) / (2.0 * h_);
      in.wdot[k] = (w1[k] - w0[k]) / (2.0 * h_);
    }
  }

 private:
  struct Ref {
    double t_s;
    double f[3], w[3];
  };
  void at(double tq, double* f, double* w) const {
    if (ref_.empty()) {
      for (int k = 0; k < 3; ++k) f[k] = w[k] = 0.0;
      return;
    }
    auto it = std::lower_bound(ref_.begin(), ref_.end(), tq, [](const Ref& r, double t) { return r.t_s < t; });
    const Ref* a;
    const Ref* b;
    if (it == ref_.begin()) a = b = &*it;
    else if (it == ref_.end()) a = b = &ref_.back();
    else {
      b = &*it;
      a = &*(it - 1);
      if (b->t_s - a->t_s > gap_) {  // a gap in the reference: take the nearer side, never bridge it
        if (tq - a->t_s < b->t_s - tq) b = a;
        else a = b;
      } else if (step_at(it - 1)) {
        b = a;  // an instantaneous pose change: the input holds until the sample that shows the new pose
      } else if (it - ref_.begin() >= 2 && ref_.end() - it >= 2) {
        // Within smooth motion, the cubic through the two rows on each side: a line between rows misses the
        // curvature by h²/8·|ü| (7.7e-4 rad/s at 100 Hz on a 1 s raised-cosine turn of 90°, above a gyro's
        // noise per sample, read as a gyro scale_nonlinearity once a 1.1 s clock was re-evaluated), the cubic by
        // O(h⁴). Rows beyond a gap or a step keep the line (samples that near a step are left out anyway).
        const Ref* q[4] = {&*(it - 2), a, b, &*(it + 1)};
        if (q[1]->t_s - q[0]->t_s <= gap_ && q[3]->t_s - q[2]->t_s <= gap_ && !step_at(it - 2) && !step_at(it)) {
          double L[4];
          for (int i = 0; i < 4; ++i) {
            L[i] = 1.0;
            for (int j = 0; j < 4; ++j)
              if (j != i) L[i] *= (tq - q[j]->t_s) / (q[i]->t_s - q[j]->t_s);
          }
          for (int k = 0; k < 3; ++k) {
            f[k] = w[k] = 0.0;
            for (int i = 0; i < 4; ++i) {
              f[k] += L[i] * q[i]->f[k];
              w[k] += L[i] * q[i]->w[k];
            }
          }
          return;
        }
      }
    }
    const double u = b->t_s > a->t_s ? (tq - a->t_s) / (b->t_s - a->t_s) : 0.0;
    for (int k = 0; k < 3; ++k) {
      f[k] = a->f[k] + u * (b->f[k] - a->f[k]);
      w[k] = a->w[k] + u * (b->w[k] - a->w[k]);
    }
  }
  template <class It>
  bool step_at(It i) const {
    return reference_step(i == ref_.begin() ? nullptr : &*(i - 1), *i, *(i + 1), i + 2 == ref_.end() ? nullptr : &*(i + 2));
  }
  template <class It>
  bool kink_at(It i) const {
    const auto before = i - ref_.begin(), after = ref_.end() - i;  // rows before i, rows from i on
    return reference_kink(before >= 2 ? &*(i - 2) : nullptr, before >= 1 ? &*(i - 1) : nullptr, *i, *(i + 1),
                          after >= 3 ? &*(i + 2) : nullptr, after >= 4 ? &*(i + 3) : nullptr);
  }

 public:
  // True when the reference rows reach tq on both sides with no gap between them. A sensor read early by a
  // clock that has drifted (varied4 random-1: 0.12 s by the end) reads, in its last samples, input the log
  // has no reference for; clamped to the last row, a sine's held rate made the last block 670 σ off and the
  // gyro "unexplained". Such samples are left out, as at a gap.
  bool covered(double tq) const {
    if (ref_.size() < 2 || tq < ref_.front().t_s || tq > ref_.back().t_s) return false;
    auto it = std::lower_bound(ref_.begin(), ref_.end(), tq, [](const Ref& r, double t) { return r.t_s < t; });
    return it == ref_.begin() || it->t_s - (it - 1)->t_s <= gap_;
  }
  // True when a step of the reference (step_at: an instantaneous pose or rate change, whether or not the
  // reference moves on either side) lies within one sample interval of tq: the output sample read there shows
  // the old or the new pose depending on where in the row interval the change fell, which no timing model can
  // say, and its central-difference derivative is the step over two samples, not a rate. Such samples are
  // left out (shifted or not). A step into a motion must count too: on a blind log the rate steps into
  // tumbles and sines, kept, read the step at a timing error of a millisecond as a segment offset of
  // (step / samples in the segment), ~1e-2 rad/s at 300 °/s, and pulled the gyro clock estimate with it.
  // A kink of the reference (kink_at, step_lag.h: a table starting or stopping its acceleration) counts too:
  // the linear interpolation of the shifted reference misses it.
  // margin_s widens the window on both sides (TimeShift::step_margin_s).
  bool near_step(double tq, double margin_s = 0) const {
    if (ref_.size() < 2) return false;
    const double eps = 1e-6 * h_, w = h_ + margin_s;
    auto it = std::lower_bound(ref_.begin(), ref_.end(), tq - w - eps, [](const Ref& r, double t) { return r.t_s < t; });
    if (it != ref_.begin()) --it;
    for (; it + 1 != ref_.end() && it->t_s < tq + w - eps; ++it) {
      const Ref& b = *(it + 1);
      if (b.t_s > tq - w + eps && (step_at(it) || kink_at(it))) return true;
    }
    return false;
  }

 private:
  SampleSource& src_;
  double ahead_, hist_, h_, gap_;
  std::deque<Sample> q_;
  std::deque<Ref> ref_;
  bool eof_ = false;
};

constexpr double kMemoryTaus_s[4] = {3.0, 10.0, 30.0, 100.0};
// A motor's or a bearing's heat reaches the sensor through the fixture in minutes, not seconds (Block::turn_mem).
constexpr double kTurnLagTaus_s[3] = {30.0, 100.0, 300.0};
// A board's or a case's thermal lag behind the die (Block::T_grad): minutes, between the Ṫ of a lag much shorter than
// a chamber ramp and the T of one longer than the log. None shorter: a lag of 100 or 300 s follows what a hysteresis
// at a wrong threshold leaves after each reversal (LR 152 and 40 against a bar of 33 in
// HysteresisThresholdIsProfiledNotAssumed, 9.9 at 1000 s), and the true hysteresis was withdrawn for it.
constexpr double kGradTaus_s[2] = {1000.0, 3000.0};
// A block turning faster than this is motion (0.57 °/s, far above the Earth's rate); a step of the specific force
// larger than this is a pose change (a tilt of 0.3°, far above a dwell's drift). A static block has neither
// within it; between two static blocks a step is a pose change (fill_motion_settling).
constexpr double kMotionRate_rad_s = 0.01;
constexpr double kPoseStep_m_s2 = 0.05;
// The signature's hats of temperature (signature_functions): about kTempHats over the die's range, no closer
// than kTempHatMinSpacing_C (a block's own temperature spread on a ramp, and the look-elsewhere count, bound it).
constexpr double kTempHats = 10.0;
constexpr double kTempHatMinSpacing_C = 2.0;
// Their names start with this; the `follows` check finds them by it among the library's functions.
constexpr const char* kTempHatPrefix = "T near ";
bool is_temp_hat(const std::string& name) { return name.rfind(kTempHatPrefix, 0) == 0; }

// Block::f_mem / w_mem / turn_mem: each input low-passed at each time constant, stepped from block to block at
// their mid times (a block's mean input taken as the input over the interval before it: exact where the input
// changes at the blocks' edges, as on instantaneous pose changes). The inputs' lags start at the first block's
// input, the turning's at rest (a table still before the log). The temperature's lags (Block::T_grad) take the
// temperature as linear between the blocks' mid times, exactly (a first-order lag of a ramp of slope s from L₀:
// L₁ = T₁ − sτ + (L₀ − T₀ + sτ) e^{−Δ/τ}), since the die's temperature moves through the motions between the
// dwells; they start at the first block's temperature (a die that has held it). O(blocks).
void fill_input_memory(std::vector<Block>& blocks) {
  double f[3][4] = {}, w[3][4] = {}, turn[3] = {}, t_prev = blocks.empty() ? 0.0 : blocks[0].t0;
  double Tl[2] = {}, T_prev = kNaN, tT_prev = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    Block& x = blocks[b];
    if (std::isfinite(x.T)) {
      if (!std::isfinite(T_prev)) {
        for (double& l : Tl) l = x.T;
      } else {
        const double dt = std::max(x.t - tT_prev, 0.0), slope = dt > 0 ? (x.T - T_prev) / dt : 0.0;
        for (int j = 0; j < 2; ++j) {
          const double st = slope * kGradTaus_s[j];
          Tl[j] = x.T - st + (Tl[j] - T_prev + st) * std::exp(-dt / kGradTaus_s[j]);
        }
      }
      for (int j = 0; j < 2; ++j) x.T_grad[j] = x.T - Tl[j];
      T_prev = x.T;
      tT_prev = x.t;
    }
    const double turning = x.absw > kMotionRate_rad_s ? 1.0 : 0.0;
    for (int j = 0; j < 3; ++j) {
      turn[j] += (1.0 - std::exp(-std::max(x.t - t_prev, 0.0) / kTurnLagTaus_s[j])) * (turning - turn[j]);
      x.turn_mem[j] = turn[j];
    }
    for (int j = 0; j < 4; ++j) {
      const double a = b == 0 ? 1.0 : 1.0 - std::exp(-std::max(x.t - t_prev, 0.0) / kMemoryTaus_s[j]);
      for (int k = 0; k < 3; ++k) {
        f[k][j] += a * (x.f[k] - f[k][j]);
        w[k][j] += a * (x.w[k] - w[k][j]);
        x.f_mem[k][j] = f[k][j];
        x.w_mem[k][j] = w[k][j];
      }
    }
    t_prev = x.t;
  }
}

constexpr double kSettleTaus_s[3] = {3.0, 10.0, 30.0};

// A static run's temperature moving or holding (TempMotionNoise): 1 °C/min and more is a chamber ramping, 0.5 °C/min
// and less a soak or a die settling slowly on a plateau (the blind generator's dies still move 0.3–0.5 °C/min there,
// and hold nowhere closer); between, neither.
constexpr double kTempMovingRate_C_s = 1.0 / 60.0, kTempHoldingRate_C_s = 0.5 / 60.0;

// Block::settle. A rotation ends at the last moving block's end; a pose change halfway across the gap between two
// static blocks at different poses. Exact for a block wholly after the end: the mean of e^{−s/τ} over [s0, s1] is
// τ (e^{−s0/τ} − e^{−s1/τ}) / (s1 − s0). O(blocks).
void fill_motion_settling(std::vector<Block>& blocks) {
  double t_end[2] = {kNaN, kNaN};
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    Block& x = blocks[b];
    const bool moving = x.absw > kMotionRate_rad_s;
    if (b > 0 && !moving) {
      const Block& p = blocks[b - 1];
      double df = 0;
      for (int k = 0; k < 3; ++k) df = std::max(df, std::fabs(x.f[k] - p.f[k]));
      if (p.absw > kMotionRate_rad_s)
        t_end[0] = t_end[1] = p.t1;
      else if (df > kPoseStep_m_s2)
        t_end[1] = 0.5 * (p.t1 + x.t0);
    }
    for (int m = 0; m < 2; ++m)
      for (int j = 0; j < 3; ++j) {
        double v = 0;
        if (!moving && std::isfinite(t_end[m])) {
          const double tau = kSettleTaus_s[j], s0 = std::max(x.t0 - t_end[m], 0.0), s1 = std::max(x.t1 - t_end[m], s0);
          v = s1 - s0 > 1e-9 ? tau * (std::exp(-s0 / tau) - std::exp(-s1 / tau)) / (s1 - s0) : std::exp(-s0 / tau);
        }
        x.settle[m][j] = v;
      }
  }
}

struct Pass1 {
  std::vector<Block> blocks;
  std::array<AllanAccumulator, kNumAxes> allan;
  // The same records split by what the die's temperature does over the run (TempMotionNoise): moving (at least
  // kTempMovingRate_C_s) or holding (at most kTempHoldingRate_C_s); runs between are in neither.
  std::array<AllanAccumulator, kNumAxes> allan_moving, allan_holding;
  std::array<double, kNumAxes> dz2{};
  long long ndz = 0;
  long long n_used = 0;
  int n_units = 0;
  std::array<OutputBitCounter, kNumAxes> bits;  // every row's output word (StuckBits), where counted
};

// The stuck bits of a log's output words (output_bits.h). They depend on the codes alone, not on the shift, the
// mount rotation or the candidates of a re-run: the first diagnose_core of a diagnosis counts them and the re-runs
// take its result (counting every row again was 6 % of diagnosis_bench at stop 64).
using OutputWords = std::array<StuckBits, kNumAxes>;

// The static dwells' scatter while the die's temperature moves against while it holds (TempMotionNoise, diagnose.h):
// at each τ both records reach, the ratio of the Allan variances and its z on the log scale (ln ratio has variance
// 2/edf per estimate); the largest ratio among the τ where z ≥ opt.temp_motion_z, flagged at ≥ opt.temp_motion_ratio.
TempMotionNoise compare_temp_motion(const std::vector<AllanAccumulator::Point>& moving, const std::vector<AllanAccumulator::Point>& holding,
                                    const Options& opt) {
  TempMotionNoise out;
  // Record lengths: the first point's differences, one per bin of τ0 less two per record.
  if (!moving.empty()) out.moving_s = moving.front().tau_s * static_cast<double>(moving.front().terms);
  if (!holding.empty()) out.holding_s = holding.front().tau_s * static_cast<double>(holding.front().terms);
  for (const auto& m : moving) {
    for (const auto& h : holding) {
      if (h.tau_s != m.tau_s || !(h.avar > 0) || !(m.avar > 0)) continue;
      const double ratio = m.avar / h.avar;
      const double z = std::log(ratio) / std::sqrt(2.0 / m.edf + 2.0 / h.edf);
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "temp motion tau %.3g: avar moving %.3g (edf %.0f) holding %.3g (edf %.0f): ratio %.2f z %.1f\n", m.tau_s, m.avar, m.edf,
                     h.avar, h.edf, ratio, z);
      // The largest ratio among the τ whose z passes (flagged where it reaches the ratio's bar; reported either way).
      if (!(opt.temp_motion_z > 0 && z >= opt.temp_motion_z)) continue;
      if (ratio > out.ratio) {
        const bool pass = ratio >= opt.temp_motion_ratio;
        out.flagged = pass;
        out.z = z;
        out.ratio = ratio;
        out.tau_s = m.tau_s;
        out.edf_moving = m.edf;
        out.edf_holding = h.edf;
      }
    }
  }
  return out;
}

Pass1 run_pass1(SampleSource& src_in, const Pass0& p0, const Options& opt, const std::vector<ParamId> ids[2],
                bool want_regressors, const TimeShift shift[2] = nullptr, bool count_words = false) {
  const TimeShift none[2];
  if (!shift) shift = none;
  const double dur_all = p0.t_last - p0.t_first;
  // The window holds every reference row near_step reads at a shifted time: ±(h + step margin) around it, the
  // row beyond, and the two rows further out on each side that reference_kink compares with (at the window's
  // edge a missing row would make the same row pair a kink or not depending on where the window stands).
  double ahead = 2.0 / p0.fs, back = 2.0 / p0.fs;
  for (int s = 0; s < 2; ++s)
    for (double tt : {0.0, dur_all}) {
      ahead = std::max(ahead, -shift[s].at(tt) + shift[s].step_margin_s + 6.0 / p0.fs);
      back = std::max(back, shift[s].at(tt) + shift[s].step_margin_s + 6.0 / p0.fs);
    }
  ShiftedReference src(src_in, ahead, back, p0.fs);
  TableErrors table_d[2] = {TableErrors(opt), TableErrors(opt)};  // per sensor: each reads at its own time
  const bool table_cols = want_regressors && table_d[0].known();
  // Both sensors read at one time (the same shift, or none): one derivative serves both.
  const bool table_shared = shift[0].latency_s == shift[1].latency_s && shift[0].ppm == shift[1].ppm;
  DerivativeGroup table_group;
  table_group.n_group = std::clamp(static_cast<int>(std::lround(p0.fs / 100.0)), 1, kDerivGroup);
  const bool mount = opt.mount_rotation_rad[0] != 0.0 || opt.mount_rotation_rad[1] != 0.0 || opt.mount_rotation_rad[2] != 0.0;
  Pass1 out;
  for (int a = 0; a < kNumAxes && count_words; ++a) {
    const double lsb = opt.output_lsb[static_cast<std::size_t>(a / 3)];
    out.bits[static_cast<std::size_t>(a)] = OutputBitCounter(lsb > 0 ? lsb : p0.out_step[static_cast<std::size_t>(a)]);
  }
  const double dur = p0.t_last - p0.t_first;
  const double min_block_s = std::max(2.0 / p0.fs, dur / std::max(1, opt.max_blocks));
  const long long max_bins = 1LL << 20;
  const long m0 = std::max<long long>(1, (p0.n + max_bins - 1) / max_bins);
  for (auto& a : out.allan) a.set_tau0(static_cast<double>(m0) / p0.fs);
  for (auto& a : out.allan_moving) a.set_tau0(static_cast<double>(m0) / p0.fs);
  for (auto& a : out.allan_holding) a.set_tau0(static_cast<double>(m0) / p0.fs);
  const int np[2] = {static_cast<int>(ids[0].size()), static_cast<int>(ids[1].size())};
  const model::RegressorPlan plan[2] = {model::RegressorPlan(Sensor::kAccel, ids[0]), model::RegressorPlan(Sensor::kGyro, ids[1])};
  // The regressors' sums on a thread of their own where there is one (regressor_sums.h): a third of the pass.
  std::optional<RegressorSums> sums;
  if (want_regressors) sums.emplace(plan[0], plan[1], opt.T_ref_C);

  // The logged temperature is noisy: it is smoothed once (model::kLoggedTempSmoothing_s, measure.h) and every
  // tracker reads the smoothed value. A given threshold runs its one tracker; otherwise the grid's trackers run
  // (their block means kept for diagnose_core's profile) and the regressors see the catalog's default among them
  // until the profile replaces those columns.
  const bool profile = !std::isfinite(opt.hysteresis_threshold_C);
  model::LowPass temp_lp(model::kLoggedTempSmoothing_s);
  model::HysteresisTracker hyst(profile ? model::ThermalConstants{}.hysteresis_threshold_C : opt.hysteresis_threshold_C);
  std::array<model::HysteresisTracker, kHysteresisGrid> hyst_grid;
  int k_default = -1;
  for (int k = 0; k < kHysteresisGrid; ++k) {
    hyst_grid[static_cast<std::size_t>(k)] = model::HysteresisTracker(kHysteresisGrid_C[static_cast<std::size_t>(k)]);
    if (kHysteresisGrid_C[static_cast<std::size_t>(k)] == model::ThermalConstants{}.hysteresis_threshold_C) k_default = k;
  }
  std::array<double, kHysteresisGrid> d_grid{};
  BlockAcc acc;
  int unit = -1, last_seg = -2;
  double last_ref_t = -1e300;
  bool last_had_ref = false;

  std::array<std::vector<double>, kNumAxes> run_series;
  int run_unit = -1;
  double run_Tmin = 1e300, run_Tmax = -1e300;
  std::vector<double> run_T;
  std::vector<std::array<double, kHysteresisGrid + 1>> run_D;  // aligned with run_series
  // A static run loses opt.settle_s at both ends: an output that lags (or leads) its reference by a latency
  // or an accumulated clock error still moves there, and a few such samples would read as drift noise.
  const std::size_t settle_bins = static_cast<std::size_t>(std::ceil(opt.settle_s * p0.fs / static_cast<double>(m0)));
  auto flush_run = [&]() {
    // A soak whose die temperature still settles: the base model's own thermal terms (bias in T, T²) would
    // read as low-frequency noise. Regress [1, T, T²] out of the run first (it also takes the smooth
    // Ṫ-driven part of a settling soak); below 0.05 °C of range T is left out.
    //
    // A temperature turn inside a soak or a slow ramp flips temp_hysteresis: a bias step of 2h (h at the first
    // move from the start). A step inside an Allan record reads as bias instability of that axis, and the
    // dwells' noise model then hid the very effect that made it (a consumer gyro's hysteresis of 4e-4 rad/s,
    // flipped on a 70 °C ramp, read as a flicker B four times the other axes' and was never significant). So
    // each hysteresis state that changes inside the run (the tracked d, or d at a threshold of the profile's
    // grid: the sensor's own is not known yet) is tried as a step, per axis, with the T terms. Where one
    // stands above kAllanStepZ both on the run's white scatter and on its own slow wander, the axis's record
    // is cut at its changes and each piece is an Allan record of its own (with the T trend fitted jointly with
    // the step): an Allan difference then never straddles the step. Elsewhere the run stays whole, as before.
    // Cutting at every change (or dropping the run) took the longest record apart on every warm-up, where
    // all thresholds' d move once, and short logs then lost the flicker level of quiet axes (and named noise
    // as size_effect / temp_rate); regressing every changing d out read the noise low where the thermal
    // effects are tested (docs/diagnosis.md § 2).
    constexpr double kAllanStepZ = 5.0;
    // A level step at an unknown bin (below) must stand four times as far above both: the scan over every bin picks
    // the largest of many, and a random walk's record always has a best split. The blind suites' out-of-catalog
    // steps stand at z 90 and 65 over the wander; a gyro's tail after its motion (varied5 random-11, not a step)
    // at z 10-33.
    constexpr double kAllanLevelStepZ = 4.0 * kAllanStepZ;
    const std::size_t nb = run_series[0].size();
    std::vector<int> dcols;  // distinct d columns that change inside the run
    if (run_D.size() == nb) {
      for (int c = 0; c <= kHysteresisGrid; ++c) {
        const auto uc = static_cast<std::size_t>(c);
        bool varies = false;
        for (std::size_t i = 1; i < nb && !varies; ++i) varies = run_D[i][uc] != run_D[0][uc];
        bool dup = false;
        for (int e : dcols) {
          bool same = true;
          for (std::size_t i = 0; i < nb && same; ++i) same = run_D[i][static_cast<std::size_t>(e)] == run_D[i][uc];
          dup = dup || same;
        }
        if (varies && !dup) dcols.push_back(c);
      }
    }
    bool have_T = !run_T.empty() && run_T.size() == nb;
    double tmin = 1e300, tmax = -1e300, tm = 0;
    for (double T : run_T) {
      if (!std::isfinite(T)) have_T = false;
      tmin = std::min(tmin, T);
      tmax = std::max(tmax, T);
      tm += T;
    }
    if (have_T) tm /= static_cast<double>(nb);
    const bool use_T = have_T && tmax - tmin > 0.05 && nb > 8;
    // What the temperature does over the run: the slope of a line through its bins (the smoothed logged value
    // flickers by its sensor's noise; a range would read that as motion on a long soak).
    int motion = 0;  // +1 moving, −1 holding, 0 neither (or no temperature)
    if (have_T && nb > 8) {
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      for (std::size_t i = 0; i < nb; ++i) {
        const double x = static_cast<double>(i);
        sx += x, sy += run_T[i], sxx += x * x, sxy += x * run_T[i];
      }
      const double nn = static_cast<double>(nb), den = nn * sxx - sx * sx;
      const double rate_C_s = den > 0 ? std::fabs((nn * sxy - sx * sy) / den) * p0.fs / static_cast<double>(m0) : 0.0;
      motion = rate_C_s >= kTempMovingRate_C_s ? 1 : rate_C_s <= kTempHoldingRate_C_s ? -1 : 0;
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "allan run: %zu bins, T %.2f..%.2f, %.3g C/min: %s\n", nb, tmin, tmax, 60.0 * rate_C_s,
                     motion > 0 ? "moving" : motion < 0 ? "holding" : "neither");
    }
    // One candidate step: the run's design [1, (T − tm, (T − tm)²), d], the same for every axis, so its
    // factorisation and the change positions of d are built once per run. d: a hysteresis state per bin, or
    // (col −1) a level step at one bin.
    struct StepColumn {
      int col = -1;
      std::vector<double> d;
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
      double vd = kNaN;      // (XᵀX)⁻¹ at d: the step coefficient's variance per unit noise variance
      std::vector<int> chg;  // changes of d in bins [1, i)
      double dmax = 0;       // the largest change of d (1 from the start, 2 at a turn)
    };
    auto design_row = [&](std::size_t i, const StepColumn& sc, Eigen::VectorXd& x) {
      int k = 0;
      x[k++] = 1.0;
      if (use_T) {
        const double d = run_T[i] - tm;
        x[k++] = d;
        x[k++] = d * d;
      }
      x[k] = sc.d[i];
    };
    const int p = (use_T ? 3 : 1) + 1;
    // false: d follows T's shape over a short run (no step of its own to estimate)
    auto make_step = [&](StepColumn& sc) {
      Eigen::MatrixXd H = Eigen::MatrixXd::Zero(p, p);
      Eigen::VectorXd x(p);
      for (std::size_t i = 0; i < nb; ++i) {
        design_row(i, sc, x);
        H.noalias() += x * x.transpose();
      }
      sc.qr = Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(H);
      if (sc.qr.rank() < p) return false;
      sc.vd = sc.qr.inverse()(p - 1, p - 1);
      sc.chg.assign(nb + 1, 0);
      for (std::size_t i = 1; i < nb; ++i) {
        const double jump = std::fabs(sc.d[i] - sc.d[i - 1]);
        sc.dmax = std::max(sc.dmax, jump);
        sc.chg[i + 1] = sc.chg[i] + (jump > 0 ? 1 : 0);
      }
      return true;
    };
    std::vector<StepColumn> steps;
    if (nb > 8) {
      for (int col : dcols) {
        StepColumn sc;
        sc.col = col;
        sc.d.resize(nb);
        for (std::size_t i = 0; i < nb; ++i) sc.d[i] = run_D[i][static_cast<std::size_t>(col)];
        if (make_step(sc)) steps.push_back(std::move(sc));
      }
    }
    // A step's size on the run's white scatter (z) and on its own slow wander (zlf) for one axis' record rs, with
    // its fit c; false when it cannot be judged. The white scatter alone would call a flicker or random-walk wander
    // a step (a null automotive gyro, B 5.8e-5 rad/s, cut at z 6–9 and then read a Gauss-Markov instead of its
    // flicker). So the step must also stand above the run's own slow wander: the difference of two adjacent means
    // of nb/8 bins (twice the Allan variance there) over the residual, from the pairs that straddle no change of d.
    auto step_size = [&](const StepColumn& sc, const std::vector<double>& rs, double s2, Eigen::VectorXd& c, double& z, double& zlf) {
      Eigen::VectorXd x(p), g = Eigen::VectorXd::Zero(p);
      for (std::size_t i = 0; i < nb; ++i) {
        design_row(i, sc, x);
        g += x * rs[i];
      }
      c = sc.qr.solve(g);
      if (!c.allFinite() || !(sc.vd > 0) || !(s2 > 0)) return false;
      const double beta = c[p - 1];
      z = std::fabs(beta) / std::sqrt(s2 * sc.vd);
      const std::size_t m = std::max<std::size_t>(2, nb / 8);
      std::vector<double> cs(nb + 1, 0.0);
      for (std::size_t i = 0; i < nb; ++i) {
        design_row(i, sc, x);
        cs[i + 1] = cs[i] + (rs[i] - x.dot(c));
      }
      double av = 0;
      long npair = 0;
      for (std::size_t i = 0; i + 2 * m <= nb; ++i) {
        if (sc.chg[i + 2 * m] - sc.chg[i + 1] > 0) continue;  // a change inside the pair's span
        const double dm = (cs[i + 2 * m] - 2.0 * cs[i + m] + cs[i]) / static_cast<double>(m);
        av += 0.5 * dm * dm;
        ++npair;
      }
      if (npair == 0) return false;
      zlf = std::fabs(beta) * sc.dmax / std::sqrt(2.0 * av / static_cast<double>(npair));
      return true;
    };
    // [1, T − tm, (T − tm)²] fitted to one axis's record alone (the run's T trend where it is not cut).
    auto t_trend = [&](const std::vector<double>& rs) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      for (std::size_t i = 0; i < nb; ++i) {
        const Eigen::Vector3d x(1.0, run_T[i] - tm, (run_T[i] - tm) * (run_T[i] - tm));
        H += x * x.transpose();
        g += x * rs[i];
      }
      return Eigen::Vector3d(Eigen::LDLT<Eigen::Matrix3d>(H).solve(g));
    };
    for (int a = 0; a < kNumAxes; ++a) {
      auto& rs = run_series[static_cast<std::size_t>(a)];
      const StepColumn* cut = nullptr;
      StepColumn level;  // a level step found by the scan below
      Eigen::VectorXd cut_c;
      double s2 = 0;  // white scatter of one bin, from first differences
      if (nb > 8) {
        double dd = 0;
        for (std::size_t i = 1; i < nb; ++i) dd += (rs[i] - rs[i - 1]) * (rs[i] - rs[i - 1]);
        s2 = dd / (2.0 * static_cast<double>(nb - 1));
      }
      double best_z = kAllanStepZ, best_zlf = 0;
      for (const StepColumn& sc : steps) {
        Eigen::VectorXd c;
        double z = 0, zlf = 0;
        if (!step_size(sc, rs, s2, c, z, zlf) || z <= best_z || !(zlf > kAllanStepZ)) continue;
        best_z = z;
        best_zlf = zlf;
        cut = &sc;
        cut_c = c;
      }
      if (std::getenv("IMUFORGE_DIAG_TRACE") && cut)
        std::fprintf(stderr, "allan run %s: %zu bins (T %.2f..%.2f), a hysteresis step at z %.1f, %.1f over the wander (d column %d): cut\n",
                     axis_name(a), nb, tmin, tmax, best_z, best_zlf, cut->col);
      // A bias step the catalog does not have (a jump of the sensor's own bias) inside a static run reads as bias
      // instability just as a hysteresis flip does, and the dwells' noise model then hides it: varied8
      // ooc-bias_step-0, a 3.3e-3 m/s² accel.z step inside a soak, read as flicker B 1.1e-3 (40× the other axes')
      // and the axis was at noise. So the run's most likely single level step (the largest standardised CUSUM of
      // the residual of the T terms) is tried the same way, at four times the levels (kAllanLevelStepZ), and it is
      // cut there instead when it stands further above the white scatter than the hysteresis step: a grid
      // threshold's state that changes on a warm-up is no reason to keep a step elsewhere in the record.
      if (nb > 32 && s2 > 0) {
        std::vector<double> r(rs);
        if (use_T) {
          const Eigen::Vector3d c = t_trend(rs);
          for (std::size_t i = 0; i < nb && c.allFinite(); ++i)
            r[i] -= c[0] + c[1] * (run_T[i] - tm) + c[2] * (run_T[i] - tm) * (run_T[i] - tm);
        } else {
          double mean = 0;
          for (double v : r) mean += v;
          mean /= static_cast<double>(nb);
          for (double& v : r) v -= mean;
        }
        // Not in the first or last eighth: a motion's tail that settle_s leaves (a gyro lag of 2357 snr, varied5
        // random-11) stands there, and a step so near an end has few Allan differences straddling it.
        const std::size_t edge = std::max<std::size_t>(4, nb / 8);
        double S = 0, best = 0;
        std::size_t kbest = 0;
        for (std::size_t k = 1; k < nb; ++k) {
          S += r[k - 1];
          if (k < edge || k > nb - edge) continue;
          const double st = std::fabs(S) * std::sqrt(static_cast<double>(nb) / (static_cast<double>(k) * static_cast<double>(nb - k)));
          if (st > best) {
            best = st;
            kbest = k;
          }
        }
        // A maximum on the edge of the scan is a trend or a tail running into the end, not a step inside the run.
        if (kbest > edge + nb / 100 && kbest + edge + nb / 100 < nb) {
          level.d.assign(nb, 0.0);
          for (std::size_t i = kbest; i < nb; ++i) level.d[i] = 1.0;
          Eigen::VectorXd c;
          double z = 0, zlf = 0;
          if (make_step(level) && step_size(level, rs, s2, c, z, zlf) && z > kAllanLevelStepZ && zlf > kAllanLevelStepZ &&
              (!cut || z > best_z)) {
            cut = &level;
            cut_c = c;
            if (std::getenv("IMUFORGE_DIAG_TRACE"))
              std::fprintf(stderr, "allan run %s: %zu bins (T %.2f..%.2f), a level step at bin %zu, z %.1f, %.1f over the wander: cut\n",
                           axis_name(a), nb, tmin, tmax, kbest, z, zlf);
          }
        }
      }
      // The T trend: fitted jointly with the step where the record is cut, else alone (the 3×3 solve kept as it
      // was, so a log without a cut gives the output it gave before).
      double c1 = 0, c2 = 0;
      if (cut && use_T) {
        c1 = cut_c[1];
        c2 = cut_c[2];
      } else if (!cut && use_T) {
        const Eigen::Vector3d c = t_trend(rs);
        if (c.allFinite()) {
          c1 = c[1];
          c2 = c[2];
        }
      }
      if (c1 != 0 || c2 != 0)
        for (std::size_t i = 0; i < nb; ++i) {
          const double d = run_T[i] - tm;
          rs[i] -= c1 * d + c2 * d * d;
        }
      // The pieces of constant state (one, without a cut), after settle_s at both ends of the run.
      if (nb > 2 * settle_bins) {
        const std::size_t lo = settle_bins, hi = nb - settle_bins;
        std::size_t b0 = lo;
        for (std::size_t i = lo + 1; i <= hi; ++i)
          if (i == hi || (cut && cut->d[i] != cut->d[i - 1])) {
            const std::vector<double> piece(rs.begin() + static_cast<long>(b0), rs.begin() + static_cast<long>(i));
            out.allan[static_cast<std::size_t>(a)].add_series(piece);
            if (motion != 0) (motion > 0 ? out.allan_moving : out.allan_holding)[static_cast<std::size_t>(a)].add_series(piece);
            b0 = i;
          }
      }
      rs.clear();
    }
    run_T.clear();
    run_D.clear();
    run_unit = -1;
  };
  auto close_block = [&]() {
    if (!acc.open) return;
    Block& b = acc.b;
    const double n = static_cast<double>(b.n);
    if (table_cols) table_group.flush(table_d, table_shared, b.D);
    b.D /= n;
    for (int a = 0; a < kNumAxes; ++a) b.z[a] /= n;
    b.t /= n;
    b.Tdot /= n;
    b.absTdot /= n;
    b.d /= n;
    for (double& x : b.d_grid) x /= n;
    b.absw /= n;
    b.wound_rad /= n;
    for (int k = 0; k < 3; ++k) {
      b.f[k] /= n;
      b.w[k] /= n;
      b.ww[k] /= n;
      for (int l = 0; l < 3; ++l) b.wq[k][l] /= n;
      for (int l = 0; l < 3; ++l) b.wc[k][l] /= n;
      for (int l = 0; l < 3; ++l) b.ff[k][l] /= n;
      if (b.n_a[k] > 0) {
        b.sin_a[k] /= static_cast<double>(b.n_a[k]);
        b.cos_a[k] /= static_cast<double>(b.n_a[k]);
      } else {
        b.sin_a[k] = b.cos_a[k] = kNaN;
      }
    }
    b.T = acc.nT > 0 ? acc.sT / static_cast<double>(acc.nT) : kNaN;
    double frange = 0;
    for (int k = 0; k < 3; ++k) frange = std::max(frange, acc.fmax[k] - acc.fmin[k]);
    const double Trange = acc.nT > 0 ? acc.Tmax - acc.Tmin : 0.0;
    b.is_static = acc.maxw < kMotionRate_rad_s && frange < kPoseStep_m_s2 && Trange < 2.0 * opt.block_temp_tol_C && b.n >= 8;
    // Static blocks of one segment are joined into one Allan series (long τ needs long records).
    // ... but only while the temperature stays within the block tolerance: a thermal ramp would otherwise
    // turn bias_temp / temp_rate drift into apparent low-frequency noise and hide them.
    const double bTmin = acc.nT > 0 ? acc.Tmin : run_Tmin, bTmax = acc.nT > 0 ? acc.Tmax : run_Tmax;
    const bool temp_ok = acc.nT == 0 || run_Tmin > run_Tmax ||
                         std::max(run_Tmax, bTmax) - std::min(run_Tmin, bTmin) < opt.static_run_temp_tol_C;
    if (b.is_static && b.unit == run_unit && temp_ok) {
      run_Tmin = std::min(run_Tmin, bTmin);
      run_Tmax = std::max(run_Tmax, bTmax);
      for (int a = 0; a < kNumAxes; ++a) {
        auto& rs = run_series[static_cast<std::size_t>(a)];
        const auto& bs = acc.series[static_cast<std::size_t>(a)];
        rs.insert(rs.end(), bs.begin(), bs.end());
      }
      run_T.insert(run_T.end(), acc.Tseries.begin(), acc.Tseries.end());
      run_D.insert(run_D.end(), acc.Dseries.begin(), acc.Dseries.end());
    } else {
      flush_run();
      if (b.is_static) {
        run_unit = b.unit;
        run_Tmin = acc.nT > 0 ? acc.Tmin : 1e300;
        run_Tmax = acc.nT > 0 ? acc.Tmax : -1e300;
        for (int a = 0; a < kNumAxes; ++a) run_series[static_cast<std::size_t>(a)] = acc.series[static_cast<std::size_t>(a)];
        run_T = acc.Tseries;
        run_D = acc.Dseries;
      }
    }
    if (b.is_static) {
      for (int a = 0; a < kNumAxes; ++a) out.dz2[static_cast<std::size_t>(a)] += acc.dz2[static_cast<std::size_t>(a)];
      out.ndz += acc.ndz;
    }
    out.blocks.push_back(std::move(b));
    acc = BlockAcc{};
  };

  // One-sample lookahead for the input derivatives (size effect, timing).
  Sample prev, cur, nxt;
  double wound_rad = 0, wound_t = kNaN;  // Block::wound_rad's running integral, and the last sample it reached
  double zprev[kNumAxes] = {};
  bool have_prev = false, have_cur = false, have_next = false;
  src.rewind();
  have_cur = src.next(cur);
  if (have_cur) have_next = src.next(nxt);
  while (have_cur) {
    if (count_words)
      for (int a = 0; a < kNumAxes; ++a) out.bits[static_cast<std::size_t>(a)].add(cur.y[a]);
    const double T_smooth_C = std::isnan(cur.temp_C) ? cur.temp_C : temp_lp.update(cur.temp_C, cur.t_s);
    double d;
    if (profile && k_default >= 0) {
      for (int k = 0; k < kHysteresisGrid; ++k) d_grid[static_cast<std::size_t>(k)] = hyst_grid[static_cast<std::size_t>(k)].update(T_smooth_C);
      d = d_grid[static_cast<std::size_t>(k_default)];
    } else {
      d = hyst.update(T_smooth_C);
    }
    if (cur.has_ref) {
      // The reference's |ω|² and |ω|, once per sample: the wound-up rotation, the cut at the static bar and the
      // block's accumulation all use them.
      double wn2 = 0;
      for (int k = 0; k < 3; ++k) wn2 += cur.w[k] * cur.w[k];
      const double wn = std::sqrt(wn2);
      // The rotation wound up about the specific force (Block::wound_rad), over every referenced sample, those left
      // out at a step included; not across a gap in the reference.
      {
        const double fn = std::sqrt(cur.f[0] * cur.f[0] + cur.f[1] * cur.f[1] + cur.f[2] * cur.f[2]);
        const double dt = cur.t_s - wound_t;
        if (dt > 0 && dt < 5.0 / p0.fs && fn > 1.0 && wn > kMotionRate_rad_s)
          wound_rad += (cur.w[0] * cur.f[0] + cur.w[1] * cur.f[1] + cur.w[2] * cur.f[2]) / fn * dt;
        wound_t = cur.t_s;
      }
      model::MeasureInput in;
      double ta = cur.t_s, tb = cur.t_s;
      const double *fa = cur.f, *fb = cur.f, *wa = cur.w, *wb = cur.w;
      if (have_prev && prev.has_ref && cur.t_s - prev.t_s < 5.0 / p0.fs) { ta = prev.t_s; fa = prev.f; wa = prev.w; }
      if (have_next && nxt.has_ref && nxt.t_s - cur.t_s < 5.0 / p0.fs) { tb = nxt.t_s; fb = nxt.f; wb = nxt.w; }
      for (int k = 0; k < 3; ++k) {
        in.f[k] = cur.f[k];
        in.w[k] = cur.w[k];
        if (tb > ta) {
          in.fdot[k] = (fb[k] - fa[k]) / (tb - ta);
          in.wdot[k] = (wb[k] - wa[k]) / (tb - ta);
        }
      }
      const bool hasT = std::isfinite(cur.temp_C);
      in.T_C = hasT ? cur.temp_C : opt.T_ref_C;
      in.Tdot_C_s = hasT ? p0.tdot_at(cur.t_s) : 0.0;
      in.d = d;
      in.t_s = cur.t_s - p0.t_first;
      // Per sensor: the reference at the sensor's shifted time (identical to `in` without a shift).
      model::MeasureInput ins[2] = {in, in};
      double us[kNumAxes];
      // An instantaneous pose change within a sample of the time each sensor reads its input (the logged
      // time, or the shifted one once its timing is re-evaluated): the sample on either side of the step is
      // left out (ShiftedReference::near_step says why).
      bool at_step = false;
      for (int s = 0; s < 2; ++s) {
        at_step |= src.near_step(cur.t_s - shift[s].at(in.t_s), shift[s].step_margin_s);
        if (shift[s].active()) at_step |= !src.covered(cur.t_s - shift[s].at(in.t_s));
      }
      at_step |= p0.clamped(cur);  // a saturated output says only that the input is beyond its limit
      if (at_step) {
        // last_seg / last_had_ref keep the previous sample's: the next one still starts a new segment.
        prev = cur;
        have_prev = true;
        cur = nxt;
        have_cur = have_next;
        if (have_cur) have_next = src.next(nxt);
        continue;
      }
      for (int s = 0; s < 2; ++s) {
        if (shift[s].active()) src.eval(cur.t_s - shift[s].at(in.t_s), ins[s]);
        for (int k = 0; k < 3; ++k) us[3 * s + k] = s == 0 ? ins[0].f[k] : ins[1].w[k];
      }

      // Block cutting.
      if (cur.segment != last_seg || !last_had_ref || cur.t_s - last_ref_t > 5.0 / p0.fs) ++unit;
      bool cut = !acc.open || acc.b.unit != unit;
      if (!cut) {
        const double bd = cur.t_s - acc.b.t0;
        if (bd >= opt.block_max_s) cut = true;
        else if (bd >= min_block_s) {
          for (int k = 0; k < 3; ++k)
            if (std::fabs(cur.f[k] - acc.f0[k]) > opt.block_f_tol || std::fabs(cur.w[k] - acc.w0[k]) > opt.block_w_tol) cut = true;
          if (hasT && std::isfinite(acc.T0) && std::fabs(cur.temp_C - acc.T0) > opt.block_temp_tol_C) cut = true;
        }
        // A dwell the motion leaves or reaches smoothly (a table ramping its rate from rest and back, as real
        // tables do) is cut where the rate crosses the static bar (kMotionRate_rad_s), not only once it has moved
        // by block_w_tol or past min_block_s: otherwise the ramp's first samples join the dwell's block, which is
        // then not static (a dwell between two ramps lost to the Allan curve and the noise fit). The dwell's
        // block before the crossing needs a second (and is_static's eight samples), so a reference hovering about
        // the bar cannot shatter the log into blocks.
        if (!cut && opt.cut_at_motion_bar && cur.t_s - acc.b.t0 >= std::max(1.0, 8.0 / p0.fs)) {
          const bool moving_now = wn2 >= kMotionRate_rad_s * kMotionRate_rad_s;
          cut = moving_now != (acc.maxw >= kMotionRate_rad_s);
        }
      }
      if (cut) {
        close_block();
        acc.open = true;
        acc.b.segment = cur.segment;
        acc.b.unit = unit;
        acc.b.t0 = cur.t_s;
        for (int k = 0; k < 3; ++k) {
          acc.f0[k] = acc.fmin[k] = acc.fmax[k] = cur.f[k];
          acc.w0[k] = cur.w[k];
        }
        acc.T0 = cur.temp_C;
      }
      // The case sits rotated on the fixture by δ (Options::mount_rotation_rad): the regressors see the input in
      // the case, u + δ × u; the output is still compared with the reference (z above), whose δ × u the
      // misalignment carries.
      if (mount) {
        const model::Vec3 dl(opt.mount_rotation_rad[0], opt.mount_rotation_rad[1], opt.mount_rotation_rad[2]);
        for (auto& x : ins)
          for (model::Vec3* v : {&x.f, &x.w, &x.fdot, &x.wdot}) *v += dl.cross(*v);
      }
      Block& b = acc.b;
      // The open block is the next one close_block() keeps.
      if (sums) sums->add(static_cast<int>(out.blocks.size()), ins);
      if (table_cols) {
        physics::TableState st[2];
        bool ok[2] = {false, false};
        for (int s = 0; s < (table_shared ? 1 : 2); ++s) ok[s] = table_d[s].state_of(cur, shift[s].at(in.t_s), st[s]);
        table_group.add(st, ok);
        if (table_group.full()) table_group.flush(table_d, table_shared, b.D);
      }
      double z[kNumAxes];
      for (int a = 0; a < kNumAxes; ++a) {
        z[a] = cur.y[a] - us[a];
        b.z[a] += z[a];
        acc.bin_sum[static_cast<std::size_t>(a)] += z[a];
      }
      acc.binD_sum[0] += d;
      for (int k = 0; k < kHysteresisGrid; ++k) acc.binD_sum[static_cast<std::size_t>(k) + 1] += d_grid[static_cast<std::size_t>(k)];
      if (std::isfinite(cur.temp_C)) {
        acc.binT_sum += cur.temp_C;
        ++acc.binT_n;
      }
      if (++acc.bin_n == m0) {
        acc.Tseries.push_back(acc.binT_n > 0 ? acc.binT_sum / static_cast<double>(acc.binT_n) : kNaN);
        for (double& x : acc.binD_sum) x /= static_cast<double>(m0);
        acc.Dseries.push_back(acc.binD_sum);
        acc.binD_sum.fill(0.0);
        acc.binT_sum = 0;
        acc.binT_n = 0;
        for (int a = 0; a < kNumAxes; ++a) {
          acc.series[static_cast<std::size_t>(a)].push_back(acc.bin_sum[static_cast<std::size_t>(a)] / static_cast<double>(m0));
          acc.bin_sum[static_cast<std::size_t>(a)] = 0;
        }
        acc.bin_n = 0;
      }
      // Sample-to-sample scatter, from static blocks only and after settle_s (close_block): a pose jump read
      // late by a latency or clock error must not inflate the white-noise floor.
      if (b.n > 0 && have_prev && prev.has_ref && cur.t_s - b.t0 > opt.settle_s) {
        for (int a = 0; a < kNumAxes; ++a) {
          const double zp = zprev[a];
          acc.dz2[static_cast<std::size_t>(a)] += (z[a] - zp) * (z[a] - zp);
        }
        ++acc.ndz;
      }
      for (int a = 0; a < kNumAxes; ++a) zprev[a] = z[a];
      ++b.n;
      b.t1 = cur.t_s;
      b.t += in.t_s;
      b.Tdot += in.Tdot_C_s;
      b.absTdot += std::fabs(in.Tdot_C_s);
      b.d += d;
      for (int k = 0; k < kHysteresisGrid; ++k) b.d_grid[static_cast<std::size_t>(k)] += d_grid[static_cast<std::size_t>(k)];
      for (int k = 0; k < 3; ++k) {
        b.f[k] += cur.f[k];
        b.w[k] += cur.w[k];
        b.ww[k] += cur.w[k] * cur.w[k];
        for (int l = 0; l < 3; ++l) b.wq[k][l] += ins[1].w[k] * ins[1].w[l];
        for (int l = 0; l < 3; ++l) b.wc[k][l] += ins[1].w[k] * ins[1].w[k] * ins[1].w[l];
        for (int l = 0; l < 3; ++l) b.ff[k][l] += cur.f[k] * cur.f[l];
        if (std::isfinite(cur.table_angle_rad[k])) {
          b.sin_a[k] += std::sin(cur.table_angle_rad[k]);
          b.cos_a[k] += std::cos(cur.table_angle_rad[k]);
          ++b.n_a[k];
        }
        acc.fmin[k] = std::min(acc.fmin[k], cur.f[k]);
        acc.fmax[k] = std::max(acc.fmax[k], cur.f[k]);
      }
      b.absw += wn;
      b.wound_rad += wound_rad;
      acc.maxw = std::max(acc.maxw, wn);
      if (hasT) {
        acc.sT += cur.temp_C;
        ++acc.nT;
        acc.Tmin = std::min(acc.Tmin, cur.temp_C);
        acc.Tmax = std::max(acc.Tmax, cur.temp_C);
      }
      ++out.n_used;
      last_ref_t = cur.t_s;
    }
    last_had_ref = cur.has_ref;
    last_seg = cur.segment;
    prev = cur;
    have_prev = true;
    cur = nxt;
    have_cur = have_next;
    if (have_cur) have_next = src.next(nxt);
  }
  close_block();
  flush_run();
  if (sums) {
    // Each block's regressor means: its sums (summed in sample order, RegressorSums) over its samples.
    std::vector<std::array<Eigen::MatrixXd, 2>> J = sums->take();
    for (std::size_t i = 0; i < out.blocks.size(); ++i) {
      Block& b = out.blocks[i];
      for (int s = 0; s < 2; ++s) {
        if (i < J.size()) {
          b.J[s] = std::move(J[i][static_cast<std::size_t>(s)]);
          b.J[s] /= static_cast<double>(b.n);
        } else {
          b.J[s] = Eigen::MatrixXd::Zero(3, np[s]);
        }
      }
    }
  }
  out.n_units = unit + 1;
  // A dwell cut by a reference gap (a reference-free pose of several still parts, a dropout) is still one
  // dwell: its parts share one reference, so withholding one part while fitting another is no withholding.
  // Units are the withholdable groups, so parts of one segment number become one unit. Only done when a
  // segment number does repeat, so logs without repeats keep their unit numbering (and folds) unchanged.
  {
    std::map<int, std::set<int>> units_of_seg;
    for (const Block& b : out.blocks)
      if (b.segment >= 0) units_of_seg[b.segment].insert(b.unit);
    bool repeats = false;
    for (const auto& [seg, us] : units_of_seg) repeats = repeats || us.size() > 1;
    if (repeats) {
      std::map<std::pair<int, int>, int> group;  // (segment, -1) or (-1, unit) -> new unit, first-seen order
      for (Block& b : out.blocks) {
        const std::pair<int, int> key = b.segment >= 0 ? std::make_pair(b.segment, -1) : std::make_pair(-1, b.unit);
        auto it = group.find(key);
        if (it == group.end()) it = group.emplace(key, static_cast<int>(group.size())).first;
        b.unit = it->second;
      }
      out.n_units = static_cast<int>(group.size());
    }
  }
  fill_input_memory(out.blocks);
  fill_motion_settling(out.blocks);
  return out;
}

// ---------------------------------------------------------------------------------------------------
// Block-level weighted least squares for one axis.
struct AxisData {
  int axis = 0;
  Sensor sensor = Sensor::kAccel;
  std::vector<ParamId> cols;   // parameters acting on this axis (catalog ids)
  // temp_hysteresis's threshold profile (diagnose_core): n_grid more columns after cols, the d(t) of each grid
  // threshold (hyst_grid), never in a model's column set; h_id is the axis's hysteresis parameter they stand for
  // and h_col its column in cols (−1: none).
  int n_grid = 0;
  ParamId h_id = -1;
  int h_col = -1;
  Eigen::MatrixXd X;           // B × P block-mean regressors, whitened (Kalman innovations, noise_model.h)
  Eigen::VectorXd z, v;        // whitened block means of y − u, and their innovation variances
  Eigen::MatrixXd Xr;          // the same before whitening (cells, plots, signatures), with
  Eigen::VectorXd zr, vr;      // the marginal variance of each block mean
  // Per fold and total, in the shared estimator core: info = Σ x xᵀ/v, rhs = Σ x z/v, cost = Σ z²/v,
  // n_obs = blocks, weight = Σ 1/v.
  estimator::FoldedNormalEquations ne;
};

// The fits and held-out scores run on the estimator core shared with the solver (host/estimator):
// fit_subset's priority-ordered scaled Cholesky, and the k-fold evaluation from per-fold statistics.
using Fit = estimator::SubsetFit;  // kept/dropped are indices into AxisData::cols
using estimator::HeldOut;

// Fits columns `sel` (indices into cols, in priority order) on all folds except `skip` (−1 = none).
// Columns whose information is (nearly) a combination of earlier ones are dropped, never solved.
Fit fit_axis(const AxisData& ad, const std::vector<int>& sel, int skip) { return estimator::fit_without(ad.ne, sel, skip); }
// The fit's misfit per degree of freedom, at least 1: the factor that puts an axis's in-sample χ² differences in
// units of its own unmodelled scatter (tie-breaks and in-sample swap tests).
double augmented_misfit(const AxisData& ad, const Fit& f) {
  return std::max(1.0, f.rss / std::max(1.0, static_cast<double>(ad.ne.total.n_obs) - static_cast<double>(f.kept.size())));
}

// The block means fit f predicts on axis ad, before whitening (Xr θ over the kept columns). O(B·P).
Eigen::VectorXd fitted_means(const AxisData& ad, const Fit& f) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(ad.Xr.rows());
  for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) y += ad.Xr.col(f.kept[static_cast<std::size_t>(i)]) * f.theta[i];
  return y;
}

// The fit uses `fit_ad` (blocks); the withheld data are scored on `ad` (blocks, or whole segments for the gap).
HeldOut heldout_axis(const AxisData& fit_ad, const AxisData& ad, const std::vector<int>& sel, int folds) {
  if (folds != ad.ne.folds()) throw DiagnosisError("internal: held-out statistics built for another fold count");
  return estimator::heldout(fit_ad.ne, ad.ne, sel);
}

// Per-block held-out residuals and predicted variances (for cells and plots).
void heldout_blocks(const AxisData& ad, const std::vector<int>& sel, int folds, const std::vector<Block>& blocks,
                    std::vector<double>& r, std::vector<double>& pv) {
  const int B = static_cast<int>(blocks.size());
  r.assign(static_cast<std::size_t>(B), 0.0);
  pv.assign(static_cast<std::size_t>(B), 1.0);
  for (int k = 0; k < folds; ++k) {
    if (ad.ne.fold[static_cast<std::size_t>(k)].n_obs == 0) continue;
    Fit f = fit_axis(ad, sel, k);
    const int p = static_cast<int>(f.kept.size());
    for (int b = 0; b < B; ++b) {
      if (blocks[static_cast<std::size_t>(b)].fold != k) continue;
      Eigen::VectorXd x(p);
      for (int i = 0; i < p; ++i) x[i] = ad.Xr(b, f.kept[static_cast<std::size_t>(i)]);
      r[static_cast<std::size_t>(b)] = ad.zr[b] - (p ? x.dot(f.theta) : 0.0);
      pv[static_cast<std::size_t>(b)] = ad.vr[b] + (p ? x.dot(f.cov * x) : 0.0);
    }
  }
}

std::vector<int> cols_for(const AxisData& ad, const std::set<ParamId>& model_ids, const std::vector<ParamId>& extra = {}) {
  std::vector<int> sel;
  // Model parameters first (priority in the rank check), the candidate after.
  for (int i = 0; i < static_cast<int>(ad.cols.size()); ++i)
    if (model_ids.count(ad.cols[static_cast<std::size_t>(i)])) sel.push_back(i);
  for (ParamId id : extra)
    for (int i = 0; i < static_cast<int>(ad.cols.size()); ++i)
      if (ad.cols[static_cast<std::size_t>(i)] == id && !model_ids.count(id)) sel.push_back(i);
  return sel;
}

using SignatureFunction = std::pair<std::string, std::function<double(const Block&)>>;

// "f_x*time" … "w_z*time", the library's inputs times time: k (0–2) and whether it is a specific force.
bool is_input_times_time(const std::string& name, int& k, bool& is_f) {
  if (name.size() != 8 || name.compare(3, 5, "*time") != 0 || (name[0] != 'f' && name[0] != 'w') || name[1] != '_' ||
      name[2] < 'x' || name[2] > 'z')
    return false;
  k = name[2] - 'x';
  is_f = name[0] == 'f';
  return true;
}

// Where an input times a step may start: 46 block times, the 5th to the 95th percentile of the blocks' times
// (a step nearer an end is a bias over a few segments, which "segment" already reads). O(B log B).
std::vector<double> step_t0_grid(const std::vector<Block>& blocks) {
  std::vector<double> ts;
  for (const Block& b : blocks) ts.push_back(b.t);
  std::sort(ts.begin(), ts.end());
  std::vector<double> out;
  if (ts.size() < 2) return out;
  for (int q = 0; q <= 45; ++q)
    out.push_back(ts[static_cast<std::size_t>((0.05 + 0.9 * q / 45.0) * static_cast<double>(ts.size() - 1))]);
  return out;
}

// Per block, input k (a specific force when is_f, else a rate) from t0 on, 0 before: an input times a step. O(B).
Eigen::VectorXd input_step(const std::vector<Block>& blocks, int k, bool is_f, double t0) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(blocks.size()));
  for (std::size_t b = 0; b < blocks.size(); ++b)
    v[static_cast<Eigen::Index>(b)] = blocks[b].t >= t0 ? (is_f ? blocks[b].f[k] : blocks[b].w[k]) : 0.0;
  return v;
}

// "w_y from 1617 s on": the input of an input-times-time name, from t0 (seconds after the first block) on. Where
// later grid times t0..t0_last give the same function (the input is zero between them: a soak at a pose that does
// not load it), the step lies anywhere there: "f_x from between 1512 and 4136 s on".
std::string step_name(const std::string& times_time, double t0, double t0_last, const std::vector<Block>& blocks) {
  double t_first = t0;
  for (const Block& b : blocks) t_first = std::min(t_first, b.t);
  char buf[80];
  if (t0_last > t0)
    std::snprintf(buf, sizeof buf, "%.3s from between %.0f and %.0f s on", times_time.c_str(), t0 - t_first, t0_last - t_first);
  else
    std::snprintf(buf, sizeof buf, "%.3s from %.0f s on", times_time.c_str(), t0 - t_first);
  return buf;
}

// The simple functions of the logged inputs a residual signature ranks (residual_signature), by name; also what
// the report's residual plot is drawn against when one of them leads (diagnose_core). pv: the blocks' variances,
// the weights of the means that temperature and time are taken about.
std::vector<SignatureFunction> signature_functions(const std::vector<Block>& blocks, const std::vector<double>& pv) {
  const char* ax = "xyz";
  std::vector<SignatureFunction> feats;
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("f_") + ax[k], [k](const Block& b) { return b.f[k]; }});
  for (int k = 0; k < 3; ++k)
    for (int l = k; l < 3; ++l)
      feats.push_back({k == l ? std::string("f_") + ax[k] + "^2" : std::string("f_") + ax[k] + "*f_" + ax[l],
                       [k, l](const Block& b) { return b.ff[k][l]; }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("w_") + ax[k], [k](const Block& b) { return b.w[k]; }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("w_") + ax[k] + "^2", [k](const Block& b) { return b.ww[k]; }});
  // Cubes (of the block mean: exact on the static and constant-rate blocks that carry them): odd nonlinearities
  // the linear terms only partly absorb (a cubic g-sensitivity).
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("f_") + ax[k] + "^3", [k](const Block& b) { return b.f[k] * b.f[k] * b.f[k]; }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("w_") + ax[k] + "^3", [k](const Block& b) { return b.w[k] * b.w[k] * b.w[k]; }});
  // The rotation speed (block mean of |ω|): what a rectified rate follows (bearing friction, a motor's vibration
  // or field that grows with speed, whatever the direction). Even in ω like ω², but linear in speed: on a
  // campaign with several rate levels the two part.
  feats.push_back({"|w|", [](const Block& b) { return b.absw; }});
  // The direction of rotation (0 on blocks turning slower than 1e-3 rad/s, which the Earth's rate never
  // reaches): a bias that flips with it and no polynomial in ω has (a rate-dependent offset saturating within
  // a few °/s).
  for (int k = 0; k < 3; ++k)
    feats.push_back({std::string("sign(w_") + ax[k] + ")", [k](const Block& b) { return std::fabs(b.w[k]) > 1e-3 ? (b.w[k] > 0 ? 1.0 : -1.0) : 0.0; }});
  // Products of two kinds of input (of the block means: exact where one of them is constant over the block, as
  // on static and constant-rate blocks): a rate read with a scale that depends on the specific force (ω_k f_l),
  // a sensitivity that moves with temperature (f_k·T) or with time (an ageing scale: f_k·time, ω_k·time).
  // Temperature and time are taken about their weighted means over the blocks, so that these are not the input
  // itself again.
  double sw0 = 0, sT = 0, st = 0, swT = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const double w = 1.0 / pv[b];
    sw0 += w;
    st += w * blocks[b].t;
    if (std::isfinite(blocks[b].T)) {
      swT += w;
      sT += w * blocks[b].T;
    }
  }
  const double Tm = swT > 0 ? sT / swT : 0.0, tm = sw0 > 0 ? st / sw0 : 0.0;
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l)
      feats.push_back({std::string("w_") + ax[k] + "*f_" + ax[l], [k, l](const Block& b) { return b.w[k] * b.f[l]; }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("f_") + ax[k] + "*T", [k, Tm](const Block& b) { return b.f[k] * (b.T - Tm); }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("f_") + ax[k] + "*time", [k, tm](const Block& b) { return b.f[k] * (b.t - tm); }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("w_") + ax[k] + "*time", [k, tm](const Block& b) { return b.w[k] * (b.t - tm); }});
  // A sensitivity that moves with the die's temperature rate (a gradient across the die while it heats or cools
  // bends the sense structure): the model's scale takes its mean, temp_rate the part that is a bias, and what is
  // left goes with the input times Ṫ (stop 64: unseen13's tdot_scale read as "f_x from 259 s on").
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("f_") + ax[k] + "*Tdot", [k](const Block& b) { return b.f[k] * b.Tdot; }});
  for (int k = 0; k < 3; ++k) feats.push_back({std::string("w_") + ax[k] + "*Tdot", [k](const Block& b) { return b.w[k] * b.Tdot; }});
  feats.push_back({"T", [](const Block& b) { return b.T; }});
  // The die temperature's square and cube (about its weighted mean): a bias curved in T beyond the model's
  // polynomial (a leakage doubling every few degrees) leaves, once the model's own degree is projected off, mostly
  // the next power's shape. The hats below draw it too, but on ten degrees of freedom where this is one: `unseen18`
  // ooc-temp_exp, a consumer accel.y bias doubling every 9 °C over 0–40 °C (blindgen SNR 28), read LR 49 through
  // the hats at p 3.9e-7 against a bar of 2.2e-9 beside a walk that took the rest, and the axis went unnamed.
  // Named about that mean, so that the verdict's "follows (T-26 degC)^3" and the plot's axis read in degrees.
  {
    char n2[48], n3[48];
    std::snprintf(n2, sizeof n2, "(T%+.0f degC)^2", -Tm);
    std::snprintf(n3, sizeof n3, "(T%+.0f degC)^3", -Tm);
    feats.push_back({n2, [Tm](const Block& b) { return (b.T - Tm) * (b.T - Tm); }});
    feats.push_back({n3, [Tm](const Block& b) { return (b.T - Tm) * (b.T - Tm) * (b.T - Tm); }});
  }
  // A bias that departs from the polynomial in T over a few degrees only (a mode crossing, a regulator's or a
  // package's change of state near one temperature): hats of T, each 1 at its knot and 0 a knot spacing away,
  // knots spread over the die's range. Where the die passes a temperature more than once (heating and cooling,
  // a plateau and the ramps to it), such a bias comes back each time, where a wander in time does not.
  double Tlo = std::numeric_limits<double>::infinity(), Thi = -Tlo;
  for (const auto& b : blocks)
    if (std::isfinite(b.T)) {
      Tlo = std::min(Tlo, b.T);
      Thi = std::max(Thi, b.T);
    }
  if (Thi - Tlo >= 2.0 * kTempHatMinSpacing_C) {
    const double dT = std::max((Thi - Tlo) / kTempHats, kTempHatMinSpacing_C);
    for (double c = Tlo + 0.5 * dT; c < Thi; c += dT) {
      char name[64];
      std::snprintf(name, sizeof name, "%s%.0f degC (+-%.0f)", kTempHatPrefix, c, dT);
      feats.push_back({name, [c, dT](const Block& b) { return std::isfinite(b.T) ? std::max(0.0, 1.0 - std::fabs(b.T - c) / dT) : 0.0; }});
    }
  }
  feats.push_back({"Tdot", [](const Block& b) { return b.Tdot; }});
  // The die's temperature rate either way: a thermal gradient across the package stresses it alike when heating and
  // when cooling (temp_rate, odd in Ṫ, takes half of it; temp_hysteresis, constant between turns, another part).
  feats.push_back({"|Tdot|", [](const Block& b) { return b.absTdot; }});
  // The inputs as a lag remembers them (Block::f_mem): a residual the model's columns see as the input itself
  // minus that memory (a creeping suspension) is left with the memory once the input's own part is projected off.
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 4; ++j) {
      char name[48];
      std::snprintf(name, sizeof name, "f_%c low-passed at %.0f s", ax[k], kMemoryTaus_s[j]);
      feats.push_back({name, [k, j](const Block& b) { return b.f_mem[k][j]; }});
      std::snprintf(name, sizeof name, "w_%c low-passed at %.0f s", ax[k], kMemoryTaus_s[j]);
      feats.push_back({name, [k, j](const Block& b) { return b.w_mem[k][j]; }});
    }
  // The gradient between the die and what lags it by minutes (Block::T_grad): a board or case bending the package
  // while the chamber moves the temperature and relaxing as it holds (`unseen17` ooc-thermal_gradient: the
  // whole-log wander took it as a random walk 9x the dwells', and Ṫ, the nearest function, as LR 18 beside it).
  for (int j = 0; j < 2; ++j) {
    char name[64];
    std::snprintf(name, sizeof name, "T minus T lagged %.0f s", kGradTaus_s[j]);
    feats.push_back({name, [j](const Block& b) { return b.T_grad[j]; }});
  }
  // The table motor's heat (Block::turn_mem): one sign whatever the turn's axis or direction, growing with how long
  // the table has turned, so neither the rates, their squares nor the settlings after each turn carry it.
  for (int j = 0; j < 3; ++j) {
    char name[48];
    std::snprintf(name, sizeof name, "turning low-passed at %.0f s", kTurnLagTaus_s[j]);
    feats.push_back({name, [j](const Block& b) { return b.turn_mem[j]; }});
  }
  // The rotation wound up about the vertical (Block::wound_rad): a cable twisted by the turns, or any strain that
  // remembers them. It moves only while the table turns about the specific force and holds through the dwells after,
  // one sign for each direction, so neither the rates, the turning's lags nor the settlings carry it.
  feats.push_back({"rotation wound about the vertical (rad)", [](const Block& b) { return b.wound_rad; }});
  // A settling after every motion (Block::settle): one sign whatever the pose or the turn, so neither the inputs
  // nor their lagged memories carry it, and on dwells of one length the bias takes all of it but for the moving
  // blocks and the dwells' differing lengths.
  for (int m = 0; m < 2; ++m)
    for (int j = 0; j < 3; ++j) {
      char name[48];
      std::snprintf(name, sizeof name, "settling %.0f s after each %s", kSettleTaus_s[j], m == 0 ? "turn" : "pose change");
      feats.push_back({name, [m, j](const Block& b) { return b.settle[m][j]; }});
    }
  feats.push_back({"time", [](const Block& b) { return b.t; }});
  for (int k = 0; k < 3; ++k) {
    feats.push_back({"sin(table angle " + std::to_string(k) + ")", [k](const Block& b) { return b.sin_a[k]; }});
    feats.push_back({"cos(table angle " + std::to_string(k) + ")", [k](const Block& b) { return b.cos_a[k]; }});
  }
  // Twice each table angle: a two-lobed field (a motor's or a magnet's). From the block means of sin and cos:
  // exact on a block at one angle, about 0 on a block that turns through whole revolutions, as the mean of
  // sin 2θ is.
  for (int k = 0; k < 3; ++k) {
    feats.push_back({"sin(2 table angle " + std::to_string(k) + ")", [k](const Block& b) { return 2.0 * b.sin_a[k] * b.cos_a[k]; }});
    feats.push_back({"cos(2 table angle " + std::to_string(k) + ")",
                     [k](const Block& b) { return b.cos_a[k] * b.cos_a[k] - b.sin_a[k] * b.sin_a[k]; }});
  }
  return feats;
}

// Weighted correlation of the held-out block residuals with simple functions of the logged inputs, best
// first: what an out-of-catalog effect follows. period_s > 0 adds a sinusoid in time of that period (the
// whole-log wander's sinusoid check found one); settle_tau_s > 0 a settling transient e^{−time/τ} (its settling
// check found one).
// X (blocks × model columns, before whitening; null: none) is the final model's design. Each function and the
// residual are correlated after their projections on those columns are taken out (weights 1/pv): the
// added-variable (partial) correlation. The residual has already lost that projection to the fit, so the raw
// function compares it with something it can no longer contain: a bias that flips with the direction of
// rotation, fitted by the scale factor first, is left positive at low rates and negative at high ones and read
// r = −0.29 against ω³ and nothing against the direction (`unseen3` ooc-sign_rate-0); its direction, with the
// scale's part taken out, reads it whole. A function the model contains (T, where bias_temp is in it) has
// nothing left and drops out. "segment" is the projected residual's own segment means.
std::vector<SignatureEntry> residual_signature(const std::vector<Block>& blocks, const std::vector<double>& r,
                                               const std::vector<double>& pv, double period_s, double settle_tau_s,
                                               const Eigen::MatrixXd* X = nullptr) {
  std::vector<SignatureFunction> feats = signature_functions(blocks, pv);
  // A sinusoid in time the whole log's residual was found to carry (periodic_bias), at its best phase: the phase
  // fitted here to these residuals by weighted least squares, so the correlation is that fit's multiple r.
  if (period_s > 0) {
    const double w0 = 2.0 * M_PI / period_s;
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (std::size_t b = 0; b < blocks.size(); ++b) {
      const Eigen::Vector3d x(1.0, std::sin(w0 * blocks[b].t), std::cos(w0 * blocks[b].t));
      A += x * x.transpose() / pv[b];
      g += x * r[b] / pv[b];
    }
    const Eigen::Vector3d c = A.ldlt().solve(g);
    const double phase = std::atan2(c[2], c[1]);
    char name[80];
    std::snprintf(name, sizeof name, "sin(2 pi time / %.0f s %+.2f)", period_s, phase);
    feats.push_back({name, [w0, phase](const Block& b) { return std::sin(w0 * b.t + phase); }});
  }
  if (settle_tau_s > 0) {
    const double t_first = blocks.empty() ? 0.0 : std::min_element(blocks.begin(), blocks.end(), [](const Block& x, const Block& y) {
                                                    return x.t < y.t;
                                                  })->t;
    char name[80];
    std::snprintf(name, sizeof name, "exp(-time / %.0f s)", settle_tau_s);
    feats.push_back({name, [settle_tau_s, t_first](const Block& b) { return std::exp(-(b.t - t_first) / settle_tau_s); }});
  }
  // The projection off X: with G = Xᵀ W X (W = diag 1/pv), a vector v keeps v − X G⁻¹ Xᵀ W v. Columns without
  // weight (a parameter the blocks do not excite) are dropped by the rank-revealing solve. O(B·P² + P³) once,
  // O(B·P) per vector.
  const int B = static_cast<int>(blocks.size());
  const bool project = X && X->rows() == B && X->cols() > 0;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
  if (project) {
    Eigen::MatrixXd Xw = *X;
    for (int b = 0; b < B; ++b) Xw.row(b) /= std::sqrt(pv[static_cast<std::size_t>(b)]);
    qr.compute(Xw);
  }
  auto project_off = [&](Eigen::VectorXd& v) {
    Eigen::VectorXd vs(B);
    for (int b = 0; b < B; ++b) vs[b] = v[b] / std::sqrt(pv[static_cast<std::size_t>(b)]);
    v -= *X * qr.solve(vs);
  };
  // The residual is projected too, so the correlation is the added-variable one (Frisch–Waugh–Lovell: the
  // function's coefficient beside the model's columns, on the residual). The held-out residual is not the
  // in-sample one: each fold's fit leaves its own share of the model's columns in it, which the raw residual
  // would compare with the projected function as misfit. Measured (stop 47): with the function alone projected,
  // `varied16` mixed-heading read sin(table angle 2) at r = 0.58, behind "segment"; with both, 0.79, first;
  // `varied15` mixed-bias_step read time 0.65 against 0.82.
  std::vector<double> rr(r);
  if (project) {
    Eigen::VectorXd rv = Eigen::Map<const Eigen::VectorXd>(r.data(), B);
    project_off(rv);
    for (int b = 0; b < B; ++b) rr[static_cast<std::size_t>(b)] = rv[b];
  }
  // "segment": the residual's own per-segment mean (a constant per segment that no input explains).
  std::map<int, std::pair<double, double>> seg;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    auto& e = seg[blocks[b].unit];
    e.first += rr[b] / pv[b];
    e.second += 1.0 / pv[b];
  }
  feats.push_back({"segment", [&seg](const Block& b) {
                     const auto& e = seg.at(b.unit);
                     return e.first / e.second;
                   }});
  std::vector<SignatureEntry> out;
  Eigen::VectorXd xv(B);
  // The weighted correlation of xv (ok: the blocks that have it) with the projected residual; NaN when either
  // has no spread.
  auto correlation = [&](const Eigen::VectorXd& x_b, const std::vector<char>& ok) {
    double sw = 0, sx = 0, sy = 0;
    for (int b = 0; b < B; ++b) {
      if (!ok[static_cast<std::size_t>(b)]) continue;
      const double w = 1.0 / pv[static_cast<std::size_t>(b)];
      sw += w;
      sx += w * x_b[b];
      sy += w * rr[static_cast<std::size_t>(b)];
    }
    if (!(sw > 0)) return std::numeric_limits<double>::quiet_NaN();
    const double mx = sx / sw, my = sy / sw;
    double cxx = 0, cyy = 0, cxy = 0;
    for (int b = 0; b < B; ++b) {
      if (!ok[static_cast<std::size_t>(b)]) continue;
      const double x = x_b[b];
      const double w = 1.0 / pv[static_cast<std::size_t>(b)];
      cxx += w * (x - mx) * (x - mx);
      cyy += w * (rr[static_cast<std::size_t>(b)] - my) * (rr[static_cast<std::size_t>(b)] - my);
      cxy += w * (x - mx) * (rr[static_cast<std::size_t>(b)] - my);
    }
    if (!(cxx > 1e-30 * sw) || !(cyy > 0)) return std::numeric_limits<double>::quiet_NaN();
    return cxy / std::sqrt(cxx * cyy);
  };
  for (const auto& [name, fn] : feats) {
    std::vector<char> ok(static_cast<std::size_t>(B), 0);
    for (int b = 0; b < B; ++b) {
      xv[b] = fn(blocks[static_cast<std::size_t>(b)]);
      ok[static_cast<std::size_t>(b)] = std::isfinite(xv[b]);
      if (!ok[static_cast<std::size_t>(b)]) xv[b] = 0.0;
    }
    // A function missing on some blocks (a table angle logged on part of the log) is correlated raw over the
    // blocks that have it: the projection needs it on every block.
    if (project && name != "segment" && std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; })) {
      // A function the model holds (nothing but rounding left of it) is not a signature.
      auto wnorm2 = [&](const Eigen::VectorXd& v) {
        double n2 = 0;
        for (int b = 0; b < B; ++b) n2 += v[b] * v[b] / pv[static_cast<std::size_t>(b)];
        return n2;
      };
      const double before = wnorm2(xv);
      project_off(xv);
      if (!(wnorm2(xv) > 1e-10 * before)) continue;
    }
    const double c = correlation(xv, ok);
    if (std::isfinite(c)) out.push_back({name, c});
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const SignatureEntry& a, const SignatureEntry& b) { return std::fabs(a.correlation) > std::fabs(b.correlation); });
  // A sensitivity that changed at once rather than gradually (the package slipping on its mount: a misalignment
  // step) reads as the nearest product with time. Where an input times time is the first input function, the
  // input times a step at t0 is asked too (step_t0_grid, the stand-in check's grid), and the likeliest step goes
  // ahead of it where it correlates better: "w_y from 1617 s on" (`unseen9` ooc-mount_slip-1, the truth's slip at
  // 1575 s, read as w_y*time at r 0.74).
  {
    const auto first = std::find_if(out.begin(), out.end(), [](const SignatureEntry& e) { return e.input != "segment"; });
    int k = -1;
    bool is_f = false;
    if (first != out.end() && is_input_times_time(first->input, k, is_f)) {
      double best = std::fabs(first->correlation), best_c = 0, best_t0 = std::numeric_limits<double>::quiet_NaN();
      double last_t0 = best_t0;  // the last grid time giving the same function (the input is 0 between them)
      const std::vector<char> all_ok(static_cast<std::size_t>(B), 1);
      for (const double t0 : step_t0_grid(blocks)) {
        xv = input_step(blocks, k, is_f, t0);
        if (project) project_off(xv);
        const double c = correlation(xv, all_ok);
        if (!std::isfinite(c)) continue;
        if (std::fabs(c) > best * (1.0 + 1e-9)) best = std::fabs(c), best_c = c, best_t0 = last_t0 = t0;
        else if (std::isfinite(best_t0) && std::fabs(c) >= best * (1.0 - 1e-9)) last_t0 = t0;
      }
      if (std::isfinite(best_t0)) out.insert(first, {step_name(first->input, best_t0, last_t0, blocks), best_c});
    }
  }
  // "segment" is the residual's own per-segment mean: it bounds what any per-segment function can reach and
  // is ~1 whenever a segment is one block (static poses), so it names the residual only when no logged input
  // comes close (within 80 % of its |r|); otherwise the best input leads.
  {
    auto is_seg = [](const SignatureEntry& e) { return e.input == "segment"; };
    auto it = std::find_if(out.begin(), out.end(), is_seg);
    auto in = std::find_if_not(out.begin(), out.end(), is_seg);
    if (it != out.end() && in != out.end() && it < in && std::fabs(in->correlation) >= 0.8 * std::fabs(it->correlation))
      std::rotate(it, it + 1, in + 1);
  }
  if (out.size() > 6) out.resize(6);
  return out;
}

// What a residual follows, as functions of the blocks: the entries of its signature at |r| >= 0.3 that
// signature_functions holds, in the signature's order ("segment", and a sinusoid or settling fitted to that one
// residual, are not among them). fns: signature_functions under the signature's own weights.
std::vector<const SignatureFunction*> signature_leaders(const std::vector<SignatureEntry>& sig, const std::vector<SignatureFunction>& fns) {
  std::vector<const SignatureFunction*> out;
  for (const SignatureEntry& se : sig) {
    if (!(std::fabs(se.correlation) >= 0.3)) continue;
    const auto it = std::find_if(fns.begin(), fns.end(), [&](const SignatureFunction& f) { return f.first == se.input; });
    if (it != fns.end()) out.push_back(&*it);
  }
  return out;
}

// Effective number of distinct tests among K correlated columns (Li & Ji 2005): from the eigenvalues λ of their
// correlation, Σ [λ ≥ 1] + (λ − ⌊λ⌋). 1 for identical columns, K for orthogonal ones. S: their information (or
// any covariance-like matrix); columns without information are left out. O(K³).
double effective_tests(const Eigen::MatrixXd& S) {
  std::vector<int> inf;
  const double top = S.diagonal().maxCoeff();
  for (int k = 0; k < S.rows(); ++k)
    if (S(k, k) > 1e-12 * top && S(k, k) > 0) inf.push_back(k);
  if (inf.size() < 2) return 1.0;
  const auto n = static_cast<Eigen::Index>(inf.size());
  Eigen::MatrixXd C(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index i2 = 0; i2 < n; ++i2)
      C(i, i2) = S(inf[static_cast<std::size_t>(i)], inf[static_cast<std::size_t>(i2)]) /
                 std::sqrt(S(inf[static_cast<std::size_t>(i)], inf[static_cast<std::size_t>(i)]) * S(inf[static_cast<std::size_t>(i2)], inf[static_cast<std::size_t>(i2)]));
  const Eigen::VectorXd lam = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(C).eigenvalues();
  double m = 0;
  for (Eigen::Index i = 0; i < lam.size(); ++i) {
    const double x = std::fabs(lam[i]);
    m += (x >= 1.0 ? 1.0 : 0.0) + (x - std::floor(x));
  }
  return std::clamp(m, 1.0, static_cast<double>(n));
}

double variable_of(const Block& b, const std::string& var, int axis) {
  if (var == "temp_C") return b.T;
  if (var == "dTdt_C_s") return b.Tdot;
  if (var == "hysteresis_d") return b.d;
  if (var == "rate_rad_s") return b.absw;
  if (var == "time_s") return b.t;
  if (var.rfind("f_", 0) == 0) return b.f[var[2] - 'x'];
  if (var == "input") return nominal_input(b.f, b.w, axis);
  return b.t;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
double max_timing_shift_s(const DiagnosisResult& r) {
  std::map<std::string, std::pair<double, double>> timing;  // fitted axis -> (latency_s, ppm)
  for (const auto& pe : r.final_params) {
    const auto dot = pe.name.rfind('.');
    if (pe.name.find(".timing.") == std::string::npos || dot == std::string::npos) continue;
    auto& lp = timing[pe.axis.empty() ? pe.name.substr(0, pe.name.find('.')) : pe.axis];
    (pe.name.compare(dot + 1, std::string::npos, "ppm") == 0 ? lp.second : lp.first) = pe.value;
  }
  double shift_s = 0;
  for (const auto& [axis, lp] : timing)
    shift_s = std::max({shift_s, std::abs(lp.first), std::abs(lp.first + 1e-6 * lp.second * r.duration_s)});
  return shift_s;
}

double plausible_limit(const model::ParamInfo& p) {
  const bool acc = p.sensor == Sensor::kAccel;
  const double pw = p.power > 0 ? std::pow(10.0, -(p.power - 1)) : 1.0;  // each temperature power: ÷10
  switch (p.effect) {
    case Effect::kBias: return acc ? 2.0 : 0.2;
    case Effect::kScale: return 0.1;
    case Effect::kMisalign: return 0.05;
    case Effect::kBiasTemp: return (acc ? 0.05 : 5e-3) * pw;
    case Effect::kScaleTemp: return 1e-3 * pw;
    case Effect::kMisalignTemp: return 1e-3 * pw;
    case Effect::kScaleNonlinearity:
      if (p.power == 2) return acc ? 1e-3 : 0.05;
      return acc ? 1e-4 : 0.02;
    case Effect::kScaleAsymmetry: return 0.02;
    case Effect::kCrossCoupling: return acc ? 1e-3 : 0.05;  // gyro: 10x a consumer MEMS part (5e-3 1/(rad/s))
    case Effect::kGSensitivity: return 1e-3;
    case Effect::kG2Sensitivity: return 2e-5;
    case Effect::kCrossAxisNonlinearity: return 1e-3;  // as the accelerometer's own k2
    case Effect::kSizeEffect: return 0.05;
    case Effect::kTempHysteresis: return acc ? 0.1 : 0.01;
    case Effect::kTempRate: return acc ? 0.5 : 0.05;
    case Effect::kTiming: return p.component == "ppm" ? 1000.0 : 0.5;
    default: return std::numeric_limits<double>::infinity();
  }
}

// ---------------------------------------------------------------------------------------------------
BaseModel basic_model() {
  BaseModel m;
  for (Sensor s : {Sensor::kAccel, Sensor::kGyro})
    for (Effect e : {Effect::kBias, Effect::kScale, Effect::kMisalign}) {
      for (ParamId id : model::effect_params(s, e)) m.params.push_back(id);
      m.effect_names.push_back(effect_key(s, e));
    }
  return m;
}

BaseModel base_model_from_spec(const model::ModelSpec& spec) {
  BaseModel m;
  m.T_ref_C = spec.T_ref_C;
  m.hysteresis_threshold_C = spec.hysteresis_threshold_C;
  m.params = spec.parameters();
  for (const auto& e : spec.effects)
    if (model::effect_info(e.effect).kind == model::EffectKind::kDeterministic) m.effect_names.push_back(effect_key(e.sensor, e.effect));
  return m;
}

std::array<std::vector<AllanAccumulator::Point>, kNumAxes> static_allan(SampleSource& src, const Options& opt) {
  Pass0 p0 = run_pass0(src, opt);
  std::vector<ParamId> ids[2];
  Pass1 p1 = run_pass1(src, p0, opt, ids, false);
  std::array<std::vector<AllanAccumulator::Point>, kNumAxes> out;
  for (int a = 0; a < kNumAxes; ++a) out[static_cast<std::size_t>(a)] = p1.allan[static_cast<std::size_t>(a)].points();
  return out;
}

namespace {
// words: the stuck bits an earlier run of the same diagnosis counted (OutputWords); null counts them here.
DiagnosisResult diagnose_core(SampleSource& src_in, const BaseModel& base, const Options& opt, const TimeShift shift[2],
                              const OutputWords* words) {
  FixtureCorrectedSource fixture_src(src_in, opt);
  // The re-evaluated reference (the table's kinematics per sample) on a thread of its own (prefetch.h).
  PrefetchSource fixture_ahead(fixture_src);
  SampleSource& src = fixture_src.active() ? static_cast<SampleSource&>(fixture_ahead) : src_in;
  DiagnosisResult R;
  R.alpha = opt.alpha;
  R.base_effects = base.effect_names;
  R.claimed_N = opt.claimed_N;
  R.sim_allan = opt.sim_allan;
  Options o = opt;
  o.T_ref_C = base.T_ref_C;
  if (std::isfinite(base.hysteresis_threshold_C)) o.hysteresis_threshold_C = base.hysteresis_threshold_C;

  const Pass0 p0 = run_pass0(src, o);
  R.n_samples = p0.n;
  R.duration_s = p0.t_last - p0.t_first;
  R.sample_rate_hz = p0.fs;
  if (p0.n_ref == 0)
    throw DiagnosisError("no sample carries a reference (f_ref/w_ref): use reference-free mode (--mode reference-free)");

  for (int a = 0; a < kNumAxes; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    if (p0.n_clamped[ua] == 0) continue;
    std::string lim;
    for (const double v : {p0.clamp_hi[ua], p0.clamp_lo[ua]}) {
      if (!std::isfinite(v)) continue;
      char b[40];
      std::snprintf(b, sizeof b, "%s%.6g", lim.empty() ? "" : ", ", v);
      lim += b;
    }
    char buf[300];
    std::snprintf(buf, sizeof buf, "%s: %lld samples read the output's limit (%s) while the reference lies beyond it: saturated, left out",
                  axis_name(a), p0.n_clamped[ua], lim.c_str());
    R.warnings.push_back(buf);
  }
  std::vector<ParamId> ids[2] = {sensor_params(Sensor::kAccel), sensor_params(Sensor::kGyro)};
  Pass1 p1 = run_pass1(src, p0, o, ids, true, shift, words == nullptr);
  std::vector<Block>& blocks = p1.blocks;
  R.n_used = p1.n_used;
  R.n_blocks = static_cast<int>(blocks.size());
  R.n_units = p1.n_units;

  // ---- Noise: pooled Allan variance of static blocks, IEEE 952 terms per axis.
  for (int a = 0; a < kNumAxes; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    R.allan[ua] = p1.allan[ua].points();
    if (R.allan[ua].size() >= 2) {
      R.noise[ua] = fit_noise_terms(R.allan[ua]);
    } else {
      // No static record: white noise from first differences within blocks.
      const double var = p1.ndz > 0 ? p1.dz2[ua] / (2.0 * static_cast<double>(p1.ndz)) : 0.0;
      R.noise[ua].terms.N = std::sqrt(var / p0.fs);
    }
  }
  if (words)
    R.stuck_bits = *words;
  else
    for (int a = 0; a < kNumAxes; ++a) R.stuck_bits[static_cast<std::size_t>(a)] = p1.bits[static_cast<std::size_t>(a)].finish();
  for (int a = 0; a < kNumAxes; ++a)
    R.temp_motion[static_cast<std::size_t>(a)] = compare_temp_motion(p1.allan_moving[static_cast<std::size_t>(a)].points(),
                                                                      p1.allan_holding[static_cast<std::size_t>(a)].points(), o);
  bool any_static = false;
  for (int a = 0; a < kNumAxes; ++a) any_static |= R.allan[static_cast<std::size_t>(a)].size() >= 2;
  if (!any_static)
    R.warnings.push_back("no static record long enough for an Allan deviation: the noise floor comes from sample-to-sample "
                         "differences and ignores correlated noise, so significance may be overstated");
  // The stochastic model carried into the likelihood (noise_model.h): white + quantization + Gauss-Markov +
  // rate random walk, fitted to the static Allan curve before any deterministic effect is looked at.
  const double D_log = std::max(R.duration_s, 1e-9);
  std::array<StochasticModel, kNumAxes> verdict_stoch;
  for (int a = 0; a < kNumAxes; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    StochasticModel m = R.allan[ua].size() >= 2 ? fit_stochastic_model(R.allan[ua], D_log) : StochasticModel{};
    // Never below the white level implied by the data's sample-to-sample scatter (guards a degenerate fit).
    if (p1.ndz > 0) {
      const double wvar = 0.5 * p1.dz2[ua] / (2.0 * static_cast<double>(p1.ndz));
      m.N = std::max(m.N, std::sqrt(wvar / p0.fs));
    }
    m.N = std::max(m.N, 1e-300);
    // A quantised output: the noise ahead of the quantiser (from the output's white level) sets how much
    // rounding bias each static mean keeps (noise_model.h, output_step).
    if (p0.out_step[ua] > 0) {
      R.quant[ua].step = p0.out_step[ua];
      R.quant[ua].noise_sigma = quantizer_input_sigma(R.quant[ua].step, m.N * m.N * p0.fs);
      m.seg_bias_var = quantization_mean_bias_var(R.quant[ua].step, R.quant[ua].noise_sigma);
    }
    // The held-out verdict's noise: the whole log's wander where diagnose() found the dwells' too low (point
    // and likelihood level alike); the selection's likelihood keeps the dwells' (R.stoch).
    StochasticModel mv = m;
    if (std::isfinite(o.wander_B[ua]) && !m.bank_tau_s.empty()) {
      const double unit = flicker_B_of_sigma(1.0, m.bank_tau_s);
      if (unit > 0) {
        mv.bank_sigma = o.wander_B[ua] / unit;
        mv.flicker_B = o.wander_B[ua];
        if (!o.wander_B_floor[ua]) {
          mv.bank_sigma_lik = mv.bank_sigma;
          mv.flicker_B_upper = o.wander_B[ua];
        }
        R.wander[ua].adopted = true;
        R.wander[ua].kind = "flicker";
        R.wander[ua].value = o.wander_B[ua];
      }
    } else if (std::isfinite(o.wander_K[ua])) {
      mv.K = o.wander_K[ua];
      // The flicker the whole log's walk goes with, where it is below the dwells' (point and likelihood level).
      if (std::isfinite(o.wander_K_B[ua]) && !m.bank_tau_s.empty()) {
        const double unit = flicker_B_of_sigma(1.0, m.bank_tau_s);
        const double s = unit > 0 ? o.wander_K_B[ua] / unit : 0.0;
        if (s < mv.bank_sigma) {
          mv.bank_sigma = s;
          mv.flicker_B = o.wander_K_B[ua];
        }
        if (s < mv.bank_sigma_lik) {
          mv.bank_sigma_lik = s;
          mv.flicker_B_upper = o.wander_K_B[ua];
        }
        R.wander[ua].walk_flicker_B = o.wander_K_B[ua];
      }
      R.wander[ua].adopted = true;
      R.wander[ua].kind = "random_walk";
      R.wander[ua].value = o.wander_K[ua];
    }
    verdict_stoch[ua] = mv;
    R.stoch[ua] = m;
    if (std::getenv("IMUFORGE_DIAG_TRACE"))
      std::fprintf(stderr, "noise %s: N=%.3g Q=%.3g gm=%.3g/%.3gs flickerB=%.3g (upper %.3g) K=%.3g (%d pts)\n", axis_name(a), m.N, m.Q, m.gm_sigma,
                   m.gm_tau_s, m.flicker_B, m.flicker_B_upper, m.K, m.n_points);
    R.rw_prior_var[ua] = m.K * m.K * D_log / 6.0;  // a random walk's offset from its mean over the log
  }
  for (auto& b : blocks) {
    const double tau = static_cast<double>(b.n) / p0.fs;
    for (int a = 0; a < kNumAxes; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      // Marginal variance of a block mean (cells, plots): white part + the whole correlated bias.
      b.v[a] = std::max(block_covariance(R.stoch[ua], b.t, tau, b.t, tau, true, b.t, R.rw_prior_var[ua]), 1e-300);
    }
  }

  if (p1.n_units < 3) {
    // Nothing can be withheld: only the noise analysis stands.
    R.warnings.push_back("only " + std::to_string(p1.n_units) + " segment(s): nothing can be withheld, so no effect can be scored "
                         "(too short to tell); only the Allan-deviation noise analysis is reported");
    for (int a = 0; a < kNumAxes; ++a) {
      const auto u = static_cast<std::size_t>(a);
      R.gap_before.gap[u] = R.gap_before.rms[u] = R.gap_before.floor[u] = R.gap_before.chi2_dof[u] = kNaN;
    }
    R.gap_after = R.gap_before;
    R.cv_mode = "none";
    for (const Block& b : blocks) R.n_static_blocks += b.is_static ? 1 : 0;
    return R;
  }

  // ---- Folds: whole units (contiguous segments), or whole temperature plateaus.
  std::vector<double> plateau_T;
  {
    std::vector<double> Ts;
    for (const auto& b : blocks)
      if (std::isfinite(b.T)) Ts.push_back(b.T);
    std::sort(Ts.begin(), Ts.end());
    for (double T : Ts)
      if (plateau_T.empty() || T - plateau_T.back() > 2.0) plateau_T.push_back(T);
  }
  auto plateau_of = [&](double T) {
    if (!std::isfinite(T) || plateau_T.empty()) return -1;
    int best = 0;
    for (int i = 0; i < static_cast<int>(plateau_T.size()); ++i)
      if (T >= plateau_T[static_cast<std::size_t>(i)] - 1e-9) best = i;
    return best;
  };
  int folds = o.folds;
  R.cv_mode = "segment";
  if (o.cv == "plateau" && plateau_T.size() >= 3) {
    R.cv_mode = "plateau";
    folds = static_cast<int>(plateau_T.size());
    // A unit belongs to the plateau of its first block.
    std::map<int, int> unit_fold;
    for (auto& b : blocks) {
      auto it = unit_fold.find(b.unit);
      if (it == unit_fold.end()) it = unit_fold.emplace(b.unit, std::max(0, plateau_of(b.T))).first;
      b.fold = it->second;
    }
  } else {
    if (o.cv == "plateau") R.warnings.push_back("fewer than 3 temperature plateaus: K-fold by segment used instead");
    folds = std::max(2, std::min(folds, p1.n_units));
    // Not unit mod K (until stop 28): on `varied3` random-1 (60 segments per plateau) that put all three outer-axis
    // sine segments in fold 4, whose fit then had no sine about that axis and extrapolated the gyro timing to them
    // (held-out z 19.6 on gyro.z): a 0.43 ms latency at 17 σ read as in-sample gain only, held-out shrink −89 %.
    for (auto& b : blocks) b.fold = estimator::interleaved_fold(b.unit, folds);
  }
  R.folds = folds;
  if (p1.n_units < 2 * folds || blocks.size() < 10)
    R.warnings.push_back("only " + std::to_string(p1.n_units) + " segments / " + std::to_string(blocks.size()) +
                         " blocks: too short to tell reliably; held-out figures rest on very few withheld segments");

  // ---- Per-axis design.
  std::array<AxisData, kNumAxes> ax;
  const int B = static_cast<int>(blocks.size());
  // Mid time and length of every block (time order): what each GLS whitening run of the block means takes.
  std::vector<double> blk_t(static_cast<std::size_t>(B)), blk_dur(static_cast<std::size_t>(B));
  std::vector<int> blk_seg(static_cast<std::size_t>(B));  // segment of each block: where a per-segment bias restarts
  for (int b = 0; b < B; ++b) blk_seg[static_cast<std::size_t>(b)] = blocks[static_cast<std::size_t>(b)].unit;
  for (int b = 0; b < B; ++b) {
    blk_t[static_cast<std::size_t>(b)] = blocks[static_cast<std::size_t>(b)].t;
    blk_dur[static_cast<std::size_t>(b)] = static_cast<double>(blocks[static_cast<std::size_t>(b)].n) / p0.fs;
  }
  // Rows [z | x_kept | `extra` columns left zero for the caller] of one axis's unwhitened block means.
  auto design_rows = [&](const AxisData& ad, const std::vector<int>& kept, int extra) {
    const int P = static_cast<int>(kept.size());
    Eigen::MatrixXd rows = Eigen::MatrixXd::Zero(B, 1 + P + extra);
    for (int b = 0; b < B; ++b) {
      rows(b, 0) = ad.zr[b];
      for (int i = 0; i < P; ++i) rows(b, 1 + i) = ad.Xr(b, kept[static_cast<std::size_t>(i)]);
    }
    return rows;
  };
  // GLS of one axis under the likelihood's noise model (the flicker at its upper confidence limit).
  auto whiten_axis = [&](AxisData& ad, const StochasticModel& sm, double rw0_override = -1.0) {
    const int a = ad.axis;
    const int P = static_cast<int>(ad.Xr.cols());  // cols and the profile's grid columns
    ad.ne.reset(folds, P);
    // GLS: whiten the block means, in time order over the whole log, by the Kalman filter over the
    // correlated bias states. The bias wander is one process across segments: flicker states of hours
    // carry from one pose to the next, so a pose's offset is judged against its neighbours', not as a
    // fresh random bias per segment (which would hide every pose-dependent effect in short dwells).
    // Whitened rows of one filter run cannot simply be left out by fold (the filter used the withheld blocks
    // to predict the others; without them, e.g. the first block's absolute information on the bias is
    // gone), so each fold's training sums come from their own run that treats the fold's blocks as missing:
    // fit_axis on "all but fold k" (H − Hk[k]) is then the exact GLS fit on the training blocks.
    {
      std::vector<int> all(static_cast<std::size_t>(P));
      for (int i = 0; i < P; ++i) all[static_cast<std::size_t>(i)] = i;
      const Eigen::MatrixXd rows = design_rows(ad, all, 0);
      Eigen::MatrixXd innov;
      Eigen::VectorXd S;
      const double rw0 = rw0_override >= 0 ? rw0_override : R.rw_prior_var[static_cast<std::size_t>(a)];
      estimator::NormalEquations& tot = ad.ne.total;
      tot = gls_normal_equations(sm, blk_t, blk_dur, rows, rw0, &blk_seg, nullptr, nullptr, &innov, &S);
      for (int b = 0; b < B; ++b) {
        ad.z[b] = innov(b, 0);
        ad.X.row(b) = innov.row(b).tail(P);
        ad.v[b] = S[b];
        const auto k = static_cast<std::size_t>(blocks[static_cast<std::size_t>(b)].fold);
        ad.ne.weight[k] += 1.0 / S[b];
        ad.ne.fold[k].n_obs += 1;
      }
      std::vector<char> missing(static_cast<std::size_t>(B));
      for (int k = 0; k < folds; ++k) {
        for (int b = 0; b < B; ++b) missing[static_cast<std::size_t>(b)] = blocks[static_cast<std::size_t>(b)].fold == k;
        const estimator::NormalEquations train = gls_normal_equations(sm, blk_t, blk_dur, rows, rw0, &blk_seg, &missing);
        estimator::NormalEquations& fk = ad.ne.fold[static_cast<std::size_t>(k)];
        fk.info = tot.info - train.info;
        fk.rhs = tot.rhs - train.rhs;
        fk.cost = tot.cost - train.cost;
      }
    }
  };
  // ---- temp_hysteresis's threshold (docs/diagnosis.md § 5, "temp_hysteresis's threshold"). d(t) turns when the
  // die has moved by the threshold from its last extreme, and a sensor's threshold is its own (blindgen's
  // tactical: 0.3 °C; the catalog's default 0.5 °C). Built at the wrong one, the columns miss the blocks between
  // the two turns: varied random-9's tactical accel hysteresis (snr 48) fell to −log10 p 3.6 at 0.5 °C and reads
  // 16 at 0.3 °C. Unless the threshold is given (base model or Options), it is profiled over kHysteresisGrid_C:
  //  - temp_hysteresis a candidate: the axes carry one more column per grid threshold (AxisData::n_grid), and the
  //    candidate is scored at the threshold whose columns explain most against the model it is tested on
  //    (score_one), so a hysteresis masked by other effects at the first step is profiled where it shows. The
  //    choice is paid for in its p-value: × the effective number of distinct tests among the grid's columns (Li &
  //    Ji 2005, from the eigenvalues of their correlation after that model: 1 when they differ only in a block
  //    or two near each turn, the grid's size when unrelated). Selected, its threshold becomes the hysteresis
  //    columns of both sensors (one die, one threshold: set_hysteresis_threshold).
  //  - temp_hysteresis in the base model: chosen once, before the selection, against the base model without it
  //    (summed over the sensors that model it), and the other sensor's candidate pays the same factor.
  R.hysteresis_threshold_C = std::isfinite(o.hysteresis_threshold_C) ? o.hysteresis_threshold_C : model::ThermalConstants{}.hysteresis_threshold_C;
  R.hysteresis_threshold_given = std::isfinite(o.hysteresis_threshold_C);
  double hyst_tests = 1.0;       // the factor on a temp_hysteresis candidate's p-value when the base chose it
  std::vector<int> hyst_grid;    // grid indices of the profile's columns (empty: no profile)
  bool hyst_in_base = false;
  for (ParamId id : base.params) hyst_in_base |= model::param_info(id).effect == Effect::kTempHysteresis;
  {
    bool hyst_sensor[2] = {false, false};
    for (Sensor s : {Sensor::kAccel, Sensor::kGyro}) {
      const int si = static_cast<int>(s);
      for (ParamId id : base.params) hyst_sensor[si] |= model::param_info(id).sensor == s && model::param_info(id).effect == Effect::kTempHysteresis;
      for (const auto& c : (o.candidates.empty() ? std::vector<std::pair<Sensor, Effect>>{{s, Effect::kTempHysteresis}} : o.candidates))
        hyst_sensor[si] |= c.first == s && c.second == Effect::kTempHysteresis;
    }
    std::vector<int> live;  // grid thresholds at which d moves at all
    for (int k = 0; k < kHysteresisGrid; ++k) {
      bool moves = false;
      for (const Block& b : blocks) moves = moves || b.d_grid[static_cast<std::size_t>(k)] != blocks.front().d_grid[static_cast<std::size_t>(k)];
      if (moves) live.push_back(k);
    }
    if (!R.hysteresis_threshold_given && (hyst_sensor[0] || hyst_sensor[1]) && !live.empty()) hyst_grid = live;
  }

  for (int a = 0; a < kNumAxes; ++a) {
    AxisData& ad = ax[static_cast<std::size_t>(a)];
    ad.axis = a;
    ad.sensor = a < 3 ? Sensor::kAccel : Sensor::kGyro;
    const int s = a / 3, j = a % 3;
    std::vector<int> src_cols;
    for (int i = 0; i < static_cast<int>(ids[s].size()); ++i) {
      const auto& pi = model::param_info(ids[s][static_cast<std::size_t>(i)]);
      if (pi.j == j || pi.j < 0) {
        ad.cols.push_back(pi.id);
        src_cols.push_back(i);
      }
    }
    const int P = static_cast<int>(ad.cols.size());
    for (int c = 0; c < P; ++c)
      if (model::param_info(ad.cols[static_cast<std::size_t>(c)]).effect == Effect::kTempHysteresis) {
        ad.h_col = c;
        ad.h_id = ad.cols[static_cast<std::size_t>(c)];
      }
    ad.n_grid = ad.h_col >= 0 ? static_cast<int>(hyst_grid.size()) : 0;
    ad.X.resize(B, P + ad.n_grid);
    ad.z.resize(B);
    ad.v.resize(B);
    ad.ne.reset(folds, P + ad.n_grid);
    for (int b = 0; b < B; ++b) {
      const Block& bl = blocks[static_cast<std::size_t>(b)];
      for (int c = 0; c < P; ++c) ad.X(b, c) = bl.J[s](j, src_cols[static_cast<std::size_t>(c)]);
      for (int k = 0; k < ad.n_grid; ++k) ad.X(b, P + k) = bl.d_grid[static_cast<std::size_t>(hyst_grid[static_cast<std::size_t>(k)])];
      ad.z[b] = bl.z[a];
      ad.v[b] = bl.v[a];
    }
    ad.Xr = ad.X;
    ad.zr = ad.z;
    ad.vr = ad.v;
    whiten_axis(ad, R.stoch[static_cast<std::size_t>(a)]);
    // The folds were set as complements of exact training runs (above), not summed rows: no finish().
  }

  // ---- The same design aggregated per segment (unit): the gap is scored on withheld whole segments, whose
  // means carry every steady effect with far fewer noise degrees of freedom than blocks.
  std::vector<double> seg_t, seg_dur;  // per segment (time order): mid time, length (s)
  std::vector<int> seg_fold;
  // models: the noise of each axis the segment-mean variances are judged against.
  auto build_axu = [&](const std::array<StochasticModel, kNumAxes>& models, const std::array<double, kNumAxes>& rw0,
                       std::array<AxisData, kNumAxes>& axu) {
    std::map<int, std::vector<int>> unit_blocks;
    for (int b = 0; b < B; ++b) unit_blocks[blocks[static_cast<std::size_t>(b)].unit].push_back(b);
    const int U = static_cast<int>(unit_blocks.size());
    for (int a = 0; a < kNumAxes; ++a) {
      const AxisData& ad = ax[static_cast<std::size_t>(a)];
      AxisData& au = axu[static_cast<std::size_t>(a)];
      au.axis = a;
      au.sensor = ad.sensor;
      au.cols = ad.cols;
      au.n_grid = ad.n_grid;
      au.h_id = ad.h_id;
      au.h_col = ad.h_col;
      const int P = static_cast<int>(ad.Xr.cols());
      au.X = Eigen::MatrixXd::Zero(U, P);
      au.z = Eigen::VectorXd::Zero(U);
      au.v = Eigen::VectorXd::Zero(U);
      au.ne.reset(folds, P);
      int u = 0;
      for (const auto& [unit_id, bl] : unit_blocks) {
        double n = 0;
        for (int b : bl) {
          const double nb = static_cast<double>(blocks[static_cast<std::size_t>(b)].n);
          au.X.row(u) += nb * ad.Xr.row(b);
          au.z[u] += nb * ad.zr[b];
          n += nb;
        }
        au.X.row(u) /= n;
        au.z[u] /= n;
        // Variance of the segment mean under the stochastic model (correlated bias included).
        double var = 0;
        const double t_start = blocks[static_cast<std::size_t>(bl.front())].t;
        for (int b : bl)
          for (int b2 : bl) {
            const Block& x1 = blocks[static_cast<std::size_t>(b)];
            const Block& x2 = blocks[static_cast<std::size_t>(b2)];
            var += static_cast<double>(x1.n) * static_cast<double>(x2.n) / (n * n) *
                   block_covariance(models[static_cast<std::size_t>(a)], x1.t, static_cast<double>(x1.n) / p0.fs, x2.t,
                                    static_cast<double>(x2.n) / p0.fs, b == b2, t_start, rw0[static_cast<std::size_t>(a)]);
          }
        au.v[u] = std::max(var, 1e-300);
        if (a == 0 && seg_t.size() < static_cast<std::size_t>(U)) {
          // Segment as one block for the whitened held-out score: mid time weighted by samples, its length.
          double tw = 0;
          for (int b : bl) tw += static_cast<double>(blocks[static_cast<std::size_t>(b)].n) * blocks[static_cast<std::size_t>(b)].t;
          seg_t.push_back(tw / n);
          seg_dur.push_back(n / p0.fs);
          seg_fold.push_back(blocks[static_cast<std::size_t>(bl.front())].fold);
        }
        au.ne.add_row(blocks[static_cast<std::size_t>(bl.front())].fold, au.X.row(u).transpose(), au.z[u], 1.0 / au.v[u]);
        ++u;
      }
      au.ne.finish();
    }
  };
  std::array<AxisData, kNumAxes> axu, axv;
  build_axu(R.stoch, R.rw_prior_var, axu);
  // The verdict's segment-mean variances (reported gaps, the unexplained test): the whole log's wander where
  // adopted (Options::wander_B/K), else the same as the selection's.
  bool any_wander = false;
  std::array<double, kNumAxes> rw0_v = R.rw_prior_var;
  for (int a = 0; a < kNumAxes; ++a)
    if (R.wander[static_cast<std::size_t>(a)].adopted) {
      any_wander = true;
      rw0_v[static_cast<std::size_t>(a)] = verdict_stoch[static_cast<std::size_t>(a)].K * verdict_stoch[static_cast<std::size_t>(a)].K * D_log / 6.0;
    }
  if (any_wander) build_axu(verdict_stoch, rw0_v, axv);
  const std::array<AxisData, kNumAxes>& axg = any_wander ? axv : axu;
  // The blocks whitened under the verdict's noise where the whole log's wander is adopted: the fits whose
  // withheld residuals are whitened under it (gap_verdict) must know it too, or each fold's fit follows the wander
  // its own way and the residual series jumps from one fold's segment to the next's.
  std::array<AxisData, kNumAxes> axw;
  for (int a = 0; a < kNumAxes; ++a)
    if (R.wander[static_cast<std::size_t>(a)].adopted) {
      axw[static_cast<std::size_t>(a)] = ax[static_cast<std::size_t>(a)];
      whiten_axis(axw[static_cast<std::size_t>(a)], verdict_stoch[static_cast<std::size_t>(a)], rw0_v[static_cast<std::size_t>(a)]);
    }

  // ---- The model as a set of parameter ids per sensor.
  std::set<ParamId> model_ids(base.params.begin(), base.params.end());
  std::set<std::pair<int, int>> in_model;  // (sensor, effect)
  for (ParamId id : base.params) {
    const auto& pi = model::param_info(id);
    in_model.insert({static_cast<int>(pi.sensor), static_cast<int>(pi.effect)});
  }
  std::vector<std::pair<Sensor, Effect>> candidates = o.candidates;
  if (candidates.empty()) {
    for (const auto& e : model::effects()) {
      if (e.kind != model::EffectKind::kDeterministic) continue;
      for (Sensor s : {Sensor::kAccel, Sensor::kGyro}) {
        if (!(e.sensors & (s == Sensor::kAccel ? model::kMaskAccel : model::kMaskGyro))) continue;
        if (in_model.count({static_cast<int>(s), static_cast<int>(e.effect)})) continue;
        candidates.push_back({s, e.effect});
      }
    }
  }
  candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                  [&](const std::pair<Sensor, Effect>& c) {
                                    return std::find(o.excluded.begin(), o.excluded.end(), c) != o.excluded.end();
                                  }),
                   candidates.end());
  // Base parameters the campaign cannot determine.
  for (int a = 0; a < kNumAxes; ++a) {
    Fit f = fit_axis(ax[static_cast<std::size_t>(a)], cols_for(ax[static_cast<std::size_t>(a)], model_ids), -1);
    for (int c : f.dropped)
      R.warnings.push_back("model parameter " + model::param_info(ax[static_cast<std::size_t>(a)].cols[static_cast<std::size_t>(c)]).name +
                           " is not excited by this campaign (left at zero)");
  }

  // ---- The rate table's axis errors (Options::table; docs/diagnosis.md, "Fixture errors"), with the base model:
  // GLS per axis under its noise model, the base parameters of each axis eliminated by their Schur complement,
  // the errors shared by the six axes (as the mount rotation below). A prior of fixture_prior_rad on each whole
  // error (the one evaluated at + this correction) holds what the campaign cannot separate from the base model.
  // First estimated before any selection, on purpose: a sensor effect selected first takes the part of the errors'
  // signature it can (the accelerometer of a null sensor on campaign-eol read them as scale_asymmetry and
  // size_effect), while the errors, rotations of the reference that depend on the pose through the table's
  // gimbals, take less of a sensor effect's. The re-run then tests every candidate on the re-evaluated reference,
  // and once the reference is re-evaluated the correction is estimated again jointly with the model that run
  // selected (below, before the mount rotation): what the base model alone pushed into the errors (the automotive
  // example's eleven effects moved fixture.axis2.tilt_b 4 σ) goes back to the effects it belongs to.
  auto fixture_estimate = [&](const std::set<ParamId>& ids_model) {
    DiagnosisResult::FixtureEstimate fe;
    const TableErrors te(o);
    const int N = te.n();
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(N, N);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(N);
    for (int a = 0; a < kNumAxes; ++a) {
      const auto& ad = ax[static_cast<std::size_t>(a)];
      const Fit f = fit_axis(ad, cols_for(ad, ids_model), -1);
      const int P = static_cast<int>(f.kept.size());
      Eigen::MatrixXd rows = design_rows(ad, f.kept, N);
      for (int b = 0; b < B; ++b) rows.block(b, 1 + P, 1, N) = blocks[static_cast<std::size_t>(b)].D.block(a, 0, 1, N);
      const estimator::NormalEquations ne =
          gls_normal_equations(R.stoch[static_cast<std::size_t>(a)], blk_t, blk_dur, rows, R.rw_prior_var[static_cast<std::size_t>(a)], &blk_seg);
      // The base model's reduced χ² above 1 scales the errors' information down (a sensor effect the base model
      // lacks is then not read as a confident table error).
      const double s2 = std::max(1.0, f.rss / std::max(1.0, static_cast<double>(B - P)));
      Eigen::MatrixXd Hdd = ne.info.bottomRightCorner(N, N);
      Eigen::VectorXd gd = ne.rhs.tail(N);
      if (P > 0) {
        const Eigen::MatrixXd Htd = ne.info.topRightCorner(P, N);
        const Eigen::LDLT<Eigen::MatrixXd> l(ne.info.topLeftCorner(P, P));
        Hdd -= Htd.transpose() * l.solve(Htd);
        gd -= Htd.transpose() * l.solve(ne.rhs.head(P));
      }
      H += Hdd / s2;
      g += gd / s2;
    }
    Eigen::VectorXd e0(N);
    for (int m = 0; m < N; ++m) e0[m] = o.fixture_error[static_cast<std::size_t>(m / 3)].part(m % 3);
    const double ip = 1.0 / (o.fixture_prior_rad * o.fixture_prior_rad);
    const Eigen::MatrixXd Hp = H + ip * Eigen::MatrixXd::Identity(N, N);
    const Eigen::LDLT<Eigen::MatrixXd> l(Hp);
    const Eigen::VectorXd d = l.solve(g - ip * e0);
    fe.n = N;
    if (d.allFinite() && l.info() == Eigen::Success) {
      const Eigen::MatrixXd C = l.solve(Eigen::MatrixXd::Identity(N, N));
      fe.valid = true;
      for (int m = 0; m < N; ++m) {
        fe.delta_rad[static_cast<std::size_t>(m)] = d[m];
        fe.sigma_rad[static_cast<std::size_t>(m)] = std::sqrt(std::max(C(m, m), 0.0));
      }
      fe.chi2 = d.dot(H * d);
    }
    return fe;
  };
  // fixture_src.active(): the reference is re-evaluated at some error already.
  if (o.table.known && !fixture_src.active()) R.fixture_est = fixture_estimate(model_ids);

  // Held-out gap of a model on withheld segments. gap_verdict: against the verdict's variances (whole-log
  // wander where adopted), what is reported and what the unexplained claim is judged on. gap_of: against the
  // dwells' noise, which the selection and its backward steps judge on, so a raised wander never adds an
  // effect that the dwells' noise would not. The unexplained check that withdraws effects judges an axis by the
  // verdict's rule (`over`, with the GLS fit under an adopted wander), so it never withdraws an effect for an
  // axis the verdict then calls at noise.
  auto gap_on = [&](const std::array<AxisData, kNumAxes>& segs, const std::set<ParamId>& ids_model) {
    Gap g;
    for (int a = 0; a < kNumAxes; ++a) {
      const auto& ad = ax[static_cast<std::size_t>(a)];
      HeldOut h = heldout_axis(ad, segs[static_cast<std::size_t>(a)], cols_for(ad, ids_model), folds);
      g.gap[static_cast<std::size_t>(a)] = h.gap();
      g.rms[static_cast<std::size_t>(a)] = h.rms();
      g.floor[static_cast<std::size_t>(a)] = h.floor();
      g.chi2_dof[static_cast<std::size_t>(a)] = h.nb ? (o.heldout_predictive ? h.chi2_pred : h.chi2) / h.nb : 0.0;
    }
    return g;
  };
  // The same against the selection's (the dwells') noise: which selected effects the withdrawal keeps.
  auto gap_of = [&](const std::set<ParamId>& ids_model) { return gap_on(axu, ids_model); };
  auto pos = [](double x) { return std::max(x, 0.0); };
  // Held-out χ² of the withheld segment means, WHITENED in time order under the stochastic model: each
  // segment's held-out residual (its fold's fit) is judged against what the residuals of the segments before
  // it predict through the correlated bias states (Kalman innovation), not against its marginal variance.
  // A slow drift is shared by neighbouring segments of different folds (folds interleave segments in time):
  // with marginal variances, any smooth regressor (Ṫ, the hysteresis branch, the temperature history) fitted
  // on the training segments follows the drift and "predicts" the withheld ones, a held-out gain that is only
  // the drift's autocorrelation. Whitened, that part of the residual is already predicted by the noise model,
  // so the gain counts only what the drift cannot explain; under the model, E[χ²] = number of segments.
  auto heldout_white = [&](int a, const std::vector<int>& sel) {
    const auto& ad = ax[static_cast<std::size_t>(a)];
    const auto& au = axu[static_cast<std::size_t>(a)];
    const int U = static_cast<int>(au.z.size());
    Eigen::MatrixXd r = Eigen::MatrixXd::Zero(U, 1);
    for (int k = 0; k < folds; ++k) {
      if (au.ne.fold[static_cast<std::size_t>(k)].n_obs == 0) continue;
      const Fit f = fit_axis(ad, sel, k);
      const int p = static_cast<int>(f.kept.size());
      for (int u = 0; u < U; ++u) {
        if (seg_fold[static_cast<std::size_t>(u)] != k) continue;
        double pred = 0;
        for (int i = 0; i < p; ++i) pred += au.X(u, f.kept[static_cast<std::size_t>(i)]) * f.theta[i];
        r(u, 0) = au.z[u] - pred;
      }
    }
    Eigen::MatrixXd nu(U, 1);
    Eigen::VectorXd S(U);
    whiten_segment(R.stoch[static_cast<std::size_t>(a)], seg_t, seg_dur, r, R.rw_prior_var[static_cast<std::size_t>(a)], nu, S);
    double chi2 = 0;
    for (int u = 0; u < U; ++u) chi2 += nu(u, 0) * nu(u, 0) / S[u];
    return std::make_pair(chi2, U);
  };

  // The verdict's gap. On an axis whose whole-log wander is adopted, also the GLS χ²/dof of the model's fit under
  // that wander (the blocks' Kalman innovations, axw): the segment means share one slow bias, so their marginal
  // held-out χ² has only a few effective degrees of freedom (a random walk's first Karhunen-Loève mode carries
  // 61 % of its variance: Σ r²/σ² exceeds 3 per dof in about 6 % of logs with nothing beyond the model), while
  // the innovations are independent under the noise model. The unexplained claim needs both (`over`): an axis
  // the adoption calls stationary wander is not also called a signal unless the wander cannot whiten it.
  // Held-out innovations were tried first: the folds' fits differ by their share of the wander, and whitening
  // turns those offsets between neighbouring segments of different folds into innovations (stoch-consumer-24
  // accel.z: 5.2 on the dwells' fits, 8.1 on fits under the wander, 0.86 in-sample).
  // The χ²/dof of a model's fit to an axis's blocks as whitened in `ad` (under an adopted wander, axw, or the one an
  // axis would carry: the unexplained check); NaN without a degree of freedom.
  auto gls_chi2_dof = [&](const AxisData& ad, const std::set<ParamId>& ids_model) {
    const Fit f = fit_axis(ad, cols_for(ad, ids_model), -1);
    const double dof = static_cast<double>(ad.z.size()) - static_cast<double>(f.kept.size());
    return dof > 0 ? f.rss / dof : std::numeric_limits<double>::quiet_NaN();
  };
  // The GLS χ²/dof under the adopted wander (axw), per axis where it is adopted, added to a gap.
  auto add_wander_chi2 = [&](Gap g, const std::set<ParamId>& ids_model) {
    for (int a = 0; a < kNumAxes; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      if (!R.wander[ua].adopted) continue;
      const double c = gls_chi2_dof(axw[ua], ids_model);
      if (std::isfinite(c)) g.chi2_dof_wander[ua] = c;
    }
    return g;
  };
  auto gap_verdict = [&](const std::set<ParamId>& ids_model) { return add_wander_chi2(gap_on(axg, ids_model), ids_model); };

  // ---- The threshold profile's helpers (temp_hysteresis; see the threshold's comment above).
  // Catalog id of column c of an axis: a grid column stands for the axis's hysteresis parameter.
  auto param_of = [](const AxisData& ad, int c) { return c < static_cast<int>(ad.cols.size()) ? ad.cols[static_cast<std::size_t>(c)] : ad.h_id; };
  auto hysteresis_in = [](const std::set<ParamId>& ids_model) {
    for (Sensor s : {Sensor::kAccel, Sensor::kGyro})
      for (ParamId id : model::effect_params(s, Effect::kTempHysteresis))
        if (ids_model.count(id)) return true;
    return false;
  };
  // The columns of `cur` plus a candidate's: its own, or, for temp_hysteresis at grid position gk ≥ 0, that grid
  // column in place of the hysteresis column.
  auto candidate_cols = [&](const AxisData& ad, const std::set<ParamId>& ids_model, const std::vector<ParamId>& eids, int gk) {
    if (gk < 0 || ad.n_grid == 0) return cols_for(ad, ids_model, eids);
    std::vector<int> sel = cols_for(ad, ids_model);
    sel.push_back(static_cast<int>(ad.cols.size()) + gk);
    return sel;
  };
  int hyst_cur = -1;  // grid position the hysteresis columns hold (−1: R.hysteresis_threshold_C as given/default)
  struct HysteresisChoice {
    int gk = -1;
    double tests = 1.0;
    std::vector<std::pair<double, double>> profile;
  };
  // The grid threshold whose column explains most on the sensor's axes against `cur` (GLS likelihood ratio, each
  // axis in units of its own misfit under `cur`), and the effective number of distinct tests among the grid's
  // columns after `cur`. O(axes · K · fit).
  auto choose_hysteresis_threshold = [&](const std::set<ParamId>& ids_model, const std::vector<Sensor>& sensors) {
    HysteresisChoice hc;
    const int K = static_cast<int>(hyst_grid.size());
    Eigen::VectorXd lr_k = Eigen::VectorXd::Zero(K);
    Eigen::MatrixXd S_sum = Eigen::MatrixXd::Zero(K, K);
    for (int a = 0; a < kNumAxes; ++a) {
      const AxisData& ad = ax[static_cast<std::size_t>(a)];
      if (ad.n_grid != K || std::find(sensors.begin(), sensors.end(), ad.sensor) == sensors.end()) continue;
      const int P = static_cast<int>(ad.cols.size());
      const Fit fc = fit_axis(ad, cols_for(ad, ids_model), -1);
      const int nk = static_cast<int>(fc.kept.size());
      const double s2 = std::max(1.0, fc.rss / std::max(1, static_cast<int>(ad.ne.total.n_obs) - nk));
      for (int k = 0; k < K; ++k) {
        std::vector<int> sel = fc.kept;
        sel.push_back(P + k);
        const Fit fk = fit_axis(ad, sel, -1);
        if (static_cast<int>(fk.kept.size()) > nk) lr_k[k] += std::max(fc.rss - fk.rss, 0.0) / s2;
      }
      // Information of the grid columns left after `cur` (Schur complement): their correlation.
      const Eigen::MatrixXd& H = ad.ne.total.info;
      Eigen::MatrixXd Hb(nk, nk), Hbd(nk, K);
      for (int i = 0; i < nk; ++i) {
        for (int i2 = 0; i2 < nk; ++i2) Hb(i, i2) = H(fc.kept[static_cast<std::size_t>(i)], fc.kept[static_cast<std::size_t>(i2)]);
        for (int k = 0; k < K; ++k) Hbd(i, k) = H(fc.kept[static_cast<std::size_t>(i)], P + k);
      }
      Eigen::MatrixXd Sk = H.block(P, P, K, K);
      if (nk > 0) Sk -= Hbd.transpose() * Hb.ldlt().solve(Hbd);
      if (Sk.allFinite()) S_sum += Sk / s2;
    }
    int kd = -1;  // the catalog's default among the columns
    for (int k = 0; k < K; ++k) {
      const double thr = kHysteresisGrid_C[static_cast<std::size_t>(hyst_grid[static_cast<std::size_t>(k)])];
      hc.profile.push_back({thr, lr_k[k]});
      if (S_sum(k, k) > 0 && (hc.gk < 0 || lr_k[k] > lr_k[hc.gk])) hc.gk = k;
      if (S_sum(k, k) > 0 && thr == model::ThermalConstants{}.hysteresis_threshold_C) kd = k;
    }
    if (kd >= 0 && hc.gk >= 0 && lr_k[hc.gk] - lr_k[kd] < kHysteresisDefaultMargin) hc.gk = kd;
    hc.tests = effective_tests(S_sum);
    return hc;
  };
  // Makes grid position gk the hysteresis columns of every axis (fits, held-out sets, blocks): a column copy in
  // the whitened design and its normal equations, exact because whitening acts on each column alone.
  auto set_hysteresis_threshold = [&](int gk) {
    if (gk < 0 || gk == hyst_cur) return;
    auto copy_col = [](estimator::NormalEquations& ne, int h, int g) {
      Eigen::VectorXd r = ne.info.row(g).transpose();
      r[h] = ne.info(g, g);
      ne.info.row(h) = r.transpose();
      ne.info.col(h) = r;
      ne.rhs[h] = ne.rhs[g];
    };
    for (auto* set : {&ax, &axu, &axv, &axw})
      for (AxisData& ad : *set) {
        if (ad.n_grid == 0 || ad.h_col < 0) continue;
        const int h = ad.h_col, g = static_cast<int>(ad.cols.size()) + gk;
        if (ad.X.cols() > g) ad.X.col(h) = ad.X.col(g);
        if (ad.Xr.cols() > g) ad.Xr.col(h) = ad.Xr.col(g);
        if (ad.ne.total.size() > g) copy_col(ad.ne.total, h, g);
        for (auto& f : ad.ne.fold)
          if (f.size() > g) copy_col(f, h, g);
      }
    const int kb = hyst_grid[static_cast<std::size_t>(gk)];
    for (Block& bl : blocks) bl.d = bl.d_grid[static_cast<std::size_t>(kb)];
    R.hysteresis_threshold_C = kHysteresisGrid_C[static_cast<std::size_t>(kb)];
    hyst_cur = gk;
  };
  auto grid_position = [&](double thr_C) {
    for (int k = 0; k < static_cast<int>(hyst_grid.size()); ++k)
      if (kHysteresisGrid_C[static_cast<std::size_t>(hyst_grid[static_cast<std::size_t>(k)])] == thr_C) return k;
    return -1;
  };
  // temp_hysteresis in the base model: its threshold is chosen once, against the base model without it, on the
  // sensors that model it; the other sensor's candidate is scored at it and pays the choice's factor.
  if (hyst_in_base && !hyst_grid.empty()) {
    std::set<ParamId> without = model_ids;
    std::vector<Sensor> modelled;
    for (Sensor s : {Sensor::kAccel, Sensor::kGyro})
      for (ParamId id : model::effect_params(s, Effect::kTempHysteresis))
        if (without.erase(id) && std::find(modelled.begin(), modelled.end(), s) == modelled.end()) modelled.push_back(s);
    const HysteresisChoice hc = choose_hysteresis_threshold(without, modelled);
    if (hc.gk >= 0) {
      set_hysteresis_threshold(hc.gk);
      hyst_tests = hc.tests;
      R.hysteresis_effective_tests = hc.tests;
      R.hysteresis_profile = hc.profile;
    }
  }

  // Compares model `cur` with `cur ∪ effect (s, e)` (forward) and returns the score of the effect.
  // Per axis: admitted new columns (rank check), GLS likelihood ratio on the whitened blocks, held-out χ²
  // and gap on withheld segments, magnitudes with σ.
  auto score_one = [&](const std::set<ParamId>& cur, Sensor s, Effect e) {
    CandidateScore cs;
    cs.effect = model::effect_info(e).name;
    cs.sensor = model::sensor_name(s);
    const std::vector<ParamId>& eids = candidate_params(s, e);
    double lr = 0, excess_cur = 0, ho_gain = 0;
    int dof = 0, n_obs = 0;
    std::vector<int> mag_axis;  // the axis of each entry of mags
    std::array<double, kNumAxes> s2_axis;
    s2_axis.fill(1.0);
    const int a0 = s == Sensor::kAccel ? 0 : 3;
    std::vector<ParamEstimate> mags;
    // temp_hysteresis with its threshold free (no hysteresis in `cur`): scored at the grid threshold whose columns
    // explain most against `cur`, the choice paid for in the p-value (see the threshold's comment above).
    int gk = -1;
    double tests = e == Effect::kTempHysteresis ? hyst_tests : 1.0;
    if (e == Effect::kTempHysteresis) {
      cs.hysteresis_threshold_C = R.hysteresis_threshold_C;
      if (!hyst_grid.empty() && !hysteresis_in(cur)) {
        const HysteresisChoice hc = choose_hysteresis_threshold(cur, {s});
        gk = hc.gk;
        tests = hc.tests;
        cs.hysteresis_profile = hc.profile;
        if (gk >= 0) cs.hysteresis_threshold_C = kHysteresisGrid_C[static_cast<std::size_t>(hyst_grid[static_cast<std::size_t>(gk)])];
      }
      cs.hysteresis_tests = tests;
    }
    for (int a = a0; a < a0 + 3; ++a) {
      const auto& ad = ax[static_cast<std::size_t>(a)];
      const std::vector<int> sel0 = cols_for(ad, cur);
      const std::vector<int> sel = candidate_cols(ad, cur, eids, gk);
      Fit fc = fit_axis(ad, sel0, -1);
      Fit fa = fit_axis(ad, sel, -1);
      const int extra = static_cast<int>(fa.kept.size()) - static_cast<int>(fc.kept.size());
      for (int c : fa.dropped)
        if (!cur.count(param_of(ad, c)))
          cs.not_excitable.push_back(model::param_info(param_of(ad, c)).name + "@" + axis_name(a));
      if (extra <= 0) continue;
      dof += extra;
      n_obs += static_cast<int>(ad.ne.total.n_obs);
      HeldOut ha = heldout_axis(ad, axu[static_cast<std::size_t>(a)], sel, folds);
      HeldOut hc = heldout_axis(ad, axu[static_cast<std::size_t>(a)], sel0, folds);
      // Robustness against a noise floor the data exceed, PER AXIS: the LR of this axis is scaled by its own
      // augmented fit's reduced χ² when > 1. The in-sample excess counts within-segment structure (transients
      // at pose changes read at a slightly wrong time) that the segment-level held-out score averages out, so
      // the scale is capped at the axis's augmented held-out χ²/dof, the misfit the selection is judged on.
      // Per axis, because one axis far above its noise (an out-of-catalog bias: χ²/dof 10³) must not scale
      // away the evidence of a real effect on the sensor's other axes.
      const double s2_in = fa.rss / std::max(1, static_cast<int>(ad.ne.total.n_obs) - static_cast<int>(fa.kept.size()));
      const double s2_ho = ha.nb > 0 ? ha.chi2 / ha.nb : s2_in;
      s2_axis[static_cast<std::size_t>(a)] = std::max(1.0, std::min(s2_in, s2_ho));
      lr += (fc.rss - fa.rss) / s2_axis[static_cast<std::size_t>(a)];
      // The drop of the held-out χ², predictive (Options::heldout_gain_predictive: a fold fit's extrapolation is
      // judged against its own uncertainty, so an effect the campaign pins down loosely in one fold earns nothing
      // there rather than losing hundreds) or plain (noise variance only). An axis the augmented model leaves
      // unexplained (held-out χ²/dof above unexplained_chi2_dof) counts in units of that misfit: summed raw,
      // one axis far above its noise (an out-of-catalog bias at χ²/dof 10³) outweighs the sensor's other axes,
      // and a real effect whose fold fits mispredict that axis by a few per cent of its excess lost a gain of
      // hundreds of noise variances on the axes it explains. An axis the effect brings below the threshold
      // keeps its whole gain; so does one a little above its noise (1.5–2 from transients at the steps of a
      // short log), where dividing lost a true misalign_temp (smoke random-104: gain 33 for 36 needed).
      double s2_g = 1.0;
      double gain_a = 0, exc_a = 0;
      if (o.whiten_heldout) {
        const auto wa = heldout_white(a, sel), wc = heldout_white(a, sel0);
        gain_a = wc.first - wa.first;
        exc_a = pos(wc.first - wc.second);
        s2_g = wa.second > 0 ? wa.first / wa.second : 1.0;
      } else if (e == Effect::kTiming && o.timing_heldout_blocks) {
        // Timing is judged on the withheld segments' BLOCKS (their GLS innovations given the training blocks),
        // not on the segments' means. Its regressor is u̇, whose mean over a segment is (u_end − u_start) / T:
        // on a sine, a tumble or a rate run between steps (the samples at the steps are left out) it averages
        // to nothing, so the segment means cannot see a latency the blocks within the segment show at thousands
        // of σ (varied5 random-2: a 0.49 ms gyro latency at 100 Hz on six 10 s sines, fitted 0.490 ± 0.012 ms,
        // ΔBIC −6e4, held-out shrink −2 % on segment means: the issue's "timing" contradiction). The folds stay
        // whole segments, so the score is still out of sample.
        // Predictive as the segment means are (Options::heldout_gain_predictive): a per-axis latency that one
        // fold's training segments pin down only as latency + drift · time (one axis sampled at its own instant,
        // unseen11 ooc-axis_skew-0: gyro.z 0.49 ms early, −log10 p 313, its sines in two folds) lost −451 % on the
        // plain χ² of the fold extrapolated to and went unselected, its axis unnamed.
        const HeldOut hba = heldout_axis(ad, ad, sel, folds), hbc = heldout_axis(ad, ad, sel0, folds);
        const double ba = o.heldout_gain_predictive ? hba.chi2_pred : hba.chi2;
        const double bc = o.heldout_gain_predictive ? hbc.chi2_pred : hbc.chi2;
        gain_a = bc - ba;
        exc_a = pos(bc - hbc.nb);
        s2_g = hba.nb > 0 ? ba / hba.nb : 1.0;
      } else {
        const double ca = o.heldout_gain_predictive ? ha.chi2_pred : ha.chi2, cc = o.heldout_gain_predictive ? hc.chi2_pred : hc.chi2;
        gain_a = cc - ca;
        exc_a = pos(cc - hc.nb);
        s2_g = ha.nb > 0 ? ca / ha.nb : 1.0;
      }
      if (!o.heldout_axis_scale || !(s2_g > o.unexplained_chi2_dof)) s2_g = 1.0;
      ho_gain += gain_a / s2_g;
      excess_cur += exc_a / s2_g;
      for (int i = 0; i < static_cast<int>(fa.kept.size()); ++i) {
        const ParamId id = param_of(ad, fa.kept[static_cast<std::size_t>(i)]);
        if (cur.count(id) || std::find(eids.begin(), eids.end(), id) == eids.end()) continue;
        ParamEstimate pe;
        pe.name = model::param_info(id).name;
        pe.axis = axis_name(a);
        pe.value = fa.theta[i];
        pe.sigma = std::sqrt(std::max(fa.cov(i, i), 0.0));
        mags.push_back(pe);
        mag_axis.push_back(a);
      }
    }
    cs.dof = dof;
    if (dof == 0) {
      cs.excitable = false;
      return cs;
    }
    cs.lr = std::max(lr, 0.0);
    cs.p_value = chi2_sf(cs.lr, dof);
    cs.score = -chi2_log10_sf(cs.lr, dof);
    if (tests > 1.0) {  // temp_hysteresis: its threshold was chosen on these data
      cs.p_value = std::min(1.0, cs.p_value * tests);
      cs.score = std::max(0.0, cs.score - std::log10(tests));
    }
    cs.delta_bic = -cs.lr + dof * std::log(std::max(2, n_obs));
    cs.heldout_chi2_gain = ho_gain;
    // Shrink of the held-out χ² excess (withheld segments) of the axes the effect acts on. Axes already at or
    // below their held-out expectation (a noise model that errs conservative, e.g. a bias instability read
    // from a soak a thermal effect moved) have no excess to shrink: a positive held-out gain then counts as
    // all of it, and the gain (> 2·dof) and the significance decide alone.
    cs.heldout_shrink_pct = excess_cur > 0 ? 100.0 * ho_gain / excess_cur : (ho_gain > 0 ? 100.0 : 0.0);
    for (std::size_t k = 0; k < mags.size(); ++k) {
      auto& m = mags[k];
      m.sigma *= std::sqrt(s2_axis[static_cast<std::size_t>(mag_axis[k])]);
      cs.min_detectable.push_back(5.0 * m.sigma);
      const double lim = plausible_limit(model::param_info(model::find_param(m.name)));
      if (o.check_plausibility && std::fabs(m.value) > lim && std::fabs(m.value) > 3.0 * m.sigma)
        cs.implausible.push_back(m.name + "@" + m.axis);
    }
    cs.magnitude = mags;
    return cs;
  };
  // Selection needs significance (Bonferroni over the candidates of the step) AND a material held-out
  // improvement: a χ² gain above twice the added degrees of freedom and a positive shrink of the gap.
  // A magnitude outside the plausible range (docs/error-model.md) disqualifies the candidate (flagged).
  auto qualifies = [&](const CandidateScore& c, double level) {
    return c.excitable && c.p_value < level && c.heldout_chi2_gain > 2.0 * c.dof && c.heldout_shrink_pct >= o.min_shrink_pct;
  };
  // temp_rate is an output offset ∝ Ṫ: the same coefficient on heating and on cooling ramps. A slow bias wander
  // that happens to run along one ramp (the final 20 °C ramp of a blind log is one-way) gives a coefficient on
  // that ramp's sign only. Per axis, the Ṫ column is split by its sign (blocks are cut at 0.5 °C, so one block
  // is on one side), the model refitted by GLS under the likelihood's noise model, and the two coefficients
  // compared (Wald, one dof per axis). Returns the p-value of "equal" (−1: not testable, e.g. one-way only).
  auto heat_cool_p = [&](const std::set<ParamId>& cur, Sensor s) {
    double W = 0;
    int dof = 0;
    const std::vector<ParamId> tr = model::effect_params(s, Effect::kTempRate);
    for (int a = s == Sensor::kAccel ? 0 : 3, e = a + 3; a < e; ++a) {
      const AxisData& ad = ax[static_cast<std::size_t>(a)];
      int c_tr = -1;
      for (int i = 0; i < static_cast<int>(ad.cols.size()); ++i)
        if (std::find(tr.begin(), tr.end(), ad.cols[static_cast<std::size_t>(i)]) != tr.end()) c_tr = i;
      if (c_tr < 0) continue;
      const Fit f0 = fit_axis(ad, cols_for(ad, cur), -1);  // the admitted model columns (rank-checked)
      const int P = static_cast<int>(f0.kept.size());
      Eigen::MatrixXd rows = design_rows(ad, f0.kept, 2);
      double e_pos = 0, e_neg = 0;
      for (int b = 0; b < B; ++b) {
        const double x = ad.Xr(b, c_tr);
        rows(b, P + 1) = std::max(x, 0.0);
        rows(b, P + 2) = std::min(x, 0.0);
        e_pos += x > 0 ? x * x : 0.0;
        e_neg += x < 0 ? x * x : 0.0;
      }
      if (!(e_pos > 0) || !(e_neg > 0)) continue;
      const estimator::NormalEquations ne =
          gls_normal_equations(R.stoch[static_cast<std::size_t>(a)], blk_t, blk_dur, rows, R.rw_prior_var[static_cast<std::size_t>(a)], &blk_seg);
      std::vector<int> cols(static_cast<std::size_t>(P + 2));
      std::iota(cols.begin(), cols.end(), 0);
      const estimator::SubsetFit f = estimator::fit_subset(ne, cols);
      // Positions of the heating and the cooling column among the kept ones (either dropped: not testable).
      const auto ip = std::find(f.kept.begin(), f.kept.end(), P), in = std::find(f.kept.begin(), f.kept.end(), P + 1);
      if (ip == f.kept.end() || in == f.kept.end()) continue;
      const auto kp = static_cast<int>(ip - f.kept.begin()), kn = static_cast<int>(in - f.kept.begin());
      const double d = f.theta[kp] - f.theta[kn];
      const double v = f.cov(kp, kp) + f.cov(kn, kn) - 2.0 * f.cov(kp, kn);
      if (!(v > 0) || !std::isfinite(d)) continue;
      W += d * d / v;
      ++dof;
    }
    return dof > 0 ? chi2_sf(W, dof) : -1.0;
  };
  // Turns of the temperature history the hysteresis column shows: its sign runs over the blocks in time order.
  // With one turn (two runs), hysteresis is one offset between the two stretches of the log, which any slow
  // drift gives as well (varied blind suite: a one-turn schedule under a 60 s Gauss-Markov gyro bias selected
  // gyro.temp_hysteresis at p = 1e-4); two turns make it an alternation, which a drift does not mimic.
  // gk: at grid position gk of the threshold profile (−1: the hysteresis columns as they stand).
  auto hysteresis_runs = [&](int gk) {
    // d is one column for every axis that carries a hysteresis parameter (either sensor's, whichever is a
    // candidate or in the model).
    const AxisData* adp = nullptr;
    for (int a = 0; a < kNumAxes && !adp; ++a)
      if (ax[static_cast<std::size_t>(a)].h_col >= 0) adp = &ax[static_cast<std::size_t>(a)];
    if (!adp) return -1;
    const AxisData& ad = *adp;
    const int c_h = gk >= 0 && ad.n_grid > gk ? static_cast<int>(ad.cols.size()) + gk : ad.h_col;
    int runs = 0, last = 0;
    for (int b = 0; b < B; ++b) {
      const double x = ad.Xr(b, c_h);
      const int sg = x > 0.5 ? 1 : x < -0.5 ? -1 : 0;  // blocks across a turn (mean of d near 0) say nothing
      if (sg != 0 && sg != last) ++runs, last = sg;
    }
    return runs;
  };
  // With one turn, the hysteresis is tested again under the largest bias wander the whole log supports WITHOUT
  // it: per axis of the sensor, the likelier whole-log raise (flicker or random walk; noise_model.h) of the model
  // as it stands, whatever its checks say, then the GLS likelihood ratio of the hysteresis columns under that
  // raise, summed over the axes. A drift that happens to differ between the two stretches is what the raise
  // describes, so its "hysteresis" falls to noise; a real hysteresis is one jump at the turn that a stationary
  // wander cannot make, and stays far above the level. Returns the p-value (−1: nothing to test).
  // The likelier of the two whole-log raises (nullptr: neither improves the likelihood).
  // A line below the likelihood's level (WholeLogWander::below_likelihood) answers no likelihood question: only the
  // final model's verdict floor may take it (below).
  auto raises = [](const WholeLogWander& l) { return l.kind != WholeLogWander::kNone && !l.below_likelihood; };
  auto likelier = [&](const std::array<WholeLogWander, 3>& lines) {
    const WholeLogWander* pick = nullptr;
    for (const auto& l : lines)
      if (raises(l) && (!pick || l.gain > pick->gain)) pick = &l;
    return pick;
  };
  // What a bias wander's spread must not follow (WholeLogWander::hetero_*): per block, the rotation speed and the
  // magnitude of the axis' own input (|f_a| for an accelerometer axis, |ω_a| for a gyro axis).
  std::array<Eigen::MatrixXd, kNumAxes> hetero_cov;
  for (int a = 0; a < kNumAxes; ++a) {
    auto& Z = hetero_cov[static_cast<std::size_t>(a)];
    Z.resize(static_cast<Eigen::Index>(blocks.size()), 2);
    for (std::size_t b = 0; b < blocks.size(); ++b) {
      Z(static_cast<Eigen::Index>(b), 0) = blocks[b].absw;
      Z(static_cast<Eigen::Index>(b), 1) = std::fabs(a < 3 ? blocks[b].f[a] : blocks[b].w[a - 3]);
    }
  }
  // The whole log's wander of axis a under the model `ids` (both lines, noise_model.h), and why a line's maximiser
  // is not wander: too large, a jump, or correlated innovations (a periodic bias); "" when it is. The one rule for
  // the one-turn hysteresis check, the wander re-test and the final model's wander that diagnose() decides to carry.
  // input_check: also the spread's test against the inputs (WholeLogWander::hetero_*), which only the final model's
  // raise is judged on.
  auto wander_lines = [&](int a, const std::set<ParamId>& ids, bool input_check = false) {
    const auto ua = static_cast<std::size_t>(a);
    const AxisData& ad = ax[ua];
    const Fit f = fit_axis(ad, cols_for(ad, ids), -1);
    return whole_log_wander(R.stoch[ua], blk_t, blk_dur, design_rows(ad, f.kept, 0), R.rw_prior_var[ua], R.duration_s,
                            std::max(4.0 * o.wander_max_factor, 1.15 * o.wander_rw_max_factor), &blk_seg, input_check ? &hetero_cov[ua] : nullptr);
  };
  auto wander_reason = [&](const std::array<WholeLogWander, 3>& lines, const WholeLogWander& l) -> const char* {
    const bool rw_likelier = raises(lines[1]) && (!raises(lines[0]) || lines[1].gain >= lines[0].gain);
    const double limit = l.kind == WholeLogWander::kRandomWalk && rw_likelier ? o.wander_rw_max_factor : o.wander_max_factor;
    // The shape's failures first: a raise past its limit that also leaves a step or a line is that structure, which
    // names the axis (is_structured, below), where "too large" alone does not. `unseen9` mixed-compressor accel.y:
    // a bias oscillating while the chamber cools, which the dwells (cooling too) read as a flicker 6x the class's;
    // the walk raised 15x leaves a line of period 78 s at p 3e-16, and the axis went unnamed as "too large".
    return l.max_abs_z > o.wander_max_z && l.jump_persist_z > o.wander_step_persist_z ? "jump"
           : l.line_p < o.wander_max_line_p ? "periodic"
           : l.limit_ratio > limit          ? "too_large"
                                            : "";
  };
  // The likelier line, unless it fails a check and the other passes them (flicker and random walk differ in shape
  // beyond a quarter of the log, where the likelihood tells them apart least).
  auto wander_pick = [&](const std::array<WholeLogWander, 3>& lines) {
    const WholeLogWander* pick = likelier(lines);
    if (pick && *wander_reason(lines, *pick)) {
      const WholeLogWander& other = pick == &lines[0] ? lines[1] : lines[0];
      if (raises(other) && !*wander_reason(lines, other) && other.gain > 3.84) pick = &other;
    }
    return pick;
  };
  // −2 log L (up to a constant) of the GLS fit of [z | kept columns] of one axis under noise sm: Σ log S + χ².
  // with_logS false: the χ² alone (the LR of nested columns under one noise model).
  auto gls_m2ll = [&](const AxisData& ad, const StochasticModel& sm, double rw0, const std::vector<int>& kept, bool with_logS) {
    double logS = 0;
    const estimator::NormalEquations ne =
        gls_normal_equations(sm, blk_t, blk_dur, design_rows(ad, kept, 0), rw0, &blk_seg, nullptr, with_logS ? &logS : nullptr);
    std::vector<int> cols(kept.size());
    std::iota(cols.begin(), cols.end(), 0);
    return logS + estimator::fit_subset(ne, cols).rss;
  };
  // gk, tests: the candidate's grid position and the factor its threshold's choice costs (score_one).
  auto one_turn_p = [&](const std::set<ParamId>& cur, Sensor s, int gk, double tests) {
    const std::vector<ParamId> eids = model::effect_params(s, Effect::kTempHysteresis);
    double lr = 0;
    int dof = 0;
    for (int a = s == Sensor::kAccel ? 0 : 3, e = a + 3; a < e; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      const AxisData& ad = ax[ua];
      const Fit fc = fit_axis(ad, cols_for(ad, cur), -1);
      const Fit fa = fit_axis(ad, candidate_cols(ad, cur, eids, gk), -1);
      if (fa.kept.size() <= fc.kept.size()) continue;
      double rw0 = 0;
      const StochasticModel sm = with_wander(R.stoch[ua], likelier(wander_lines(a, cur)), R.duration_s, R.rw_prior_var[ua], rw0);
      lr += std::max(gls_m2ll(ad, sm, rw0, fc.kept, false) - gls_m2ll(ad, sm, rw0, fa.kept, false), 0.0);
      dof += static_cast<int>(fa.kept.size() - fc.kept.size());
    }
    return dof > 0 ? std::min(1.0, chi2_sf(lr, dof) * tests) : -1.0;
  };
  auto score_all = [&](const std::set<ParamId>& cur, const std::set<std::pair<int, int>>& cur_effects) {
    std::vector<CandidateScore> out;
    for (auto [s, e] : candidates) {
      if (cur_effects.count({static_cast<int>(s), static_cast<int>(e)})) continue;
      out.push_back(score_one(cur, s, e));
    }
    int m = 0;
    for (const auto& c : out) m += c.excitable ? 1 : 0;
    const double level = o.alpha / std::max(1, m);
    for (auto& c : out) {
      c.significant = qualifies(c, level) && c.implausible.empty();
      if (c.significant && c.effect == model::effect_info(Effect::kTempRate).name) {
        c.heat_cool_p = heat_cool_p(cur, c.sensor == "accel" ? Sensor::kAccel : Sensor::kGyro);
        if (c.heat_cool_p >= 0 && c.heat_cool_p < 0.01) c.significant = false;
      }
      const int gk = c.hysteresis_profile.empty() ? -1 : grid_position(c.hysteresis_threshold_C);
      const int runs = c.effect == model::effect_info(Effect::kTempHysteresis).name ? hysteresis_runs(gk) : -1;
      if (c.significant && runs >= 0 && runs < 3) {
        c.one_turn_p = one_turn_p(cur, c.sensor == "accel" ? Sensor::kAccel : Sensor::kGyro, gk, c.hysteresis_tests);
        if (c.one_turn_p >= level) c.significant = false;
      }
    }
    std::stable_sort(out.begin(), out.end(), [](const CandidateScore& x, const CandidateScore& y) {
      if (x.excitable != y.excitable) return x.excitable;
      return x.score > y.score;
    });
    return out;
  };
  auto effect_of = [](const std::string& sensor, const std::string& effect) {
    Effect e = Effect::kBias;
    model::find_effect(effect, e);
    return std::make_pair(sensor == "accel" ? Sensor::kAccel : Sensor::kGyro, e);
  };
  auto add_effect = [](std::set<ParamId>& ids, std::set<std::pair<int, int>>& effs, Sensor s, Effect e) {
    effs.insert({static_cast<int>(s), static_cast<int>(e)});
    for (ParamId id : candidate_params(s, e)) ids.insert(id);
  };
  auto remove_effect = [](std::set<ParamId>& ids, std::set<std::pair<int, int>>& effs, Sensor s, Effect e) {
    effs.erase({static_cast<int>(s), static_cast<int>(e)});
    for (ParamId id : model::effect_params(s, e)) ids.erase(id);
  };
  // The parameters of a model without one of its effects (leave-one-out re-tests and checks).
  auto params_without = [](const std::set<ParamId>& ids, Sensor s, Effect e) {
    std::set<ParamId> w = ids;
    for (ParamId id : model::effect_params(s, e)) w.erase(id);
    return w;
  };
  auto make_step = [&](const std::string& sensor, const std::string& effect, double p, double lr, const std::set<ParamId>& cur) {
    Step st;
    st.effect = effect;
    st.sensor = sensor;
    st.p_value = p;
    st.lr = lr;
    st.gap_after = gap_verdict(cur);
    for (int a = 0; a < kNumAxes; ++a) {
      const double g0 = R.gap_before.gap[static_cast<std::size_t>(a)];
      st.shrink_pct[static_cast<std::size_t>(a)] = g0 > 0 ? 100.0 * (1.0 - pos(st.gap_after.gap[static_cast<std::size_t>(a)]) / g0) : 0.0;
    }
    return st;
  };

  R.gap_before = gap_verdict(model_ids);
  if (std::getenv("IMUFORGE_DIAG_TRACE"))
    for (int a = 0; a < kNumAxes; ++a) {
      const auto w = heldout_white(a, cols_for(ax[static_cast<std::size_t>(a)], model_ids));
      const HeldOut hr = heldout_axis(ax[static_cast<std::size_t>(a)], axg[static_cast<std::size_t>(a)],
                                      cols_for(ax[static_cast<std::size_t>(a)], model_ids), folds);
      std::fprintf(stderr, "whitened held-out %s: chi2/dof %.3f (%d segments), marginal %.3f (sum r2/v %.3f)\n", axis_name(a),
                   w.first / w.second, w.second, R.gap_before.chi2_dof[static_cast<std::size_t>(a)], hr.nb ? hr.chi2 / hr.nb : 0.0);
    }
  std::set<std::pair<int, int>> cur_effects = in_model;
  std::set<ParamId> cur = model_ids;
  // Effects forced in (timing of a sensor whose reference is already re-evaluated at its shifted time).
  for (auto [s, e] : o.forced) {
    add_effect(cur, cur_effects, s, e);
    R.selected.push_back(make_step(model::sensor_name(s), model::effect_info(e).name, 0.0, 0.0, cur));
  }
  const std::set<std::pair<int, int>> fixed_effects = cur_effects;  // never dropped by the backward step
  // The AIC gain (LR − 2·dof) of effect (s, e) over `cur` on its best subset of components, for the ambiguity
  // tie-break below. Per axis, the effect's components of that axis alone are removed one at a time while removing
  // one costs less than 2 in the LR (each axis's LR in units of its own augmented misfit, at least 1). An effect
  // that bundles orders the data do not need must not lose the tie-break for them: a true accelerometer u² read
  // on tilted poses carries scale_nonlinearity's u³ terms beside it (3 dof that fit nothing), and
  // scale_asymmetry's |u|, which fits the same signature worse, won by "the larger AIC gain" on three fresh
  // blind suites (varied19 random-3, mixed-heading, mixed-bias_step: by 0.7-2.5). Components shared between
  // axes (timing's latency) stay. Also returns how many components that subset keeps. O(axes · components² · fit).
  struct Subset {
    double aic = 0;
    int components = 0;
    std::set<ParamId> kept;  // those components
  };
  auto best_subset_aic = [&](const std::set<ParamId>& cur, Sensor s, Effect e) {
    const std::vector<ParamId>& eids = candidate_params(s, e);
    const int a0 = s == Sensor::kAccel ? 0 : 3;
    Subset out;
    for (int a = a0; a < a0 + 3; ++a) {
      const AxisData& ad = ax[static_cast<std::size_t>(a)];
      const std::vector<int> sel0 = cols_for(ad, cur);
      std::vector<int> sel = cols_for(ad, cur, eids);
      const Fit fc = fit_axis(ad, sel0, -1);
      Fit fa = fit_axis(ad, sel, -1);
      if (fa.kept.size() <= fc.kept.size()) continue;
      // The candidate's columns the rank check dropped carry nothing to remove.
      sel.erase(std::remove_if(sel.begin() + static_cast<std::ptrdiff_t>(sel0.size()), sel.end(),
                               [&](int c) { return std::find(fa.kept.begin(), fa.kept.end(), c) == fa.kept.end(); }),
                sel.end());
      const double s2 = augmented_misfit(ad, fa);
      for (;;) {
        std::size_t drop = 0;
        Fit fd_best;
        bool any = false;
        for (std::size_t i = sel0.size(); i < sel.size(); ++i) {
          if (model::param_info(param_of(ad, sel[i])).j != a - a0) continue;
          std::vector<int> sub = sel;
          sub.erase(sub.begin() + static_cast<std::ptrdiff_t>(i));
          Fit fd = fit_axis(ad, sub, -1);
          if (!any || fd.rss < fd_best.rss) {
            drop = i;
            fd_best = std::move(fd);
            any = true;
          }
        }
        if (!any) break;
        const int lost = static_cast<int>(fa.kept.size()) - static_cast<int>(fd_best.kept.size());
        if (!((fd_best.rss - fa.rss) / s2 < 2.0 * lost)) break;
        sel.erase(sel.begin() + static_cast<std::ptrdiff_t>(drop));
        fa = std::move(fd_best);
      }
      out.aic += (fc.rss - fa.rss) / s2 - 2.0 * static_cast<double>(fa.kept.size() - fc.kept.size());
      out.components += static_cast<int>(fa.kept.size() - fc.kept.size());
      for (std::size_t i = sel0.size(); i < sel.size(); ++i) out.kept.insert(param_of(ad, sel[i]));
    }
    return out;
  };
  // The fitted signal X_e θ_e of effect (s, e) per block on one axis, under fit f of that axis.
  auto effect_signal = [&](const AxisData& ad, const Fit& f, Sensor s, Effect e) {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(B);
    for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) {
      const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i)])]);
      if (pi.sensor == s && pi.effect == e) c += ad.Xr.col(f.kept[static_cast<std::size_t>(i)]) * f.theta[i];
    }
    return c;
  };
  std::map<std::pair<int, int>, int> times_dropped;
  for (int step = 0;; ++step) {
    std::vector<CandidateScore> sc = score_all(cur, cur_effects);
    if (step == 0) R.ranking = sc;
    if (std::getenv("IMUFORGE_DIAG_TRACE")) {
      std::fprintf(stderr, "step %d\n", step);
      for (std::size_t i = 0; i < sc.size() && i < 8; ++i)
        std::fprintf(stderr, "  %s.%s score=%.1f gain=%.1f shrink=%.1f%% dof=%d sig=%d impl=%zu\n", sc[i].sensor.c_str(),
                     sc[i].effect.c_str(), sc[i].score, sc[i].heldout_chi2_gain, sc[i].heldout_shrink_pct, sc[i].dof,
                     sc[i].significant ? 1 : 0, sc[i].implausible.size());
    }
    if (step >= o.max_steps) break;
    const CandidateScore* best = nullptr;
    for (const auto& c : sc)
      if (c.significant && times_dropped[{static_cast<int>(effect_of(c.sensor, c.effect).first), static_cast<int>(effect_of(c.sensor, c.effect).second)}] < 2) {
        best = &c;
        break;
      }
    if (!best) break;
    // Competing explanations of one signature (scale_asymmetry |u| against scale_nonlinearity u², u³ when the
    // campaign has few input levels of each sign): the ranking by p-value favours the one with fewer degrees of
    // freedom, whichever fits better. For each other qualifying candidate of the same sensor with a larger
    // likelihood ratio, each is re-tested with the other in the model. Both still qualifying: both are present
    // (the second is added at a later step). Neither qualifying: the data see one signature and cannot say
    // which effect it is; the one with the larger AIC gain (LR − 2·dof: the expected in-sample gain of the
    // extra columns removed), each on the subset of its components the data need (best_subset_aic), is selected
    // and the pair is reported as ambiguous. Only the best one still qualifying: it stays. (Parsimony first, the
    // smaller subset whatever its AIC, was tried at stop 55: it read two true accelerometer k2 of `varied25` as
    // scale_asymmetry, whose |u| is a different function that fits the signature worse.)
    CandidateScore swapped;
    {
      int m = 0;
      for (const auto& c : sc) m += c.excitable ? 1 : 0;
      const double level = o.alpha / std::max(1, m);
      const auto [bs0, be0] = effect_of(best->sensor, best->effect);
      const CandidateScore* pick = best;
      DiagnosisResult::Ambiguity amb;
      for (const auto& c : sc) {
        if (&c == best || c.sensor != best->sensor || !c.significant || !(c.lr > best->lr)) continue;
        const auto [cs_, ce_] = effect_of(c.sensor, c.effect);
        // Dropped twice by the backward step, as `best` would have to be: chosen again, it cycled in and out
        // until the step limit, each time reporting the pair again (stop 49: AnAmbiguousPairIsJudgedOnThe-
        // ComponentsTheDataNeed's poses with a k2 of 2.5e-5 instead of 3e-5, seeds 6 and 8, 20 entries each). The
        // backward step's level (α over every candidate of the step) is stricter than the forward one (α over
        // the excitable ones), so an effect near the level can pass one and fail the other.
        if (times_dropped[{static_cast<int>(cs_), static_cast<int>(ce_)}] >= 2) continue;
        std::set<ParamId> with_c = cur, with_b = cur;
        std::set<std::pair<int, int>> e_c = cur_effects, e_b = cur_effects;
        add_effect(with_c, e_c, cs_, ce_);
        add_effect(with_b, e_b, bs0, be0);
        const CandidateScore b_given_c = score_one(with_c, bs0, be0);
        const CandidateScore c_given_b = score_one(with_b, cs_, ce_);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "ambiguity? %s.%s given %s.%s: p %.2g shrink %.1f%% | %s given it: p %.2g shrink %.1f%% (level %.2g)\n",
                       best->sensor.c_str(), best->effect.c_str(), c.sensor.c_str(), c.effect.c_str(), b_given_c.p_value,
                       b_given_c.heldout_shrink_pct, c.effect.c_str(), c_given_b.p_value, c_given_b.heldout_shrink_pct, level);
        if (qualifies(c_given_b, level) || qualifies(b_given_c, level)) continue;
        const Subset sub_b = best_subset_aic(cur, bs0, be0), sub_c = best_subset_aic(cur, cs_, ce_);
        const bool c_wins = sub_c.aic > sub_b.aic;
        const CandidateScore& win = c_wins ? c : *best;
        const CandidateScore& lose = c_wins ? *best : c;
        amb.chosen = win.sensor + "." + win.effect;
        amb.alternative = lose.sensor + "." + lose.effect;
        amb.lr_chosen = win.lr;
        amb.lr_alternative = lose.lr;
        amb.dof_chosen = win.dof;
        amb.dof_alternative = lose.dof;
        amb.delta_aic = c_wins ? sub_c.aic - sub_b.aic : sub_b.aic - sub_c.aic;
        amb.components_chosen = c_wins ? sub_c.components : sub_b.components;
        amb.components_alternative = c_wins ? sub_b.components : sub_c.components;
        if (c_wins) pick = &c;
        break;
      }
      // One entry per pair, the latest choice (reported after the loop, for the choices that stayed selected).
      if (!amb.chosen.empty()) {
        auto same = std::find_if(R.ambiguous.begin(), R.ambiguous.end(), [&](const DiagnosisResult::Ambiguity& x) {
          return same_pair(x, amb.chosen, amb.alternative);
        });
        if (same != R.ambiguous.end()) *same = amb;
        else R.ambiguous.push_back(amb);
      }
      if (pick != best) {
        swapped = *pick;
        // "Best first": the ranking of the first step follows the same choice (the chosen one just ahead of
        // the one it displaced).
        if (step == 0) {
          auto same = [](const CandidateScore& x, const CandidateScore& y) { return x.sensor == y.sensor && x.effect == y.effect; };
          auto ib = std::find_if(R.ranking.begin(), R.ranking.end(), [&](const CandidateScore& x) { return same(x, *best); });
          auto ip = std::find_if(R.ranking.begin(), R.ranking.end(), [&](const CandidateScore& x) { return same(x, swapped); });
          if (ib != R.ranking.end() && ip != R.ranking.end() && ip > ib) std::rotate(ib, ip, ip + 1);
        }
        best = &swapped;
      }
    }
    const auto [bs, be] = effect_of(best->sensor, best->effect);
    // A temp_hysteresis scored at a profiled threshold: that threshold becomes the model's hysteresis columns.
    if (be == Effect::kTempHysteresis && !best->hysteresis_profile.empty()) {
      set_hysteresis_threshold(grid_position(best->hysteresis_threshold_C));
      R.hysteresis_effective_tests = best->hysteresis_tests;
      R.hysteresis_profile = best->hysteresis_profile;
    }
    add_effect(cur, cur_effects, bs, be);
    R.selected.push_back(make_step(best->sensor, best->effect, best->p_value, best->lr, cur));
    // Backward: re-test every selected effect against the model without it; drop the weakest that no
    // longer qualifies (significance and held-out gain, as for an addition).
    for (;;) {
      const CandidateScore* worst = nullptr;
      CandidateScore wc;
      std::vector<CandidateScore> back;
      for (const auto& ef : cur_effects) {
        if (fixed_effects.count(ef)) continue;
        const Sensor s = static_cast<Sensor>(ef.first);
        const Effect e = static_cast<Effect>(ef.second);
        back.push_back(score_one(params_without(cur, s, e), s, e));
      }
      const double level = o.alpha / std::max<std::size_t>(1, sc.size());
      for (const auto& c : back)
        if (!qualifies(c, level) && (!worst || c.score < worst->score)) {
          wc = c;
          worst = &wc;
        }
      if (!worst) break;
      const auto [ws, we] = effect_of(worst->sensor, worst->effect);
      remove_effect(cur, cur_effects, ws, we);
      ++times_dropped[{static_cast<int>(ws), static_cast<int>(we)}];
      R.dropped.push_back(worst->sensor + "." + worst->effect);
      R.selected.erase(std::remove_if(R.selected.begin(), R.selected.end(),
                                      [&](const Step& st) { return st.sensor == worst->sensor && st.effect == worst->effect; }),
                       R.selected.end());
    }
  }
  // The in-sample χ² of sensor si's axes under the columns of `ids` (the two swap steps' bound below).
  auto insample_chi2 = [&](const std::set<ParamId>& ids, int si) {
    double q = 0;
    for (int a = 3 * si; a < 3 * si + 3; ++a) q += fit_axis(ax[static_cast<std::size_t>(a)], cols_for(ax[static_cast<std::size_t>(a)], ids), -1).rss;
    return q;
  };
  // The selected effects the two swap steps below ask, as selected now: not forced, and neither timing nor
  // temp_hysteresis (the re-evaluated reference, the profiled threshold).
  auto swappable = [&]() {
    std::vector<std::pair<int, int>> out;
    for (const auto& be : cur_effects) {
      const Effect e = static_cast<Effect>(be.second);
      if (!fixed_effects.count(be) && e != Effect::kTiming && e != Effect::kTempHysteresis) out.push_back(be);
    }
    return out;
  };
  // One of them as the swap steps ask it: its sensor and effect, the model without it, and the in-sample χ² of its
  // sensor's axes under the model with it.
  auto swap_subject = [&](const std::pair<int, int>& be) {
    const Sensor s_ = static_cast<Sensor>(be.first);
    const Effect e_ = static_cast<Effect>(be.second);
    return std::make_tuple(s_, e_, params_without(cur, s_, e_), insample_chi2(cur, be.first));
  };
  // Puts c in the selected b's place (the two swap steps below): the model becomes `with_c` (`rest`, the model
  // without b, plus c), the pair goes into `ambiguous` (one entry per pair, replacing an earlier one), and b's step
  // in the selection becomes c's.
  auto swap_effect = [&](Sensor bs, Effect bef, Sensor cs_, Effect ce_, const std::set<ParamId>& rest, const std::set<ParamId>& with_c,
                         const std::set<std::pair<int, int>>& e_c, const Subset& sub_b, const Subset& sub_c,
                         const CandidateScore& c_alone, bool nested) {
    const std::string bkey = effect_key(bs, bef), ckey = effect_key(cs_, ce_);
    DiagnosisResult::Ambiguity amb;
    amb.chosen = ckey;
    amb.alternative = bkey;
    amb.lr_chosen = c_alone.lr;
    amb.dof_chosen = c_alone.dof;
    const CandidateScore b_alone = score_one(rest, bs, bef);
    amb.lr_alternative = b_alone.lr;
    amb.dof_alternative = b_alone.dof;
    amb.delta_aic = sub_c.aic - sub_b.aic;
    amb.components_chosen = sub_c.components;
    amb.components_alternative = sub_b.components;
    amb.nested = nested;
    R.ambiguous.erase(std::remove_if(R.ambiguous.begin(), R.ambiguous.end(),
                                     [&](const DiagnosisResult::Ambiguity& x) { return same_pair(x, bkey, ckey); }),
                      R.ambiguous.end());
    R.ambiguous.push_back(amb);
    cur = with_c;
    cur_effects = e_c;
    for (auto& st : R.selected)
      if (st.sensor + "." + st.effect == bkey) st = make_step(model::sensor_name(cs_), model::effect_info(ce_).name, c_alone.p_value, c_alone.lr, cur);
  };
  // ---- A nested equivalent of a selected effect. On static poses IEEE 1293's cross-axis squares K_pp f_p² +
  // K_oo f_o² at K_pp = K_oo are k2 f_j² (|f| = g): scale_nonlinearity's k2 lies within the span of the
  // cross-axis effect and the bias, and on a rate table departs from it only by the centripetal term. The
  // forward step meets such a pair against the model of its step, where an effect still missing can make the
  // richer one fit better for a while: `varied25` random-28 took the cross-axis squares at step 1, by an LR of 38
  // over a true k2 of SNR 151, with the sensor's misalign_temp not yet in. Against the final model each selected
  // effect b is asked once more, as a nested test: an unselected candidate c of its sensor whose fitted signal lies
  // within the model's span (nested_share below kNestedShare), that has fewer components in the catalog and
  // needs no more of them here (best_subset_aic), that qualifies in b's place and beside which b does not qualify,
  // takes b's place; the pair is reported as ambiguous. Of two that need as many components here the one the
  // catalog gives fewer is taken (`varied24` random-11: a true k2 on y, 1 component against the cross-axis
  // effect's y.xx and y.zz, chosen by the forward step's AIC at a margin the test calls nothing, p 0.73 and 0.69).
  // Pairs that are not nested keep the forward step's AIC tie-break alone: parsimony there read two true k2 as
  // scale_asymmetry, whose |u| is another function (stop 55, `varied25` random-17 and 20). A bound
  // skips most pairs before the fold fits: what b adds beside c is at least the in-sample GLS χ² the swap costs,
  // so where that is significant at the level on b's dof, b qualifies. Timing and temp_hysteresis (the
  // reference's re-evaluation, the profiled threshold) are not asked.
  {
    // The share of what c explains in b's place that the model with b cannot: c's fitted signal X_c θ_c per block
    // (fit of `with_c`: the model without b and with the components of c the data need, all axes of the sensor),
    // regressed on the columns of `ids`, blocks weighted at 1/vr; the residual's norm over the signal's spread
    // about its weighted mean, summed over the axes. 0: c is nested. What counts is the signal c fits on the
    // components it needs, not each of its columns: scale_nonlinearity's u³ terms are in no span of squares, and
    // carry nothing but noise where the sensor has a k2 alone. O(axes · B · P²).
    auto nested_share = [&](const std::set<ParamId>& ids, const std::set<ParamId>& with_c, Sensor cs, Effect ce) {
      double outside = 0, spread = 0;
      const int a0 = cs == Sensor::kAccel ? 0 : 3;
      for (int a = a0; a < a0 + 3; ++a) {
        const AxisData& ad = ax[static_cast<std::size_t>(a)];
        const Eigen::VectorXd w = ad.vr.cwiseInverse().cwiseSqrt();
        const Eigen::VectorXd x = effect_signal(ad, fit_axis(ad, cols_for(ad, with_c), -1), cs, ce).cwiseProduct(w);
        const double mean = x.dot(w) / w.squaredNorm();
        const double sp = (x - mean * w).squaredNorm();
        if (!(sp > 0)) continue;
        const std::vector<int> m = cols_for(ad, ids);
        Eigen::MatrixXd M(B, static_cast<Eigen::Index>(m.size()));
        for (std::size_t i = 0; i < m.size(); ++i) M.col(static_cast<Eigen::Index>(i)) = ad.Xr.col(m[i]).cwiseProduct(w);
        outside += (x - M * M.colPivHouseholderQr().solve(x)).squaredNorm();
        spread += sp;
      }
      return spread > 0 ? std::sqrt(outside / spread) : 1.0;
    };
    const double level = o.alpha / static_cast<double>(std::max<std::size_t>(1, candidates.size()));
    for (const auto& be : swappable()) {
      if (!cur_effects.count(be)) continue;  // an earlier swap took it out
      const auto [bs, bef, rest, q_cur] = swap_subject(be);
      std::optional<Subset> sub_b;
      for (auto [cs_, ce_] : candidates) {
        if (cs_ != bs || ce_ == bef || ce_ == Effect::kTiming || ce_ == Effect::kTempHysteresis) continue;
        if (cur_effects.count({static_cast<int>(cs_), static_cast<int>(ce_)})) continue;
        if (candidate_params(cs_, ce_).size() >= candidate_params(bs, bef).size()) continue;
        std::set<ParamId> with_c = rest;
        std::set<std::pair<int, int>> e_c = cur_effects;
        e_c.erase(be);
        add_effect(with_c, e_c, cs_, ce_);
        const double bound = std::max(insample_chi2(with_c, be.first) - q_cur, 0.0);
        const int dof_b = static_cast<int>(candidate_params(bs, bef).size());
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "nested bound %s.%s for %s: in-sample cost %.1f on %d dof\n", model::sensor_name(cs_),
                       model::effect_info(ce_).name, model::effect_info(bef).name, bound, dof_b);
        if (chi2_sf(bound, dof_b) < level) continue;
        if (!sub_b) sub_b = best_subset_aic(rest, bs, bef);
        const Subset sub_c = best_subset_aic(rest, cs_, ce_);
        if (sub_c.components > sub_b->components) continue;
        std::set<ParamId> with_c_needed = rest;
        with_c_needed.insert(sub_c.kept.begin(), sub_c.kept.end());
        const double share = nested_share(cur, with_c_needed, cs_, ce_);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "nested? %s.%s in the model with %s: share outside %.3g\n", model::sensor_name(cs_),
                       model::effect_info(ce_).name, model::effect_info(bef).name, share);
        if (!(share < kNestedShare)) continue;
        const CandidateScore b_given_c = score_one(with_c, bs, bef);
        const CandidateScore c_alone = score_one(rest, cs_, ce_);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "simpler? %s.%s (%d components, AIC %.1f) for %s (%d, AIC %.1f): bound %.1f; it given %s p %.2g shrink %.1f%%; %s in its place p %.2g shrink %.1f%%\n",
                       model::sensor_name(cs_), model::effect_info(ce_).name, sub_c.components, sub_c.aic, model::effect_info(bef).name,
                       sub_b->components, sub_b->aic, bound, model::effect_info(ce_).name, b_given_c.p_value, b_given_c.heldout_shrink_pct,
                       model::effect_info(ce_).name, c_alone.p_value, c_alone.heldout_shrink_pct);
        if (qualifies(b_given_c, level) || !qualifies(c_alone, level)) continue;
        swap_effect(bs, bef, cs_, ce_, rest, with_c, e_c, *sub_b, sub_c, c_alone, true);
        break;
      }
    }
  }
  // ---- The forward step's tie-break, asked again against the final model. Two effects that explain one
  // signature (scale_asymmetry's |u| and scale_nonlinearity's u² on a campaign with few input levels) are told apart
  // at the step that meets them, against the model of that step; an effect added later can change which of the
  // two fits better. `varied29` random-15 (stop 59): a true accelerometer k2 of blindgen SNR 32 beside the
  // cross-axis squares, which came in at the last step. At step 1 scale_asymmetry ranked ahead of k2 (−log10 p 123.5
  // against 117.8) and took the signature; k2 was never significant beside it. With the squares in the model k2
  // ranks first and reads −2.05e-5 ± 1.6e-6 for the sensor's −1.97e-5. So for each selected effect b and each
  // unselected candidate c of its sensor below the first step's level: where c fits more of what b explains,
  // against the model without b (the larger AIC gain on the components the data need, best_subset_aic, as at the
  // forward step), c qualifies in b's place (plausibly) and b does not qualify beside c, c takes b's place and the
  // pair is reported as ambiguous. A pair the nested test above decided is not asked, and neither are timing and
  // temp_hysteresis (the reference's re-evaluation, the profiled threshold). The in-sample bound of the nested step
  // skips most pairs before any fold fit: where the swap's in-sample cost is significant at the level on b's dof, b
  // qualifies beside c. O(selected · candidates · in-sample fits), plus two scored fits per pair that passes.
  {
    const double level = o.alpha / static_cast<double>(std::max<std::size_t>(1, candidates.size()));
    // The first step's candidates below its level (its qualifying ones and those its held-out or plausibility
    // rule held back: the pair's other half can read an implausible k3 until the effect that shares its signal is in).
    int m0 = 0;
    for (const auto& c : R.ranking) m0 += c.excitable ? 1 : 0;
    std::set<std::pair<int, int>> below_level_first;
    for (const auto& c : R.ranking)
      if (c.excitable && c.p_value < o.alpha / std::max(1, m0)) {
        const auto [s_, e_] = effect_of(c.sensor, c.effect);
        below_level_first.insert({static_cast<int>(s_), static_cast<int>(e_)});
      }
    for (const auto& be : swappable()) {
      if (!cur_effects.count(be)) continue;  // an earlier swap took it out
      const auto [bs, bef, rest, q_cur] = swap_subject(be);
      const int dof_b = static_cast<int>(candidate_params(bs, bef).size());
      std::optional<Subset> sub_b;
      for (const auto& ce : below_level_first) {
        const Sensor cs_ = static_cast<Sensor>(ce.first);
        const Effect ce_ = static_cast<Effect>(ce.second);
        if (cs_ != bs || ce_ == bef || ce_ == Effect::kTiming || ce_ == Effect::kTempHysteresis || cur_effects.count(ce)) continue;
        // A pair the nested test decided stays decided: parsimony there, not the AIC.
        const std::string bkey = effect_key(bs, bef), ckey = effect_key(cs_, ce_);
        if (std::any_of(R.ambiguous.begin(), R.ambiguous.end(), [&](const DiagnosisResult::Ambiguity& x) {
              return x.nested && same_pair(x, bkey, ckey);
            }))
          continue;
        std::set<ParamId> with_c = rest;
        std::set<std::pair<int, int>> e_c = cur_effects;
        e_c.erase(be);
        add_effect(with_c, e_c, cs_, ce_);
        const double bound = std::max(insample_chi2(with_c, be.first) - q_cur, 0.0);
        if (chi2_sf(bound, dof_b) < level) continue;
        if (!sub_b) sub_b = best_subset_aic(rest, bs, bef);
        const Subset sub_c = best_subset_aic(rest, cs_, ce_);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "tie-break again? %s.%s (AIC %.1f on %d components) for %s (AIC %.1f on %d): swap cost %.1f on %d dof\n",
                       model::sensor_name(cs_), model::effect_info(ce_).name, sub_c.aic, sub_c.components, model::effect_info(bef).name,
                       sub_b->aic, sub_b->components, bound, dof_b);
        if (!(sub_c.aic > sub_b->aic)) continue;
        const CandidateScore b_given_c = score_one(with_c, bs, bef);
        if (qualifies(b_given_c, level)) continue;
        const CandidateScore c_alone = score_one(rest, cs_, ce_);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "  %s given it p %.2g shrink %.1f%%; it in its place p %.2g shrink %.1f%%\n", model::effect_info(bef).name,
                       b_given_c.p_value, b_given_c.heldout_shrink_pct, c_alone.p_value, c_alone.heldout_shrink_pct);
        if (!qualifies(c_alone, level) || !c_alone.implausible.empty()) continue;
        swap_effect(bs, bef, cs_, ce_, rest, with_c, e_c, *sub_b, sub_c, c_alone, false);
        break;
      }
    }
  }
  // ---- scale_nonlinearity's k2 within the cross-axis squares. On every static pose |f| = g, so k2 f_j² = k2 g² −
  // k2 f_p² − k2 f_o²: a sensor with a k2 on axis j and IEEE 1293's squares K_pp, K_oo on that axis is fitted as well
  // by the squares alone, at K_pp − k2 and K_oo − k2 (the bias takes k2 g²), and only the rate table's centripetal
  // term tells them apart. Where the sensor has both effects the forward step takes the cross-axis one and k2 is
  // never significant beside it (`varied29`, stop 58: a k2 of blindgen SNR 13–152 missed in five cases; in
  // mixed-angle2 the fitted squares on x read −3.39e-4 and −3.45e-4 for a true k2 of 3.47e-4). On
  // each axis where the two fitted squares are equal within their noise (Wald, kEqualSquaresP) and their common
  // part is significant (at the selection's level), one k2 column replaces the two squares, provided the swap's
  // in-sample cost on that axis does not reject it (kSquaresSwapP on 1 dof): the same signature on one component
  // for two.
  // The cross-axis components left (the other axes' squares, the products) stay where they are still significant
  // together beside k2, else the effect goes (k2 alone then explains it). O(3 fits per accel axis).
  {
    const std::pair<int, int> cx{static_cast<int>(Sensor::kAccel), static_cast<int>(Effect::kCrossAxisNonlinearity)};
    const std::pair<int, int> k2e{static_cast<int>(Sensor::kAccel), static_cast<int>(Effect::kScaleNonlinearity)};
    bool k2_asked = false;
    for (auto [cs_, ce_] : candidates) k2_asked = k2_asked || (cs_ == Sensor::kAccel && ce_ == Effect::kScaleNonlinearity);
    const double level = o.alpha / static_cast<double>(std::max<std::size_t>(1, candidates.size()));
    if (k2_asked && cur_effects.count(cx) && !cur_effects.count(k2e) && !fixed_effects.count(cx)) {
      std::set<ParamId> next = cur;
      std::string axes_swapped, detail;
      for (int a = 0; a < 3; ++a) {
        const AxisData& ad = ax[static_cast<std::size_t>(a)];
        const Fit f = fit_axis(ad, cols_for(ad, next), -1);
        int i1 = -1, i2 = -1;  // the axis's two squares among f.kept
        for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) {
          const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i)])]);
          if (pi.sensor != Sensor::kAccel || pi.effect != Effect::kCrossAxisNonlinearity || pi.j != a) continue;
          if (pi.k >= 0 && pi.k == pi.l) (i1 < 0 ? i1 : i2) = i;
        }
        const ParamId k2 = model::find_param(std::string("accel.scale_nonlinearity.") + "xyz"[a] + ".k2");
        if (i1 < 0 || i2 < 0 || k2 < 0) continue;
        const double s2 = augmented_misfit(ad, f);
        const double d = f.theta[i1] - f.theta[i2], m = 0.5 * (f.theta[i1] + f.theta[i2]);
        const double vd = s2 * (f.cov(i1, i1) + f.cov(i2, i2) - 2.0 * f.cov(i1, i2));
        const double vm = s2 * 0.25 * (f.cov(i1, i1) + f.cov(i2, i2) + 2.0 * f.cov(i1, i2));
        if (!(vd > 0 && vm > 0)) continue;
        const double p_equal = chi2_sf(d * d / vd, 1), p_common = chi2_sf(m * m / vm, 1);
        std::set<ParamId> trial = next;
        trial.erase(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i1)])]);
        trial.erase(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i2)])]);
        trial.insert(k2);
        const Fit ft = fit_axis(ad, cols_for(ad, trial), -1);
        const double p_swap = chi2_sf(std::max(ft.rss - f.rss, 0.0) / s2, 1);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "k2 in the squares? accel.%c: squares %.4g %.4g, equal p %.2g, common p %.2g, swap p %.2g\n", "xyz"[a],
                       f.theta[i1], f.theta[i2], p_equal, p_common, p_swap);
        if (!(p_equal > kEqualSquaresP && p_common < level && p_swap > kSquaresSwapP)) continue;
        next = trial;
        char buf[160];
        std::snprintf(buf, sizeof buf, "%s%c (squares %.3g and %.3g, k2 %.3g)", axes_swapped.empty() ? "" : ", ", "xyz"[a],
                      f.theta[i1], f.theta[i2], -m);
        axes_swapped += "xyz"[a];
        detail += buf;
      }
      if (!axes_swapped.empty()) {
        // What is left of the cross-axis effect, asked together beside k2.
        std::set<ParamId> without_cx = next;
        for (ParamId id : model::effect_params(Sensor::kAccel, Effect::kCrossAxisNonlinearity)) without_cx.erase(id);
        double q_next = 0, q_wo = 0, q_nok2 = 0;
        std::set<ParamId> without_k2 = next;
        for (ParamId id : model::effect_params(Sensor::kAccel, Effect::kScaleNonlinearity)) without_k2.erase(id);
        int left = 0;
        for (ParamId id : next) left += model::param_info(id).effect == Effect::kCrossAxisNonlinearity && model::param_info(id).sensor == Sensor::kAccel;
        for (int a = 0; a < 3; ++a) {
          const AxisData& ad = ax[static_cast<std::size_t>(a)];
          const Fit fn = fit_axis(ad, cols_for(ad, next), -1);
          const double s2 = augmented_misfit(ad, fn);
          q_next += fn.rss / s2;
          q_wo += fit_axis(ad, cols_for(ad, without_cx), -1).rss / s2;
          q_nok2 += fit_axis(ad, cols_for(ad, without_k2), -1).rss / s2;
        }
        const bool cx_stays = left > 0 && chi2_sf(std::max(q_wo - q_next, 0.0), left) < level;
        const double lr_k2 = std::max(q_nok2 - q_next, 0.0);
        const int n_k2 = static_cast<int>(axes_swapped.size());
        cur = cx_stays ? next : without_cx;
        cur_effects.insert(k2e);
        if (!cx_stays) cur_effects.erase(cx);
        if (!cx_stays)
          R.selected.erase(std::remove_if(R.selected.begin(), R.selected.end(),
                                          [](const Step& st) { return st.sensor == "accel" && st.effect == "cross_axis_nonlinearity"; }),
                           R.selected.end());
        R.selected.push_back(make_step("accel", "scale_nonlinearity", chi2_sf(lr_k2, n_k2), lr_k2, cur));
        R.warnings.push_back(std::string("accel.cross_axis_nonlinearity's two squares are equal on ") + detail +
                             ": on static poses (|f| = g) that is accel.scale_nonlinearity's k2 on one component for two, "
                             "selected there in their place" +
                             (cx_stays ? std::string("; the cross-axis effect keeps its other components")
                                       : std::string("; what is left of the cross-axis effect is not significant beside it and is dropped")) +
                             " (a rate table's centripetal term, or a centrifuge, tells the two apart)");
      }
    }
  }
  R.gap_after = gap_verdict(cur);
  // An ambiguous pair whose choice the backward step later dropped says nothing about the model that stays.
  R.ambiguous.erase(std::remove_if(R.ambiguous.begin(), R.ambiguous.end(),
                                   [&](const DiagnosisResult::Ambiguity& x) {
                                     const size_t dot = x.chosen.find('.');
                                     const auto [s, e] = effect_of(x.chosen.substr(0, dot), x.chosen.substr(dot + 1));
                                     return !cur_effects.count({static_cast<int>(s), static_cast<int>(e)});
                                   }),
                    R.ambiguous.end());
  for (const auto& amb : R.ambiguous)
    R.warnings.push_back(amb.chosen + " and " + amb.alternative + " explain the same signature on this campaign (neither is " +
                         "significant once the other is in the model); " + amb.chosen + " is selected: " +
                         ambiguity_reason(amb) + " (a campaign that excites the two differently separates them)");

  // Timing estimate of the selected model, before any withdrawal (the wrapper re-evaluates the reference at
  // it: a large shift leaves a gap the linear term cannot close, and that gap must not veto its own fix).
  for (int si = 0; si < 2; ++si) {
    const Sensor s = static_cast<Sensor>(si);
    if (!cur_effects.count({si, static_cast<int>(Effect::kTiming)})) continue;
    double swl = 0, sl = 0, swp = 0, sp = 0;
    for (int a = 3 * si; a < 3 * si + 3; ++a) {
      const auto& ad = ax[static_cast<std::size_t>(a)];
      Fit f = fit_axis(ad, cols_for(ad, cur), -1);
      for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) {
        const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i)])]);
        if (pi.sensor != s || pi.effect != Effect::kTiming || !(f.cov(i, i) > 0)) continue;
        const double w = 1.0 / f.cov(i, i);
        if (pi.component == "latency_s") { swl += w; sl += w * f.theta[i]; }
        else { swp += w; sp += w * f.theta[i]; }
      }
    }
    auto& te = R.timing_est[static_cast<std::size_t>(si)];
    te.valid = true;
    te.latency_s = swl > 0 ? sl / swl : 0.0;
    te.ppm = swp > 0 ? sp / swp : 0.0;
    te.sigma_latency_s = swl > 0 ? 1.0 / std::sqrt(swl) : 1.0;
    te.sigma_ppm = swp > 0 ? 1.0 / std::sqrt(swp) : 1.0;
  }

  // ---- Mount rotation (docs/diagnosis.md, "Mount rotation"). The case sits on the fixture rotated by a small δ
  // that the fixture does not know. For the linear terms the misalignment carries it; a cross-coupling
  // c_jk u_j u_k acts on the case's input, u + δ × u, and read against the fixture's leaves on axis j
  // Σ_k c_jk [(δ × u)_j u_k + u_j (δ × u)_k]: squares and products of the inputs that no single catalog effect
  // spans (varied5: 4 of 25 random cases with a false gyro scale_nonlinearity or scale_asymmetry beside a
  // selected cross-coupling). A scale nonlinearity acts on the case's input too: k2 (u_j + (δ × u)_j)² + k3 (…)³
  // leaves 2 k2 u_j (δ × u)_j + 3 k3 u_j² (δ × u)_j, products of the inputs (the cubic's of three) that no catalog
  // effect spans: `varied17` random-27, a gyro.z k3 of 1.2e-4 at 1401 °/s on a 0.3 mrad mount, left gyro.z at
  // held-out χ²/dof 6.5, growing with the rate. With a gyro cross-coupling or scale nonlinearity selected, δ is
  // fitted here, jointly with the final model on each gyro axis (GLS under the axis's noise model) and shared by
  // the three axes (the θ of each axis eliminated by its Schur complement); diagnose() re-runs with the reference
  // rotated by it.
  // Where that joint fit finds no significant first correction (χ² ≤ 16.3, diagnose()'s level) and the
  // selection holds gyro effects of the inputs' squares and magnitudes (scale_nonlinearity, scale_asymmetry,
  // g2_sensitivity), δ is fitted again without them: they are what the rotation's terms pass for, and once
  // selected they take its signature from δ through the Schur complement (varied7 random-10: a 0.42 mrad mount
  // beside a 2.8e-3 cross-coupling, false g2_sensitivity at LR 235 and scale_nonlinearity at LR 79, δ at χ² 3.5).
  // A real one stays: the re-run tests it again on the rotated input, and a rotated run that leaves more axes
  // unexplained is not kept. Only as the fallback: where the joint fit is significant it is the better-posed one
  // (varied4 random-2, three couplings and a gyro clock of 18 ppm: without those effects the second correction
  // runs to 6.5 mrad; with them the selection comes out clean), and for the first correction only: on the rotated
  // input what those effects still fit is theirs (varied random-0, a true gyro scale_asymmetry and k2 beside a
  // 0.5 mrad mount: fitted without them, the second correction took 3.7 mrad about z and left gyro.y unexplained).
  if (fixture_src.active()) R.fixture_est = fixture_estimate(cur);
  if (cur_effects.count({static_cast<int>(Sensor::kGyro), static_cast<int>(Effect::kCrossCoupling)}) ||
      cur_effects.count({static_cast<int>(Sensor::kGyro), static_cast<int>(Effect::kScaleNonlinearity)})) {
    // ε_imn: (e_m × ω)_i = Σ_n ε_imn ω_n.
    auto eps = [](int i, int m, int n) { return (i == m || m == n || i == n) ? 0.0 : ((m - i + 3) % 3 == 1 ? 1.0 : -1.0); };
    auto estimate = [&](const std::set<ParamId>& model_ids) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) {
        const int a = 3 + j;
        const auto& ad = ax[static_cast<std::size_t>(a)];
        const Fit f = fit_axis(ad, cols_for(ad, model_ids), -1);
        double c_j[3] = {0, 0, 0};  // ĉ_jk
        double k2 = 0, k3 = 0;      // k̂2_j, k̂3_j
        for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) {
          const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i)])]);
          if (pi.sensor == Sensor::kGyro && pi.effect == Effect::kCrossCoupling && pi.k >= 0 && pi.k < 3) c_j[pi.k] = f.theta[i];
          if (pi.sensor == Sensor::kGyro && pi.effect == Effect::kScaleNonlinearity && pi.j == j) (pi.power == 2 ? k2 : k3) = f.theta[i];
        }
        const int P = static_cast<int>(f.kept.size());
        Eigen::MatrixXd rows = design_rows(ad, f.kept, 3);
        for (int b = 0; b < B; ++b) {
          const auto& wq = blocks[static_cast<std::size_t>(b)].wq;
          const auto& wc = blocks[static_cast<std::size_t>(b)].wc;
          for (int m = 0; m < 3; ++m) {
            double gm = 0;
            for (int k = 0; k < 3; ++k) {
              if (k == j || c_j[k] == 0.0) continue;
              for (int n = 0; n < 3; ++n) gm += c_j[k] * (eps(j, m, n) * wq[n][k] + eps(k, m, n) * wq[j][n]);
            }
            // k2 (u_j + (δ × u)_j)² + k3 (u_j + (δ × u)_j)³, to first order in δ: 2 k2 u_j (δ × u)_j + 3 k3 u_j² (δ × u)_j.
            for (int n = 0; n < 3; ++n) gm += eps(j, m, n) * (2.0 * k2 * wq[j][n] + 3.0 * k3 * wc[j][n]);
            rows(b, 1 + P + m) = gm;
          }
        }
        const estimator::NormalEquations ne =
            gls_normal_equations(R.stoch[static_cast<std::size_t>(a)], blk_t, blk_dur, rows, R.rw_prior_var[static_cast<std::size_t>(a)], &blk_seg);
        // Reduced χ² of the final fit above 1: the δ information is scaled down by it (conservative).
        const double s2 = std::max(1.0, f.rss / std::max(1.0, static_cast<double>(B - P)));
        const Eigen::MatrixXd Htt = ne.info.topLeftCorner(P, P);
        const Eigen::MatrixXd Htd = ne.info.topRightCorner(P, 3);
        Eigen::Matrix3d Hdd = ne.info.bottomRightCorner(3, 3);
        Eigen::Vector3d gd = ne.rhs.tail(3);
        if (P > 0) {
          const Eigen::LDLT<Eigen::MatrixXd> l(Htt);
          Hdd -= Htd.transpose() * l.solve(Htd);
          gd -= Htd.transpose() * l.solve(ne.rhs.head(P));
        }
        H += Hdd / s2;
        g += gd / s2;
      }
      // A prior on the whole rotation (the rotation evaluated at + this correction) of o.mount_prior_rad per axis,
      // a fixture's mounting repeatability: a rotation about an axis the campaign cannot separate from a
      // cross-coupling component (about x, c_xz's term is c_xy's) stays at zero instead of following the rest.
      const Eigen::Vector3d rot0(o.mount_rotation_rad[0], o.mount_rotation_rad[1], o.mount_rotation_rad[2]);
      const double ip = 1.0 / (o.mount_prior_rad * o.mount_prior_rad);
      const Eigen::Matrix3d Hp = H + ip * Eigen::Matrix3d::Identity();
      const Eigen::LDLT<Eigen::Matrix3d> l(Hp);
      const Eigen::Vector3d d = l.solve(g - ip * rot0);
      DiagnosisResult::MountEstimate me;
      if (d.allFinite() && l.info() == Eigen::Success) {
        const Eigen::Matrix3d C = l.solve(Eigen::Matrix3d::Identity());
        me.valid = true;
        for (int m = 0; m < 3; ++m) {
          me.sigma_rad[static_cast<std::size_t>(m)] = std::sqrt(std::max(C(m, m), 0.0));
          me.delta_rad[static_cast<std::size_t>(m)] = d[m];
        }
        me.chi2 = d.dot(H * d);
      }
      return me;
    };
    R.mount_est = estimate(cur);
    const bool rotated = o.mount_rotation_rad[0] != 0.0 || o.mount_rotation_rad[1] != 0.0 || o.mount_rotation_rad[2] != 0.0;
    if (!rotated && !(R.mount_est.valid && R.mount_est.chi2 > kMountFirstChi2)) {
      std::set<ParamId> reduced = cur;
      for (Effect e : {Effect::kScaleNonlinearity, Effect::kScaleAsymmetry, Effect::kG2Sensitivity})
        if (!fixed_effects.count({static_cast<int>(Sensor::kGyro), static_cast<int>(e)})) reduced = params_without(reduced, Sensor::kGyro, e);
      if (reduced != cur) {
        const DiagnosisResult::MountEstimate me = estimate(reduced);
        if (me.valid) R.mount_est = me;
      }
    }
  }

  // ---- Unexplained: axes still above their noise. Each selected effect of a sensor with such an axis is
  // judged on its own (leave-one-out on the held-out χ² excess, per axis): it stays when it is an
  // explanation somewhere. On an unexplained axis the held-out gain is contaminated by the signal no catalog
  // effect describes (a partial projection of it onto any regressor also "shrinks" the gap), so there it
  // must remove at least (1 − unexplained_keep_frac) of the excess it faces; on an explained axis it must be
  // needed for the axis to be explained, or remove at least one noise variance per block (its held-out
  // signal is as large as the noise). The others are withdrawn: they are not an explanation. Judging each
  // effect alone keeps a sensor's real effects when one large effect leaves an axis above the noise.
  auto over = [&](const Gap& g, int a) { return over_threshold(g, a, o.unexplained_chi2_dof); };
  // A signal of rms `rms` on axis a within a coarse output step's rounding staircase (twice its σ): it cannot be
  // told from the rounding (the output-step check of an effect; the whole-log residual's structure).
  auto within_rounding = [&](std::size_t ua, double rms) {
    return R.quant[ua].coarse() && rms < 2.0 * std::sqrt(R.stoch[ua].seg_bias_var);
  };
  // Withdraws a selected effect (form, output-step or unexplained check): out of the model and the selection,
  // listed with its sensor's unexplained axes.
  std::array<std::vector<std::string>, 2> withdrawn;
  auto withdraw = [&](const std::pair<int, int>& ef) {
    const std::string key = effect_key(static_cast<Sensor>(ef.first), static_cast<Effect>(ef.second));
    withdrawn[static_cast<std::size_t>(ef.first)].push_back(key);
    R.selected.erase(std::remove_if(R.selected.begin(), R.selected.end(),
                                    [&](const Step& st) { return st.sensor + "." + st.effect == key; }),
                     R.selected.end());
    remove_effect(cur, cur_effects, static_cast<Sensor>(ef.first), static_cast<Effect>(ef.second));
  };
  // Functional form (Ramsey's RESET test): an effect that stands in for an out-of-catalog function of the same
  // inputs removes most of that function's excess and leaves the rest as a nonlinear function of its own fitted
  // signal. A cubic g-sensitivity (f³ = g²·f on the ±1 g faces, departing on the tilts) is read as the linear
  // one this way. On axis a: c = X_e θ_e, the effect's fitted signal per block, and c², c³ are refitted as free
  // columns by GLS under the likelihood's noise model. Returns their LR (2 dof); `excess` is the in-sample χ²
  // excess (χ² − dof) of the model without them: how much is left to account for.
  auto form_lr = [&](const std::set<ParamId>& model_ids, Sensor s, Effect e, int a, double& excess, double& share) {
    excess = 0;
    share = 0;
    const AxisData& ad = ax[static_cast<std::size_t>(a)];
    const Fit f0 = fit_axis(ad, cols_for(ad, model_ids), -1);
    const int P = static_cast<int>(f0.kept.size());
    Eigen::VectorXd c = effect_signal(ad, f0, s, e);
    const double cmax = c.cwiseAbs().maxCoeff();
    if (!(cmax > 0)) return 0.0;
    c /= cmax;
    Eigen::MatrixXd rows = design_rows(ad, f0.kept, 2);
    rows.col(P + 1) = c.array().square().matrix();
    rows.col(P + 2) = c.array().cube().matrix();
    // GLS fits with and without the two columns, on the shared estimator core (its priority Cholesky drops
    // an augmentation column the model's columns already span: it then explains nothing new).
    const estimator::NormalEquations ne =
        gls_normal_equations(R.stoch[static_cast<std::size_t>(a)], blk_t, blk_dur, rows, R.rw_prior_var[static_cast<std::size_t>(a)], &blk_seg);
    std::vector<int> cols(static_cast<std::size_t>(P + 2));
    std::iota(cols.begin(), cols.end(), 0);
    const estimator::SubsetFit f0g = estimator::fit_subset(ne, std::vector<int>(cols.begin(), cols.begin() + P));
    const estimator::SubsetFit f1 = estimator::fit_subset(ne, cols);
    const double q0 = f0g.rss, q1 = f1.rss;
    excess = q0 - static_cast<double>(B - P);
    const double lr = q0 - q1;
    // What the two columns change in the fitted block means, against the effect's own signal (norms over the
    // blocks, both in the axis' unit).
    Eigen::VectorXd rem = Eigen::VectorXd::Zero(B);
    for (int k = 0; k < static_cast<int>(f1.kept.size()); ++k) rem += rows.col(1 + f1.kept[static_cast<std::size_t>(k)]) * f1.theta[k];
    for (int k = 0; k < static_cast<int>(f0g.kept.size()); ++k) rem -= rows.col(1 + f0g.kept[static_cast<std::size_t>(k)]) * f0g.theta[k];
    share = rem.norm() / (cmax * c.norm());
    return std::isfinite(lr) && lr > 0 ? lr : 0.0;
  };
  // The effect's parameters acting on axis a (catalog ids in that axis' columns).
  auto ids_on_axis = [&](Sensor s, Effect e, int a) {
    std::vector<ParamId> out;
    for (ParamId id : ax[static_cast<std::size_t>(a)].cols) {
      const auto& pi = model::param_info(id);
      if (pi.sensor == s && pi.effect == e && cur.count(id)) out.push_back(id);
    }
    return out;
  };
  // An effect that failed a check (`check`, `why`: the warning's reason) on its sensor's axes `bad`: its components
  // there go alone (into `trim`) when it stands on the other axes by itself, else the effect goes whole (into
  // `drop`, listed with `reason`). It stands when the GLS LR of its own components on the other axes, under the
  // likelihood's noise model, is significant at the selection's level (α over the candidates) and none of those
  // components is shared with a failing axis (timing's latency acts on all three).
  auto withdraw_where_failed = [&](const char* check, const char* reason, Sensor s, Effect e, const std::vector<int>& bad,
                                   const std::string& why, std::vector<ParamId>& trim, std::vector<std::pair<int, int>>& drop) {
    const int si = static_cast<int>(s);
    std::set<ParamId> bad_ids;
    std::string kept_on;
    for (int a : bad)
      for (ParamId id : ids_on_axis(s, e, a)) bad_ids.insert(id);
    double lr_rest = 0;
    int dof_rest = 0;
    bool separable = !bad_ids.empty();
    for (int b = 3 * si; b < 3 * si + 3 && separable; ++b) {
      if (std::find(bad.begin(), bad.end(), b) != bad.end()) continue;
      const std::vector<ParamId> own = ids_on_axis(s, e, b);
      for (ParamId id : own) separable = separable && !bad_ids.count(id);
      if (own.empty() || !separable) continue;
      const auto ub = static_cast<std::size_t>(b);
      const AxisData& ad = ax[ub];
      std::set<ParamId> without = cur;
      for (ParamId id : own) without.erase(id);
      const Fit f1 = fit_axis(ad, cols_for(ad, cur), -1);
      const Fit f0 = fit_axis(ad, cols_for(ad, without), -1);
      if (f1.kept.size() <= f0.kept.size()) continue;
      lr_rest += std::max(gls_m2ll(ad, R.stoch[ub], R.rw_prior_var[ub], f0.kept, false) -
                              gls_m2ll(ad, R.stoch[ub], R.rw_prior_var[ub], f1.kept, false),
                          0.0);
      dof_rest += static_cast<int>(f1.kept.size() - f0.kept.size());
      kept_on += (kept_on.empty() ? "" : ", ") + std::string(axis_name(b));
    }
    const double level = o.alpha / static_cast<double>(std::max<std::size_t>(1, candidates.size()));
    const double p_rest = dof_rest > 0 ? chi2_sf(lr_rest, dof_rest) : 1.0;
    if (std::getenv("IMUFORGE_DIAG_TRACE"))
      std::fprintf(stderr, "%s %s.%s: fails on %zu axis(es); elsewhere LR %.1f on %d dof, p %.2g (level %.2g)%s\n", check,
                   model::sensor_name(s), model::effect_info(e).name, bad.size(), lr_rest, dof_rest, p_rest, level,
                   separable ? "" : ", shares parameters with a failing axis");
    if (separable && dof_rest > 0 && p_rest < level) {
      std::string on;
      for (int a : bad) on += (on.empty() ? "" : ", ") + std::string(axis_name(a));
      char lrs[64];
      std::snprintf(lrs, sizeof lrs, "%.1f on %d dof", lr_rest, dof_rest);
      R.warnings.push_back(effect_key(s, e) + " kept on " + kept_on + " (its own LR there " + lrs + "), its components on " + on +
                           " withdrawn: " + why);
      trim.insert(trim.end(), bad_ids.begin(), bad_ids.end());
      return;
    }
    R.warnings.push_back(effect_key(s, e) + " withdrawn: " + why);
    R.withdrawn_by_check.push_back({effect_key(s, e), reason});
    drop.push_back({si, static_cast<int>(e)});
  };
  // Every selected effect, on every axis of its sensor: withdrawn when its own signal's square and cube are
  // significant (kFormLr) AND account for at least half of the in-sample χ² excess left on that axis. A catalog
  // effect whose form fits leaves nothing of the kind (measured on the 112 blind cases: LR ≤ 8 for every true
  // effect); a stand-in leaves its remainder (cubic g-sensitivity read as g_sensitivity: LR 585 for an excess of
  // 531, on an axis the effects piled on it had brought to held-out χ²/dof 1.8). Its axis then faces the
  // unexplained test below with the stand-in gone.
  //
  // The check is per axis, and so is what it withdraws when the effect stands on the sensor's other axes by itself.
  // A true effect of one axis pair beside an out-of-catalog term on another axis fits part of that term there
  // through its own components on that axis, and fails the form there alone (`unseen2` mixed-cross_w2: a true
  // gyro misalign_temp on y and z, and a gyro.x bias in ω_z², RESET LR 9173 on gyro.x; the whole effect was
  // withdrawn and gyro.z left at held-out χ²/dof 4.2). Its components on the failing axes are withdrawn, and the
  // effect is kept when the LR of its components on the others, under the likelihood's noise model, is
  // significant at the selection's level (α over the candidates) and none of them is shared with a failing axis
  // (timing's latency acts on all three). Otherwise it is withdrawn whole, as before.
  {
    std::vector<std::pair<int, int>> form_drop;
    std::vector<ParamId> form_trim;
    for (const auto& ef : cur_effects) {
      if (fixed_effects.count(ef)) continue;
      const Sensor s = static_cast<Sensor>(ef.first);
      const Effect e = static_cast<Effect>(ef.second);
      std::vector<int> bad;
      std::string why;
      for (int a = 3 * ef.first; a < 3 * ef.first + 3; ++a) {
        double excess = 0, share = 0;
        const double lr = form_lr(cur, s, e, a, excess, share);
        if (std::getenv("IMUFORGE_DIAG_TRACE") && lr > kFormLr)
          std::fprintf(stderr, "form %s.%s %s: LR %.1f excess %.1f share %.3g\n", model::sensor_name(s), model::effect_info(e).name,
                       axis_name(a), lr, excess, share);
        if (!(lr > kFormLr && excess > 0 && lr >= 0.5 * excess && share >= kFormShare)) continue;
        if (why.empty()) {
          char buf[300];
          std::snprintf(buf, sizeof buf,
                        "what it leaves on %s is a nonlinear function of its own signal (square/cube LR %.1f on 2 dof, %.0f %% "
                        "of the remaining in-sample excess, %.2g of its own signal): the catalog form does not fit; an "
                        "out-of-catalog function of the same inputs",
                        axis_name(a), lr, 100.0 * lr / excess, share);
          why = buf;
        }
        bad.push_back(a);
      }
      if (!bad.empty()) withdraw_where_failed("form", "its form does not fit", s, e, bad, why, form_trim, form_drop);
    }
    for (ParamId id : form_trim) cur.erase(id);
    for (const auto& ef : form_drop) withdraw(ef);
  }
  // Output step (noise_model.h, output_step): on an axis rounded to a step the noise does not dither, the
  // rounding leaves each mean a bias that is a function of the input (a staircase of period one step). A
  // campaign that repeats its poses and rates at several temperatures repeats that function, so a catalog
  // effect of the same inputs can fit part of it (blind stochastic cases: misalign_temp at LR 64 and
  // scale_nonlinearity k3 at LR 36, each on its quantised axis alone). The segment bias in the noise model
  // takes it as independent per segment, which repeated inputs are not. An effect is withdrawn when what it changes
  // of the fit on a quantised axis is within twice the staircase's σ there and the sensor's other axes do not
  // show it on their own (GLS LR at the selection's Bonferroni level): it cannot be told from the rounding.
  {
    std::vector<std::pair<int, int>> step_drop;
    for (const auto& ef : cur_effects) {
      if (fixed_effects.count(ef)) continue;
      const Sensor s = static_cast<Sensor>(ef.first);
      const Effect e = static_cast<Effect>(ef.second);
      const std::set<ParamId> without = params_without(cur, s, e);
      double lr_rest = 0, rms_in = 0, sb_in = 0;
      int dof_rest = 0, a_in = -1;
      for (int a = 3 * ef.first; a < 3 * ef.first + 3; ++a) {
        const auto ua = static_cast<std::size_t>(a);
        const AxisData& ad = ax[ua];
        const Fit f_with = fit_axis(ad, cols_for(ad, cur), -1), f_without = fit_axis(ad, cols_for(ad, without), -1);
        // What the effect adds to the fit on this axis: the change of the fitted means with and without it, not
        // its own columns' signal, part of which only trades with the rest of the model (k3 f³ against the scale
        // on the ±1 g faces). The rounding has to mimic the change, not the trade (varied11 stoch-tactical-11
        // accel.y: a k2, k3 of signal rms 2.2e-4 changed the fit by 1.0e-4, staircase σ 9.1e-5; other axes LR 2.0).
        const double rms = B > 0 ? std::sqrt((fitted_means(ad, f_with) - fitted_means(ad, f_without)).squaredNorm() / B) : 0.0;
        if (within_rounding(ua, rms)) {
          a_in = a;
          rms_in = rms;
          sb_in = std::sqrt(R.stoch[ua].seg_bias_var);
        } else {
          lr_rest += std::max(f_without.rss - f_with.rss, 0.0);
          dof_rest += static_cast<int>(f_with.kept.size()) - static_cast<int>(f_without.kept.size());
        }
      }
      if (a_in < 0) continue;
      if (dof_rest > 0 && chi2_sf(lr_rest, dof_rest) < o.alpha / std::max<std::size_t>(1, candidates.size())) continue;
      char buf[360];
      std::snprintf(buf, sizeof buf,
                    "%s.%s withdrawn: on %s what it changes of the fit (rms %.2g) is within the rounding staircase of the output step "
                    "(sigma %.2g) and the sensor's other axes do not show it: it cannot be told from the rounding",
                    model::sensor_name(s), model::effect_info(e).name, axis_name(a_in), rms_in, sb_in);
      R.warnings.push_back(buf);
      R.withdrawn_by_check.push_back({effect_key(s, e), "within the output step's rounding"});
      step_drop.push_back(ef);
    }
    for (const auto& ef : step_drop) withdraw(ef);
  }
  // Significance under the whole log's wander. The selection judges on the dwells' noise, which at the log's
  // length is 1.2-14x too low where the log wanders more than the dwells show: a slow bias then passes for an
  // effect whose column drifts with the schedule (Ṫ, the hysteresis branch, a pose order). Each selected effect is
  // tested again with the wander measured on the model WITHOUT it (its null hypothesis; the sensor's other
  // axes as selected), on each axis where that wander is one diagnose() would carry (a line that passes the
  // checks, Allan ratio > 1.2 at a quarter of the log, −2 log L gain > 3.84) and larger than an adopted one. There
  // the test is the profile likelihood ratio: each hypothesis at the likelier of the axis's own noise (the adopted
  // wander where there is one) and that wander. Elsewhere it is the GLS LR under the axis's own noise, and an
  // effect with neither kind of axis (null wander, adopted wander) is not re-tested. Measured only with the effect
  // in the model (stops 28-35), the wander is what the effect left of it: an effect that took the slow bias for
  // itself (varied6 stoch-automotive-10: accel.temp_rate.z −0.060 ± 0.012 from a random walk of K 1.1e-4 that the
  // 6 s dwells read as flicker) hides the very wander that explains it, and it was never re-tested. The effects
  // re-tested are the family, at Holm's step-down levels (α / k for the smallest p, up to α for the largest). The
  // search over all candidates was made at α / m on the dwells' noise; this confirms what it found, it is not a
  // second search. Cost: two whole-log wander searches per axis of each selected effect.
  {
    struct AxisNoise {
      bool null_wander = false;  // tested under the wander measured without the effect
      StochasticModel sm;
      double rw0 = 0;
    };
    struct Retest {
      std::pair<int, int> ef;
      std::set<ParamId> without;  // the model without the effect
      std::array<AxisNoise, 3> an;
      double lr = 0, p = 1;
      int dof = 0;
    };
    std::vector<Retest> retest;
    for (const auto& ef : cur_effects) {
      if (fixed_effects.count(ef)) continue;
      std::set<ParamId> without = params_without(cur, static_cast<Sensor>(ef.first), static_cast<Effect>(ef.second));
      std::array<AxisNoise, 3> an;
      bool any = false;
      for (int k = 0; k < 3; ++k) {
        const int a = 3 * ef.first + k;
        const auto ua = static_cast<std::size_t>(a);
        any = any || R.wander[ua].adopted;
        if (!o.whole_log_wander) continue;
        const std::array<WholeLogWander, 3> lines = wander_lines(a, without);
        const WholeLogWander* pick = wander_pick(lines);
        if (!pick || *wander_reason(lines, *pick) || !pick->material()) continue;
        AxisNoise& n = an[static_cast<std::size_t>(k)];
        n.sm = with_wander(R.stoch[ua], pick, R.duration_s, R.rw_prior_var[ua], n.rw0);
        // An adopted wander at least as large (Allan variance at a quarter of the log) stands as it is: the
        // profile would let a smaller wander measured without the effect undercut the level the log was judged at.
        if (R.wander[ua].adopted && !(n.sm.avar(0.25 * R.duration_s) > verdict_stoch[ua].avar(0.25 * R.duration_s))) continue;
        n.null_wander = true;
        any = true;
      }
      if (any) retest.push_back({ef, std::move(without), an});
    }
    for (Retest& t : retest) {
      const std::pair<int, int>& ef = t.ef;
      const std::array<AxisNoise, 3>& an = t.an;
      const std::set<ParamId>& without = t.without;
      double& lr = t.lr;
      int& dof = t.dof;
      for (int k = 0; k < 3; ++k) {
        const int a = 3 * ef.first + k;
        const auto ua = static_cast<std::size_t>(a);
        const AxisNoise& n = an[static_cast<std::size_t>(k)];
        const AxisData& ad = (R.wander[ua].adopted && !n.null_wander ? axw : ax)[ua];
        const Fit f1 = fit_axis(ad, cols_for(ad, cur), -1), f0 = fit_axis(ad, cols_for(ad, without), -1);
        dof += static_cast<int>(f1.kept.size()) - static_cast<int>(f0.kept.size());
        if (!n.null_wander) {
          lr += std::max(f0.rss - f1.rss, 0.0);
          continue;
        }
        // The likelihood ratio with the noise profiled: each hypothesis at its likelier of the two noise levels
        // (the axis's own, the wander measured without the effect), −2 log L = Σ log S + χ² of the GLS fit.
        // Under the wander alone the effect's columns gain nothing a wander does not; a real effect stands at
        // the axis's own noise, where the wander measured without it (its signal read as wander) has no claim.
        const bool adopted = R.wander[ua].adopted;
        const StochasticModel& own = adopted ? verdict_stoch[ua] : R.stoch[ua];
        const double own_rw0 = adopted ? rw0_v[ua] : R.rw_prior_var[ua];
        const double l0 = std::min(gls_m2ll(ad, own, own_rw0, f0.kept, true), gls_m2ll(ad, n.sm, n.rw0, f0.kept, true));
        const double l1 = std::min(gls_m2ll(ad, own, own_rw0, f1.kept, true), gls_m2ll(ad, n.sm, n.rw0, f1.kept, true));
        lr += std::max(l0 - l1, 0.0);
      }
      t.p = dof > 0 ? chi2_sf(lr, dof) : 1.0;
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "under wander %s.%s: LR %.2f dof %d p %.3g (of %zu; wander without it on %d%d%d)\n",
                     model::sensor_name(static_cast<Sensor>(ef.first)), model::effect_info(static_cast<Effect>(ef.second)).name, lr, dof,
                     t.p, retest.size(), an[0].null_wander, an[1].null_wander, an[2].null_wander);
    }
    // Holm's step-down over the family: the i-th smallest p (from 0) stands at α / (k − i); the first that fails
    // fails every larger one with it. As family-wise as α / k for each, and an effect far past the level leaves
    // the others a level they can meet.
    std::stable_sort(retest.begin(), retest.end(), [](const Retest& x, const Retest& y) { return x.p < y.p; });
    std::vector<std::pair<int, int>> wander_drop;
    bool failed = false;
    for (std::size_t i = 0; i < retest.size(); ++i) {
      const Retest& t = retest[i];
      const double level = o.alpha / static_cast<double>(retest.size() - i);
      failed = failed || !(t.p < level);
      if (!failed) continue;
      const std::pair<int, int>& ef = t.ef;
      const double lr = t.lr, p = t.p;
      const int dof = t.dof;
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "%s.%s withdrawn: not significant under the whole log's bias wander (GLS LR %.1f on %d dof, p %.2g "
                    "against the level %.2g): a slow bias drifting with the schedule passes for it under the dwells' noise",
                    model::sensor_name(static_cast<Sensor>(ef.first)), model::effect_info(static_cast<Effect>(ef.second)).name, lr, dof, p,
                    level);
      R.warnings.push_back(buf);
      R.withdrawn_by_check.push_back({effect_key(static_cast<Sensor>(ef.first), static_cast<Effect>(ef.second)),
                                      "not significant under the whole log's wander"});
      wander_drop.push_back(ef);
    }
    for (const auto& ef : wander_drop) withdraw(ef);
  }
  // What axis a's held-out residual under the current model follows (period_s > 0: a sinusoid in time as well;
  // settle_tau_s > 0: a settling transient). pv_out: the held-out blocks' variances it was weighted by.
  auto signature_of = [&](int a, double period_s, double settle_tau_s, std::vector<double>* pv_out = nullptr) {
    std::vector<double> r, pv;
    const std::vector<int> cols = cols_for(ax[static_cast<std::size_t>(a)], cur);
    heldout_blocks(ax[static_cast<std::size_t>(a)], cols, folds, blocks, r, pv);
    Eigen::MatrixXd X(static_cast<Eigen::Index>(blocks.size()), static_cast<Eigen::Index>(cols.size()));
    for (std::size_t i = 0; i < cols.size(); ++i) X.col(static_cast<Eigen::Index>(i)) = ax[static_cast<std::size_t>(a)].Xr.col(cols[i]);
    if (pv_out) *pv_out = pv;
    return residual_signature(blocks, r, pv, period_s, settle_tau_s, &X);
  };
  // The final model's whole-log wander of axis a under `cur` (diagnose() decides whether to carry it): the line
  // picked, and why it is not stationary wander ("" when it is), filled as far as its rounding check; nullopt when
  // no line raises. Asked by the stand-in check (an axis named for a function its residual follows) and by the
  // final model's wander below, which keeps the stand-in check's answer while `cur` is unchanged.
  Eigen::MatrixXd follows_F;                // the functions the `follows` check asks, one column each (input_bias)
  std::vector<std::string> follows_names;  // and their names
  std::vector<int> temp_hats;               // the columns that are hats of the die temperature
  // After the library's columns (n_single of them, all the single `follows` check asks): each axis's own input
  // (f_j for accel axis j, ω_j for gyro) times each hat, the columns of a scale factor's curve in T.
  int n_single = 0;
  std::array<std::vector<int>, kNumAxes> scale_hats;
  // The `follows` check's functions, built once (the same for every axis); before two axes are assessed at once.
  auto build_follows = [&] {
    std::vector<double> pv_sig(static_cast<std::size_t>(B), 1.0);
    std::vector<SignatureFunction> feats = signature_functions(blocks, pv_sig);
    feats.erase(std::remove_if(feats.begin(), feats.end(), [](const SignatureFunction& f) { return f.first == "time"; }),
                feats.end());
    n_single = static_cast<int>(feats.size());
    for (int k = 0; k < n_single; ++k)
      if (is_temp_hat(feats[static_cast<std::size_t>(k)].first)) temp_hats.push_back(k);
    follows_F.resize(B, static_cast<Eigen::Index>(n_single + kNumAxes * static_cast<int>(temp_hats.size())));
    for (int k = 0; k < n_single; ++k) {
      follows_names.push_back(feats[static_cast<std::size_t>(k)].first);
      for (int b = 0; b < B; ++b) {
        const double v = feats[static_cast<std::size_t>(k)].second(blocks[static_cast<std::size_t>(b)]);
        follows_F(b, k) = std::isfinite(v) ? v : 0.0;
      }
    }
    for (int ax_i = 0; ax_i < kNumAxes; ++ax_i)
      for (int h : temp_hats) {
        const int k = static_cast<int>(follows_names.size());
        const int j = ax_i % 3;
        follows_names.push_back(std::string(ax_i < 3 ? "f_" : "w_") + "xyz"[j] + " * " + follows_names[static_cast<std::size_t>(h)]);
        for (int b = 0; b < B; ++b) {
          const Block& x = blocks[static_cast<std::size_t>(b)];
          follows_F(b, k) = (ax_i < 3 ? x.f[j] : x.w[j]) * follows_F(b, h);
        }
        scale_hats[static_cast<std::size_t>(ax_i)].push_back(k);
      }
  };
  // Within the held-out threshold, but what is left is neither a catalog effect nor stationary wander
  // (Options::wander_unexplained_*): the static dwells already took a slow periodic bias or a step for a random
  // walk, and the floor it raised hides the residual from the held-out χ².
  auto is_structured = [](const DiagnosisResult::Wander& w) {
    return w.beyond_reason == "jump" || w.beyond_reason == "periodic" || w.beyond_reason == "sinusoid" ||
           w.beyond_reason == "modulated" || w.beyond_reason == "drift" || w.beyond_reason == "settling" ||
           w.beyond_reason == "input" || w.beyond_reason == "follows";
  };
  // The period of the line an axis's residual is named for: the sinusoid that beat the raise ("sinusoid"), or the
  // line in what the raise leaves ("periodic"; the line's own period where its sinusoid was not fitted, the raise
  // being large enough to name the axis by itself). 0 for every other reason.
  auto line_period_of = [](const DiagnosisResult::Wander& w) {
    return w.beyond_reason == "sinusoid"   ? w.sinusoid.period_s
           : w.beyond_reason == "periodic" ? (w.sinusoid.period_s > 0 ? w.sinusoid.period_s : w.measured.line_period_s)
                                           : 0.0;
  };
  // The evidence of the shape a structured residual takes, by reason: the verdict names an axis within the
  // threshold when this or the raise's own gain reaches wander_unexplained_gain (a warm-up the first temperature
  // ramp mostly takes leaves a transient that a walk raised 4.6x gains only 15 for and the transient 41 beside it:
  // `unseen` ooc-warmup-0 accel.x), and the stand-in check asks the effects on such an axis about that shape.
  auto shape_gain_of = [](const DiagnosisResult::Wander& w) {
    return w.beyond_reason == "drift"       ? w.trend.line_gain
           : w.beyond_reason == "settling"  ? w.trend.settle_own_gain
           : w.beyond_reason == "follows"   ? w.follows.own_gain
           : w.beyond_reason == "modulated" ? w.modulated_own_gain
           : w.beyond_reason == "periodic"  ? w.sinusoid.gain
                                            : 0.0;
  };
  auto assess_wander = [&](int a) -> std::optional<DiagnosisResult::Wander> {
    const auto ua = static_cast<std::size_t>(a);
    const std::array<WholeLogWander, 3> lines = wander_lines(a, cur, true);
    auto reason = [&](const WholeLogWander& l) { return wander_reason(lines, l); };
    if (std::getenv("IMUFORGE_DIAG_TRACE"))
      for (const auto& l : lines)
        std::fprintf(stderr, "wander %s %s: ratio %.2f gain %.1f max|z| %.2f (next %.2f) LB p %.2g sum r^2 %.3f line p %.2g period %.0f s hetero LM %.1f p %.2g ratio %.2f\n",
                     axis_name(a), l.below_likelihood ? "floor" : l.kind == WholeLogWander::kFlicker ? "flicker" : l.kind == WholeLogWander::kRandomWalk ? "rw" : "none",
                     l.ratio, l.gain, l.max_abs_z, l.jump_persist_z, l.whiteness_p, l.autocorr_sq, l.line_p, l.line_period_s,
                     l.hetero_lm, l.hetero_p, l.hetero_ratio);
    const WholeLogWander* pick = wander_pick(lines);
    // No raise above the likelihood's level would be carried, but the whole log prefers a floor between the
    // dwells' point estimate and that level (noise_model.h, below_likelihood): the verdict's floor takes it.
    // Not where its own innovations' spread grows with the inputs as the raise's "input" check asks
    // (WholeLogWander::hetero_*; the size condition wander_hetero_min_raise is a raise's, and a floor never reaches it):
    // the floor then carries an input-dependent residual into the verdict's noise. `varied37` ooc-w_cubed-1: a gyro.y
    // bias in |w|^3 at held-out chi2/dof 6.83; the raises refused as too large, the floor (1.26x the dwells') took it
    // to 2.43 "in a GLS fit under the whole-log wander" and the axis went unnamed, though its innovations' spread was
    // 16x larger where the rate is (Breusch-Pagan p 2e-109). On 132 whole-catalog cases (varied36, varied37) no axis
    // outside an out-of-catalog term had a floor picked with p < 1e-10.
    // One test of the spread for both: the raise adds its size gate below.
    auto spread_follows_input = [&](const WholeLogWander& l) {
      return l.hetero_p < o.wander_max_hetero_p && l.hetero_ratio >= o.wander_hetero_ratio;
    };
    std::vector<int> follows_cols;  // the functions (columns of follows_F) the follows check names, when it does
    const WholeLogWander& floor = lines[2];
    if (floor.below_likelihood && !*reason(floor) && !spread_follows_input(floor) && floor.material() &&
        (!pick || *reason(*pick) || !pick->material()))
      pick = &floor;
    if (!pick) return std::nullopt;
    DiagnosisResult::Wander w = R.wander[ua];
    w.kind = pick->kind == WholeLogWander::kFlicker ? "flicker" : "random_walk";
    w.value = pick->kind == WholeLogWander::kFlicker ? pick->B : pick->K;
    w.measured = *pick;
    w.beyond_reason = reason(*pick);
    // As a reason, asked of the final model's raise only (the floor above is asked it before adoption): during
    // selection a catalog effect not yet in the model leaves the same
    // input-dependent spread, and the raise that takes it there is what the candidate's test is judged against.
    if (w.beyond_reason.empty() && !pick->below_likelihood && pick->material() && spread_follows_input(*pick) &&
        pick->ratio >= o.wander_hetero_min_raise)
      w.beyond_reason = "input";
    // A line in the innovations (reason "periodic") under a raise too small to name the axis: the static dwells
    // already read the periodic bias as wander (a walk or a flicker as large as it), so the whole log asks little
    // more of the level, and the line's own evidence is what the verdict weighs (below, as a drift's or a
    // settling's): the best sinusoid's likelihood gain beside the columns under the dwells' own level, as
    // periodic_bias asks it of a raise that passes. `unseen15` ooc-beat_chirp-0 gyro.z: a bias beating at 167 s
    // (7.4e-4 rad/s, its frequency following the die temperature) that the dwells took for a rate random walk of
    // K 4.2e-5 (the part's: 4e-9); the walk raised 1.19x gains 22.7 with a line at p 7.5e-11, the sinusoid 115, and
    // the axis went unnamed at held-out chi2/dof 0.83.
    if (w.beyond_reason == "periodic" && pick->gain < o.wander_unexplained_gain) {
      const AxisData& ad = ax[ua];
      const Fit f = fit_axis(ad, cols_for(ad, cur), -1);
      double rw0 = 0;
      const StochasticModel m0 = with_wander(R.stoch[ua], nullptr, R.duration_s, R.rw_prior_var[ua], rw0);
      w.sinusoid = periodic_bias(m0, blk_t, blk_dur, design_rows(ad, f.kept, 0), rw0, R.duration_s, &blk_seg);
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "periodic line %s: raise gain %.1f, line p %.2g at %.0f s; sine gain %.1f period %.0f s (%d periods)\n",
                     axis_name(a), pick->gain, pick->line_p, pick->line_period_s, w.sinusoid.gain, w.sinusoid.period_s,
                     w.sinusoid.n_periods);
    }
    // A raise that passes its checks and would be carried: is the residual it takes a sinusoid of a few cycles
    // rather than wander (noise_model.h, periodic_bias)? Asked of the raise alone: the verdict's floor is judged
    // from a different level, and a refused raise is not carried anyway.
    if (w.beyond_reason.empty() && !pick->below_likelihood && pick->material()) {
      const AxisData& ad = ax[ua];
      const Fit f = fit_axis(ad, cols_for(ad, cur), -1);
      double rw0 = 0;
      const StochasticModel m0 = with_wander(R.stoch[ua], nullptr, R.duration_s, R.rw_prior_var[ua], rw0);
      const Eigen::MatrixXd rows = design_rows(ad, f.kept, 0);
      w.sinusoid = periodic_bias(m0, blk_t, blk_dur, rows, rw0, R.duration_s, &blk_seg);
      w.trend = trend_bias(R.stoch[ua], blk_t, blk_dur, rows, R.rw_prior_var[ua], R.duration_s, *pick, &blk_seg);
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "periodic %s: pick %s gain %.1f evidence %.1f ratio %.2f | sine gain %.1f period %.0f s (%d periods) | modulated gain %.1f period %.0f s (%d windows) | trend gain %.1f, LR %.1f | settle LR %.1f tau %.0f s\n",
                     axis_name(a), pick->kind == WholeLogWander::kFlicker ? "flicker" : "rw", pick->gain, pick->evidence(),
                     pick->ratio, w.sinusoid.gain, w.sinusoid.period_s, w.sinusoid.n_periods, w.sinusoid.mod_gain,
                     w.sinusoid.mod_period_s, w.sinusoid.mod_windows, w.trend.line_gain, w.trend.gain,
                     w.trend.settle_gain, w.trend.settle_tau_s);
      if (w.sinusoid.gain - pick->gain > o.wander_sinusoid_margin)
        w.beyond_reason = "sinusoid";
      else if (std::max(w.trend.gain, w.trend.settle_gain) > o.wander_trend_chi2)
        w.beyond_reason = w.trend.gain >= w.trend.settle_gain ? "drift" : "settling";
      // A line whose amplitude changes through the log (noise_model.h, PeriodicBias::mod_*), asked as the
      // hats' curve is below: its stretches' columns together beside the raise, each profiled, on 2·windows dof,
      // the bar's χ²(1) tail halved and shared among the periods searched (the look-elsewhere count).
      if (w.beyond_reason.empty() && o.wander_modulated_chi2 > 0 && w.sinusoid.mod_windows >= 2) {
        const Eigen::MatrixXd mcols =
            modulated_sinusoid(blk_t, blk_dur, w.sinusoid.mod_period_s, w.sinusoid.mod_windows);
        const InputBias g = input_group_bias(R.stoch[ua], blk_t, blk_dur, rows, R.rw_prior_var[ua], R.duration_s, *pick,
                                             mcols, &blk_seg);
        w.modulated_gain = g.gain;
        w.modulated_own_gain = g.own_gain;
        const double p_group = g.n_functions > 0 ? chi2_sf(g.gain, g.n_functions) : 1.0;
        const double p_bar = 0.5 * chi2_sf(o.wander_modulated_chi2, 1.0) / std::max(1, w.sinusoid.n_periods);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "modulated %s: period %.0f s in %d stretches beside the raise LR %.1f (own %.1f) p %.2g, bar p %.2g\n",
                       axis_name(a), w.sinusoid.mod_period_s, w.sinusoid.mod_windows, g.gain, g.own_gain, p_group, p_bar);
        if (p_group < p_bar) w.beyond_reason = "modulated";
      }
      // Does the residual the raise takes follow a logged input (noise_model.h, input_bias)? The signature
      // library's functions, time left to the drift check above; the bar carries the look-elsewhere count.
      if (w.beyond_reason.empty() && o.wander_follows_chi2 > 0) {
        if (follows_names.empty()) build_follows();  // the same for every axis: built once
        w.follows = input_bias(R.stoch[ua], blk_t, blk_dur, rows, R.rw_prior_var[ua], R.duration_s, *pick,
                               follows_F.leftCols(n_single), &blk_seg);
        if (w.follows.best >= 0) w.follows_input = follows_names[static_cast<std::size_t>(w.follows.best)];
        const double bar = o.wander_follows_chi2 + 2.0 * std::log(std::max(1, w.follows.n_functions));
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "follows %s: %s LR %.1f (own %.1f) over %d functions, bar %.1f\n", axis_name(a),
                       w.follows_input.c_str(), w.follows.gain, w.follows.own_gain, w.follows.n_functions, bar);
        if (w.follows.gain > bar) {
          w.beyond_reason = "follows";
          follows_cols = {w.follows.best};
        }
        // The die temperature's hats together: a curve of T that no one hat draws (input_group_bias), at the
        // level of the bar above (its χ²(1) tail, halved: two such families are asked) on as many degrees of
        // freedom as hats. The family's live hats when it passes (gain and own_gain to w.follows), else 0.
        const double p_bar = 0.5 * chi2_sf(bar, 1.0);
        auto family_passes = [&](const std::vector<int>& cols, const char* what) {
          const InputBias g = input_group_bias(R.stoch[ua], blk_t, blk_dur, rows, R.rw_prior_var[ua], R.duration_s, *pick,
                                               follows_F(Eigen::all, cols), &blk_seg);
          const double p_group = g.n_functions > 0 ? chi2_sf(g.gain, g.n_functions) : 1.0;
          if (std::getenv("IMUFORGE_DIAG_TRACE"))
            std::fprintf(stderr, "follows %s: %s through %d hats LR %.1f (own %.1f) p %.2g, bar p %.2g\n", axis_name(a), what,
                         g.n_functions, g.gain, g.own_gain, p_group, p_bar);
          if (!(p_group < p_bar)) return 0;
          w.beyond_reason = "follows";
          follows_cols = cols;
          w.follows.gain = g.gain;
          w.follows.own_gain = g.own_gain;
          return g.n_functions;
        };
        int n_live = 0;
        if (w.beyond_reason.empty() && !temp_hats.empty() && (n_live = family_passes(temp_hats, "a curve in T")) > 0) {
          // The stand-in check asks one function, and the verdict names one: the hat the held-out residual's
          // signature ranks first (a partial correlation, as the verdict's "nearest" reads it).
          int best = temp_hats.front();
          for (const auto& e : signature_of(a, 0.0, 0.0)) {
            if (!is_temp_hat(e.input)) continue;
            const auto it = std::find(follows_names.begin(), follows_names.end(), e.input);
            if (it != follows_names.end()) best = static_cast<int>(it - follows_names.begin());
            break;
          }
          w.follows.best = best;
          w.follows.n_functions += 1;
          w.follows_input = "a curve in T through " + std::to_string(n_live) + " hats (nearest " +
                            follows_names[static_cast<std::size_t>(best)] + ")";
        }
        // The same of the axis's scale factor: its own input times each hat, together (a scale that departs from
        // the model's line in T over a few degrees, a drive loop's resonance crossing: `unseen6` ooc-scale_bump).
        // Named for the product the single check ranks first among them (the signature has no products).
        const std::vector<int>& sh = scale_hats[ua];
        if (w.beyond_reason.empty() && !sh.empty() && (n_live = family_passes(sh, "a scale curve in T")) > 0) {
          const InputBias one = input_bias(R.stoch[ua], blk_t, blk_dur, rows, R.rw_prior_var[ua], R.duration_s, *pick,
                                           follows_F(Eigen::all, sh), &blk_seg);
          const int best = sh[static_cast<std::size_t>(std::max(one.best, 0))];
          w.follows.best = best;
          w.follows.n_functions += 2;
          w.follows_input = "a scale curve in T through " + std::to_string(n_live) + " hats (nearest " +
                            follows_names[static_cast<std::size_t>(best)] + ")";
        }
      }
    }
    w.beyond_limit = !w.beyond_reason.empty();
    // A coarse output step's rounding bias is a function of the input (noise_model.h, output_step), and an input
    // the temperature carries slowly through the steps turns it into a slow oscillation of the means: a line or
    // a jump in the whole log's residual that is neither wander nor an effect outside the catalog (varied6
    // stoch-consumer-6 gyro.z: a line of period 284 s, residual rms 2.6e-4 beside a staircase sigma of 2.0e-4).
    // The output-step check's rule for an effect holds for this structure too: within twice the staircase's
    // sigma, the residual as a whole cannot be told from the rounding, and the axis is not named.
    // Where the residual follows a function of the inputs, the part of it that function takes is what is asked, as
    // the output-step check asks an effect what it changes of the fit: the rounding bias is itself a function of
    // the input and the die temperature (it moves as the bias curve carries each pose's mean through the steps), so
    // some function of the library matches it in part, on an axis whose static means also carry the dwells'
    // flicker, which the whole residual's rms counts. `varied39` stoch-consumer-3 accel.x: step 0.13 with 0.33
    // step of noise ahead, no deterministic effect at all; f_z*T passed the follows bar (LR 41.5 over 108
    // functions) and the axis was named, the whole residual's rms being above twice the staircase's sigma.
    if (is_structured(w) && R.quant[ua].coarse()) {
      const AxisData& ad = ax[ua];
      const Fit f = fit_axis(ad, cols_for(ad, cur), -1);
      const Eigen::VectorXd r = ad.zr - fitted_means(ad, f);
      w.residual_rms = B > 0 ? std::sqrt(r.squaredNorm() / B) : 0.0;
      double rms = w.residual_rms;
      if (w.beyond_reason == "follows" && !follows_cols.empty() && B > 0) {
        // The functions beside the model's columns (unweighted, as the residual's rms is): the rms of what they add
        // to the fitted means.
        Eigen::MatrixXd Xm(B, static_cast<Eigen::Index>(f.kept.size()));
        for (std::size_t i = 0; i < f.kept.size(); ++i) Xm.col(static_cast<Eigen::Index>(i)) = ad.Xr.col(f.kept[i]);
        Eigen::MatrixXd Xa(B, Xm.cols() + static_cast<Eigen::Index>(follows_cols.size()));
        Xa << Xm, follows_F(Eigen::all, follows_cols);
        const Eigen::VectorXd p0 = Xm.cols() > 0 ? Eigen::VectorXd(Xm * Xm.colPivHouseholderQr().solve(ad.zr))
                                                 : Eigen::VectorXd(Eigen::VectorXd::Zero(B));
        const Eigen::VectorXd p1 = Xa * Xa.colPivHouseholderQr().solve(ad.zr);
        w.shape_rms = std::sqrt((p1 - p0).squaredNorm() / B);
        rms = w.shape_rms;
      }
      w.within_rounding = within_rounding(ua, rms);
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "rounding %s: %s residual rms %.3g, shape rms %.3g, staircase sigma %.3g -> %s\n",
                     axis_name(a), w.beyond_reason.c_str(), w.residual_rms, w.shape_rms,
                     std::sqrt(R.stoch[ua].seg_bias_var), w.within_rounding ? "within" : "beyond");
    }
    return w;
  };
  std::array<std::optional<DiagnosisResult::Wander>, kNumAxes> wander_asked;
  std::array<std::optional<std::vector<int>>, kNumAxes> wander_asked_cols;  // the axis's columns they were asked under
  // assess_wander(a) under `cur`, asked once per model of the axis (a whole-log search): the unexplained check, the
  // stand-in check and the final model's wander ask the same question while the axis's columns are unchanged.
  // assess_wander(a) sees `cur` only through them (cols_for(ax[a], cur)), so an effect withdrawn from the other
  // sensor, or from this one where it has no column on a, does not ask it again (on the bench's 1 h table case
  // four of the six axes were asked twice for the same answer, 3 s of 41).
  auto wander_now = [&](int a) -> const std::optional<DiagnosisResult::Wander>& {
    const auto ua = static_cast<std::size_t>(a);
    std::vector<int> cols = cols_for(ax[ua], cur);
    if (!wander_asked_cols[ua] || *wander_asked_cols[ua] != cols) {
      wander_asked[ua] = assess_wander(a);
      wander_asked_cols[ua] = std::move(cols);
    }
    return wander_asked[ua];
  };
  // The effect's GLS LR on one axis against the model without it, both fitted to the blocks as whitened in `ad`, and
  // whether it is significant there at the selection's Bonferroni level. chi2_dof_without: that fit's χ²/dof.
  struct AxisLR {
    double lr = 0, chi2_dof_without = 0;
    int dof = 0;
    bool significant = false;
  };
  auto axis_lr = [&](const AxisData& ad, const std::set<ParamId>& without) {
    const Fit f_with = fit_axis(ad, cols_for(ad, cur), -1), f_without = fit_axis(ad, cols_for(ad, without), -1);
    AxisLR r;
    r.dof = static_cast<int>(f_with.kept.size()) - static_cast<int>(f_without.kept.size());
    r.lr = f_without.rss - f_with.rss;
    const double dof_without = static_cast<double>(ad.z.size()) - static_cast<double>(f_without.kept.size());
    r.chi2_dof_without = dof_without > 0 ? f_without.rss / dof_without : 0.0;
    r.significant = r.dof > 0 && r.lr > 0 && chi2_sf(r.lr, r.dof) < o.alpha / std::max<std::size_t>(1, candidates.size());
    return r;
  };
  // Which axes are unexplained is the verdict's rule (`over`): on the dwells' noise, and not whitened by an
  // adopted wander. On the dwells' noise alone, an axis whose whole-log wander the verdict adopts stayed "over"
  // here: its effects were withdrawn for leaving it unexplained, and the verdict then called it at noise, so a
  // true effect vanished behind a claim that was never made (varied random-0: gyro.scale_asymmetry at LR 213
  // under the wander, gyro.y 4.07 on the dwells' noise, 0.98 under the wander). The effects such an axis keeps
  // have passed the re-test under that wander above.
  //
  // Nor on an axis not yet adopted whose whole-log wander, asked under the model as selected (the effect in), the
  // final model would carry: a stationary raise (assess_wander, every check of the verdict's: structure, input,
  // follows, rounding) under which the model's GLS χ²/dof is within the threshold. The adoption is decided on the
  // final model, so an effect withdrawn here was never judged under the wander it leaves: without it the residual
  // follows the effect's own column and no raise is carried, and the axis stayed "over" for want of the raise its
  // withdrawal refused (`varied37` random-1: a true gyro.g_sensitivity at GLS LR 828 under the wander, gyro.y 3.58 on the
  // dwells' noise, whose Gauss–Markov of 100 s the dwells read as 8 s, 0.83 under the walk it would carry; withdrawn,
  // gyro.y was named for f_x, its own column). A stand-in leaves the out-of-catalog residual that the raise's checks
  // refuse. The effects kept this way are re-tested under that wander when the run under it repeats this.
  const Gap sel_gap = add_wander_chi2(gap_of(cur), cur);
  std::array<std::optional<AxisData>, kNumAxes> carried;  // such an axis, its blocks whitened under that wander
  auto over_here = [&](int a) { return over(sel_gap, a) && !carried[static_cast<std::size_t>(a)]; };
  bool withdrew = false;  // by the check below: the stand-in check then needs the gap again
  for (int si = 0; si < 2; ++si) {
    bool any_over = false;
    for (int a = 3 * si; a < 3 * si + 3; ++a) any_over = any_over || over(sel_gap, a);
    std::vector<std::pair<int, int>> sel_s;
    for (const auto& ef : cur_effects)
      if (ef.first == si && !fixed_effects.count(ef)) sel_s.push_back(ef);
    if (!any_over || sel_s.empty()) continue;
    if (o.whole_log_wander)
      for (int a = 3 * si; a < 3 * si + 3; ++a) {
        const auto ua = static_cast<std::size_t>(a);
        if (!over(sel_gap, a) || R.wander[ua].adopted) continue;
        const std::optional<DiagnosisResult::Wander>& w = wander_now(a);
        if (!w || w->beyond_limit || !w->measured.material()) continue;
        AxisData aw = ax[ua];
        double rw0 = 0;
        whiten_axis(aw, with_wander(R.stoch[ua], &w->measured, R.duration_s, R.rw_prior_var[ua], rw0), rw0);
        const double c = gls_chi2_dof(aw, cur);
        if (std::getenv("IMUFORGE_DIAG_TRACE"))
          std::fprintf(stderr, "over %s: the wander it would carry (%s %.3g, %.2fx) gives GLS chi2/dof %.3g\n", axis_name(a),
                       w->kind.c_str(), w->value, w->measured.ratio, std::isfinite(c) ? c : 0.0);
        if (c <= o.unexplained_chi2_dof) carried[ua] = std::move(aw);
      }
    std::vector<std::pair<int, int>> drop;
    for (const auto& ef : sel_s) {
      const std::set<ParamId> without = params_without(cur, static_cast<Sensor>(ef.first), static_cast<Effect>(ef.second));
      const Gap g0 = gap_of(without);
      bool explains = false;
      for (int a = 3 * si; a < 3 * si + 3; ++a) {
        const double c0 = g0.chi2_dof[static_cast<std::size_t>(a)];
        const double c1 = sel_gap.chi2_dof[static_cast<std::size_t>(a)];
        const double shrink = pos(c0 - 1.0) - pos(c1 - 1.0);
        if (over_here(a)) {
          explains = explains || (shrink > 0 && shrink >= (1.0 - o.unexplained_keep_frac) * pos(c0 - 1.0));
        } else if (const AxisData* aw_p = carried[static_cast<std::size_t>(a)] ? &*carried[static_cast<std::size_t>(a)]
                                          : R.wander[static_cast<std::size_t>(a)].adopted && c1 > o.unexplained_chi2_dof
                                              ? &axw[static_cast<std::size_t>(a)]
                                              : nullptr) {
          // An axis at noise only under a wander (adopted, or the one it would carry) is judged under it: on the
          // dwells' noise it is over the threshold with the effect or without, so "needed to explain it" says nothing
          // there. The effect stays when without it the GLS χ²/dof under that wander is over the threshold, or when
          // it is significant there (GLS LR at the selection's Bonferroni level). `unseen14` mixed-drive_current
          // accel.y: a true k2 (snr 38) beside accel.scale_asymmetry, which the sensor does not have, at 3.23 -> 3.21
          // on the dwells' noise, 0.82 under the wander without it (LR 3.9 on 1 dof).
          const AxisLR l = axis_lr(*aw_p, without);
          explains = explains || l.chi2_dof_without > o.unexplained_chi2_dof || l.significant;
          if (std::getenv("IMUFORGE_DIAG_TRACE"))
            std::fprintf(stderr, "  under the wander of %s: chi2/dof without %.3g, LR %.1f on %d dof\n", axis_name(a),
                         l.chi2_dof_without, l.lr, l.dof);
        } else {
          explains = explains || c0 > o.unexplained_chi2_dof || shrink >= 1.0;
          // On an axis the out-of-catalog signal does not reach, the effect's own evidence there: significant on
          // that axis alone (GLS LR at the selection's Bonferroni level) and a better held-out fit. A real effect
          // of a sensor whose OTHER axis is unexplained stays (an accelerometer hysteresis of 100 σ beside a bias
          // ∝ |ω| on x: 1.88 → 0.11 on y, withdrawn before); a stand-in for that other axis's signal has no
          // evidence of its own here.
          if (!explains && c1 < c0) explains = axis_lr(ax[static_cast<std::size_t>(a)], without).significant;
        }
      }
      if (std::getenv("IMUFORGE_DIAG_TRACE")) {
        std::fprintf(stderr, "withdraw? %s.%s explains=%d", model::sensor_name(static_cast<Sensor>(ef.first)),
                     model::effect_info(static_cast<Effect>(ef.second)).name, explains ? 1 : 0);
        for (int a = 3 * si; a < 3 * si + 3; ++a)
          std::fprintf(stderr, " %s %.3g->%.3g", axis_name(a), g0.chi2_dof[static_cast<std::size_t>(a)],
                       sel_gap.chi2_dof[static_cast<std::size_t>(a)]);
        std::fprintf(stderr, "\n");
      }
      if (!explains) drop.push_back(ef);
    }
    for (const auto& ef : drop) withdraw(ef);
    withdrew = withdrew || !drop.empty();
  }
  // Stand-in (encompassing) check. An effect kept on an axis that stays unexplained may be there for the share of
  // the out-of-catalog function its columns can take, not for a signal of its own: `varied17` ooc-abs_rate-1, an
  // accel.y bias ∝ |ω| (no catalog effect has it), took accel.size_effect (ω² terms) for 65 % of its held-out
  // excess; the axis stayed at held-out χ²/dof 14.1 and its signature read |w| at r = 0.85, and accel.x and z were
  // "explained by size_effect" at 0 % shrink. The unexplained check above keeps such an effect, since it removes
  // enough of the excess. Here the function the axis's residual follows (its signature's first entry at |r| ≥ 0.3
  // among the logged inputs' functions; not time, which temperature and the wander share, nor "segment") enters
  // that axis's GLS fit as a free column g, and each selected effect with components there is tested against it:
  //   - the effect given g: its components' LR, at the selection's level (α over the candidates);
  //   - g given the effect: the column's LR, at the same level.
  // The effect is a stand-in on that axis when g stays significant beside it and it is not significant beside g:
  // g carries what the effect took, and the effect cannot carry g. When each is redundant given the other (g and
  // the effect's columns collinear on this campaign) the catalog effect stays. A true effect beside an
  // out-of-catalog term on its axis keeps its own LR beside g (the term's function is not its signal). A stand-in
  // is withdrawn, or its components on the failing axes alone when it stands on its sensor's other axes by itself
  // (withdraw_where_failed). Its axis then faces the verdict with it gone.
  {
    const double level = o.alpha / static_cast<double>(std::max<std::size_t>(1, candidates.size()));
    const Gap now_gap = withdrew ? add_wander_chi2(gap_of(cur), cur) : sel_gap;
    std::vector<std::pair<int, int>> standin_drop;
    std::vector<ParamId> standin_trim;
    for (int si = 0; si < 2; ++si) {
      std::vector<std::pair<int, int>> sel_s;
      for (const auto& ef : cur_effects)
        if (ef.first == si && !fixed_effects.count(ef)) sel_s.push_back(ef);
      if (sel_s.empty()) continue;
      // The function g of each unexplained axis (per block, scaled to unit peak), its name, and the noise model
      // the axis was judged under: the dwells' on the held-out χ², the refused raise where the residual follows
      // an input.
      std::array<Eigen::MatrixXd, 3> gcol;  // one column, or a line's sine and cosine (its phase free)
      std::array<std::string, 3> gname;
      std::array<StochasticModel, 3> gnoise;
      std::array<double, 3> grw{};
      for (int a = 3 * si; a < 3 * si + 3; ++a) {
        const auto ua = static_cast<std::size_t>(a), ka = static_cast<std::size_t>(a - 3 * si);
        gnoise[ka] = R.stoch[ua];
        grw[ka] = R.rw_prior_var[ua];
        if (!over(now_gap, a)) {
          // Within the held-out threshold, an axis the final model's wander would name for following a function
          // of the inputs (`follows`): what the catalog effects kept there took of that function is asked the
          // same way, under the raise the function beat (`varied23` ooc-abs_rate-1: accel.y ∝ |ω| named on |w|
          // at 113, beside accel.size_effect and cross_coupling that the sensor does not have).
          bool touched = false;
          for (const auto& ef : sel_s) touched = touched || !ids_on_axis(static_cast<Sensor>(ef.first), static_cast<Effect>(ef.second), a).empty();
          if (!touched || !o.whole_log_wander || R.wander[ua].adopted) continue;
          const std::optional<DiagnosisResult::Wander>& w = wander_now(a);
          if (!w || w->within_rounding) continue;
          const bool named = std::max(w->measured.gain, shape_gain_of(*w)) >= o.wander_unexplained_gain;
          if (w->beyond_reason == "follows" && w->follows.best >= 0 && named) {
            const Eigen::VectorXd g = follows_F.col(w->follows.best);
            const double gmax = g.cwiseAbs().maxCoeff();
            if (!(gmax > 0)) continue;
            gcol[ka] = g / gmax;
            gname[ka] = w->follows_input;
            gnoise[ka] = with_wander(R.stoch[ua], &w->measured, R.duration_s, R.rw_prior_var[ua], grw[ka]);
            continue;
          }
          // Named for a line: a sinusoid that beat the raise ("sinusoid"), or a line in what the raise leaves
          // ("periodic"). g is the sinusoid at its period, sine and cosine (its phase free), asked under the raise as a
          // followed function is. `varied40` ooc-periodic-1: an accel.z bias of period 536 s (blindgen SNR 560), named
          // for its line at held-out chi2/dof 1.19, beside accel.temp_rate, which the sensor does not have: its z
          // component took the line's share that Ṫ follows (0.030 +/- 0.005), and accel.x and y read "explained by
          // temp_rate" with components of 1.3 and 0.9 sigma.
          const double line_period_s = line_period_of(*w);
          if (line_period_s > 0 && named) {
            gcol[ka] = modulated_sinusoid(blk_t, blk_dur, line_period_s, 1);
            char nm[64];
            std::snprintf(nm, sizeof nm, "a sinusoid of period %.0f s", line_period_s);
            gname[ka] = nm;
            gnoise[ka] = with_wander(R.stoch[ua], &w->measured, R.duration_s, R.rw_prior_var[ua], grw[ka]);
            continue;
          }
          // Named because what is left grows with the input ("input"): no one function beat the raise, and the raise
          // is refused, so the axis is judged at the dwells' level; the function is the held-out residual's, as on an
          // axis over the threshold (below). The misalignment step of the test
          // AMisalignmentThatStepsMidRunIsNotReadAsATemperatureCoefficient at 5e-5 rad: the temperature coefficient
          // takes enough that the rest reads as a spread growing with ω_y.
          if (w->beyond_reason != "input" || w->measured.gain < o.wander_unexplained_gain) continue;
        }
        std::vector<double> pva;
        const std::vector<SignatureEntry> sig = signature_of(a, 0.0, 0.0, &pva);
        const std::vector<SignatureFunction> fns = signature_functions(blocks, pva);
        for (const SignatureFunction* fn : signature_leaders(sig, fns)) {
          if (fn->first == "time") continue;
          Eigen::VectorXd g(B);
          bool finite = true;
          for (int b = 0; b < B; ++b) {
            g[b] = fn->second(blocks[static_cast<std::size_t>(b)]);
            finite = finite && std::isfinite(g[b]);
          }
          const double gmax = g.cwiseAbs().maxCoeff();
          if (!finite || !(gmax > 0)) continue;
          gcol[static_cast<std::size_t>(a - 3 * si)] = g / gmax;
          gname[static_cast<std::size_t>(a - 3 * si)] = fn->first;
          break;
        }
      }
      for (const auto& ef : sel_s) {
        const Sensor s = static_cast<Sensor>(ef.first);
        const Effect e = static_cast<Effect>(ef.second);
        std::vector<int> bad;
        std::string why;
        for (int a = 3 * si; a < 3 * si + 3; ++a) {
          const auto ua = static_cast<std::size_t>(a);
          if (gname[ua - 3 * static_cast<std::size_t>(si)].empty() || ids_on_axis(s, e, a).empty()) continue;
          const AxisData& ad = ax[ua];
          const Fit f = fit_axis(ad, cols_for(ad, cur), -1);
          const int P = static_cast<int>(f.kept.size());
          const auto ka = ua - 3 * static_cast<std::size_t>(si);
          const int ng = static_cast<int>(gcol[ka].cols());
          Eigen::MatrixXd rows = design_rows(ad, f.kept, ng);
          rows.middleCols(P + 1, ng) = gcol[ka];
          std::vector<int> all, no_e, no_g;
          for (int i = 0; i < P; ++i) {
            const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i)])]);
            all.push_back(i);
            no_g.push_back(i);
            if (!(pi.sensor == s && pi.effect == e)) no_e.push_back(i);
          }
          for (int i = P; i < P + ng; ++i) {
            all.push_back(i);
            no_e.push_back(i);
          }
          std::string g_label = gname[ka];
          estimator::NormalEquations ne = gls_normal_equations(gnoise[ka], blk_t, blk_dur, rows, grw[ka], &blk_seg);
          // A sensitivity that changed during the run changed gradually (an input times time, the library's) or at
          // once: the package slipping on its mount, a misalignment step (`unseen9` ooc-mount_slip-1 gyro.z, ω_y
          // from mid-run on, named on ω_y·time at r 0.53 while gyro.misalign_temp took 71 % of it through the cold
          // half). The input times a step at t0 is asked too, t0 on the blocks' times between the 5th and 95th
          // percentile (step_t0_grid), the likeliest beside the model without the effect; the step replaces the line
          // where it fits better there.
          int k = -1;
          bool is_f = false;
          if (ng == 1 && is_input_times_time(g_label, k, is_f)) {
            double best_rss = estimator::fit_subset(ne, no_e).rss, best_t0 = std::numeric_limits<double>::quiet_NaN();
            Eigen::MatrixXd rs = rows;
            for (const double t0 : step_t0_grid(blocks)) {
              const Eigen::VectorXd g = input_step(blocks, k, is_f, t0);
              const double gm = g.cwiseAbs().maxCoeff();
              if (!(gm > 0)) continue;
              rs.col(P + 1) = g / gm;
              const double rss =
                  estimator::fit_subset(gls_normal_equations(gnoise[ka], blk_t, blk_dur, rs, grw[ka], &blk_seg), no_e).rss;
              if (rss < best_rss) best_rss = rss, best_t0 = t0;
            }
            if (std::isfinite(best_t0)) {
              const Eigen::VectorXd g = input_step(blocks, k, is_f, best_t0);
              rows.col(P + 1) = g / g.cwiseAbs().maxCoeff();
              ne = gls_normal_equations(gnoise[ka], blk_t, blk_dur, rows, grw[ka], &blk_seg);
              g_label = step_name(g_label, best_t0, best_t0, blocks);
            }
          }
          const estimator::SubsetFit f_all = estimator::fit_subset(ne, all), f_no_e = estimator::fit_subset(ne, no_e),
                                     f_no_g = estimator::fit_subset(ne, no_g);
          const int dof_e = static_cast<int>(f_all.kept.size()) - static_cast<int>(f_no_e.kept.size());
          const int dof_g = static_cast<int>(f_all.kept.size()) - static_cast<int>(f_no_g.kept.size());
          const double lr_e = std::max(f_no_e.rss - f_all.rss, 0.0), lr_g = std::max(f_no_g.rss - f_all.rss, 0.0);
          const double p_e = dof_e > 0 ? chi2_sf(lr_e, dof_e) : 1.0, p_g = dof_g > 0 ? chi2_sf(lr_g, dof_g) : 1.0;
          if (std::getenv("IMUFORGE_DIAG_TRACE"))
            std::fprintf(stderr, "standin %s.%s %s vs %s: effect|g LR %.1f on %d dof p %.2g; g|effect LR %.1f p %.2g (level %.2g)\n",
                         model::sensor_name(s), model::effect_info(e).name, axis_name(a), g_label.c_str(), lr_e, dof_e, p_e,
                         lr_g, p_g, level);
          if (!(p_g < level && p_e >= level)) continue;
          if (why.empty()) {
            char buf[300];
            std::snprintf(buf, sizeof buf,
                          "a stand-in for what %s follows (%s): beside that function it is not significant (LR %.1f on %d dof, "
                          "p %.2g) and the function still is (LR %.1f)",
                          axis_name(a), g_label.c_str(), lr_e, dof_e, p_e, lr_g);
            why = buf;
          }
          bad.push_back(a);
        }
        if (!bad.empty())
          withdraw_where_failed("standin", "a stand-in for an out-of-catalog function", s, e, bad, why, standin_trim, standin_drop);
      }
    }
    for (ParamId id : standin_trim) cur.erase(id);
    for (const auto& ef : standin_drop) withdraw(ef);
  }
  R.gap_after = gap_verdict(cur);
  R.final_ids = cur;
  for (int a = 0; a < kNumAxes; ++a) {
    if (!over(R.gap_after, a)) continue;
    Unexplained u;
    u.axis = axis_name(a);
    u.chi2_dof_after = R.gap_after.chi2_dof[static_cast<std::size_t>(a)];
    u.withdrawn = withdrawn[static_cast<std::size_t>(a / 3)];
    u.signature = signature_of(a, 0.0, 0.0);
    R.unexplained.push_back(u);
  }

  // ---- In-sample gain without held-out gain. A first-step candidate far past the level in-sample whose held-out
  // shrink is ≤ 0 is a contradiction the ranking must not leave unexplained (the issue's timing case: ΔBIC −6414,
  // shrink −64 %). It is scored again against the final model: gone there, its first-step gain was the signal of
  // effects selected later, borrowed through correlated columns; still there, it fits the training folds and
  // not the withheld ones (columns nearly collinear with the model's on this campaign, so a fold fit
  // extrapolates). On the four blind suites 68 candidates of 327 logs are such (gyro.misalign_temp 15, ...).
  {
    const double level0 = R.alpha_per_candidate();
    for (auto& c : R.ranking) {
      if (!c.excitable || !(c.p_value < level0) || c.heldout_shrink_pct > 0) continue;
      const auto [s, e] = effect_of(c.sensor, c.effect);
      if (cur_effects.count({static_cast<int>(s), static_cast<int>(e)})) continue;
      const CandidateScore f = score_one(cur, s, e);
      c.final_p = f.p_value;
      c.final_shrink_pct = f.heldout_shrink_pct;
    }
  }

  // ---- Final parameters on all data.
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& ad = ax[static_cast<std::size_t>(a)];
    Fit f = fit_axis(ad, cols_for(ad, cur), -1);
    for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) {
      const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(f.kept[static_cast<std::size_t>(i)])]);
      ParamEstimate pe;
      pe.name = pi.name;
      pe.axis = axis_name(a);
      pe.value = f.theta[i];
      pe.sigma = std::sqrt(std::max(f.cov(i, i), 0.0));
      R.final_params.push_back(pe);
    }
  }

  // ---- Whole-log wander of the final model (diagnose() decides whether to carry it).
  // Two axes' questions at once (concurrency.h): each reads only what no one writes while they run (the blocks, the
  // axis's own data, the model's columns, the `follows` functions built first). Not under IMUFORGE_DIAG_TRACE, whose
  // lines would interleave.
  if (o.whole_log_wander && concurrency_allowed() && !std::getenv("IMUFORGE_DIAG_TRACE")) {
    std::vector<int> todo;
    std::array<std::vector<int>, kNumAxes> todo_cols;
    for (int a = 0; a < kNumAxes; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      if (R.wander[ua].adopted) continue;
      todo_cols[ua] = cols_for(ax[ua], cur);
      if (!wander_asked_cols[ua] || *wander_asked_cols[ua] != todo_cols[ua]) todo.push_back(a);
    }
    if (todo.size() >= 2) {
      if (o.wander_follows_chi2 > 0 && follows_names.empty()) build_follows();
      // Each side writes its own axis's slot, so the two never write the same memory.
      for (std::size_t i = 0; i + 1 < todo.size(); i += 2) {
        const auto a0 = static_cast<std::size_t>(todo[i]), a1 = static_cast<std::size_t>(todo[i + 1]);
        run_concurrently([&] { wander_asked[a1] = assess_wander(static_cast<int>(a1)); },
                         [&] { wander_asked[a0] = assess_wander(static_cast<int>(a0)); });
        wander_asked_cols[a0] = todo_cols[a0];
        wander_asked_cols[a1] = todo_cols[a1];
      }
    }
  }
  if (o.whole_log_wander)
    for (int a = 0; a < kNumAxes; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      if (R.wander[ua].adopted) continue;
      const std::optional<DiagnosisResult::Wander> asked = wander_now(a);
      if (!asked) continue;
      auto& w = R.wander[ua];
      w = *asked;
      const bool structured = is_structured(w);
      // An axis already named on its held-out χ² whose residual is that sinusoid or transient: its signature gets it.
      const double sig_period_s = w.beyond_reason == "modulated" ? w.sinusoid.mod_period_s : line_period_of(w);
      const double sig_tau_s = w.beyond_reason == "settling" ? w.trend.settle_tau_s : 0.0;
      if ((sig_period_s > 0 || sig_tau_s > 0) && over(R.gap_after, a))
        for (auto& u : R.unexplained)
          if (u.axis == axis_name(a)) u.signature = signature_of(a, sig_period_s, sig_tau_s);
      // The whole log rejects the model's own level decisively: by the raise's gain, or by its shape's own
      // (shape_gain_of: the drift's, the settling's, the followed function's, the line's sinusoid where the dwells
      // took a periodic bias for wander).
      if (structured && !w.within_rounding && std::max(w.measured.gain, shape_gain_of(w)) >= o.wander_unexplained_gain &&
          !over(R.gap_after, a)) {
        Unexplained u;
        u.axis = axis_name(a);
        u.chi2_dof_after = R.gap_after.chi2_dof[ua];
        u.basis = "wander";
        u.signature = signature_of(a, sig_period_s, sig_tau_s);
        R.unexplained.push_back(u);
      }
    }

  // ---- Magnitude sensitivity. A catalog effect that is not selected but that the data cannot exclude
  // either (p < 0.5 against the final model, unadjusted) may still be there; when adding it moves a selected
  // effect's magnitude by more than 3σ, that σ does not cover what the campaign cannot separate (campaign-eol:
  // gyro scale_asymmetry 2.5e-5 ± 2.2e-5 for a truth of 4e-4, the sensor's unselected k2 ω² absorbed by it).
  // Reported, never used to change the selection.
  {
    std::set<std::pair<int, int>> selected_effects;
    for (const auto& st : R.selected) {
      const auto [ss, se] = effect_of(st.sensor, st.effect);
      selected_effects.insert({static_cast<int>(ss), static_cast<int>(se)});
    }
    for (auto [s, e] : candidates) {
      if (cur_effects.count({static_cast<int>(s), static_cast<int>(e)})) continue;
      bool sensor_has_selection = false;
      for (const auto& se : selected_effects) sensor_has_selection = sensor_has_selection || se.first == static_cast<int>(s);
      if (!sensor_has_selection) continue;
      const CandidateScore c = score_one(cur, s, e);
      if (!c.excitable || !(c.p_value < 0.5)) continue;
      const std::vector<ParamId>& eids = candidate_params(s, e);
      const int a0 = s == Sensor::kAccel ? 0 : 3;
      // Every component of a selected effect is kept; an effect is reported whole when any of its components
      // moves by > 3σ (one dependence, seen most on some axes).
      std::vector<std::pair<std::pair<int, int>, DiagnosisResult::Sensitivity>> all;  // (selected effect, entry)
      std::set<std::pair<int, int>> moved;
      for (int a = a0; a < a0 + 3; ++a) {
        const auto& ad = ax[static_cast<std::size_t>(a)];
        const Fit f0 = fit_axis(ad, cols_for(ad, cur), -1);
        const Fit f1 = fit_axis(ad, cols_for(ad, cur, eids), -1);
        std::map<int, double> with;
        for (int i = 0; i < static_cast<int>(f1.kept.size()); ++i) with[f1.kept[static_cast<std::size_t>(i)]] = f1.theta[i];
        for (int i = 0; i < static_cast<int>(f0.kept.size()); ++i) {
          const int col = f0.kept[static_cast<std::size_t>(i)];
          const auto& pi = model::param_info(ad.cols[static_cast<std::size_t>(col)]);
          if (!selected_effects.count({static_cast<int>(pi.sensor), static_cast<int>(pi.effect)})) continue;
          const double sig = std::sqrt(std::max(f0.cov(i, i), 0.0));
          auto it = with.find(col);
          if (it == with.end() || !(sig > 0)) continue;
          const double shift = std::fabs(it->second - f0.theta[i]) / sig;
          const std::pair<int, int> owner{static_cast<int>(pi.sensor), static_cast<int>(pi.effect)};
          if (shift > 3.0) moved.insert(owner);
          DiagnosisResult::Sensitivity sv;
          sv.name = pi.name;
          sv.axis = axis_name(a);
          sv.value = f0.theta[i];
          sv.sigma = sig;
          sv.value_with = it->second;
          sv.shift_sigma = shift;
          sv.alternative = c.sensor + "." + c.effect;
          sv.p_alternative = c.p_value;
          all.push_back({owner, sv});
        }
      }
      for (const auto& [owner, sv] : all)
        if (moved.count(owner)) R.sensitivity.push_back(sv);
    }
    std::map<std::string, std::pair<std::string, double>> worst;  // selected effect → (alternative, max shift)
    for (const auto& sv : R.sensitivity) {
      const std::string eff = sv.name.substr(0, sv.name.find('.', sv.name.find('.') + 1));
      if (!(sv.shift_sigma > 3.0)) continue;
      auto& w = worst[eff + " / " + sv.alternative];
      if (sv.shift_sigma > w.second) w = {sv.name + "@" + sv.axis, sv.shift_sigma};
    }
    for (const auto& [pair, w] : worst) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.0f", w.second);
      R.warnings.push_back("magnitudes depend on an effect the campaign can neither confirm nor exclude (" + pair +
                           "): adding the second moves " + w.first + " by " + buf +
                           " sigma; its sigma does not cover that (magnitude_sensitivity in diagnosis.json)");
    }
  }

  // ---- Cells: held-out residuals of the base model per axis × condition.
  std::array<std::vector<double>, kNumAxes> rb, pvb;
  for (int a = 0; a < kNumAxes; ++a)
    heldout_blocks(ax[static_cast<std::size_t>(a)], cols_for(ax[static_cast<std::size_t>(a)], model_ids), folds, blocks,
                   rb[static_cast<std::size_t>(a)], pvb[static_cast<std::size_t>(a)]);
  double maxu[kNumAxes] = {}, maxw = 0;
  for (const auto& b : blocks) {
    for (int a = 0; a < kNumAxes; ++a) maxu[a] = std::max(maxu[a], std::fabs(nominal_input(b.f, b.w, a)));
    maxw = std::max(maxw, b.absw);
  }
  using Pred = std::function<bool(const Block&, int)>;
  struct CellDef {
    std::string cond, label;
    Pred pred;
  };
  std::vector<CellDef> defs;
  {
    std::set<int> segs;
    for (const auto& b : blocks) segs.insert(b.segment);
    for (int sg : segs) defs.push_back({"segment", sg < 0 ? "moving" : "seg " + std::to_string(sg), [sg](const Block& b, int) { return b.segment == sg; }});
    const char* ilab[5] = {"u<<0", "u<0", "u~0", "u>0", "u>>0"};
    for (int i = 0; i < 5; ++i)
      defs.push_back({"input", ilab[i], [i, &maxu](const Block& b, int a) {
                        const double u = nominal_input(b.f, b.w, a), S = std::max(maxu[a], 1e-12);
                        const double r = u / S;
                        const int bin = r < -0.6 ? 0 : r < -0.1 ? 1 : r <= 0.1 ? 2 : r <= 0.6 ? 3 : 4;
                        return bin == i;
                      }});
    const char* rlab[4] = {"static", "low", "mid", "high"};
    for (int i = 0; i < 4; ++i)
      defs.push_back({"rate", rlab[i], [i, maxw](const Block& b, int) {
                        const int bin = b.absw < 0.01 ? 0 : b.absw < 0.33 * maxw ? 1 : b.absw < 0.67 * maxw ? 2 : 3;
                        return bin == i;
                      }});
    for (int i = 0; i < static_cast<int>(plateau_T.size()); ++i) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.1f C", plateau_T[static_cast<std::size_t>(i)]);
      defs.push_back({"plateau", buf, [i, &plateau_of](const Block& b, int) { return plateau_of(b.T) == i; }});
    }
    if (!plateau_T.empty()) {
      const char* tl[3] = {"cooling", "steady", "heating"};
      for (int i = 0; i < 3; ++i)
        defs.push_back({"temp_rate", tl[i], [i](const Block& b, int) {
                          const int bin = b.Tdot < -0.002 ? 0 : b.Tdot > 0.002 ? 2 : 1;
                          return bin == i;
                        }});
    }
    const double D = std::max(R.duration_s, 1e-9);
    for (int i = 0; i < 5; ++i)
      defs.push_back({"time", std::to_string(i * 20) + "-" + std::to_string(i * 20 + 20) + "%", [i, D](const Block& b, int) {
                        return std::min(4, static_cast<int>(5.0 * b.t / D)) == i;
                      }});
  }
  const double t_log = blocks.empty() ? 0.0 : blocks.front().t0;
  for (int a = 0; a < kNumAxes; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    std::vector<double> ct, cd, cu, cdiag;
    std::vector<int> cseg;
    // Each block's own variance in a cell: its held-out one, with the verdict's marginal (its random walk from
    // the log's start, as across blocks) in place of the selection's. Once per block, whatever the cells.
    std::vector<double> own(static_cast<std::size_t>(B));
    for (int b = 0; b < B; ++b) {
      const double t = blocks[static_cast<std::size_t>(b)].t, dur = blk_dur[static_cast<std::size_t>(b)];
      own[static_cast<std::size_t>(b)] =
          pvb[ua][static_cast<std::size_t>(b)] - ax[ua].vr[b] + block_covariance(verdict_stoch[ua], t, dur, t, dur, true, t_log, rw0_v[ua]);
    }
    for (const auto& d : defs) {
      Cell c;
      c.condition = d.cond;
      c.label = d.label;
      c.axis = a;
      double sw = 0, swr = 0, sr2 = 0;
      ct.clear(), cd.clear(), cu.clear(), cdiag.clear(), cseg.clear();
      for (int b = 0; b < B; ++b) {
        const Block& blk = blocks[static_cast<std::size_t>(b)];
        if (!d.pred(blk, a)) continue;
        const double r = rb[ua][static_cast<std::size_t>(b)], pv = pvb[ua][static_cast<std::size_t>(b)];
        sw += 1.0 / pv;
        swr += r / pv;
        sr2 += r * r / pv;
        ++c.n_blocks;
        // The mean's standard error under the verdict's noise: the blocks of a cell share the slow bias
        // (noise_model.h weighted_sum_variance).
        ct.push_back(blk.t), cd.push_back(blk_dur[static_cast<std::size_t>(b)]), cu.push_back(1.0 / pv), cseg.push_back(blk.unit);
        cdiag.push_back(own[static_cast<std::size_t>(b)]);
      }
      if (c.n_blocks == 0) continue;
      c.mean = swr / sw;
      const double var = weighted_sum_variance(verdict_stoch[ua], ct, cd, cseg, cu, cdiag, t_log, rw0_v[ua]);
      c.z = swr / std::sqrt(var > 0 ? var : sw);
      c.chi2_dof = sr2 / c.n_blocks;
      R.cells.push_back(c);
    }
    // Frequency: measured Allan variance against the claim (model white noise, simulation, or white-only fit).
    const auto& pts = R.allan[static_cast<std::size_t>(a)];
    NoiseFit white = fit_noise_terms(pts, 0x2);
    for (const auto& p : pts) {
      double claim = white.terms.avar(p.tau_s);
      if (std::isfinite(o.claimed_N[static_cast<std::size_t>(a)])) claim = o.claimed_N[static_cast<std::size_t>(a)] * o.claimed_N[static_cast<std::size_t>(a)] / p.tau_s;
      else if (!o.sim_allan[static_cast<std::size_t>(a)].empty()) {
        const auto& sp = o.sim_allan[static_cast<std::size_t>(a)];
        double best = 1e300;
        for (const auto& q : sp)
          if (std::fabs(std::log(q.tau_s / p.tau_s)) < best) {
            best = std::fabs(std::log(q.tau_s / p.tau_s));
            claim = q.avar;
          }
      }
      if (!(claim > 0)) continue;
      Cell c;
      c.condition = "frequency";
      char buf[32];
      std::snprintf(buf, sizeof buf, "tau=%.3gs", p.tau_s);
      c.label = buf;
      c.axis = a;
      c.n_blocks = static_cast<int>(p.terms);
      c.mean = std::sqrt(p.avar) - std::sqrt(claim);
      c.z = (p.avar / claim - 1.0) * std::sqrt(p.edf / 2.0);
      c.chi2_dof = p.avar / claim;
      R.cells.push_back(c);
    }
  }

  // ---- Stochastic effects through the Allan curve: white-only (or claimed) against each added term.
  {
    const int n_tests = 3 * kNumAxes;
    for (int a = 0; a < kNumAxes; ++a) {
      const auto& pts = R.allan[static_cast<std::size_t>(a)];
      if (pts.size() < 3) continue;
      // An output filter (a MEMS part's digital low-pass, an internally filtered unit) colours the noise over
      // a few samples: the short end of the Allan curve bends flat, which a white-only baseline cannot follow,
      // so bias instability and rate random walk "improve" it by orders of magnitude (a hand-held MPU-6050 read
      // B = 4e-3 rad/s and K = 0.036 rad/s/√s). When the likelihood's noise model found a Gauss-Markov term
      // that short (T within 5 shortest cluster times), it is part of the baseline, as IEEE 952's exponentially
      // correlated term, and each added term must improve on white + that filter. A longer GM is a drift and
      // stays out of the baseline, so a bias instability is still tested against white noise.
      const StochasticModel& sm = R.stoch[static_cast<std::size_t>(a)];
      const bool filtered = sm.gm_sigma > 0 && sm.gm_tau_s > 0 && sm.gm_tau_s <= 5.0 * pts.front().tau_s;
      // The noise model's T sits on a coarse grid, and a shape mismatch of a few % at the short end is
      // "significant" there (tens of thousands of degrees of freedom), so T is profiled on a fine grid.
      auto fit_with = [&](unsigned mask) {
        if (!filtered) return fit_noise_terms(pts, mask);
        NoiseFit best;
        best.chi2 = std::numeric_limits<double>::infinity();
        for (int k = -12; k <= 12; ++k) {
          NoiseFit f = fit_noise_terms(pts, mask, sm.gm_tau_s * std::pow(2.0, k / 8.0));
          if (f.chi2 < best.chi2) best = f;
        }
        return best;
      };
      NoiseFit w = fit_with(0x2);
      if (!std::isfinite(w.chi2)) w = fit_noise_terms(pts, 0x2);
      const char* names[3] = {"quantization", "bias_instability", "rate_random_walk"};
      const unsigned bits[3] = {0x1, 0x4, 0x8};
      for (int t = 0; t < 3; ++t) {
        NoiseFit f = fit_with(0x2 | bits[t]);
        if (!std::isfinite(f.chi2)) f = NoiseFit{};
        StochasticScore ss;
        ss.effect = names[t];
        ss.axis = axis_name(a);
        const int ti = t == 0 ? 0 : t == 1 ? 2 : 3;
        ss.value = ti == 0 ? f.terms.Q : ti == 2 ? f.terms.B : f.terms.K;
        ss.sigma = f.sigma[ti];
        ss.delta_chi2 = f.n_points > 0 ? std::max(0.0, w.chi2 - f.chi2) : 0.0;
        ss.p_value = chi2_sf(ss.delta_chi2, 1.0);
        ss.significant = ss.value > 0 && ss.p_value < o.alpha / n_tests;
        ss.against_filter = filtered;
        R.stochastic.push_back(ss);
      }
      if (std::isfinite(o.claimed_N[static_cast<std::size_t>(a)]) && R.noise[static_cast<std::size_t>(a)].sigma[1] > 0) {
        StochasticScore ss;
        ss.effect = "white_noise";
        ss.axis = axis_name(a);
        ss.value = R.noise[static_cast<std::size_t>(a)].terms.N;
        ss.sigma = R.noise[static_cast<std::size_t>(a)].sigma[1];
        const double zz = (ss.value - o.claimed_N[static_cast<std::size_t>(a)]) / ss.sigma;
        ss.delta_chi2 = zz * zz;
        ss.p_value = chi2_sf(ss.delta_chi2, 1.0);
        ss.significant = ss.p_value < o.alpha / n_tests;
        R.stochastic.push_back(ss);
      }
    }
  }

  // ---- Plot data: residuals before/after against the variable the top effect depends on. With nothing selected and
  // an axis named unexplained, that axis (the largest held-out χ²/dof) against the first function of its signature,
  // at |r| ≥ 0.3 (time where none is; the axis' own input where its residual grows with
  // it: the whole-log raise refused as "input"): the top-ranked candidate is then not significant, and its
  // axis may be one at its noise (`unseen2` ooc-scale_age-0 plotted accel.y against the rate beside two gyro axes
  // named unexplained).
  {
    std::string eff, sen;
    const Unexplained* worst = nullptr;
    for (const auto& u : R.unexplained)
      if (!worst || u.chi2_dof_after > worst->chi2_dof_after) worst = &u;
    if (!R.selected.empty()) {
      eff = R.selected[0].effect;
      sen = R.selected[0].sensor;
    } else if (worst) {
      eff = "unexplained";
      sen = worst->axis.substr(0, worst->axis.find('.'));
    } else if (!R.ranking.empty() && R.ranking[0].excitable) {
      eff = R.ranking[0].effect;
      sen = R.ranking[0].sensor;
    }
    if (!eff.empty()) {
      const int a0 = sen == "accel" ? 0 : 3;
      int axis = a0;
      for (int a = a0; a < a0 + 3; ++a)
        if (R.gap_before.gap[static_cast<std::size_t>(a)] > R.gap_before.gap[static_cast<std::size_t>(axis)]) axis = a;
      if (eff == "unexplained")
        for (int a = 0; a < kNumAxes; ++a)
          if (axis_name(a) == worst->axis) axis = a;
      std::vector<double> ra, pva;
      heldout_blocks(ax[static_cast<std::size_t>(axis)], cols_for(ax[static_cast<std::size_t>(axis)], cur), folds, blocks, ra, pva);
      std::string var = "input";
      std::function<double(const Block&)> sig_fn;
      if (eff == "unexplained") {
        // The signature's first leader (signature_leaders, weighted as in the signature): the residual against the
        // function itself, as the signature correlated it.
        var = "time_s";
        const std::vector<SignatureFunction> fns = signature_functions(blocks, pva);
        const std::vector<const SignatureFunction*> leaders = signature_leaders(worst->signature, fns);
        if (!leaders.empty()) {
          var = leaders.front()->first;
          sig_fn = leaders.front()->second;
        }
        // A residual whose spread grows with the input (the whole-log raise refused for it) against that input.
        if (R.wander[static_cast<std::size_t>(axis)].beyond_reason == "input") {
          var = "input";
          sig_fn = nullptr;
        }
      } else if (eff == "bias_temp" || eff == "scale_temp" || eff == "misalign_temp") var = "temp_C";
      else if (eff == "temp_rate") var = "dTdt_C_s";
      else if (eff == "temp_hysteresis") var = "hysteresis_d";
      else if (eff == "size_effect" || eff == "timing") var = "rate_rad_s";
      else if (eff == "g_sensitivity" || eff == "g2_sensitivity") {
        var = "f_z";
        double bestz = -1;
        for (const auto& c : R.ranking)
          if (c.effect == eff && c.sensor == sen)
            for (const auto& m : c.magnitude) {
              const double zz = std::fabs(m.value) / std::max(m.sigma, 1e-300);
              if (m.axis == axis_name(axis) && zz > bestz) {
                bestz = zz;
                const auto& pi = model::param_info(model::find_param(m.name));
                if (pi.k >= 0) var = std::string("f_") + static_cast<char>('x' + pi.k);
              }
            }
      }
      R.plot_variable = var;
      R.plot_axis = axis_name(axis);
      for (int b = 0; b < B; ++b) {
        ScatterPoint sp;
        sp.x = sig_fn ? sig_fn(blocks[static_cast<std::size_t>(b)]) : variable_of(blocks[static_cast<std::size_t>(b)], var, axis);
        if (!std::isfinite(sp.x)) continue;
        sp.before = rb[static_cast<std::size_t>(axis)][static_cast<std::size_t>(b)];
        sp.after = ra[static_cast<std::size_t>(b)];
        sp.sd = std::sqrt(pva[static_cast<std::size_t>(b)]);
        R.scatter.push_back(sp);
      }
    }
  }
  for (const Block& b : blocks) R.n_static_blocks += b.is_static ? 1 : 0;
  return R;
}

}  // namespace

// Timing without linearisation: when a sensor's timing is selected, its reference is re-evaluated at the
// estimated shifted time (ShiftedReference) and the whole diagnosis re-run with the timing pair kept as a
// linear correction around the shift; repeated until the correction is below a tenth of its σ.
namespace {
DiagnosisResult diagnose_timed(SampleSource& src, const BaseModel& base, const Options& opt, const OutputWords* words_seen = nullptr) {
  TimeShift shift[2];
  DiagnosisResult first = diagnose_core(src, base, opt, shift, words_seen);
  const OutputWords words = first.stuck_bits;  // every re-run below reads the same codes
  DiagnosisResult R = first;
  Options o = opt;
  // A lag of a sample or more, read off the steps of the reference, seeds the re-evaluation (the linearised
  // first pass cannot see it there): that sensor's timing is then in the model, refined below.
  int it0 = 1;
  std::vector<std::string> probe_notes;
  bool force_linear[2] = {false, false};
  // A sensor whose linear timing correction the log cannot determine (no motion within segments: no sines,
  // only constant rates and static poses between instantaneous steps): its timing is left out of the model,
  // and the reference keeps the shift the steps gave (if any). Moving on such a correction diverges.
  bool linear_off[2] = {false, false};
  auto set_forced = [&](Options& oo) {
    oo.forced.clear();
    for (int si = 0; si < 2; ++si)
      if ((shift[si].active() || force_linear[si]) && !linear_off[si]) oo.forced.push_back({static_cast<Sensor>(si), Effect::kTiming});
  };
  std::array<StepLag, 2> lag{};
  if (opt.max_timing_iterations > 0) {
    lag = probe_step_lag(src, first.sample_rate_hz, first.duration_s);
    if (std::getenv("IMUFORGE_DIAG_TRACE"))
      for (int si = 0; si < 2; ++si)
        std::fprintf(stderr, "step lag %d: valid %d n %d out %d late %d early %d latency %.4g ppm %.4g rms %.3g max %.3g\n", si,
                     lag[si].valid, lag[si].n_steps, lag[si].n_outliers, lag[si].n_late, lag[si].n_early, lag[si].latency_s, lag[si].ppm, lag[si].rms_s,
                     lag[si].max_abs_s);
    bool seeded = false;
    // The re-evaluation of sensor si starts at the probe's line L (what it was read off, and from how many).
    auto seed = [&](int si, const StepLag& L, const char* reads, const std::string& count) {
      shift[si].latency_s = std::clamp(L.latency_s, -1.0, 1.0);
      shift[si].ppm = std::clamp(L.ppm, -1000.0, 1000.0);
      seeded = true;
      char buf[320];
      std::snprintf(buf, sizeof buf, "%s: the output %s up to %.3g s %s (%s: latency %.3g s, %.3g ppm): reference re-evaluated at that shift",
                    model::sensor_name(static_cast<Sensor>(si)), reads, L.max_abs_s,
                    L.latency_s + L.ppm * 1e-6 * first.duration_s * 0.5 >= 0 ? "late" : "early", count.c_str(), L.latency_s, L.ppm);
      probe_notes.push_back(buf);
    };
    for (int si = 0; si < 2; ++si) {
      const StepLag& L = lag[static_cast<std::size_t>(si)];
      if (!L.valid && L.sign != 0) {
        bool have = false;
        for (const auto& st : first.selected)
          have = have || (st.sensor == model::sensor_name(static_cast<Sensor>(si)) && st.effect == "timing");
        if (!have) {
          force_linear[si] = true;
          char buf[256];
          std::snprintf(buf, sizeof buf,
                        "%s: the output reads %d of %d reference steps %s (a lag below one sample): timing kept in the model",
                        model::sensor_name(static_cast<Sensor>(si)), L.sign > 0 ? L.n_late : L.n_early, L.n_steps,
                        L.sign > 0 ? "late" : "early");
          probe_notes.push_back(buf);
        }
      }
      if (!L.valid) continue;
      seed(si, L, "reads the reference steps", std::to_string(L.n_steps) + " steps");
    }
    // No step to read (a table that accelerates into every move): the motion itself. It seeds only a shift the
    // linear term cannot start from (20 ms or two samples somewhere in the log), and only for a sensor the steps
    // said nothing about.
    std::array<StepLag, 2> mlag{};
    bool want_motion = false;
    for (int si = 0; si < 2; ++si) want_motion = want_motion || (!lag[static_cast<std::size_t>(si)].valid && lag[static_cast<std::size_t>(si)].sign == 0);
    if (want_motion) mlag = probe_motion_lag(src, first.sample_rate_hz, first.duration_s);
    const double min_seed_s = std::max(2.0 / std::max(first.sample_rate_hz, 1e-9), 0.02);
    for (int si = 0; si < 2; ++si) {
      const StepLag& M = mlag[static_cast<std::size_t>(si)];
      StepLag& L = lag[static_cast<std::size_t>(si)];
      if (L.valid || L.sign != 0 || !M.valid || !(M.max_abs_s >= min_seed_s)) continue;
      L = M;
      seed(si, M, "follows the reference's motion",
           std::to_string(M.n_steps - M.n_outliers) + " of " + std::to_string(M.n_steps) + " moving stretches");
    }
    if (seeded || force_linear[0] || force_linear[1]) {
      set_forced(o);
      R = diagnose_core(src, base, o, shift, &words);
      R.timing_iterations = seeded ? 1 : 0;
      it0 = seeded ? 2 : 1;
    }
  }
  for (int it = it0; it <= opt.max_timing_iterations; ++it) {
    // Per sensor: the timing correction of the selected model (inverse-variance over the axes).
    bool any = false, moved = false, dropped = false;
    TimeShift next[2] = {shift[0], shift[1]};
    const double h = 1.0 / std::max(R.sample_rate_hz, 1e-9);
    for (int si = 0; si < 2; ++si) {
      const auto& te = R.timing_est[static_cast<std::size_t>(si)];
      if (!te.valid) continue;
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "timing it %d sensor %d: shift %.4g s %.4g ppm; correction %.4g +/- %.3g s, %.4g +/- %.3g ppm\n", it, si,
                     shift[si].latency_s, shift[si].ppm, te.latency_s, te.sigma_latency_s, te.ppm, te.sigma_ppm);
      // Determined: the correction's σ, as a time shift anywhere in the log, below half a sample interval (where
      // the sines excite it, σ is 1e-5–1e-4 s at 100 Hz; with no motion within segments only the Earth rate turning
      // in the body does, and σ is ~0.1 s: the "correction" is then whatever the other unmodelled effects push it to).
      const double sig_end = std::hypot(te.sigma_latency_s, te.sigma_ppm * 1e-6 * R.duration_s);
      if (!(te.sigma_latency_s < 0.5 * h && sig_end < 0.5 * h)) {
        if ((shift[si].active() || force_linear[si]) && !linear_off[si]) {
          linear_off[si] = true;
          dropped = true;
          // What the steps leave: with the steps' shift, its scatter (a bracket of ±h about the line); without
          // one (a lag below a sample at the start that a clock drift carries past it), as far as any step was
          // misread.
          const StepLag& L = lag[static_cast<std::size_t>(si)];
          next[si].step_margin_s = shift[si].active() ? std::max(h, 3.0 * L.rms_s) : L.max_n * h;
          char buf[320];
          std::snprintf(buf, sizeof buf,
                        "%s: the log cannot refine the timing beyond the reference steps (linear correction sigma %.2g s, "
                        "%.2g ppm: no motion within segments excites it): timing left out of the model%s",
                        model::sensor_name(static_cast<Sensor>(si)), te.sigma_latency_s, te.sigma_ppm,
                        shift[si].active() ? ", the reference kept at the steps' shift"
                        : L.sign != 0 ? "; selected on the steps' one-sided misreadings (a lag below one sample)" : "");
          probe_notes.push_back(buf);
        }
        continue;
      }
      any = true;
      if (std::fabs(te.latency_s) > 0.1 * te.sigma_latency_s || std::fabs(te.ppm) > 0.1 * te.sigma_ppm) moved = true;
      next[si].latency_s += te.latency_s;
      next[si].ppm += te.ppm;
      // The linearised step can overshoot far from the optimum: cap it to what it can still describe.
      next[si].latency_s = std::clamp(next[si].latency_s, -1.0, 1.0);
      next[si].ppm = std::clamp(next[si].ppm, -1000.0, 1000.0);
    }
    // Below half a sample interval the linear term is exact to second order and interpolating the reference
    // would add more error (curvature between samples) than it removes: stay linear.
    double max_shift = 0;
    for (int si = 0; si < 2; ++si)
      for (double tt : {0.0, R.duration_s}) max_shift = std::max(max_shift, std::fabs(next[si].at(tt)));
    if (!dropped) {
      if (it == 1 && max_shift < 0.5 * h) break;
      if (!any || (!moved && it > 1)) break;
    }
    if (max_shift >= 0.5 * h || it > 1) {
      shift[0] = next[0];
      shift[1] = next[1];
    }
    for (int si = 0; si < 2; ++si) shift[si].step_margin_s = next[si].step_margin_s;
    set_forced(o);
    const int ti = R.timing_iterations;
    R = diagnose_core(src, base, o, shift, &words);
    R.timing_iterations = dropped && !moved ? ti : it;
    if (!moved && !dropped) break;
  }
  // The rate table's axis errors (Options::table): estimated in every run (diagnose_core: with the base model on the
  // logged reference, jointly with the run's selection once re-evaluated); an estimate significant as a whole (χ² of
  // its 3·axes dof, p 1e-3; a further one p 0.01) re-runs the diagnosis on the reference re-evaluated at the
  // accumulated errors, at most max_fixture_iterations times. After the timing: on campaign-eol's 0.19 s clock the errors
  // estimated against the unshifted reference are the rate runs' timing residual, not the table's.
  int fixture_iterations = 0;
  if (opt.table.known) {
    for (int it = 0; it < opt.max_fixture_iterations; ++it) {
      const auto& fe = R.fixture_est;
      if (std::getenv("IMUFORGE_DIAG_TRACE")) {
        std::fprintf(stderr, "fixture it %d valid %d chi2 %g:", it, fe.valid, fe.chi2);
        for (int m = 0; m < fe.n; ++m) std::fprintf(stderr, " %.3g(%.2g)", fe.delta_rad[static_cast<std::size_t>(m)], fe.sigma_rad[static_cast<std::size_t>(m)]);
        std::fprintf(stderr, "\n");
      }
      if (!fe.valid || !(chi2_sf(fe.chi2, fe.n) < (it == 0 ? 1e-3 : 1e-2))) break;
      for (int m = 0; m < fe.n; ++m) o.fixture_error[static_cast<std::size_t>(m / 3)].part(m % 3) += fe.delta_rad[static_cast<std::size_t>(m)];
      const int ti = R.timing_iterations;
      R = diagnose_core(src, base, o, shift, &words);
      R.timing_iterations = ti;
      fixture_iterations = it + 1;
    }
  }
  // Mount rotation: where a gyro cross-coupling or scale nonlinearity is selected, its terms say how the case sits on the
  // fixture (diagnose_core). A first correction significant as a whole (χ² of 3 dof > 16.3, p 1e-3) within
  // mount_max_rad re-runs the diagnosis with the reference rotated into the case; it is refined while the
  // correction is significant (χ² > 11.3, p 0.01). The rotated diagnosis is kept unless it leaves more axes
  // unexplained. Measured (stop 31): on varied5 random-3, -7, -15, -17 and varied2 random-4 the false gyro
  // scale_nonlinearity / scale_asymmetry go; about the axes the rates pair with the cross-coupling the estimate
  // is within 0.1 mrad of blindgen's mount error, about the others the prior holds it (docs/diagnosis.md).
  {
    std::array<double, 3> rot{};
    std::optional<DiagnosisResult> R0;  // the unrotated result, kept once a rotated run replaces it
    for (int it = 0; it < opt.max_mount_iterations; ++it) {
      if (std::getenv("IMUFORGE_DIAG_TRACE"))
        std::fprintf(stderr, "mount it %d valid %d chi2 %g d %g %g %g sig %g %g %g\n", it, R.mount_est.valid, R.mount_est.chi2, R.mount_est.delta_rad[0], R.mount_est.delta_rad[1], R.mount_est.delta_rad[2], R.mount_est.sigma_rad[0], R.mount_est.sigma_rad[1], R.mount_est.sigma_rad[2]);
      const auto& me = R.mount_est;
      if (!me.valid || !(me.chi2 > (it == 0 ? kMountFirstChi2 : kMountNextChi2))) break;
      std::array<double, 3> next = rot;
      double mx = 0;
      for (int m = 0; m < 3; ++m) {
        next[static_cast<std::size_t>(m)] += me.delta_rad[static_cast<std::size_t>(m)];
        mx = std::max(mx, std::fabs(next[static_cast<std::size_t>(m)]));
      }
      if (!(mx <= opt.mount_max_rad)) break;
      rot = next;
      o.mount_rotation_rad = rot;
      if (!R0) R0 = R;
      const int ti = R.timing_iterations;
      R = diagnose_core(src, base, o, shift, &words);
      R.timing_iterations = ti;
      R.mount_iterations = it + 1;
    }
    // Nor when an axis the unrotated run held within the threshold goes over it: the rotation the gyro's terms ask
    // for then breaks another fit, and is not how the case sits. `varied39` random-18: a real gyro cross-coupling
    // of 3.8e-3 beside a scale asymmetry asked for (-0.39, -2.8, -2.6) mrad (blindgen's mount: 0.40, 0.45, -0.47
    // about x, y, z); evaluated there, a true accel size effect (x.ry -3.8 mm, snr 6600) left 0.6 % of its signal as
    // a nonlinear remainder, the form check withdrew it and accel.x stood at held-out chi2/dof 1.7e5, where the
    // unrotated run had it explained. The count alone let it through: the unrotated run named gyro.x and gyro.y on
    // the whole log's residual (following w_y^2, w_z^2) at held-out chi2/dof within the threshold.
    std::string broke;
    if (R0)
      for (int a = 0; a < kNumAxes; ++a) {
        auto over_in = [&](const DiagnosisResult& X) { return over_threshold(X.gap_after, a, o.unexplained_chi2_dof); };
        if (over_in(R) && !over_in(*R0) && broke.empty()) {
          char b[160];
          std::snprintf(b, sizeof b, "%s goes over its noise (held-out chi2/dof %.3g, against %.3g unrotated)", axis_name(a),
                        R.gap_after.chi2_dof[static_cast<std::size_t>(a)], R0->gap_after.chi2_dof[static_cast<std::size_t>(a)]);
          broke = b;
        }
      }
    if (R0 && (R.unexplained.size() > R0->unexplained.size() || !broke.empty())) {
      char buf[420];
      std::snprintf(buf, sizeof buf,
                    "a rotation of the case on the fixture by (%.2g, %.2g, %.2g) mrad was estimated from the gyro cross_coupling "
                    "or scale_nonlinearity but not used: evaluated there, %s",
                    1e3 * rot[0], 1e3 * rot[1], 1e3 * rot[2], broke.empty() ? "more axes stay unexplained" : broke.c_str());
      R = std::move(*R0);
      rot = {};
      o.mount_rotation_rad = rot;
      probe_notes.push_back(buf);
    }
    R.mount_rotation_rad = rot;
    if (R.mount_iterations > 0) {
      const auto& sg = R.mount_est.sigma_rad;
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "the case sits rotated on the fixture by (%.2g +/- %.2g, %.2g +/- %.2g, %.2g +/- %.2g) mrad about x, y, z, "
                    "from the selected gyro cross_coupling's or scale_nonlinearity's terms (prior %.2g mrad): the catalog's terms are "
                    "evaluated on the input in the case",
                    1e3 * rot[0], 1e3 * sg[0], 1e3 * rot[1], 1e3 * sg[1], 1e3 * rot[2], 1e3 * sg[2], 1e3 * opt.mount_prior_rad);
      probe_notes.push_back(buf);
    }
  }
  // Whole-log wander. The static dwells fit the bias wander only up to their own length; with the final model,
  // the whole log's block means say how large it is over the hours between plateaus (REML, noise_model.h). Where
  // that is significantly more (Δ(−2 log L) > 3.84) than the likelihood carried, but not more than
  // wander_max_factor × (beyond it a residual is a deterministic signal no catalog effect has, and must stay
  // visible as such), the diagnosis is run again with it: selection, held-out scores and the unexplained
  // verdict then judge against the wander the log really has. Measured on blind logs: the dwells' level is
  // 0.5–0.9 of the true one (median; the flicker floor starts past the dwells' length), docs/diagnosis.md.
  if (opt.whole_log_wander) {
    Options ow = o;
    std::vector<std::string> notes;
    std::array<DiagnosisResult::Wander, kNumAxes> seen = R.wander;
    for (int a = 0; a < kNumAxes; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      const auto& w = R.wander[ua];
      if (w.adopted || w.kind.empty() || w.beyond_limit || !w.measured.material()) continue;
      (w.kind == "flicker" ? ow.wander_B : ow.wander_K)[ua] = w.value;
      ow.wander_B_floor[ua] = w.measured.below_likelihood;
      // A walk whose joint maximum lowered the flicker the dwells show carries that flicker with it.
      if (w.kind == "random_walk" && w.measured.flicker_lowered) ow.wander_K_B[ua] = w.measured.B;
      char buf[360];
      std::snprintf(buf, sizeof buf,
                    "%s: the whole log's bias wander is %.2g x what the static dwells show (Allan deviation at a quarter "
                    "of the log; as %s %.3g; -2 log L gain %.1f): carried into the likelihood and the held-out variances",
                    axis_name(a), w.measured.ratio, w.kind == "flicker" ? "flicker B" : "rate random walk K", w.value,
                    w.measured.evidence());
      notes.push_back(buf);
    }
    if (!notes.empty()) {
      if (R.timing_iterations > 0 || force_linear[0] || force_linear[1]) {
        Options of = opt;
        of.wander_B = ow.wander_B;
        of.wander_K = ow.wander_K;
        of.wander_K_B = ow.wander_K_B;
        of.wander_B_floor = ow.wander_B_floor;
        const TimeShift none[2];
        first = diagnose_core(src, base, of, none, &words);
      }
      const int ti = R.timing_iterations, mi = R.mount_iterations;
      const auto mr = R.mount_rotation_rad;
      R = diagnose_core(src, base, ow, shift, &words);
      R.timing_iterations = ti;
      R.mount_iterations = mi;
      R.mount_rotation_rad = mr;
      // An adopted axis is not re-estimated: it keeps the estimate that adopted it.
      for (std::size_t a = 0; a < static_cast<std::size_t>(kNumAxes); ++a)
        if (R.wander[a].adopted) {
          R.wander[a] = seen[a];
          R.wander[a].adopted = true;
          R.wander[a].walk_flicker_B = ow.wander_K_B[a];
        }
      R.warnings.insert(R.warnings.end(), notes.begin(), notes.end());
    }
  }
  // A timing the steps measured and the motion cannot refine: selected on the steps' evidence (whole-sample
  // misreadings, which noise cannot make: step_lag.h), its magnitude the steps' line with that line's σ.
  // Likewise a lag below one sample that the steps show only by the side they are misread on (sign): its
  // magnitude is the steps' line through those few misreadings (about the share misread × h), with the same σ.
  for (int si = 0; si < 2; ++si) {
    const StepLag& L = lag[static_cast<std::size_t>(si)];
    if (!linear_off[si] || !(shift[si].active() || (L.sign != 0 && L.sigma_latency_s > 0))) continue;
    Step st;
    st.sensor = model::sensor_name(static_cast<Sensor>(si));
    st.effect = "timing";
    st.p_value = 0;
    st.from_reference_steps = true;
    st.gap_after = R.gap_after;
    R.selected.push_back(st);
    // With a shift the reference was re-evaluated at, the value is that shift (added below); without, the line.
    const bool sub = !shift[si].active();
    R.final_params.push_back({st.sensor + ".timing.latency_s", st.sensor, sub ? L.latency_s : 0.0, L.sigma_latency_s});
    R.final_params.push_back({st.sensor + ".timing.ppm", st.sensor, sub ? L.ppm : 0.0, L.sigma_ppm});
  }
  R.warnings.insert(R.warnings.end(), probe_notes.begin(), probe_notes.end());
  // The "before" picture is the base model against the reference as logged (re-evaluated neither at a time shift
  // nor at the table's axis errors: what the log shows before the diagnosis explains anything).
  const bool timing_moved = R.timing_iterations > 0 || force_linear[0] || force_linear[1];
  if (timing_moved || fixture_iterations > 0) {
    R.gap_before = first.gap_before;
    R.cells = first.cells;
    for (auto& st : R.selected)
      for (int a = 0; a < kNumAxes; ++a) {
        const double g0 = R.gap_before.gap[static_cast<std::size_t>(a)];
        st.shrink_pct[static_cast<std::size_t>(a)] =
            g0 > 0 ? 100.0 * (1.0 - std::max(st.gap_after.gap[static_cast<std::size_t>(a)], 0.0) / g0) : 0.0;
      }
  }
  if (timing_moved) {
    // Timing candidates keep their first-pass score (against the logged reference) in the ranking, once: a
    // sensor whose timing left the model (linear_off) was scored again in the last pass.
    R.ranking.erase(std::remove_if(R.ranking.begin(), R.ranking.end(), [](const CandidateScore& c) { return c.effect == "timing"; }),
                    R.ranking.end());
    for (const auto& c : first.ranking)
      if (c.effect == "timing") R.ranking.push_back(c);
    std::stable_sort(R.ranking.begin(), R.ranking.end(), [](const CandidateScore& x, const CandidateScore& y) {
      if (x.excitable != y.excitable) return x.excitable;
      return x.score > y.score;
    });
  }
  for (int si = 0; si < 2; ++si) {
    R.timing_shift_latency_s[static_cast<std::size_t>(si)] = shift[si].latency_s;
    R.timing_shift_ppm[static_cast<std::size_t>(si)] = shift[si].ppm;
    const StepLag& L = lag[static_cast<std::size_t>(si)];
    R.step_reading[static_cast<std::size_t>(si)] = {L.n_steps, L.n_late, L.n_early, L.sign};
  }
  if (opt.table.known) {
    R.fixture_known = true;
    R.fixture_iterations = fixture_iterations;
    for (int m = 0; m < R.fixture_est.n; ++m)
      R.fixture_error_rad[static_cast<std::size_t>(m)] = o.fixture_error[static_cast<std::size_t>(m / 3)].part(m % 3);
  }
  // Reported timing = the shift the reference was re-evaluated at + the remaining linear correction.
  for (auto& pe : R.final_params) {
    for (int si = 0; si < 2; ++si) {
      const std::string pre = std::string(model::sensor_name(static_cast<Sensor>(si))) + ".timing.";
      if (pe.name == pre + "latency_s") pe.value += shift[si].latency_s;
      if (pe.name == pre + "ppm") pe.value += shift[si].ppm;
    }
  }
  return R;
}
}  // namespace

// AxisTiming (diagnose.h): the per-axis latencies of each selected timing (not one read off the reference steps,
// which is one line per sensor). Fills r.axis_timing; returns, per sensor, whether the triad's timing should be
// withdrawn (an odd axis, and the other two within 3σ of zero).
std::array<bool, 2> check_axis_timing(DiagnosisResult& r, const Options& opt) {
  std::array<bool, 2> withdraw{false, false};
  if (!(opt.axis_timing_z > 0)) return withdraw;
  for (int si = 0; si < 2; ++si) {
    const std::string sn = model::sensor_name(static_cast<Sensor>(si));
    bool selected = false;
    for (const auto& st : r.selected) selected = selected || (st.sensor == sn && st.effect == "timing" && !st.from_reference_steps);
    if (!selected) continue;
    double v[3], sg[3];
    int n = 0;
    for (int j = 0; j < 3; ++j) {
      const std::string an = axis_name(3 * si + j);
      for (const auto& pe : r.final_params)
        if (pe.axis == an && pe.name == sn + ".timing.latency_s" && pe.sigma > 0) {
          v[j] = pe.value;
          sg[j] = pe.sigma;
          ++n;
        }
    }
    if (n != 3) continue;
    double sw = 0, swv = 0;
    for (int j = 0; j < 3; ++j) sw += 1.0 / (sg[j] * sg[j]), swv += v[j] / (sg[j] * sg[j]);
    const double mean = swv / sw;
    double chi2 = 0;
    for (int j = 0; j < 3; ++j) chi2 += (v[j] - mean) * (v[j] - mean) / (sg[j] * sg[j]);
    const double log10p = -chi2_log10_sf(chi2, 2.0);
    if (std::getenv("IMUFORGE_DIAG_TRACE"))
      std::fprintf(stderr, "axis timing %s: %.4g+-%.2g %.4g+-%.2g %.4g+-%.2g ms: chi2 %.1f (2 dof, -log10 p %.1f)\n", sn.c_str(), 1e3 * v[0],
                   1e3 * sg[0], 1e3 * v[1], 1e3 * sg[1], 1e3 * v[2], 1e3 * sg[2], chi2, log10p);
    if (log10p < opt.axis_timing_log10p) continue;
    bool any_odd = false, others_zero = true;
    for (int j = 0; j < 3; ++j) {
      double w = 0, wv = 0;
      for (int k = 0; k < 3; ++k)
        if (k != j) w += 1.0 / (sg[k] * sg[k]), wv += v[k] / (sg[k] * sg[k]);
      AxisTiming& at = r.axis_timing[static_cast<std::size_t>(3 * si + j)];
      at.latency_s = v[j];
      at.sigma_s = sg[j];
      at.others_s = wv / w;
      at.others_sigma_s = std::sqrt(1.0 / w);
      // Odd: apart from the other two, which agree with each other (where all three disagree, none is the odd one).
      const int k = (j + 1) % 3, l = (j + 2) % 3;
      at.odd = std::fabs(v[j] - at.others_s) > opt.axis_timing_z * std::hypot(sg[j], at.others_sigma_s) &&
               std::fabs(v[k] - v[l]) <= opt.axis_timing_z * std::hypot(sg[k], sg[l]);
    }
    for (int j = 0; j < 3; ++j) {
      const AxisTiming& at = r.axis_timing[static_cast<std::size_t>(3 * si + j)];
      if (!at.odd) continue;
      any_odd = true;
      if (std::fabs(at.others_s) > 3.0 * at.others_sigma_s) others_zero = false;
    }
    withdraw[static_cast<std::size_t>(si)] = any_odd && others_zero;
  }
  return withdraw;
}

// Dropouts and glitches first (dropouts.h, glitches.h): every pass, the timing probes included, reads the log with its
// runs of failed reads bridged and its isolated single-sample outliers replaced (dropouts first: a single row reading
// 0 far from its neighbours is a failed read, not a glitch of another value). Each filter searches while pass 0
// (the first to read) streams the log through it, with a look-ahead (a run's length; about a thousand rows), and
// replays its fixes on every later pass; an axis that held any is named, with what the rest of its residual says.
DiagnosisResult diagnose(SampleSource& src, const BaseModel& base, const Options& opt) {
  // The log read on a thread of its own, filtered on another, each a few batches ahead of the next (prefetch.h):
  // on the first pass, where the filters search, they take as long as reading.
  PrefetchSource raw(src);
  DropoutFilterSource bridged(raw, opt.output_lsb, opt.dropouts);
  GlitchFilterSource clean(bridged, opt.glitch_z);
  PrefetchSource ahead(clean);
  DiagnosisResult R = diagnose_timed(ahead, base, opt);
  // A timing one axis alone carries (AxisTiming): without the triad's timing where the other two show none.
  std::array<bool, 2> withdraw = check_axis_timing(R, opt);
  if (withdraw[0] || withdraw[1]) {
    Options o = opt;
    for (int si = 0; si < 2; ++si)
      if (withdraw[static_cast<std::size_t>(si)]) o.excluded.push_back({static_cast<Sensor>(si), Effect::kTiming});
    const std::array<AxisTiming, kNumAxes> seen = R.axis_timing;
    const OutputWords words = R.stuck_bits;
    R = diagnose_timed(ahead, base, o, &words);
    R.axis_timing = seen;
    // A timing the reference steps force (a shift of a sample or more: diagnose_timed) stays whatever the candidates.
    for (int si = 0; si < 2; ++si)
      for (const auto& st : R.selected)
        if (st.sensor == model::sensor_name(static_cast<Sensor>(si)) && st.effect == "timing") withdraw[static_cast<std::size_t>(si)] = false;
    for (int a = 0; a < kNumAxes; ++a) R.axis_timing[static_cast<std::size_t>(a)].triad_withdrawn = withdraw[static_cast<std::size_t>(a / 3)];
    char buf[200];
    for (int si = 0; si < 2; ++si)
      if (withdraw[static_cast<std::size_t>(si)]) {
        std::snprintf(buf, sizeof buf, "%s: the timing selected was one axis' latency alone (the other two show none): withdrawn, and the axis named",
                      model::sensor_name(static_cast<Sensor>(si)));
        R.warnings.push_back(buf);
      }
  }
  ahead.idle();  // the filters are asked for their summaries: nothing reads through them any more
  R.glitches = clean.summary();
  R.dropouts = bridged.summary();
  // An axis named on a basis of its own; take_over: the basis replaces the one that named it already (the held-out
  // χ² or the whole log's structure: what the axis' own latency explains).
  auto name_axis = [&R](int a, const char* basis, bool take_over) {
    for (auto& u : R.unexplained)
      if (u.axis == axis_name(a)) {
        if (take_over) u.basis = basis;
        return;
      }
    Unexplained u;
    u.axis = axis_name(a);
    u.chi2_dof_after = R.gap_after.chi2_dof[static_cast<std::size_t>(a)];
    u.basis = basis;
    R.unexplained.push_back(u);
  };
  for (int a = 0; a < kNumAxes; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    if (R.axis_timing[ua].odd) name_axis(a, "axis_timing", true);
    if (R.temp_motion[ua].flagged) name_axis(a, "temp_motion", false);  // colored "noise" only while T moves
    if (R.glitches[ua].count > 0) name_axis(a, "glitches", false);
    if (R.dropouts[ua].runs > 0) name_axis(a, "dropouts", false);
    if (R.stuck_bits[ua].bit >= 0) name_axis(a, "stuck_bit", true);  // the word, not the physics: it leads
  }
  return R;
}

}  // namespace imuforge::diagnosis
