// Statistics used by the gap diagnosis: chi-square tail, overlapping Allan variance, the IEEE 952 noise-term
// fit of an Allan curve, and the largest spectral line of an irregularly sampled series. No dependency on the
// rest of imuforge.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

namespace imuforge::diagnosis {

// Natural log of the regularized upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a), a > 0, x ≥ 0.
// Computed in log space so tails far below 1e-308 keep their ranking. Series for x < a+1, Lentz continued
// fraction otherwise (both converge to ~1e-15 relative). Throws std::invalid_argument for a ≤ 0 or x < 0.
double log_gamma_q(double a, double x);
double gamma_q(double a, double x);
// Survival function of the chi-square distribution with k degrees of freedom: P(X > x).
double chi2_sf(double x, double k);
// log10 of the same, for ranking scores (−log10 p).
double chi2_log10_sf(double x, double k);

// Pooled overlapping Allan variance over several contiguous series sampled at tau0_s. Series shorter
// than 2m+1 samples do not contribute at cluster size m. Cluster sizes are octaves 1, 2, 4, ...
class AllanAccumulator {
 public:
  explicit AllanAccumulator(double tau0_s = 1.0) : tau0_s_(tau0_s) {}
  void set_tau0(double tau0_s) { tau0_s_ = tau0_s; }
  double tau0() const { return tau0_s_; }
  // Adds one contiguous series. O(L log L).
  void add_series(const std::vector<double>& x);
  struct Point {
    double tau_s;
    double avar;   // Allan variance (unit²)
    double edf;    // equivalent degrees of freedom of the estimate (white-noise approximation, Howe)
    long long terms;
  };
  // Points with at least min_terms squared differences.
  std::vector<Point> points(long long min_terms = 4) const;

 private:
  double tau0_s_;
  std::vector<double> num_, edf_;
  std::vector<long long> cnt_;
};

// IEEE Std 952 Annex C noise terms of an Allan variance curve:
//   AVAR(τ) = 3Q²/τ² + N²/τ + (2 ln2/π) B² + K² τ / 3
// Q quantization (unit), N white noise density (unit/√Hz), B bias instability (unit, so that the flat
// Allan deviation floor is 0.664 B), K rate random walk (unit·√Hz).
struct NoiseTerms {
  double Q = 0, N = 0, B = 0, K = 0;
  double avar(double tau_s) const;
};
struct NoiseFit {
  NoiseTerms terms;
  double sigma[4] = {0, 0, 0, 0};  // 1σ of Q, N, B, K (from the linearised fit; 0 when the term is inactive)
  double chi2 = 0.0;               // Σ edf·(AVAR_meas − AVAR_fit)² / AVAR_fit² at the optimum
  int n_points = 0;
};
// Non-negative weighted least squares over the enabled terms (mask bit 0 Q, 1 N, 2 B, 3 K): every subset of
// the enabled terms is tried and the best feasible one kept (4 terms -> 16 small solves).
// Weighted least squares of Allan points on Σ c_i basis(i, τ), i < p, weights edf/(2·AVAR²) reweighted with the
// fit (3 passes). False when the system is singular or a coefficient is not positive (the caller tries another
// subset). chi2 = Σ edf/2 (AVAR − fit)²/fit²; H = the weighted information (for σ).
bool fit_allan_terms(const std::vector<AllanAccumulator::Point>& pts, const std::function<double(int, double)>& basis, int p,
                     Eigen::VectorXd& c, Eigen::MatrixXd& H, double& chi2);
// gm_T_s > 0: every subset also carries an exponentially correlated (first-order Gauss-Markov) term of that
// correlation time (IEEE 952's correlated noise; an output filter's bend at the short end), amplitude fitted,
// not reported among the terms; chi2 stays +inf when no subset fits with it.
NoiseFit fit_noise_terms(const std::vector<AllanAccumulator::Point>& pts, unsigned enabled_mask = 0xF, double gm_T_s = 0.0);

// Largest Lomb–Scargle power of the series e (standardised innovations, mean removed inside) sampled at t_s, over
// frequencies 2/D .. 1/(2 · median spacing) (D the span of t_s) on a grid oversampled 4× against 1/D (less, and then
// a lower top frequency, where n × frequencies would pass 4e7: O(n²) otherwise); the power
// is the χ²(2)/2 of the best-fitting sinusoid (Exp(1) under white noise at each frequency). false_alarm_p: Baluev's
// (2008) bound for the largest of them over the range searched, valid for irregular sampling. O(min(n², 4e7)) by
// trigonometric recurrence. The sums of cos², sin² and cos·sin per frequency depend on t_s alone and are kept per
// thread for the last four grids (keyed by the times' bits): a later call over the same times skips them and gives
// the powers a first call would, to the last bit. Thread-safe (nothing shared between threads).
struct SpectralLine {
  double power = 0, false_alarm_p = 1, period_s = 0;
};
SpectralLine line_power_spectrum(const std::vector<double>& t_s, const Eigen::Ref<const Eigen::VectorXd>& e);

}  // namespace imuforge::diagnosis
