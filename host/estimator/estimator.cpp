#include "host/estimator/estimator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

namespace imuforge::estimator {

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

void NormalEquations::add_row_lower(const Eigen::Ref<const Eigen::VectorXd>& j, double r, double w) {
  info.selfadjointView<Eigen::Lower>().rankUpdate(j, w);
  rhs.noalias() += (w * r) * j;
  cost += w * r * r;
  ++n_obs;
}

void NormalEquations::symmetrize() { info = info.selfadjointView<Eigen::Lower>(); }

NormalEquations& NormalEquations::operator+=(const NormalEquations& o) {
  if (o.size() != size()) throw EstimatorError("normal equations of different sizes cannot be added");
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
    throw EstimatorError("observability: information matrix and parameter names disagree in size");
  if (!info.allFinite()) throw EstimatorError("observability: information matrix has non-finite entries");
  Observability o;
  o.n_params = n;
  o.parameter_unobservable.assign(static_cast<size_t>(n), false);
  if (n == 0) return o;
  const Scaled s = scale_information(info);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(s.hs);
  if (es.info() != Eigen::Success) throw EstimatorError("observability: eigen-decomposition failed");
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
    throw EstimatorError(msg);
  }
  // The same factorization as every other solve here (fit_subset): full rank was just checked, so a
  // dropped column can only mean the information is not positive definite.
  NormalEquations ne(n);
  ne.info = info;
  std::vector<int> all(static_cast<size_t>(n));
  std::iota(all.begin(), all.end(), 0);
  const SubsetFit f = fit_subset(ne, all, nullptr, 0.0);
  if (!f.dropped.empty()) throw EstimatorError("information matrix is not positive definite");
  return 0.5 * (f.cov + f.cov.transpose());
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


SubsetFit fit_subset(const NormalEquations& ne, const std::vector<int>& sel, const NormalEquations* exclude,
                     double drop_tol) {
  SubsetFit f;
  const int p = static_cast<int>(sel.size());
  const int n = ne.size();
  for (int c : sel)
    if (c < 0 || c >= n) throw EstimatorError("fit_subset: column index out of range");
  if (exclude && exclude->size() != n) throw EstimatorError("fit_subset: excluded statistics differ in size");
  Eigen::MatrixXd H(p, p);
  Eigen::VectorXd g(p);
  double q = ne.cost;
  for (int i = 0; i < p; ++i) {
    g[i] = ne.rhs[sel[static_cast<size_t>(i)]];
    for (int j = 0; j < p; ++j) H(i, j) = ne.info(sel[static_cast<size_t>(i)], sel[static_cast<size_t>(j)]);
  }
  if (exclude) {
    for (int i = 0; i < p; ++i) {
      g[i] -= exclude->rhs[sel[static_cast<size_t>(i)]];
      for (int j = 0; j < p; ++j) H(i, j) -= exclude->info(sel[static_cast<size_t>(i)], sel[static_cast<size_t>(j)]);
    }
    q -= exclude->cost;
  }
  // Incremental Cholesky on the unit-diagonal scaled information, columns in priority order.
  Eigen::VectorXd dscale(p);
  for (int i = 0; i < p; ++i) dscale[i] = H(i, i) > 0 ? 1.0 / std::sqrt(H(i, i)) : 0.0;
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(p, p);
  std::vector<int> kept_local;
  for (int c = 0; c < p; ++c) {
    if (dscale[c] == 0.0) {
      f.dropped.push_back(sel[static_cast<size_t>(c)]);
      continue;
    }
    const int k = static_cast<int>(kept_local.size());
    Eigen::VectorXd l(k);
    for (int i = 0; i < k; ++i) {
      const int ci = kept_local[static_cast<size_t>(i)];
      double s = H(ci, c) * dscale[ci] * dscale[c];
      for (int m = 0; m < i; ++m) s -= L(i, m) * l[m];
      l[i] = s / L(i, i);
    }
    const double dd = 1.0 - l.squaredNorm();
    if (!(dd > 0.0) || dd < drop_tol) {
      f.dropped.push_back(sel[static_cast<size_t>(c)]);
      continue;
    }
    for (int i = 0; i < k; ++i) L(k, i) = l[i];
    L(k, k) = std::sqrt(dd);
    kept_local.push_back(c);
  }
  const int k = static_cast<int>(kept_local.size());
  Eigen::MatrixXd Lk = L.topLeftCorner(k, k);
  Eigen::VectorXd gs(k), ds(k);
  for (int i = 0; i < k; ++i) {
    ds[i] = dscale[kept_local[static_cast<size_t>(i)]];
    gs[i] = g[kept_local[static_cast<size_t>(i)]] * ds[i];
    f.kept.push_back(sel[static_cast<size_t>(kept_local[static_cast<size_t>(i)])]);
  }
  if (k > 0) {
    auto tri = Lk.triangularView<Eigen::Lower>();
    Eigen::VectorXd y = tri.solve(gs);
    Eigen::VectorXd u = tri.transpose().solve(y);
    f.theta = ds.asDiagonal() * u;
    Eigen::MatrixXd Linv = tri.solve(Eigen::MatrixXd::Identity(k, k));
    f.cov = ds.asDiagonal() * (Linv.transpose() * Linv) * ds.asDiagonal();
    f.rss = q - gs.dot(u);
  } else {
    f.theta.resize(0);
    f.cov.resize(0, 0);
    f.rss = q;
  }
  return f;
}

}  // namespace imuforge::estimator
