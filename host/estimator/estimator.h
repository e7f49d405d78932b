// The estimator core shared by the calibration solver (host/solver) and the gap diagnosis
// (host/diagnosis): information-form weighted (or, on whitened rows, generalised) least squares,
// covariance, rank/observability reporting, and the k-fold held-out evaluation (kfold.h).
//
// Everything here works on the *information* (normal-equation) form of a weighted least-squares problem:
//   H = Σ Jᵀ W J   (n × n, the Fisher information when W is the inverse noise covariance)
//   g = Σ Jᵀ W r   (n)
//   c = Σ rᵀ W r   (the weighted residual sum of squares at the linearisation point)
// so memory depends only on the number of parameters, never on the number of samples. GLS is the same
// problem on rows whitened by the caller (e.g. the diagnosis's Kalman innovations, noise_model.h).
//
// A singular problem is never returned as a success: solve_normal_equations() throws naming the
// unobservable combinations; fit_subset() reports every column it could not separate in `dropped`.
#pragma once

#include <Eigen/Dense>
#include <stdexcept>
#include <string>
#include <vector>

namespace imuforge::estimator {

// Any estimator failure on bad input or an ill-posed problem. what() names the cause.
// (solver::SolverError is this type.)
class EstimatorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Normal equations accumulated from whitened rows (row = Jacobian row / σ, residual / σ).
struct NormalEquations {
  Eigen::MatrixXd info;  // H = Σ Jᵀ W J
  Eigen::VectorXd rhs;   // g = Σ Jᵀ W r
  double cost = 0.0;     // Σ rᵀ W r
  long long n_obs = 0;   // scalar observations accumulated

  NormalEquations() = default;
  explicit NormalEquations(int n) { reset(n); }
  void reset(int n);
  int size() const { return static_cast<int>(rhs.size()); }
  // One scalar observation r with Jacobian row j and weight w = 1/σ². O(n²).
  void add_row(const Eigen::Ref<const Eigen::VectorXd>& j, double r, double w);
  // The same, updating only the lower triangle of info (for many rows in a row: call symmetrize() after).
  void add_row_lower(const Eigen::Ref<const Eigen::VectorXd>& j, double r, double w);
  void symmetrize();  // copies the lower triangle of info to the upper
  NormalEquations& operator+=(const NormalEquations& o);
};

// The observability of a campaign for a set of parameters, from the eigen-decomposition of the
// information matrix scaled to unit diagonal (so parameters of different units compare fairly).
struct Observability {
  int n_params = 0;
  int rank = 0;
  double condition_number = 0.0;  // λ_max / λ_min of the scaled information (inf when singular)
  // One entry per unobservable direction: a readable combination such as
  // "0.707*accel.bias.x - 0.707*accel.bias_temp.x.t1" (coefficients of the scaled null vector).
  std::vector<std::string> unobservable;
  // Per parameter: true when it has a non-negligible component in some unobservable direction.
  std::vector<bool> parameter_unobservable;
};

// A direction of parameter space as readable text: "0.707*a - 0.707*b" (components below 0.05 omitted,
// the largest made positive so the text is stable across eigen-solvers).
std::string format_combination(const Eigen::VectorXd& v, const std::vector<std::string>& names);

// rel_tol: an eigenvalue of the unit-diagonal information below rel_tol·λ_max counts as zero.
// The default sits far above double rounding (≈1e-16·n) and far below any design we call observable.
constexpr double kDefaultRankTolerance = 1e-11;
Observability analyse_observability(const Eigen::MatrixXd& info, const std::vector<std::string>& names,
                                    double rel_tol = kDefaultRankTolerance);

// An estimate with its full covariance.
struct Estimate {
  std::vector<std::string> names;
  Eigen::VectorXd value;
  Eigen::MatrixXd covariance;
  Eigen::VectorXd sigma() const;        // √diag(covariance)
  Eigen::MatrixXd correlation() const;  // covariance scaled to unit diagonal
  int index_of(const std::string& name) const;  // -1 if absent
};

// Covariance = H⁻¹ (the scaled Cholesky of fit_subset); throws EstimatorError naming the unobservable
// combinations when H is rank-deficient.
Eigen::MatrixXd covariance_from_information(const Eigen::MatrixXd& info, const std::vector<std::string>& names,
                                            Observability* obs_out = nullptr);

// Solves the linear problem H θ = g (θ measured from the linearisation point). Throws on rank deficiency.
Estimate solve_normal_equations(const NormalEquations& ne, const std::vector<std::string>& names,
                                Observability* obs_out = nullptr);

// Pseudo-inverse covariance for a possibly rank-deficient information: σ = +inf for every parameter that
// touches an unobservable direction. Used by the recursive estimator before a campaign is complete.
Estimate solve_partial(const Eigen::MatrixXd& info, const Eigen::VectorXd& rhs, const std::vector<std::string>& names,
                       double rel_tol = kDefaultRankTolerance);

// ---------------------------------------------------------------------------------------------------
// Sub-problem solve with priority: the columns `sel` of ne (indices, in priority order), minus the
// statistics of `exclude` when given (a fold left out). A Cholesky of the unit-diagonal scaled
// information is built column by column; a column whose pivot 1 − ‖l‖² falls below drop_tol (it is, to
// that tolerance, a combination of the columns kept before it) or that carries no information is
// dropped and listed, never solved. With drop_tol = 0 only an exactly dependent column is dropped.
constexpr double kDefaultDropTolerance = 1e-9;
struct SubsetFit {
  std::vector<int> kept;     // indices into ne's columns, in priority order
  std::vector<int> dropped;  // columns not separable from the kept ones (reported, never solved)
  Eigen::VectorXd theta;     // over kept
  Eigen::MatrixXd cov;       // over kept: the inverse information of the kept columns
  double rss = 0;            // weighted residual sum of squares at theta (cost − gᵀθ)
};
SubsetFit fit_subset(const NormalEquations& ne, const std::vector<int>& sel, const NormalEquations* exclude = nullptr,
                     double drop_tol = kDefaultDropTolerance);

}  // namespace imuforge::estimator
