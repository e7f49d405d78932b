// The solver's view of the shared estimator core (host/estimator/estimator.h: information-form least
// squares, covariance, observability), plus Levenberg-Marquardt for the problems that linearise
// themselves (reference-free, fixture-error modes).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "host/estimator/estimator.h"

namespace imuforge::solver {

// The estimator core (information form, covariance, observability) lives in host/estimator, shared with
// the diagnosis; these names keep the solver's code and its callers unchanged.
using SolverError = estimator::EstimatorError;  // any solver failure on bad input or an ill-posed problem
using estimator::analyse_observability;
using estimator::covariance_from_information;
using estimator::Estimate;
using estimator::format_combination;
using estimator::kDefaultRankTolerance;
using estimator::NormalEquations;
using estimator::Observability;
using estimator::solve_normal_equations;
using estimator::solve_partial;

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
