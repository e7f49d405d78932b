#include "host/solver/estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numeric>

namespace imuforge::solver {

void NormalEquations::reset(int n) {
  info = Eigen::MatrixXd::Zero(n, n);
  rhs = Eigen::VectorXd::Zero(n);
  cost = 0.0;
  n_obs = 0;
}

void NormalEquations::add_row(const Eigen::Ref<const Eigen::VectorXd>& j, double r, double w) {
  info.selfadjointView<Eigen::Lower>().rankUpdate(j, w);
  // rankUpdate fills only the lower triangle; keep the full matrix symmetric for callers.
  info.triangularView<Eigen::StrictlyUpper>() = info.transpose().triangularView<Eigen::StrictlyUpper>();
  rhs.noalias() += (w * r) * j;
  cost += w * r * r;
  ++n_obs;
}

NormalEquations& NormalEquations::operator+=(const NormalEquations& o) {
  if (o.size() != size()) throw SolverError("normal equations of different sizes cannot be added");
  info += o.info;
  rhs += o.rhs;
  cost += o.cost;
  n_obs += o.n_obs;
  return *this;
}

std::string format_combination(const Eigen::VectorXd& v, const std::vector<std::string>& names) {
  std::vector<int> idx(static_cast<size_t>(v.size()));
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](int a, int b) { return std::abs(v[a]) > std::abs(v[b]); });
  // Sign convention: the largest component positive, so the text is stable across eigen-solvers.
  const double sign = v[idx[0]] < 0 ? -1.0 : 1.0;
  std::string s;
  for (int i : idx) {
    const double c = sign * v[i];
    if (std::abs(c) < 0.05) break;
    char buf[48];
    std::snprintf(buf, sizeof buf, "%s%.3f*", s.empty() ? (c < 0 ? "-" : "") : (c < 0 ? " - " : " + "), std::abs(c));
    s += buf;
    s += names[static_cast<size_t>(i)];
  }
  return s;
}

namespace {

struct Scaled {
  Eigen::VectorXd d;  // scale: θ_scaled = θ / d, d = 1/√H_ii
  Eigen::MatrixXd hs; // unit-diagonal information
  std::vector<int> zero_diag;
};

Scaled scale_information(const Eigen::MatrixXd& info) {
  const int n = static_cast<int>(info.rows());
  Scaled s;
  s.d = Eigen::VectorXd::Zero(n);
  const double max_diag = n ? info.diagonal().cwiseAbs().maxCoeff() : 0.0;
  for (int i = 0; i < n; ++i) {
    const double h = info(i, i);
    if (!(h > max_diag * 1e-300) || !std::isfinite(h)) {
      s.zero_diag.push_back(i);
      s.d[i] = 0.0;
    } else {
      s.d[i] = 1.0 / std::sqrt(h);
    }
  }
  s.hs = s.d.asDiagonal() * info * s.d.asDiagonal();
  for (int i : s.zero_diag) s.hs(i, i) = 0.0;
  return s;
}

}  // namespace

Observability analyse_observability(const Eigen::MatrixXd& info, const std::vector<std::string>& names,
                                    double rel_tol) {
  const int n = static_cast<int>(info.rows());
  if (info.cols() != n || static_cast<int>(names.size()) != n)
    throw SolverError("observability: information matrix and parameter names disagree in size");
  if (!info.allFinite()) throw SolverError("observability: information matrix has non-finite entries");
  Observability o;
  o.n_params = n;
  o.parameter_unobservable.assign(static_cast<size_t>(n), false);
  if (n == 0) return o;
  const Scaled s = scale_information(info);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(s.hs);
  if (es.info() != Eigen::Success) throw SolverError("observability: eigen-decomposition failed");
  const Eigen::VectorXd& lam = es.eigenvalues();  // ascending
  const double lmax = std::max(lam[n - 1], 0.0);
  const double thr = rel_tol * lmax;
  o.rank = 0;
  for (int k = 0; k < n; ++k) {
    if (lam[k] > thr && lmax > 0) {
      ++o.rank;
      continue;
    }
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    o.unobservable.push_back(format_combination(v, names));
    for (int i = 0; i < n; ++i)
      if (v[i] * v[i] > 1e-6) o.parameter_unobservable[static_cast<size_t>(i)] = true;
  }
  o.condition_number = (o.rank == n) ? lmax / lam[0] : std::numeric_limits<double>::infinity();
  return o;
}

Eigen::MatrixXd covariance_from_information(const Eigen::MatrixXd& info, const std::vector<std::string>& names,
                                            Observability* obs_out) {
  Observability obs = analyse_observability(info, names);
  if (obs_out) *obs_out = obs;
  const int n = static_cast<int>(info.rows());
  if (obs.rank < n) {
    std::string msg = "rank-deficient problem: the campaign cannot separate " + std::to_string(n - obs.rank) +
                      " parameter combination(s) of " + std::to_string(n) + ": ";
    for (size_t i = 0; i < obs.unobservable.size(); ++i) msg += (i ? "; " : "") + obs.unobservable[i];
    msg += " (add excitation to the campaign or remove these effects from the model)";
    throw SolverError(msg);
  }
  const Scaled s = scale_information(info);
  Eigen::LLT<Eigen::MatrixXd> llt(s.hs);
  if (llt.info() != Eigen::Success) throw SolverError("information matrix is not positive definite");
  Eigen::MatrixXd cs = llt.solve(Eigen::MatrixXd::Identity(n, n));
  Eigen::MatrixXd cov = s.d.asDiagonal() * cs * s.d.asDiagonal();
  return 0.5 * (cov + cov.transpose());
}

Estimate solve_normal_equations(const NormalEquations& ne, const std::vector<std::string>& names,
                                Observability* obs_out) {
  Estimate e;
  e.names = names;
  e.covariance = covariance_from_information(ne.info, names, obs_out);
  e.value = e.covariance * ne.rhs;
  return e;
}

Estimate solve_partial(const Eigen::MatrixXd& info, const Eigen::VectorXd& rhs, const std::vector<std::string>& names,
                       double rel_tol) {
  const int n = static_cast<int>(info.rows());
  Estimate e;
  e.names = names;
  e.value = Eigen::VectorXd::Zero(n);
  e.covariance = Eigen::MatrixXd::Zero(n, n);
  if (n == 0) return e;
  const Scaled s = scale_information(info);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(s.hs);
  const Eigen::VectorXd& lam = es.eigenvalues();
  const double lmax = std::max(lam[n - 1], 0.0);
  Eigen::MatrixXd pinv = Eigen::MatrixXd::Zero(n, n);
  std::vector<bool> bad(static_cast<size_t>(n), false);
  for (int k = 0; k < n; ++k) {
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    if (lmax > 0 && lam[k] > rel_tol * lmax) {
      pinv.noalias() += (1.0 / lam[k]) * v * v.transpose();
    } else {
      for (int i = 0; i < n; ++i)
        if (v[i] * v[i] > 1e-6) bad[static_cast<size_t>(i)] = true;
    }
  }
  for (int i : s.zero_diag) bad[static_cast<size_t>(i)] = true;
  e.covariance = s.d.asDiagonal() * pinv * s.d.asDiagonal();
  e.value = e.covariance * rhs;
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i)
    if (bad[static_cast<size_t>(i)]) e.covariance(i, i) = inf;
  return e;
}

Eigen::VectorXd Estimate::sigma() const { return covariance.diagonal().cwiseMax(0.0).cwiseSqrt(); }

Eigen::MatrixXd Estimate::correlation() const {
  const Eigen::VectorXd s = sigma();
  const int n = static_cast<int>(s.size());
  Eigen::MatrixXd c(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double d = s[i] * s[j];
      c(i, j) = (d > 0 && std::isfinite(d)) ? covariance(i, j) / d : (i == j ? 1.0 : 0.0);
    }
  return c;
}

int Estimate::index_of(const std::string& name) const {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

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
