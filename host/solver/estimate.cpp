#include "host/solver/estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numeric>

namespace imuforge::solver {

LmResult levenberg_marquardt(const NonlinearProblem& problem, Eigen::VectorXd theta, const LmOptions& opt) {
  const int n = problem.num_params();
  if (theta.size() != n) throw SolverError("levenberg_marquardt: initial guess has the wrong size");
  LmResult res;
  NormalEquations ne(n);
  problem.linearize(theta, ne);
  if (!std::isfinite(ne.cost)) throw SolverError("levenberg_marquardt: cost is not finite at the initial guess");
  double lambda = opt.initial_lambda;
  for (int it = 0; it < opt.max_iterations; ++it) {
    res.iterations = it + 1;
    // Gauss-Newton first (lambda applied only after a failed step) keeps linear problems to one step.
    bool accepted = false;
    for (int tries = 0; tries < 30 && !accepted; ++tries) {
      Eigen::MatrixXd a = ne.info;
      const double l = (tries == 0 && it == 0) ? 0.0 : lambda;
      for (int i = 0; i < n; ++i) a(i, i) += l * std::max(ne.info(i, i), 1e-300);
      Eigen::LDLT<Eigen::MatrixXd> ldlt(a);
      Eigen::VectorXd step = ldlt.solve(ne.rhs);
      if (!step.allFinite()) {
        lambda = std::max(lambda * 10, 1e-6);
        continue;
      }
      const double step_sq = step.dot(ne.info * step);
      Eigen::VectorXd cand = theta + step;
      NormalEquations ne_c(n);
      problem.linearize(cand, ne_c);
      if (std::getenv("IMUFORGE_LM_DEBUG"))
        std::fprintf(stderr, "LM it %d try %d lambda %.3g cost %.10g -> %.10g step_sq %.3g\n", it, tries, l, ne.cost,
                     ne_c.cost, step_sq);
      if (std::isfinite(ne_c.cost) && ne_c.cost <= ne.cost * (1 + 1e-12) + 1e-300) {
        theta = cand;
        ne = ne_c;
        lambda = std::max(lambda * 0.1, 1e-12);
        accepted = true;
        if (step_sq < opt.step_tolerance_sq) {
          res.converged = true;
        }
      } else {
        lambda = std::max(lambda * 10, 1e-6);
        if (step_sq < opt.step_tolerance_sq) {  // no decrease possible at this scale: at the minimum
          res.converged = true;
          break;
        }
      }
    }
    if (res.converged || !accepted) break;
  }
  res.theta = theta;
  res.normal = ne;
  return res;
}

}  // namespace imuforge::solver
