// The stochastic model the diagnosis carries into its likelihood (docs/diagnosis.md § 2).
//
// Per axis: white noise N, quantization Q, one first-order Gauss-Markov bias (stationary σ, correlation
// time T: what a bias instability looks like over the minutes a calibration lasts), flicker (1/f) bias noise
// and a rate random walk K. Flicker is a bank of Gauss-Markov states of one common σ with correlation times
// a factor 4 apart, from the shortest Allan cluster time up to the log duration: its Allan deviation is flat
// (the IEEE 952 bias-instability floor) over that whole range, so a floor seen in static dwells of a minute
// is carried, as 1/f noise does, into the bias wander between plateaus an hour apart. One GM term fitted to
// those dwells would stop at a few minutes and leave the slower wander to read as temp_rate/hysteresis. It is fitted to the Allan variance of the static dwells FIRST, before any deterministic effect is
// tested. Then the block means of a segment are whitened by a Kalman filter that carries the Gauss-Markov
// and random-walk bias as states: generalised least squares, exactly, in O(blocks · parameters). A slow
// drift therefore enters the likelihood as correlated noise and cannot masquerade as a deterministic
// effect; the blocks of one segment are no longer counted as independent evidence.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "host/diagnosis/stats.h"
#include "host/estimator/estimator.h"
#include "host/estimator/stochastic.h"

namespace imuforge::diagnosis {

// The stochastic model and its GLS whitening live in the estimator core (host/estimator/stochastic.h), shared
// with the solver's dwell drift; the diagnosis fits the model to the Allan curve here.
using estimator::flicker_B_of_sigma;
using estimator::flicker_bank_avar;
using estimator::flicker_bank_taus;
using estimator::gauss_markov_avar;
using estimator::gm_block;
using estimator::gls_normal_equations;
using estimator::StochasticModel;
using estimator::whiten_segment;


// Fits {Q, N, GM(σ, T), flicker B, K} to an Allan curve: T on a log grid between the shortest and 4× the
// longest cluster time, the flicker bank from the shortest cluster time to max(horizon_s, 4× the longest),
// the amplitudes by non-negative weighted least squares (every subset), best penalised χ² kept.
// horizon_s: the longest time scale the model must describe (the log duration).
// Without points returns a white model with N = 0 (the caller supplies a fallback).
StochasticModel fit_stochastic_model(const std::vector<AllanAccumulator::Point>& pts, double horizon_s = 0.0);

// Sets m.bank_sigma_lik / flicker_B_upper: the largest flicker level whose Allan χ² (other terms of m
// refitted) exceeds the best by at most 2.71 (one-sided 95 %). tmin: shortest cluster time, T_hi: horizon.
void flicker_upper_limit(const std::vector<AllanAccumulator::Point>& pts, double tmin, double T_hi, StochasticModel& m);


// The bias wander the WHOLE log supports (docs/diagnosis.md § 2, "whole-log wander"). The static dwells show
// the wander only up to their own length (tens of seconds); the block means of a log whose plateaus lie an hour
// apart show the rest. Given the deterministic columns, the restricted likelihood of the block means (REML: the
// columns are profiled out and log det of their information counted, so what the fit absorbs does not bias the
// level low) is maximised over two raises of the model's long-term noise, each on a 2^(1/4) grid upward from the
// model's own likelihood level: the flicker bank's σ, or the rate random walk K (its offset prior K²·D/6 with
// it) jointly with the flicker bank at 1, ½, ¼, ⅛, 1/16 of that level or none (a walk the dwells read as flicker
// is fitted short beside that flicker held). Returns each line's maximiser ({flicker, random walk, the verdict's
// floor}; kind kNone where no raise improves the likelihood), measured by the Allan deviation it gives at a
// quarter of the log duration against the model's own there (`ratio`), searched up to ratio_max, with its residual
// checks. The third line is searched only where the dwells' point estimate of the flicker lies below the
// likelihood's level (WholeLogWander::below_likelihood).
// rows: [z | x] per block in time order, as whiten_segment takes them. O(grid · n · (P + states²)), the random-walk
// line up to six times. The flicker line with the floor, and the random-walk line, are searched at once where the
// machine has two cores (concurrency.h): each owns its evaluations, and the answer is the one-thread answer to the
// last bit.
struct WholeLogWander {
  enum Kind { kNone, kFlicker, kRandomWalk } kind = kNone;
  // kFlicker: the maximiser and its flicker B. kRandomWalk: the flicker that goes with the walk (the walk is raised
  // jointly with it, from the likelihood's level down to none: short dwells read the start of a walk as flicker).
  double bank_sigma = 0, B = 0;
  bool flicker_lowered = false;  // kRandomWalk: that flicker is below the level the search started from
  double K = 0;                  // kRandomWalk: the maximiser
  double ratio = 1;              // Allan deviation at D/4: raised model / the level the dwells show
  // The same against the likelihood's level (the flicker's upper limit where the dwells show none, else equal to
  // ratio): what the size limits are judged on (diagnose.h Options::wander_max_factor).
  double limit_ratio = 1;
  double gain = 0;               // −2 log L(model's own level) − (−2 log L(maximiser)) ≥ 0
  // The verdict's floor (whole_log_wander's third line, kFlicker): the maximiser over the levels between the
  // dwells' point estimate of the flicker (what the held-out verdict carries) and the likelihood's level, that
  // level included. gain_seen is its Δ(−2 log L) over the point estimate (`gain`, over the likelihood's level, is
  // ≥ 0 but says nothing here): the evidence that the verdict's floor is too low though the likelihood's is not
  // (varied9 null-tactical-2: a 300 s bias instability read B 3.4e-6 on the dwells, upper 4.9e-6, truth 5.8e-6;
  // gyro.z stood at held-out χ²/dof 5.8 on the point and was named unexplained on a sensor with nothing beyond
  // the model). It raises the verdict's floor only (with_wander keeps the likelihood's level), and no likelihood
  // question (the one-turn hysteresis check, the re-tests) takes it.
  bool below_likelihood = false;
  double gain_seen = 0;
  // The Δ(−2 log L) a line's adoption is judged on: over the point estimate for the verdict's floor, over the
  // likelihood's level for a raise. O(1).
  double evidence() const { return below_likelihood ? gain_seen : gain; }
  // What diagnose() carries at all: material (Allan deviation at a quarter of the log > 1.2 × the level it is
  // against) and significant (evidence > 3.84, p 0.05 on 1 dof). The one rule for adoption, the re-tests and the
  // checks asked before adoption. O(1).
  bool material() const { return ratio > 1.2 && evidence() > 3.84; }
  // Largest standardised innovation of the GLS residual under the maximiser: Gaussian wander keeps it near
  // √(2 ln n); one jump (a bias step) that a random walk "explains" on average stands out by tens.
  double max_abs_z = 0;
  // Step or outlier at that innovation: √(Δχ² of the best level step − Δχ² of the best single-block indicator), each
  // placed there or a block either side and fitted by GLS under the same model and columns, signed (> 0: the step
  // fits better). A bias step persists; one outlying block does not, and its innovation is followed by the walk's
  // swing back (varied3 random-0 accel.z: −8.9 σ, then +4.6: a transient the catalog does not model, not a step).
  double jump_persist_z = 0;
  // Ljung–Box p-value of those innovations (lags 1..10, block order): whitened by the right noise model they are
  // white; a slow periodic bias (a line in the spectrum) that the raised wander "explains" leaves them correlated.
  double whiteness_p = 1;
  // Σ r_k² of those innovations over the same lags: how much of their variance their own past predicts, an effect
  // size beside the p-value (which grows with the number of blocks for any fixed mismatch of the noise shape).
  double autocorr_sq = 0;
  // A line in the spectrum of those innovations: the largest Lomb–Scargle power over periods from twice the median
  // block spacing to half the log (line_power_spectrum), its false-alarm probability over the independent
  // frequencies searched, and its period. Correlated innovations alone do not tell a periodic bias from a wander
  // of a slightly different shape than the model's (the Ljung–Box p falls with the number of blocks for any
  // fixed mismatch: varied2 stoch-automotive-4, a 1.1e-4 m/s²/√s random walk beside a 100 s Gauss–Markov,
  // whiteness p 3e-10 at Σ r² 0.07); a sinusoid stays one line through the whitening filter (stats.h
  // line_power_spectrum).
  double line_p = 1;
  double line_period_s = 0;
  // Does the spread of those innovations grow with the inputs (Koenker's studentised Breusch–Pagan test)? A bias
  // wander adds the same variance to every block whatever the table does; a residual that the raise takes but
  // that scales with the rate or the specific force (a scale factor that moves with time, an input-dependent term
  // the catalog lacks) leaves the innovations small where the input is small and large where it is large. e_i²
  // regressed on [1, covariates] (whole_log_wander's `covariates`, one row per block): hetero_lm = n R², χ² on
  // k dof under a stationary wander, hetero_p its p-value, and hetero_ratio the fitted mean of e² over the blocks
  // in the upper quarter of that fit against the lower quarter (an effect size: the LM grows with n for any fixed
  // mismatch). 0 / 1 / 1 when no covariates were given.
  double hetero_lm = 0, hetero_p = 1, hetero_ratio = 1;
};

// m with a whole-log raise applied: w's maximiser (flicker bank σ, or random-walk K with the flicker bank σ found
// with it), or with w null or kNone the likelihood's own level (the flicker bank at the larger of its point and
// upper σ). rw_prior_var_out receives
// the random walk's prior variance that goes with it (K²·D/6 for a raised walk, else rw_prior_var). The one rule
// for the search below and for a likelihood re-run under the raise (diagnose.cpp: one-turn hysteresis). O(1).
StochasticModel with_wander(const StochasticModel& m, const WholeLogWander* w, double duration_s, double rw_prior_var,
                            double& rw_prior_var_out);
std::array<WholeLogWander, 3> whole_log_wander(const StochasticModel& m, const std::vector<double>& t_s,
                                               const std::vector<double>& dur_s, const Eigen::Ref<const Eigen::MatrixXd>& rows,
                                               double rw_prior_var, double duration_s, double ratio_max,
                                               const std::vector<int>* seg_of = nullptr,
                                               const Eigen::MatrixXd* covariates = nullptr);

// A slow periodic bias against the raised wander that would take it (diagnose.cpp, the final model's wander).
// Two or three cycles of a sinusoid in a whole log are what the random-walk line's whitening differences away:
// its innovations come out white and its likelihood gain is large (`varied12` ooc-periodic-0, an accel.y sine of
// 870 s in 1691 s: random walk Δ(−2 log L) 339, line p 0.095 under it). The question the checks of WholeLogWander
// cannot answer is asked here as a likelihood: the best sinusoid b·sin(2πt/P) + c·cos(2πt/P), fitted by GLS beside
// the columns under m (the model's own level, no raise), over periods from duration_s/25 to duration_s/1.5 (1.5
// cycles at least: a slower one is one swing, which a wander makes as well) on a grid 3× finer than 1/duration_s,
// the best refined between its neighbours. gain: its Δχ² (= Δ(−2 log L), the noise held), comparable with
// WholeLogWander::gain; n_periods: how many grid periods were searched (the look-elsewhere count).
// A periodic disturbance that runs only part of the time (a chamber's compressor while it cools, a fan, a pump)
// is one line whose amplitude changes through the log: the constant sinusoid fits it where it runs and adds it
// where it does not, so it gains half of what the line carries at best, and a random walk raised to follow it can
// gain more (`unseen9` ooc-compressor-1 gyro.y: an 86 s oscillation while the die cools, sinusoid 252 against a
// walk raised 12.8x at 811). mod_*: at each of the three best grid periods (local maxima of the constant fit's
// gain among the periods of six cycles or more), the sinusoid with its own amplitude and phase in each of
// mod_windows equal stretches of the log, as many as hold three cycles each, 2 to 8; mod_gain its Δχ² as gain's
// (2·mod_windows columns), at mod_period_s (mod_windows 0: no such period). A stationary wander spreads its power
// over the band and no one line takes much of it in any stretch.
// O(n · (P + 2F)² + F · P³ + 18 · n · P² + 3 · n · (P + 16)²), F = n_periods ≈ 70.
struct PeriodicBias {
  double gain = 0, period_s = 0;
  int n_periods = 0;
  double mod_gain = 0, mod_period_s = 0;
  int mod_windows = 0;
};
PeriodicBias periodic_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                           const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                           const std::vector<int>* seg_of = nullptr);

// The columns of a sinusoid of period_s with its own amplitude and phase in each of `windows` equal stretches of
// t_s's span (a block in the stretch of its mid time): sin, cos of stretch k in columns 2k, 2k + 1, each a block's
// mean (the value at the mid time times sinc(π dur / period_s)), zero outside the stretch. windows = 1: the
// constant sinusoid. O(n).
Eigen::MatrixXd modulated_sinusoid(const std::vector<double>& t_s, const std::vector<double>& dur_s, double period_s,
                                   int windows);

// A bias that moves linearly with time over the log (ageing, package stress settling; IEEE 952's rate ramp)
// against the raised wander that would take it, as periodic_bias asks of a sinusoid. The walk's whitening
// differences a line down to a constant innovation, a fraction of the innovations' spread, and a raised level
// takes the rest: a line and a walk reach almost the same likelihood (the `unseen` suite's ooc-drift cases, a
// drift of 20–50 segment σ over the log: the walk within 0.4–67 of the line alone, raise ratio 5–9, the axes
// called at noise). The question is whether the walk's increments average to zero: gain is the likelihood ratio
// of the raise's kind beside a line c·(t − t_mid)/duration_s against it alone, each with its level profiled (the
// raise's level × 2^(k/8), k = −32..8, and the model's own), on the ML likelihood Σ log S + χ² (one parameter:
// χ²(1) under a stationary walk). Not whole_log_wander's REML criterion, whose log det of the columns'
// information changes with the columns (≈ 10 in the line's favour on every walk of the unit test). line_gain:
// the line's Δχ² under m's own level (no raise); slope_per_s: that line's c / duration_s. rows = [z | x], m the
// model's own level as for whole_log_wander.
//
// The same question of a settling transient a·e^{−(t − t_first)/τ} (a turn-on warm-up: die and package stress
// relaxing after power-up), τ from duration_s/20 to duration_s/1.5 on a grid of √2 (n_shapes − 1 of them):
// settle_gain is the best one's likelihood ratio, settle_tau_s its τ, settle_amplitude its a under the model's
// own level at t_first and settle_own_gain its Δχ² there.
// O(42 · n · (P + n_shapes)² + 42 · n_shapes · P³): one GLS pass per level, every shape fitted from it.
struct TrendBias {
  double gain = 0, line_gain = 0, slope_per_s = 0;
  double settle_gain = 0, settle_own_gain = 0, settle_tau_s = 0, settle_amplitude = 0;
  int n_shapes = 0;
};
TrendBias trend_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                     const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                     const WholeLogWander& raise, const std::vector<int>* seg_of = nullptr);

// A function of the logged inputs against the raised wander that would take it, as trend_bias asks of a line in
// time: the whole log's residual follows something the table or the chamber did, which stationary wander cannot
// (a bias that grows with how fast the die's temperature moves either way is one slow bump per ramp; the dwells
// read it as flicker and a raise 4–8× takes it: `unseen4` ooc-abs_temp_rate, stop 54). functions: one column per
// candidate (block means, rows' order; diagnose.cpp passes the signature library of residual_signature less
// time, which trend_bias asks). gain: the largest likelihood ratio of the raise beside one function against the
// raise alone, each with its level profiled as in trend_bias; own_gain: that function's Δχ² under m's own level;
// best: its column (−1: none); n_functions: the non-zero columns asked (the look-elsewhere count the caller's
// bar carries). The functions are screened at the raise's own level and the six likeliest there profiled.
// O(n · (P + F)² + F · P³ + 42 · n · (P + 6)²), F = functions.cols().
struct InputBias {
  double gain = 0, own_gain = 0;
  int best = -1, n_functions = 0;
};
InputBias input_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                     const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                     const WholeLogWander& raise, const Eigen::Ref<const Eigen::MatrixXd>& functions,
                     const std::vector<int>* seg_of = nullptr);

// The same question of a family of functions at once: the columns of `group` together (a flexible function of
// one input, e.g. the hats of the die temperature that together draw any smooth curve of T). A single hat matches a
// bump of another width only in part, and at a high SNR the misfit it leaves still wants the raise: the curve the
// hats draw together takes the bump whole, and the raise with it (`unseen5` ooc-temp_bump). gain: the likelihood
// ratio of the raise beside all of them against the raise alone, each profiled; own_gain: theirs under m's own
// level; n_functions: the non-zero columns (the ratio's degrees of freedom); best stays −1 (no one column is the
// answer: the caller names one). O(42 · n · (P + G)²), G = group.cols().
InputBias input_group_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                           const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                           const WholeLogWander& raise, const Eigen::Ref<const Eigen::MatrixXd>& group,
                           const std::vector<int>* seg_of = nullptr);

// Rounding quantiser of an output (docs/diagnosis.md § 2, "output step"). A quantiser whose step Δ is not
// small against the noise ahead of it (σ below about 0.6 Δ) leaves a bias in the mean of a constant input x that
// depends on where x falls between two steps: Σ_k (−1)^k (Δ/πk) e^{−2π²k²σ²/Δ²} sin(2πkx/Δ). Over the poses of a
// campaign x mod Δ is as good as uniform, so each static mean carries an independent rounding bias of variance
// quantization_mean_bias_var; white noise alone would say none. IEEE 952's Q term (3Q²/τ² of an integrated
// output) does not describe it: the rounding of a rate output is white to the Allan curve.
//
// Step Δ of an output from its sample-to-sample differences: the values lie on a lattice when (nearly) every
// difference is a whole number of the smallest non-zero one (within 15 %, so a coarse step re-rounded to a
// finer LSB still counts). Returns 0 when they do not (continuous values, or fewer than 100 non-zero steps).
// abs_diffs: |y_i − y_{i−1}|; tiny: what counts as zero (float resolution of the values). O(n log n).
double output_step(std::vector<double> abs_diffs, double tiny);
// Variance, over a uniform position of the input within a step, of the mean rounding error of a constant
// input read through a rounding quantiser of step `step` after Gaussian noise `sigma`:
// Σ_k Δ²/(2π²k²) e^{−4π²k²σ²/Δ²} (Δ²/12 at σ = 0; below 1e-15 Δ² from σ ≈ 0.95 Δ on). O(1).
double quantization_mean_bias_var(double step, double sigma);
// The noise σ ahead of a quantiser of step `step` from the variance of its output within static stretches
// (out_var, the white level the Allan curve shows: N²·fs): solves σ² + Δ²/12 − quantization_mean_bias_var = out_var.
// Sheppard's σ² = out_var − Δ²/12 holds only from σ ≈ 0.5 Δ on; below, rounding hides part of the noise.
// O(60 · 64).
double quantizer_input_sigma(double step, double out_var);


// Variance of Σ u_i x_i over block means x_i in time order (mid times t_s ascending, durations dur_s, segment
// ids seg) under m: Σ_i Σ_j u_i u_j cov(x_i, x_j), with block_covariance's terms across blocks (the GM and flicker
// states at their point estimate, decaying with the time between the blocks; the random walk from t_start with
// its prior rw_prior_var; the per-segment bias within a segment only), and diag[i] as the variance of x_i itself.
// The cells of the report weigh held-out residuals of many blocks, which share the slow bias: the standard error
// of their mean is this, not √Σ u_i² diag_i (varied9 null-tactical-2, an axis at its noise under a 300 s bias
// instability: gyro.z's "rate: static" cell, 179 blocks, read z = −5.6 with the blocks taken as independent and
// −1.5 with this). One pass per correlated state: O(n · states) time, O(n) extra memory.
double weighted_sum_variance(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                             const std::vector<int>& seg, const std::vector<double>& u, const std::vector<double>& diag,
                             double t_start, double rw_prior_var);

// Covariance of two block means of one segment under the model (mid times ti, tj, durations di, dj);
// i == j includes the white part. Used for the variance of a segment mean.
double block_covariance(const StochasticModel& m, double ti, double di, double tj, double dj, bool same, double t_start,
                        double rw_prior_var);

}  // namespace imuforge::diagnosis
