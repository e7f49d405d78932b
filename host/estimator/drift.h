// Dwell-to-dwell bias drift: the time-correlated part of a fixture log's noise, and what it does to the
// covariance of a least-squares estimate (docs/calibration.md, "Dwell drift").
//
// A calibration's σ from white noise alone assumes the dwell means scatter by σ²/n. A bias instability or a
// rate random walk moves each dwell's mean by an amount that is correlated with its neighbours' over minutes
// to hours. Over a thermal campaign that wander follows the temperature schedule, so bias_temp and the bias
// take much of it while their white-noise σ claims hundreds of times the precision they have.
//
// The drift model per channel, on the dwell means d_i (dwell i at mid-time t_i, n_i samples, white-noise
// variance w_i = σ²/n_i):
//   d_i = X_i β + o_i + g(t_i) + f(t_i) + white,   o_i independent with variance `offset_var`,
//   g a first-order Gauss-Markov process of stationary variance `gm_var` and correlation time `gm_tau_s`,
//   f flicker: a bank of Gauss-Markov states of one variance `flicker_var` over every time scale the dwells show.
// A long τ is a random walk over the log (its level is taken by the bias column); a τ far below the dwell
// spacing is a per-dwell offset. The wander is taken as constant over each dwell, its value at the dwell's
// mid-time: a wander faster than a dwell then counts fully in the dwell's mean, where averaging over the dwell
// would shrink it. That is deliberate. On the blind null and stochastic cases (docs/calibration.md, "Dwell
// drift") the averaged form covered the truth within 3σ in 0.970 and within 2σ in 0.91; this form gives 0.981
// and 0.943. The fitted model is never the sensor's noise, and that margin is what the misfit needs.
//
// The three variances and τ are fitted by restricted maximum likelihood (REML: the columns X profiled out and the
// log det of their information counted, so what the fit absorbs does not bias the level low). The likelihood is the diagnosis's: the Kalman whitening of stochastic.h over the dwells in time
// order, the wander and the flicker bank as its Gauss-Markov states.
//
// The estimate itself stays the caller's (weighted least squares over every sample); only its covariance
// changes, by the sandwich H⁻¹ Gᵀ C G H⁻¹ with G the per-dwell sums of the weighted regressors (the exact
// covariance of a WLS estimate when the noise is white within dwells plus the drift between them).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace imuforge::estimator {

// The dwell means of one channel, in time order.
struct DwellSeries {
  std::vector<double> t_s;    // mid-time of each dwell, s, non-decreasing
  Eigen::VectorXd y;          // dwell mean of the observation, unit
  Eigen::MatrixXd X;          // dwell mean of each regressor (the columns the fit has on this channel)
  Eigen::VectorXd white_var;  // variance of each mean under white noise alone, unit²
};

struct DwellDrift {
  double offset_var = 0;  // independent per-dwell offset variance, unit²
  double gm_var = 0;      // Gauss-Markov stationary variance, unit²
  double gm_tau_s = 0;    // its correlation time, s (0: none)
  // Flicker (1/f) wander: a bank of Gauss-Markov states of one variance, correlation times a factor 4 apart from a
  // quarter of the dwell spacing to the log's span (stochastic.h). One Gauss-Markov term fits one time scale; a
  // flicker bias has every scale, and the long ones move bias_temp.
  double flicker_var = 0;
  std::vector<double> flicker_tau_s;
  // −2 log L_R without drift minus with the fitted drift (≥ 0): the evidence for it.
  double gain = 0;
  int dwells = 0;
  int rank = 0;           // rank of X (the columns REML profiles out)
  // gain > kDriftGainThreshold (χ² on 2 dof at p 0.05; with τ and the flicker searched too, a white series passes
  // it by chance a little more often: ≤ 20 of 200 in DwellDrift.WhiteDwellMeansAdoptNoDrift). A channel without
  // adopted drift keeps its white σ.
  bool adopted = false;
  // When adopted: every drift the data do not reject against the best, −2 log L_R within kDriftPlausible of it
  // (the best first; at most kDriftPlausibleMax, in order of likelihood). A log of a few correlation times pins
  // τ and gm_var loosely, and where the schedule makes the wander collinear with a column (a random walk over one
  // thermal cycle and bias_temp) the best fit often reads a short τ that leaves the column's σ at half its
  // worth. The covariance a caller reports is the largest over this set, per parameter: an upper confidence
  // bound on each variance, not the point estimate's.
  std::vector<DwellDrift> plausible;
  bool any() const { return offset_var > 0 || gm_var > 0 || flicker_var > 0; }
};

constexpr double kDriftGainThreshold = 5.99;
constexpr double kDriftPlausible = 2.71;  // one-sided 95 % on one dof
constexpr size_t kDriftPlausibleMax = 200;

// Fits the drift model by REML. Returns no drift (adopted false) when there are no more dwells than the rank
// of X plus 3. Throws EstimatorError on times out of order or a non-positive white variance.
// O(grid · S · r²): S dwells, r the rank of X; a few hundred grid points.
DwellDrift fit_dwell_drift(const DwellSeries& s);

// −2 log L_R of the series under a given drift (constants dropped): what fit_dwell_drift maximises. O(S · r²).
double dwell_drift_reml(const DwellSeries& s, const DwellDrift& d);

// C·G for the drift's covariance C between the dwell means: C_ij = offset_var δ_ij + Σ_states var exp(−|t_i − t_j|/τ)
// over the Gauss-Markov wander and the flicker bank's states. Rows of G in the dwells' time order. Two exponential
// recursions per state, O(states · S · cols), no S×S matrix.
Eigen::MatrixXd drift_covariance_times(const DwellDrift& d, const std::vector<double>& t_s, const Eigen::MatrixXd& G);

// One channel's part of a weighted least-squares problem for drift_covariance: its fitted drift, its dwells'
// times, and G, per dwell (rows, time order) the sums of the weighted regressors Σ φ/σ² over the dwell's samples,
// on the parameter indices `cols` (the parameters that act on the channel).
struct ChannelDrift {
  const DwellDrift* drift = nullptr;
  const std::vector<double>* t_s = nullptr;
  Eigen::MatrixXd G;
  std::vector<int> cols;
};

// The covariance of a weighted least-squares estimate whose white-noise covariance is C0 = H⁻¹ when the channels
// carry their drifts (independent between channels): C0 + Σ_c C0 G_cᵀ C_c G_c C0, C_c the drift covariance between
// the channel's dwells. Each parameter's variance is the largest over its channel's plausible drifts; the matrix
// is the one of the drift that widens the channel's most-widened parameter most, its rows and columns scaled to
// those variances (a congruence: positive definite, its correlations that drift's). Channels whose drift is not
// adopted add nothing. O(Σ_c |plausible_c| · (S_c p_c² + n p_c²)), n = C0's size.
Eigen::MatrixXd drift_covariance(const Eigen::MatrixXd& C0, const std::vector<ChannelDrift>& channels);

}  // namespace imuforge::estimator
