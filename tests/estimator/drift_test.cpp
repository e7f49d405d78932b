// The dwell-drift model of the estimator core (host/estimator/drift.h): its likelihood (the shared Kalman
// whitening, stochastic.h) against the dense REML formula, its covariance product against the dense matrix, no drift claimed on white dwell means, and the
// drift's covariance covering a WLS estimate's error where the white σ does not.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include "host/estimator/drift.h"
#include "host/estimator/estimator.h"
#include "host/estimator/stochastic.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace estimator_drift_test {

using namespace imuforge::estimator;

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

// S dwells, one every 90 s on average (jittered), a bias and a slow "temperature" column; the wander at each
// dwell's time.
DwellSeries series(int S, unsigned seed, double gm_var, double tau_s, double offset_var, double white_var) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u(60.0, 120.0);
  DwellSeries s;
  s.t_s.resize(static_cast<size_t>(S));
  s.y.resize(S);
  s.X.resize(S, 2);
  s.white_var = Eigen::VectorXd::Constant(S, white_var);
  double t = 0, g = std::sqrt(gm_var) * n01(rng);
  for (int i = 0; i < S; ++i) {
    const double dt = u(rng);
    t += dt;
    if (gm_var > 0) {
      const double phi = std::exp(-dt / tau_s);
      g = phi * g + std::sqrt(gm_var * (1 - phi * phi)) * n01(rng);
    }
    s.t_s[static_cast<size_t>(i)] = t;
    s.X(i, 0) = 1.0;
    s.X(i, 1) = std::sin(2 * M_PI * t / (S * 90.0));  // one thermal cycle over the log
    s.y[i] = 0.3 + 0.1 * s.X(i, 1) + g + std::sqrt(offset_var) * n01(rng) + std::sqrt(white_var) * n01(rng);
  }
  return s;
}

}  // namespace

TEST(DwellDrift, KalmanLikelihoodMatchesTheDenseRemlUpToAConstant) {
  const DwellSeries s = series(60, 1, 4.0, 900.0, 0.5, 1.0);
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
  const DwellSeries s = series(50, 2, 1.0, 300.0, 0.0, 1.0);
  DwellDrift d{0.7, 2.5, 450.0};
  d.flicker_var = 0.4;
  d.flicker_tau_s = flicker_bank_taus(20.0, 6000.0);
  Eigen::MatrixXd G = Eigen::MatrixXd::Random(50, 3);
  const Eigen::MatrixXd want = (dense_cov(d, s.t_s, Eigen::VectorXd::Zero(50)) * G).eval();
  const Eigen::MatrixXd got = drift_covariance_times(d, s.t_s, G);
  EXPECT_LT((got - want).norm(), 1e-10 * want.norm());
}

TEST(DwellDrift, WhiteDwellMeansAdoptNoDrift) {
  int adopted = 0;
  for (unsigned seed = 0; seed < 200; ++seed) adopted += fit_dwell_drift(series(80, 100 + seed, 0, 0, 0, 1.0)).adopted;
  // Past 5.99 on about 2 dof: ≈ 5 % by chance (the grid's other directions add a little).
  EXPECT_LE(adopted, 20) << adopted << " of 200 white series adopted a drift";
}

TEST(DwellDrift, FitsAGaussMarkovDriftAndItsCovarianceCoversTheEstimate) {
  // The slope column's WLS estimate under a 1500 s Gauss-Markov drift 4x the white variance of a dwell mean:
  // white σ says ±0.16; the drift's sandwich covariance must cover the error (RMS z near 1, not 3).
  double z2_white = 0, z2_drift = 0;
  int n = 0, adopted = 0;
  for (unsigned seed = 0; seed < 100; ++seed) {
    const DwellSeries s = series(80, 500 + seed, 4.0, 1500.0, 0.0, 1.0);
    const Eigen::MatrixXd H = s.X.transpose() * s.X;  // white weights 1/w = 1
    const Eigen::MatrixXd Hi = H.inverse();
    const Eigen::VectorXd th = Hi * (s.X.transpose() * s.y);
    const DwellDrift d = fit_dwell_drift(s);
    adopted += d.adopted;
    const Eigen::MatrixXd cov = drift_covariance(Hi, {ChannelDrift{&d, &s.t_s, s.X, {0, 1}}});
    const double e = th[1] - 0.1;
    z2_white += e * e / Hi(1, 1);
    z2_drift += e * e / cov(1, 1);
    ++n;
  }
  EXPECT_GE(adopted, 90);
  const double rms_white = std::sqrt(z2_white / n), rms_drift = std::sqrt(z2_drift / n);
  RecordProperty("rms_z_white", std::to_string(rms_white));
  RecordProperty("rms_z_drift", std::to_string(rms_drift));
  EXPECT_GT(rms_white, 2.0);
  EXPECT_GT(rms_drift, 0.75);
  EXPECT_LT(rms_drift, 1.3);
}

TEST(DwellDrift, BadSeriesIsRefusedByName) {
  DwellSeries s = series(10, 3, 0, 0, 0, 1.0);
  std::swap(s.t_s[3], s.t_s[4]);
  try {
    fit_dwell_drift(s);
    FAIL() << "times out of order accepted";
  } catch (const EstimatorError& e) {
    EXPECT_NE(std::string(e.what()).find("out of order at dwell 4"), std::string::npos) << e.what();
  }
}

}  // namespace estimator_drift_test
