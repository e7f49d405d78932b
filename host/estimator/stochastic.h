// The stochastic (time-correlated) noise model of a sensor channel and its exact GLS whitening: the one
// likelihood under which the diagnosis tests effects (host/diagnosis/noise_model.h fits the model to the Allan
// curve of the static dwells) and the solver's dwell drift is fitted (drift.h). A fix here is a fix in both.
//
// Per channel: white noise N, quantization Q, one first-order Gauss-Markov bias (stationary σ, correlation time
// T), flicker (1/f) bias noise as a bank of Gauss-Markov states of one common σ with correlation times a factor 4
// apart, a rate random walk K, and a bias constant within a segment and independent between segments.
#pragma once

#include <utility>
#include <vector>

#include <Eigen/Core>

#include "host/estimator/estimator.h"

namespace imuforge::estimator {

struct StochasticModel {
  double Q = 0;        // quantization, unit
  double N = 0;        // white noise density, unit/√Hz
  double gm_sigma = 0; // Gauss-Markov stationary σ, unit
  double gm_tau_s = 0; // its correlation time, s (0 = none)
  double K = 0;        // rate random walk, unit·√Hz
  double flicker_B = 0;               // flicker bias instability, unit (Allan floor ≈ 0.664 B)
  double bank_sigma = 0;              // common stationary σ of each flicker GM state, unit
  std::vector<double> bank_tau_s;     // their correlation times, s (empty = no flicker term)
  // The flicker level the LIKELIHOOD carries: the one-sided 95 % upper confidence limit of the bank's σ on the
  // Allan curve (profile over the other terms), ≥ bank_sigma. A static record of minutes pins a bias
  // instability that sits below its white noise only loosely (often to zero); every inertial sensor has one,
  // and an under-stated one lets its hour-scale wander read as a thermal effect. The point estimate
  // (bank_sigma, flicker_B) is what is reported.
  double bank_sigma_lik = 0;
  double flicker_B_upper = 0;         // B of bank_sigma_lik, unit
  // Variance of a bias that is constant within a segment and independent between segments: the rounding
  // bias of a quantised output's static means (quantization_mean_bias_var). Not part of the Allan fit.
  double seg_bias_var = 0;
  double chi2 = 0;     // Allan-fit χ² (Σ edf/2 (AVAR − fit)²/fit²)
  int n_points = 0;
  // Allan variance of the model at cluster time tau_s.
  double avar(double tau_s) const;
  // Variance of the mean of white + quantization noise over tau_s (what a block mean carries
  // independently of its neighbours).
  double white_var(double tau_s) const;
  // Every Gauss-Markov state (the single GM first, then the flicker bank): {σ², T}. upper_limit: the bank at
  // bank_sigma_lik (the likelihood: GLS whitening), else at the point estimate bank_sigma (the variance of a
  // block or segment mean: noise floors, held-out χ², cells).
  std::vector<std::pair<double, double>> gm_states(bool upper_limit = true) const;
};

// Correlation times of a flicker bank spanning [T_lo, T_hi] (factor 4 apart, both ends covered).
std::vector<double> flicker_bank_taus(double T_lo_s, double T_hi_s);
// Allan variance of a bank of unit-variance GM states at those correlation times.
double flicker_bank_avar(double tau_s, const std::vector<double>& bank_tau_s);

// Allan variance of a first-order Gauss-Markov process of unit stationary variance and correlation time T.
double gauss_markov_avar(double tau_s, double T_s);

// B of a flicker bank of common state σ (the bank's Allan floor inside its span is 0.664² B²).
double flicker_B_of_sigma(double bank_sigma, const std::vector<double>& bank_tau_s);

// A block mean over d of a Gauss-Markov process of correlation time T, against its value g at mid-block:
// mean = alpha·g + e, Var(mean) = vm·σ² (both → 1 for d ≪ T), so the part not carried by the state is
// (vm − alpha²)·σ². whiten_segment takes e as independent between blocks. O(1).
void gm_block(double d, double T, double& alpha, double& vm);

// GLS whitening of one segment's block means by a Kalman filter over the bias states (GM, RW).
// Blocks in time order: mid time t_s, duration dur_s, observation row [z | x] (1 + P columns).
// Outputs the innovations of every column and the innovation variance S per block, so that
//   Σ (ν_z − ν_x θ)² / S  is the exact −2 log-likelihood (up to a constant) of θ for this segment.
// rw_prior_var: variance of the random-walk bias at the segment start (it is not known from outside).
// extra_var (optional, one per block): a white variance added to the block's own (the solver's dwell means, whose
// white part is σ²/n per dwell rather than N²/d).
// missing (optional, one flag per block): blocks treated as not observed (the state is only propagated
// across them; their innovation row is 0 and S = 1), so that a training set's GLS leaves them out exactly.
// seg_of (optional, one segment id per block): where m.seg_bias_var restarts (a new id); without it every block
// is its own segment.
// O(n · P).
void whiten_segment(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                    const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, Eigen::Ref<Eigen::MatrixXd> innov,
                    Eigen::Ref<Eigen::VectorXd> S, const std::vector<char>* missing = nullptr,
                    const std::vector<int>* seg_of = nullptr, const Eigen::VectorXd* extra_var = nullptr);

// The GLS normal equations of rows = [z | x] under m, on the shared estimator core: the innovations
// whiten_segment gives, each block weighted by 1/S; blocks marked in `missing` are left out as they are there.
// Every GLS fit of the diagnosis (the selection's per-fold sums, the tests of one effect under a raised wander,
// heating against cooling, the form check, the whole-log likelihood) goes through here, so a change to the
// likelihood is one change. Optional outputs: Σ log S over the blocks used (for −2 log L), and the innovations
// and their variances themselves; extra_var as whiten_segment takes it. O(n · (P² + P · states)).
estimator::NormalEquations gls_normal_equations(const StochasticModel& m, const std::vector<double>& t_s,
                                                const std::vector<double>& dur_s, const Eigen::Ref<const Eigen::MatrixXd>& rows,
                                                double rw_prior_var, const std::vector<int>* seg_of,
                                                const std::vector<char>* missing = nullptr, double* sum_log_S = nullptr,
                                                Eigen::MatrixXd* innov_out = nullptr, Eigen::VectorXd* S_out = nullptr,
                                                const Eigen::VectorXd* extra_var = nullptr);

}  // namespace imuforge::estimator
