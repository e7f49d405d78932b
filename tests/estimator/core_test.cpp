// The estimator core shared by the solver and the diagnosis (host/estimator).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <type_traits>

#include "host/estimator/estimator.h"
#include "host/estimator/kfold.h"
#include "host/estimator/stochastic.h"
#include "host/solver/estimate.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace estimator_core_test {

using namespace imuforge::estimator;

// The solver's names are the core's (one estimator, not two that agree today).
static_assert(std::is_same_v<imuforge::solver::NormalEquations, NormalEquations>);
static_assert(std::is_same_v<imuforge::solver::SolverError, EstimatorError>);
static_assert(std::is_same_v<imuforge::solver::Estimate, Estimate>);

namespace {

// A weighted problem with rows J (m × n), targets r and weights w.
struct Problem {
  Eigen::MatrixXd J;
  Eigen::VectorXd r, w;
  NormalEquations ne() const {
    NormalEquations e(static_cast<int>(J.cols()));
    for (int i = 0; i < J.rows(); ++i) e.add_row(J.row(i).transpose(), r[i], w[i]);
    return e;
  }
  double cost(const Eigen::VectorXd& th) const {
    return (w.asDiagonal() * (r - J * th).cwiseAbs2()).sum();
  }
};

Problem random_problem(int m, int n, unsigned seed, const Eigen::VectorXd& truth, double noise) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u(0.5, 4.0);
  Problem p;
  p.J.resize(m, n);
  p.r.resize(m);
  p.w.resize(m);
  for (int i = 0; i < m; ++i) {
    for (int k = 0; k < n; ++k) p.J(i, k) = n01(rng) * std::pow(10.0, k % 3 - 1);  // mixed scales
    p.w[i] = u(rng);
    p.r[i] = p.J.row(i).dot(truth) + noise * n01(rng) / std::sqrt(p.w[i]);
  }
  return p;
}

}  // namespace

TEST(EstimatorCore, NoiseFreeProblemIsSolvedExactly) {
  Eigen::VectorXd truth(5);
  truth << 1.5, -0.25, 3e-3, 42.0, -7.0;
  const Problem p = random_problem(60, 5, 7, truth, 0.0);
  const NormalEquations ne = p.ne();
  const std::vector<std::string> names{"a", "b", "c", "d", "e"};
  Observability obs;
  const Estimate e = solve_normal_equations(ne, names, &obs);
  EXPECT_EQ(obs.rank, 5);
  EXPECT_LT((e.value - truth).cwiseAbs().maxCoeff(), 1e-9 * truth.cwiseAbs().maxCoeff());
  // Covariance = H⁻¹.
  EXPECT_LT((ne.info * e.covariance - Eigen::MatrixXd::Identity(5, 5)).cwiseAbs().maxCoeff(), 1e-9);
  // The subset solve (the diagnosis's path) on every column is the same estimate.
  const SubsetFit f = fit_subset(ne, {0, 1, 2, 3, 4});
  ASSERT_EQ(f.kept.size(), 5u);
  EXPECT_TRUE(f.dropped.empty());
  EXPECT_LT((f.theta - truth).cwiseAbs().maxCoeff(), 1e-9 * truth.cwiseAbs().maxCoeff());
  EXPECT_LT((f.cov - e.covariance).cwiseAbs().maxCoeff(), 1e-9 * e.covariance.cwiseAbs().maxCoeff());
  EXPECT_NEAR(f.rss, 0.0, 1e-9 * ne.cost);
}

TEST(EstimatorCore, EstimateIsTheMinimumOfTheCostByFiniteDifferences) {
  Eigen::VectorXd truth(4);
  truth << 0.3, -1.2, 0.05, 2.0;
  const Problem p = random_problem(200, 4, 11, truth, 1.0);
  const NormalEquations ne = p.ne();
  const Estimate e = solve_normal_equations(ne, {"a", "b", "c", "d"});
  const SubsetFit f = fit_subset(ne, {0, 1, 2, 3});
  // rss is the cost at the estimate.
  EXPECT_NEAR(f.rss, p.cost(e.value), 1e-9 * p.cost(e.value));
  EXPECT_NEAR(ne.cost, p.cost(Eigen::VectorXd::Zero(4)), 1e-9 * ne.cost);
  for (int k = 0; k < 4; ++k) {
    const double h = 1e-3 * e.sigma()[k];
    Eigen::VectorXd tp = e.value, tm = e.value;
    tp[k] += h;
    tm[k] -= h;
    const double c0 = p.cost(e.value), cp = p.cost(tp), cm = p.cost(tm);
    // Gradient zero at the minimum: the central difference is small against the curvature scale 2 H_kk h.
    EXPECT_LT(std::abs(cp - cm) / (2 * h), 1e-5 * 2 * ne.info(k, k) * e.sigma()[k]) << k;
    // Curvature 2 H_kk (the information is the half-Hessian of the cost).
    EXPECT_NEAR((cp - 2 * c0 + cm) / (h * h), 2 * ne.info(k, k), 1e-4 * 2 * ne.info(k, k)) << k;
  }
}

TEST(EstimatorCore, RankDeficientProblemIsReportedNeverSolved) {
  // Columns 1 and 2 only ever appear as their sum.
  NormalEquations ne(3);
  for (int i = 0; i < 20; ++i) ne.add_row(Eigen::Vector3d(0.1 * i, 1.0, 1.0), 0.5 + 0.1 * i, 2.0);
  const std::vector<std::string> names{"scale", "bias_a", "bias_b"};
  const Observability obs = analyse_observability(ne.info, names);
  EXPECT_EQ(obs.rank, 2);
  ASSERT_EQ(obs.unobservable.size(), 1u);
  EXPECT_NE(obs.unobservable[0].find("bias_a"), std::string::npos);
  EXPECT_NE(obs.unobservable[0].find("bias_b"), std::string::npos);
  EXPECT_THROW(solve_normal_equations(ne, names), EstimatorError);
  EXPECT_THROW(covariance_from_information(ne.info, names), EstimatorError);
  try {
    solve_normal_equations(ne, names);
  } catch (const EstimatorError& e) {
    EXPECT_NE(std::string(e.what()).find("rank-deficient"), std::string::npos) << e.what();
  }
  // The subset solve keeps the first of the two (priority order) and reports the second.
  const SubsetFit f = fit_subset(ne, {0, 1, 2});
  EXPECT_EQ(f.kept, (std::vector<int>{0, 1}));
  EXPECT_EQ(f.dropped, (std::vector<int>{2}));
  const SubsetFit g = fit_subset(ne, {2, 0, 1});
  EXPECT_EQ(g.kept, (std::vector<int>{2, 0}));
  EXPECT_EQ(g.dropped, (std::vector<int>{1}));
  // A column without information is dropped too.
  NormalEquations z(2);
  for (int i = 0; i < 5; ++i) z.add_row(Eigen::Vector2d(1.0, 0.0), 1.0, 1.0);
  EXPECT_EQ(fit_subset(z, {0, 1}).dropped, (std::vector<int>{1}));
  EXPECT_THROW(solve_normal_equations(z, {"a", "b"}), EstimatorError);
}

TEST(EstimatorCore, KFoldHeldOutMatchesABruteForceRefit) {
  Eigen::VectorXd truth(3);
  truth << 1.0, -0.5, 0.2;
  const Problem p = random_problem(90, 3, 5, truth, 1.0);
  const int K = 4;
  FoldedNormalEquations fne(K, 3);
  for (int i = 0; i < p.J.rows(); ++i) fne.add_row(i % K, p.J.row(i).transpose(), p.r[i], p.w[i]);
  fne.finish();
  const NormalEquations all = p.ne();
  EXPECT_LT((fne.total.info - all.info).cwiseAbs().maxCoeff(), 1e-9 * all.info.cwiseAbs().maxCoeff());
  EXPECT_EQ(fne.total.n_obs, all.n_obs);
  for (const std::vector<int>& sel : {std::vector<int>{0, 1, 2}, std::vector<int>{0, 2}}) {
    double chi2 = 0, expected = 0, W = 0, chi2_pred = 0;
    for (int k = 0; k < K; ++k) {
      // Refit on the rows of the other folds, directly from the rows.
      const int m = static_cast<int>(p.J.rows());
      Eigen::MatrixXd A(m, static_cast<int>(sel.size()));
      for (int c = 0; c < A.cols(); ++c) A.col(c) = p.J.col(sel[static_cast<size_t>(c)]);
      Eigen::MatrixXd H = Eigen::MatrixXd::Zero(A.cols(), A.cols());
      Eigen::VectorXd g = Eigen::VectorXd::Zero(A.cols());
      for (int i = 0; i < m; ++i)
        if (i % K != k) {
          H += p.w[i] * A.row(i).transpose() * A.row(i);
          g += p.w[i] * p.r[i] * A.row(i).transpose();
        }
      const Eigen::MatrixXd S = H.inverse();
      const Eigen::VectorXd th = S * g;
      std::vector<int> rows_k;
      for (int i = 0; i < m; ++i)
        if (i % K == k) {
          const double res = p.r[i] - A.row(i).dot(th);
          chi2 += p.w[i] * res * res;
          expected += 1.0 + p.w[i] * A.row(i).dot(S * A.row(i).transpose());
          W += p.w[i];
          rows_k.push_back(i);
        }
      // The fold's residuals against their full predictive covariance diag(1/w) + A_k S A_kᵀ, inverted directly.
      const int nk = static_cast<int>(rows_k.size());
      Eigen::MatrixXd Ak(nk, A.cols());
      Eigen::VectorXd rk(nk), vk(nk);
      for (int j = 0; j < nk; ++j) {
        const int i = rows_k[static_cast<size_t>(j)];
        Ak.row(j) = A.row(i);
        rk[j] = p.r[i] - A.row(i).dot(th);
        vk[j] = 1.0 / p.w[i];
      }
      const Eigen::MatrixXd Ck = Eigen::MatrixXd(vk.asDiagonal()) + Ak * S * Ak.transpose();
      chi2_pred += rk.dot(Ck.ldlt().solve(rk));
    }
    const HeldOut h = heldout(fne, fne, sel);
    EXPECT_NEAR(h.chi2, chi2, 1e-9 * chi2);
    EXPECT_NEAR(h.chi2_pred, chi2_pred, 1e-8 * chi2_pred);
    EXPECT_LT(h.chi2_pred, h.chi2);
    EXPECT_NEAR(h.expected, expected, 1e-9 * expected);
    EXPECT_NEAR(h.W, W, 1e-12 * W);
    EXPECT_EQ(h.nb, 90);
    EXPECT_NEAR(h.rms(), std::sqrt(chi2 / W), 1e-9);
  }
  // A fold without rows in the scored statistics is skipped, not scored as zero.
  FoldedNormalEquations sparse(K, 3);
  sparse.add_row(1, p.J.row(0).transpose(), p.r[0], p.w[0]);
  sparse.finish();
  EXPECT_EQ(heldout(fne, sparse, {0, 1, 2}).nb, 1);
  EXPECT_THROW(heldout(fne, FoldedNormalEquations(K + 1, 3), {0}), EstimatorError);
}

// A fold the others can only extrapolate to (a line fitted on x in [0, 1], withheld at x in [3, 4], as a long soak
// withheld whole is predicted from the other folds' temperatures): Σ r²/v per withheld row is biased high by the
// extrapolated fit's error, while the predictive χ² keeps its expectation of one per row. 400 draws of a fixed
// seed: the mean of chi2_pred / nb has a standard error of about 0.008.
TEST(EstimatorCore, PredictiveHeldOutChiSquareStaysAtOneWhereAFoldIsExtrapolated) {
  std::mt19937_64 rng(45);
  std::normal_distribution<double> n01;
  const int K = 5, per_fold = 20, reps = 400;
  double raw = 0, pred = 0;
  for (int rep = 0; rep < reps; ++rep) {
    FoldedNormalEquations fne(K, 2);
    for (int k = 0; k < K; ++k)
      for (int j = 0; j < per_fold; ++j) {
        const double x = k < K - 1 ? (j + 0.5) / per_fold : 3.0 + (j + 0.5) / per_fold;
        fne.add_row(k, Eigen::Vector2d(1.0, x), 0.3 - 0.2 * x + n01(rng), 1.0);
      }
    fne.finish();
    const HeldOut h = heldout(fne, fne, {0, 1});
    raw += h.chi2 / h.nb / reps;
    pred += h.chi2_pred / h.nb / reps;
  }
  EXPECT_NEAR(pred, 1.0, 0.04);
  // The extrapolated fold's prediction error, about 1.4 per row there (the slope's variance 12/80 times 3²), read
  // as misfit: about 1.3 over the five folds.
  EXPECT_GT(raw, 1.2);
}
// The GLS whitening (stochastic.h) against the likelihood written out in full: the dense covariance of the block
// means that the noise model defines, built term by term, not by a filter. Σ ν²/S + Σ log S must be zᵀΣ⁻¹z +
// log det Σ, and the whitened regressors' normal equations XᵀΣ⁻¹X and XᵀΣ⁻¹z, on irregular blocks (gaps, unequal
// durations, runs of segments), with and without Gauss-Markov states (the filter skips the transition of the
// states that do not decay).
TEST(EstimatorStochastic, WhiteningGivesTheDenseCovariancesLikelihood) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const int n = 48, P = 3;
  std::vector<double> t(n), d(n);
  std::vector<int> seg(n);
  double start = 0.0;
  int id = 0;
  for (int i = 0; i < n; ++i) {
    d[static_cast<std::size_t>(i)] = 2.0 + 28.0 * u01(rng);
    t[static_cast<std::size_t>(i)] = start + 0.5 * d[static_cast<std::size_t>(i)];
    start += d[static_cast<std::size_t>(i)] + (i % 5 == 4 ? 60.0 * u01(rng) : 0.0);  // gaps between some blocks
    if (i > 0 && u01(rng) < 0.3) ++id;
    seg[static_cast<std::size_t>(i)] = id;
  }
  Eigen::MatrixXd rows(n, 1 + P);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 1 + P; ++c) rows(i, c) = n01(rng);

  for (int with_gm = 0; with_gm < 2; ++with_gm) {
    StochasticModel m;
    m.N = 0.02;
    m.Q = 0.001;
    m.K = 3e-3;
    m.seg_bias_var = 4e-4;
    if (with_gm) {
      m.gm_sigma = 0.05;
      m.gm_tau_s = 40.0;
      m.bank_sigma = 0.01;
      m.bank_sigma_lik = 0.02;  // the likelihood's level, above the point estimate
      m.bank_tau_s = {5.0, 20.0, 80.0, 320.0};
    }
    const double rw0 = 2e-3;
    // The dense covariance of the block means.
    Eigen::MatrixXd Sig = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) Sig(i, i) += m.white_var(d[static_cast<std::size_t>(i)]);
    for (const auto& st : m.gm_states()) {  // σ², T: the mid-block states, each mean α·g plus a part of its own
      std::vector<double> alpha(n), vm(n);
      for (int i = 0; i < n; ++i) gm_block(d[static_cast<std::size_t>(i)], st.second, alpha[static_cast<std::size_t>(i)], vm[static_cast<std::size_t>(i)]);
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          const auto ui = static_cast<std::size_t>(i), uj = static_cast<std::size_t>(j);
          Sig(i, j) += i == j ? st.first * std::max(vm[ui], alpha[ui] * alpha[ui])
                              : st.first * alpha[ui] * alpha[uj] * std::exp(-std::fabs(t[ui] - t[uj]) / st.second);
        }
    }
    // The random walk W: Var W(start of block i) = rw0 + K²·(time since the first block's start); a block's mean is
    // W(start) + u/2 + e (u its increment over the block, Var e = K² d / 12), so Var = V + q/3, and the mean's
    // covariance with any later block is V + q/2.
    const double s0 = t[0] - 0.5 * d[0];
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) {
        const auto ui = static_cast<std::size_t>(i);
        const double V = rw0 + m.K * m.K * (t[ui] - 0.5 * d[ui] - s0), q = m.K * m.K * d[ui];
        const double c = j == i ? V + q / 3.0 : V + q / 2.0;
        Sig(i, j) += c;
        if (j != i) Sig(j, i) += c;
      }
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        if (seg[static_cast<std::size_t>(i)] == seg[static_cast<std::size_t>(j)]) Sig(i, j) += m.seg_bias_var;

    Eigen::MatrixXd innov(n, 1 + P);
    Eigen::VectorXd S(n);
    whiten_segment(m, t, d, rows, rw0, innov, S, nullptr, &seg);
    Eigen::MatrixXd Wt(n, 1 + P);  // whitened columns
    for (int i = 0; i < n; ++i) Wt.row(i) = innov.row(i) / std::sqrt(S[i]);
    const Eigen::LLT<Eigen::MatrixXd> llt(Sig);
    ASSERT_EQ(llt.info(), Eigen::Success);
    const Eigen::MatrixXd G_dense = rows.transpose() * llt.solve(rows);  // [z X]ᵀ Σ⁻¹ [z X]
    const Eigen::MatrixXd G_filter = Wt.transpose() * Wt;
    EXPECT_LT((G_filter - G_dense).norm(), 1e-9 * G_dense.norm()) << "with_gm " << with_gm << "\n" << G_filter << "\n" << G_dense;
    const double logdet_dense = 2.0 * Eigen::MatrixXd(llt.matrixL()).diagonal().array().log().sum();
    EXPECT_NEAR(S.array().log().sum(), logdet_dense, 1e-9 * std::fabs(logdet_dense)) << "with_gm " << with_gm;
  }
}

}  // namespace estimator_core_test

// Units in time order: neighbours in different folds, sizes balanced, and a repeated sequence whose length is a
// multiple of K spread over every fold (i mod K puts each of its positions in one fold).
TEST(EstimatorCore, InterleavedFoldsSpreadARepeatedSchedule) {
  const int K = 5, n = 600;
  std::vector<int> size(K, 0);
  int same_as_previous = 0;
  for (int i = 0; i < n; ++i) {
    const int f = imuforge::estimator::interleaved_fold(i, K);
    ASSERT_GE(f, 0);
    ASSERT_LT(f, K);
    ++size[static_cast<std::size_t>(f)];
    if (i > 0 && f == imuforge::estimator::interleaved_fold(i - 1, K)) ++same_as_previous;
  }
  for (int k = 0; k < K; ++k) EXPECT_NEAR(size[static_cast<std::size_t>(k)], n / K, 3) << k;
  EXPECT_EQ(same_as_previous, 0) << "consecutive units always in different folds (frac steps of 0.618 over 5 bins)";
  for (int period : {10, 20, 24, 60}) {
    for (int pos = 0; pos < period; ++pos) {
      std::vector<int> seen(K, 0);
      for (int r = 0; r < n / period; ++r) seen[static_cast<std::size_t>(imuforge::estimator::interleaved_fold(pos + r * period, K))] = 1;
      int folds_hit = 0;
      for (int v : seen) folds_hit += v;
      EXPECT_GE(folds_hit, std::min(K, n / period) - 1) << "period " << period << " position " << pos;
    }
  }

}
