// Estimation core of the calibration solver: information-form least squares, covariance, observability.
//
// Everything here works on the *information* (normal-equation) form of a weighted least-squares problem:
//   H = Σ Jᵀ W J   (n × n, the Fisher information when W is the inverse noise covariance)
//   g = Σ Jᵀ W r   (n)
//   c = Σ rᵀ W r   (the weighted residual sum of squares at the linearisation point)
// so memory depends only on the number of parameters, never on the number of samples.
#pragma once

#include <Eigen/Dense>
#include <stdexcept>
#include <string>
#include <vector>

namespace imuforge::solver {

// Any solver failure on bad input or an ill-posed problem. what() names the cause.
class SolverError : public std::runtime_error {
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

// Covariance = H⁻¹ (via a scaled Cholesky); throws SolverError naming the unobservable combinations when
// H is rank-deficient.
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
// Levenberg-Marquardt on a problem that can linearise itself.
class NonlinearProblem {
 public:
  virtual ~NonlinearProblem() = default;
  virtual int num_params() const = 0;
  // Fills ne with Jᵀ W J, Jᵀ W r and rᵀ W r at theta, where r = measurement − prediction(theta).
  virtual void linearize(const Eigen::VectorXd& theta, NormalEquations& ne) const = 0;
  // Weighted cost at theta; the default linearises (override when a cheaper evaluation exists).
  virtual double cost(const Eigen::VectorXd& theta) const {
    NormalEquations ne(num_params());
    linearize(theta, ne);
    return ne.cost;
  }
};

struct LmOptions {
  int max_iterations = 100;
  double initial_lambda = 1e-4;  // relative to diag(H)
  // Converged when the step, in units of the current σ (stepᵀ H step), is below this. 1e-16 ↔ 1e-8 σ.
  double step_tolerance_sq = 1e-16;
};

struct LmResult {
  Eigen::VectorXd theta;
  NormalEquations normal;  // at theta (info = Fisher information for the final covariance)
  int iterations = 0;
  bool converged = false;
};

LmResult levenberg_marquardt(const NonlinearProblem& problem, Eigen::VectorXd theta0, const LmOptions& opt = {});

}  // namespace imuforge::solver
