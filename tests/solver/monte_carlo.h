// Monte Carlo bookkeeping shared by solver_monte_carlo_test and solver_bench_monte_carlo: one fixture
// solve per seed of the same design, errors against the truth, NEES, bias and RMS/CRB per parameter.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "host/model/catalog.h"
#include "host/solver/estimate.h"

namespace mc {

// Wilson-Hilferty quantile of χ²(k) at the standard-normal quantile z.
inline double chi2_quantile(double k, double z) {
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1 - a + z * std::sqrt(a), 3);
}

struct Stats {
  std::vector<std::string> names;
  Eigen::MatrixXd crb;  // the first seed's covariance: same design every seed, so the Cramér-Rao bound
  Eigen::VectorXd sum_err, sum_sq;
  double nees_sum = 0;
  int seeds = 0;

  void add(const imuforge::solver::Estimate& e, const imuforge::model::ParamSet& truth) {
    const long n = long(e.names.size());
    if (seeds == 0) {
      names = e.names;
      crb = e.covariance;
      sum_err = Eigen::VectorXd::Zero(n);
      sum_sq = Eigen::VectorXd::Zero(n);
    }
    Eigen::VectorXd err(n);
    for (long i = 0; i < n; ++i) err[i] = e.value[i] - truth.get(names[size_t(i)]);
    sum_err += err;
    sum_sq += err.cwiseAbs2();
    nees_sum += err.dot(e.covariance.ldlt().solve(err));
    ++seeds;
  }
  long n() const { return long(names.size()); }
  double nees() const { return nees_sum / seeds; }
  // Two-sided 95 % interval of the mean NEES (N·n degrees of freedom).
  double nees_lo() const { return chi2_quantile(double(n()) * seeds, -1.959964) / seeds; }
  double nees_hi() const { return chi2_quantile(double(n()) * seeds, 1.959964) / seeds; }
  // Mean error of parameter i in standard errors (CRB/√N), and its RMS error over the CRB.
  double bias_z(long i) const { return (sum_err[i] / seeds) / (std::sqrt(crb(i, i)) / std::sqrt(double(seeds))); }
  double efficiency(long i) const { return std::sqrt(sum_sq[i] / seeds) / std::sqrt(crb(i, i)); }
};

}  // namespace mc
