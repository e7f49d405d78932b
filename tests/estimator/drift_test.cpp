// The dwell-drift model of the estimator core (host/estimator/drift.h): its likelihood (the shared Kalman
// whitening, stochastic.h) against the dense REML formula, its covariance product against the dense matrix, bad
// input refused. The statistical checks are in drift_coverage_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include "host/estimator/drift.h"
#include "host/estimator/estimator.h"
#include "host/estimator/stochastic.h"
#include "tests/estimator/drift_series.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace estimator_drift_test {

using namespace imuforge::estimator;
using estimator_drift_series::drift_series;

namespace {

// The dwell means' covariance written out: C_ij = gm_var exp(−|t_i − t_j|/τ) + the flicker bank's states, plus the
// offsets and the white variance on the diagonal.
Eigen::MatrixXd dense_cov(const DwellDrift& d, const std::vector<double>& t, const Eigen::VectorXd& w) {
  const Eigen::Index S = static_cast<Eigen::Index>(t.size());
  Eigen::MatrixXd V = Eigen::MatrixXd::Zero(S, S);
  std::vector<std::pair<double, double>> states;
  if (d.gm_var > 0) states.push_back({d.gm_var, d.gm_tau_s});
  for (double T : d.flicker_tau_s) states.push_back({d.flicker_var, T});
  for (const auto& [var, tau] : states)
    for (Eigen::Index i = 0; i < S; ++i)
      for (Eigen::Index j = 0; j < S; ++j)
        V(i, j) += var * std::exp(-std::abs(t[static_cast<size_t>(i)] - t[static_cast<size_t>(j)]) / tau);
  for (Eigen::Index i = 0; i < S; ++i) V(i, i) += w[i] + d.offset_var;
  return V;
}

double dense_reml(const DwellSeries& s, const DwellDrift& d) {
  const Eigen::MatrixXd V = dense_cov(d, s.t_s, s.white_var);
  const Eigen::LLT<Eigen::MatrixXd> llt(V);
  const Eigen::MatrixXd ViX = llt.solve(s.X);
  const Eigen::VectorXd Viy = llt.solve(s.y);
  const Eigen::MatrixXd A = s.X.transpose() * ViX;
  const Eigen::LLT<Eigen::MatrixXd> la(A);
  const double logdetV = 2.0 * Eigen::MatrixXd(llt.matrixL()).diagonal().array().log().sum();
  const double logdetA = 2.0 * Eigen::MatrixXd(la.matrixL()).diagonal().array().log().sum();
  const Eigen::VectorXd Xty = s.X.transpose() * Viy;
  return logdetV + logdetA + s.y.dot(Viy) - Xty.dot(la.solve(Xty));
}

}  // namespace

TEST(DwellDrift, KalmanLikelihoodMatchesTheDenseRemlUpToAConstant) {
  const DwellSeries s = drift_series(60, 1, 4.0, 900.0, 0.5, 1.0);
  DwellDrift d1{0.5, 4.0, 900.0}, d2{0.0, 1.0, 200.0}, d3{2.0, 0.0, 0.0};
  d2.flicker_var = 0.3;  // a flicker bank beside the wander
  d2.flicker_tau_s = flicker_bank_taus(20.0, 6000.0);
  const double k1 = dwell_drift_reml(s, d1), k2 = dwell_drift_reml(s, d2), k3 = dwell_drift_reml(s, d3);
  const double r1 = dense_reml(s, d1), r2 = dense_reml(s, d2), r3 = dense_reml(s, d3);
  // The Kalman form works on an orthonormal basis of X, the dense one on X: they differ by one constant.
  EXPECT_NEAR(k1 - k2, r1 - r2, 1e-8 * std::abs(r1));
  EXPECT_NEAR(k1 - k3, r1 - r3, 1e-8 * std::abs(r1));
}

TEST(DwellDrift, CovarianceProductMatchesTheDenseMatrix) {
  const DwellSeries s = drift_series(50, 2, 1.0, 300.0, 0.0, 1.0);
  DwellDrift d{0.7, 2.5, 450.0};
  d.flicker_var = 0.4;
  d.flicker_tau_s = flicker_bank_taus(20.0, 6000.0);
  Eigen::MatrixXd G = Eigen::MatrixXd::Random(50, 3);
  const Eigen::MatrixXd want = (dense_cov(d, s.t_s, Eigen::VectorXd::Zero(50)) * G).eval();
  const Eigen::MatrixXd got = drift_covariance_times(d, s.t_s, G);
  EXPECT_LT((got - want).norm(), 1e-10 * want.norm());
}

TEST(DwellDrift, BadSeriesIsRefusedByName) {
  DwellSeries s = drift_series(10, 3, 0, 0, 0, 1.0);
  std::swap(s.t_s[3], s.t_s[4]);
  try {
    fit_dwell_drift(s);
    FAIL() << "times out of order accepted";
  } catch (const EstimatorError& e) {
    EXPECT_NE(std::string(e.what()).find("out of order at dwell 4"), std::string::npos) << e.what();
  }
}

}  // namespace estimator_drift_test
