// Estimator core: information-form least squares, observability, SRIF == batch, LM, SHA-256.
#include <gtest/gtest.h>

#include <random>

#include "host/solver/estimate.h"
#include "host/solver/sha256.h"
#include "host/solver/srif.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_core_test {

using namespace imuforge::solver;

namespace {
// y = a + b t + c t² with noise σ: a classic linear problem with a known covariance.
struct PolyCase {
  std::vector<std::string> names{"p.a", "p.b", "p.c"};
  Eigen::Vector3d truth{0.3, -1.2, 0.05};
};
}  // namespace

TEST(SolverCore, LinearSolveMatchesClosedFormCovariance) {
  PolyCase pc;
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n01;
  const double sigma = 0.01;
  NormalEquations ne(3);
  Eigen::MatrixXd a(200, 3);
  for (int i = 0; i < 200; ++i) {
    const double t = -1 + 2.0 * i / 199;
    Eigen::Vector3d j(1, t, t * t);
    a.row(i) = j.transpose();
    ne.add_row(j, j.dot(pc.truth) + sigma * n01(rng), 1 / (sigma * sigma));
  }
  Observability obs;
  Estimate e = solve_normal_equations(ne, pc.names, &obs);
  Eigen::MatrixXd cov = (a.transpose() * a).inverse() * sigma * sigma;
  EXPECT_LT((e.covariance - cov).norm() / cov.norm(), 1e-10);
  EXPECT_EQ(obs.rank, 3);
  EXPECT_TRUE(obs.unobservable.empty());
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(e.value[k] - pc.truth[k]), 5 * e.sigma()[k]);
  EXPECT_NEAR(e.correlation()(0, 0), 1.0, 1e-12);
}

TEST(SolverCore, RankDeficiencyIsAnErrorThatNamesTheCombination) {
  // Two biases that only ever appear as their sum: the campaign cannot separate them.
  NormalEquations ne(3);
  for (int i = 0; i < 10; ++i) {
    Eigen::Vector3d j(1, 1, i * 0.1);
    ne.add_row(j, 1.0, 1.0);
  }
  std::vector<std::string> names{"accel.bias.x", "gyro.bias.x", "accel.scale.x"};
  Observability obs = analyse_observability(ne.info, names);
  EXPECT_EQ(obs.rank, 2);
  ASSERT_EQ(obs.unobservable.size(), 1u);
  EXPECT_NE(obs.unobservable[0].find("accel.bias.x"), std::string::npos);
  EXPECT_NE(obs.unobservable[0].find("gyro.bias.x"), std::string::npos);
  EXPECT_EQ(obs.unobservable[0].find("accel.scale.x"), std::string::npos);
  EXPECT_TRUE(obs.parameter_unobservable[0]);
  EXPECT_FALSE(obs.parameter_unobservable[2]);
  try {
    solve_normal_equations(ne, names);
    FAIL() << "rank-deficient problem solved silently";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("gyro.bias.x"), std::string::npos) << e.what();
  }
  // An unexcited parameter (zero column) is named alone.
  NormalEquations ne2(2);
  ne2.add_row(Eigen::Vector2d(1, 0), 1.0, 1.0);
  Observability o2 = analyse_observability(ne2.info, {"a", "b"});
  ASSERT_EQ(o2.unobservable.size(), 1u);
  EXPECT_EQ(o2.unobservable[0], "1.000*b");
}

TEST(SolverCore, SrifEqualsBatchWithin1e6Sigma) {
  const int n = 8;
  std::vector<std::string> names;
  for (int i = 0; i < n; ++i) names.push_back("p." + std::to_string(i));
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  Eigen::VectorXd truth = Eigen::VectorXd::Random(n);
  NormalEquations batch(n);
  SquareRootInformationFilter f(names);
  bool seen_incomplete = false;
  for (int seg = 0; seg < 12; ++seg) {
    NormalEquations s(n);
    // Each segment excites only a few parameters, with wildly different scales (like bias vs temp poly).
    for (int i = 0; i < 50; ++i) {
      Eigen::VectorXd j = Eigen::VectorXd::Zero(n);
      j[seg % n] = 1.0;
      j[(seg + 1) % n] = 1e3 * n01(rng);
      j[(seg + 3) % n] = 1e-3 * n01(rng);
      s.add_row(j, j.dot(truth) + 0.1 * n01(rng), 100.0);
    }
    batch += s;
    f.add_information(s.info, s.rhs);
    if (!f.complete()) {
      seen_incomplete = true;
      Estimate p = f.estimate();
      EXPECT_TRUE(std::isinf(p.covariance.diagonal().maxCoeff()));
    }
  }
  EXPECT_TRUE(seen_incomplete);
  ASSERT_TRUE(f.complete());
  Estimate b = solve_normal_equations(batch, names);
  Estimate r = f.estimate();
  for (int k = 0; k < n; ++k) {
    EXPECT_LT(std::abs(b.value[k] - r.value[k]), 1e-6 * b.sigma()[k]) << names[size_t(k)];
    EXPECT_NEAR(b.sigma()[k], r.sigma()[k], 1e-6 * b.sigma()[k]);
  }
}

namespace {
// y = A exp(-k t) + c: nonlinear in k, with an analytic Jacobian to check against finite differences.
struct ExpProblem : NonlinearProblem {
  std::vector<double> t, y;
  double sigma = 0.01;
  int num_params() const override { return 3; }
  static Eigen::Vector3d jac(const Eigen::VectorXd& th, double ti) {
    const double e = std::exp(-th[1] * ti);
    return Eigen::Vector3d(e, -th[0] * ti * e, 1.0);
  }
  static double h(const Eigen::VectorXd& th, double ti) { return th[0] * std::exp(-th[1] * ti) + th[2]; }
  void linearize(const Eigen::VectorXd& th, NormalEquations& ne) const override {
    ne.reset(3);
    for (size_t i = 0; i < t.size(); ++i) ne.add_row(jac(th, t[i]), y[i] - h(th, t[i]), 1 / (sigma * sigma));
  }
};
}  // namespace

TEST(SolverCore, LevenbergMarquardtConvergesAndJacobianMatchesFiniteDifferences) {
  ExpProblem p;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  Eigen::Vector3d truth(2.0, 0.7, -0.4);
  for (int i = 0; i < 300; ++i) {
    p.t.push_back(i * 0.02);
    p.y.push_back(ExpProblem::h(truth, p.t.back()) + p.sigma * n01(rng));
  }
  Eigen::Vector3d th(1, 1.5, 0);
  for (double ti : {0.0, 0.3, 2.0}) {
    Eigen::Vector3d fd;
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd a = th, b = th;
      a[k] += 1e-6;
      b[k] -= 1e-6;
      fd[k] = (ExpProblem::h(a, ti) - ExpProblem::h(b, ti)) / 2e-6;
    }
    EXPECT_LT((fd - ExpProblem::jac(th, ti)).norm(), 1e-7);
  }
  LmResult r = levenberg_marquardt(p, th);
  ASSERT_TRUE(r.converged);
  Estimate e;
  e.covariance = covariance_from_information(r.normal.info, {"a", "k", "c"});
  e.value = r.theta;
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(r.theta[k] - truth[k]), 5 * e.sigma()[k]);
}

TEST(SolverCore, Sha256KnownVectors) {
  Sha256 h;
  EXPECT_EQ(Sha256::hex(h.finish()), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  Sha256 h2;
  const std::string abc = "abc";
  h2.update(abc.data(), abc.size());
  EXPECT_EQ(Sha256::hex(h2.finish()), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  Sha256 h3;  // two blocks
  const std::string s = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
  h3.update(s.data(), s.size());
  EXPECT_EQ(Sha256::hex(h3.finish()), "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}
}  // namespace solver_core_test
