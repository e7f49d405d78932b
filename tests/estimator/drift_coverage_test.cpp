// The dwell-drift model by coverage over many synthetic series (host/estimator/drift.h): no drift claimed on
// white dwell means beyond chance, and the drift's covariance covering a WLS estimate's error where the white σ
// does not. Statistical (hundreds of fits), so `nosan`; drift_test.cpp runs the exact checks under ASan+UBSan.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <Eigen/Dense>

#include "host/estimator/drift.h"
#include "tests/estimator/drift_series.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace estimator_drift_coverage_test {

using namespace imuforge::estimator;
using estimator_drift_series::drift_series;

TEST(DwellDriftCoverage, WhiteDwellMeansAdoptNoDrift) {
  int adopted = 0;
  for (unsigned seed = 0; seed < 200; ++seed) adopted += fit_dwell_drift(drift_series(80, 100 + seed, 0, 0, 0, 1.0)).adopted;
  // Past 5.99 on about 2 dof: ≈ 5 % by chance (the grid's other directions add a little).
  EXPECT_LE(adopted, 20) << adopted << " of 200 white series adopted a drift";
}

TEST(DwellDriftCoverage, FitsAGaussMarkovDriftAndItsCovarianceCoversTheEstimate) {
  // The slope column's WLS estimate under a 1500 s Gauss-Markov drift 4x the white variance of a dwell mean:
  // white σ says ±0.16; the drift's sandwich covariance must cover the error (RMS z near 1, not 3).
  double z2_white = 0, z2_drift = 0;
  int n = 0, adopted = 0;
  for (unsigned seed = 0; seed < 100; ++seed) {
    const DwellSeries s = drift_series(80, 500 + seed, 4.0, 1500.0, 0.0, 1.0);
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

}  // namespace estimator_drift_coverage_test
