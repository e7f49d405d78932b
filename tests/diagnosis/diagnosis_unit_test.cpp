#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "host/diagnosis/dropouts.h"
#include "host/diagnosis/glitches.h"
#include "host/diagnosis/noise_model.h"
#include "host/diagnosis/output_bits.h"
#include "host/diagnosis/sources.h"
#include "host/model/measure.h"
#include "host/diagnosis/stats.h"
#include "host/diagnosis/step_lag.h"
#include "host/diagnosis/table_errors.h"
#include "tests/diagnosis/sim_helpers.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace diagnosis_diagnosis_unit_test {

using namespace imuforge::diagnosis;

// A hand-made sample with a reference, at 25 °C: the caller fills f, w and the outputs y.
Sample referenced_sample(double t_s, int segment) {
  Sample s;
  s.t_s = t_s;
  s.segment = segment;
  s.temp_C = 25.0;
  s.has_ref = true;
  return s;
}

using Pose = std::array<double, 3>;  // gravity in the body, m/s²

// A static log at 100 Hz: `passes` passes over `poses`, dwell_s each, one segment per pose visit; out(pass, f, y)
// fills the six outputs of every sample.
template <class Out>
std::vector<Sample> static_pose_log(const std::vector<Pose>& poses, int passes, double dwell_s, Out out) {
  const double fs = 100.0;
  std::vector<Sample> log;
  int seg = 0;
  for (int pass = 0; pass < passes; ++pass)
    for (const auto& f : poses) {
      for (int i = 0; i < static_cast<int>(dwell_s * fs); ++i) {
        Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
        for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = 0.0;
        out(pass, f, s.y);
        log.push_back(s);
      }
      ++seg;
    }
  return log;
}

// A static sample's outputs at pose f: the reference plus white noise of accel_sigma and gyro_sigma per sample
// (drawn accel then gyro, axis by axis).
template <class Rng>
void white_static_outputs(Sample& s, const Pose& f, double accel_sigma, double gyro_sigma, Rng& rng) {
  std::normal_distribution<double> n01;
  for (int j = 0; j < 3; ++j) {
    s.f[j] = f[static_cast<std::size_t>(j)];
    s.y[j] = s.f[j] + accel_sigma * n01(rng);
    s.y[3 + j] = gyro_sigma * n01(rng);
  }
}

// 24 poses tilted about two axes, so that every component of gravity takes many unrelated values.
std::vector<Pose> two_axis_tilts() {
  const double g = 9.80665;
  std::vector<Pose> poses;
  for (int k = 0; k < 24; ++k) {
    const double a = 0.4 + 0.5 * k, b = 0.25 + 0.37 * k;
    poses.push_back({g * std::sin(a) * std::cos(b), g * std::sin(b), g * std::cos(a) * std::cos(b)});
  }
  return poses;
}

TEST(DiagnosisStats, ChiSquareSurvivalAgainstClosedForms) {
  // k = 2: sf = e^{-x/2}; k = 4: e^{-x/2}(1 + x/2); k = 1: erfc(√(x/2)).
  for (double x : {0.01, 0.5, 1.0, 3.0, 10.0, 40.0, 200.0}) {
    EXPECT_NEAR(chi2_sf(x, 2) / std::exp(-x / 2), 1.0, 1e-12) << x;
    EXPECT_NEAR(chi2_sf(x, 4) / (std::exp(-x / 2) * (1 + x / 2)), 1.0, 1e-12) << x;
    EXPECT_NEAR(chi2_sf(x, 1) / std::erfc(std::sqrt(x / 2)), 1.0, 1e-10) << x;
  }
  EXPECT_NEAR(chi2_sf(3.841458820694124, 1), 0.05, 1e-12);
  EXPECT_NEAR(chi2_sf(18.307038053275146, 10), 0.05, 1e-12);
  // Far tail stays ordered in log space: k = 2 gives log10 sf = −x/(2 ln 10) exactly.
  EXPECT_NEAR(chi2_log10_sf(5000, 2), -5000 / (2 * std::log(10.0)), 1e-8);
  EXPECT_LT(chi2_log10_sf(5000, 3), chi2_log10_sf(4000, 3));
  EXPECT_EQ(chi2_sf(0, 3), 1.0);
  EXPECT_THROW(gamma_q(-1, 1), std::invalid_argument);
}

TEST(DiagnosisStats, AllanOfWhiteNoiseAndRandomWalk) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  const double sigma = 0.3, tau0 = 0.01;
  std::vector<double> x(200000);
  for (auto& v : x) v = sigma * n01(rng);
  AllanAccumulator acc(tau0);
  acc.add_series(x);
  auto pts = acc.points();
  ASSERT_GE(pts.size(), 10u);
  for (const auto& p : pts) {
    const double expect = sigma * sigma * tau0 / p.tau_s;
    EXPECT_NEAR(p.avar / expect, 1.0, 4.0 * std::sqrt(2.0 / p.edf)) << p.tau_s;
  }
  NoiseFit f = fit_noise_terms(pts);
  EXPECT_NEAR(f.terms.N, sigma * std::sqrt(tau0), 0.03 * sigma * std::sqrt(tau0));
  // Random walk of the bias: AVAR = K² τ / 3.
  const double K = 0.05;
  std::vector<double> rw(200000);
  double b = 0;
  for (auto& v : rw) {
    b += K * std::sqrt(tau0) * n01(rng);
    v = b + 0.01 * n01(rng);
  }
  AllanAccumulator acc2(tau0);
  acc2.add_series(rw);
  NoiseFit f2 = fit_noise_terms(acc2.points());
  EXPECT_NEAR(f2.terms.K, K, 0.35 * K);
}

// The likelihood's noise model (noise_model.h): a flat Allan floor seen over τ ≤ 40 s is fitted as flicker and
// carried to the log's time scales (bias wander between blocks an hour apart), white noise is not given a
// phantom drift (but the likelihood carries the flicker upper limit the record cannot exclude), and a white
// model whitens to the data itself.
TEST(DiagnosisNoiseModel, FlickerFloorIsCarriedToTheLogDuration) {
  const double N = 2e-3, B = 5e-4, horizon_s = 5000;
  const std::vector<double> bank = flicker_bank_taus(0.01, horizon_s);
  ASSERT_GE(bank.size(), 8u);
  EXPECT_GE(bank.back(), horizon_s);
  // A flicker bank's Allan curve is flat (to a few %) inside its span.
  const double a1 = flicker_bank_avar(1.0, bank), a100 = flicker_bank_avar(100.0, bank);
  EXPECT_NEAR(a100 / a1, 1.0, 0.1);
  // Exact Allan points of white + flicker at the floor 0.664 B, τ = 0.01 … 41 s (what a 160 s dwell gives).
  const double c = (2.0 * std::log(2.0) / M_PI) * B * B / a1;
  std::vector<AllanAccumulator::Point> pts, white;
  for (double tau = 0.01; tau < 45; tau *= 2) {
    pts.push_back({tau, N * N / tau + c * flicker_bank_avar(tau, bank), 200.0, 1000});
    white.push_back({tau, N * N / tau, 200.0, 1000});
  }
  StochasticModel m = fit_stochastic_model(pts, horizon_s);
  EXPECT_GT(m.bank_sigma, 0.0);
  EXPECT_NEAR(m.flicker_B, B, 0.15 * B);
  EXPECT_NEAR(m.N, N, 0.05 * N);
  EXPECT_GE(m.bank_tau_s.back(), horizon_s);
  // Two 5 s block means an hour apart still share most of the flicker wander: the offset between two poses
  // an hour apart is noise of about the floor's size, not evidence of a thermal effect.
  const double cov = block_covariance(m, 100.0, 5.0, 3700.0, 5.0, false, 0.0, 0.0);
  EXPECT_GT(cov, 0.5 * (0.664 * B) * (0.664 * B));
  // White noise alone: no phantom drift term of any kind.
  StochasticModel w = fit_stochastic_model(white, horizon_s);
  EXPECT_LT(w.flicker_B, 1e-3 * N);  // flicker is kept at any positive level the curve supports: here none
  EXPECT_EQ(w.gm_sigma, 0.0);
  EXPECT_EQ(w.K, 0.0);
  EXPECT_NEAR(w.N, N, 1e-3 * N);
  // ... but the likelihood carries the flicker a 41 s record cannot exclude (one-sided 95 %): above zero, yet
  // below the white Allan deviation at the longest cluster time (a larger floor would flatten the curve there).
  EXPECT_GT(w.flicker_B_upper, 0.0);
  EXPECT_LT(0.664 * w.flicker_B_upper, N / std::sqrt(pts.back().tau_s));
  // With a floor in the data the limit sits above the estimate and not far from the truth.
  EXPECT_GE(m.flicker_B_upper, m.flicker_B);
  EXPECT_LT(m.flicker_B_upper, 1.5 * B);
  // Block-mean variances (noise floors) use the point estimate, the whitening the limit.
  EXPECT_EQ(w.gm_states(false).size(), 0u);
  EXPECT_GT(w.gm_states(true).size(), 0u);
  // A white model whitens to the data: innovations = rows, S = N²/d.
  StochasticModel w0 = w;
  w0.bank_sigma_lik = 0.0;
  Eigen::MatrixXd rows(3, 2), innov(3, 2);
  rows << 1, 2, 3, 4, 5, 6;
  Eigen::VectorXd S(3);
  whiten_segment(w0, {0.0, 10.0, 20.0}, {4.0, 4.0, 4.0}, rows, 0.0, innov, S);
  EXPECT_NEAR((innov - rows).norm(), 0.0, 1e-12);
  EXPECT_NEAR(S[1], w0.N * w0.N / 4.0, 1e-12 * S[1]);
  // With flicker, later blocks are predicted from earlier ones: part of a constant offset is absorbed (white
  // noise would leave every innovation equal to the offset).
  Eigen::MatrixXd off = Eigen::MatrixXd::Constant(3, 1, 10.0 * B), nu(3, 1);
  whiten_segment(m, {0.0, 10.0, 20.0}, {4.0, 4.0, 4.0}, off, 0.0, nu, S);
  EXPECT_LT(std::fabs(nu(2, 0)), 0.75 * std::fabs(nu(0, 0)));
}

// Mid times of blocks of durations d, each after a gap (s) from the end of the one before.
std::vector<double> block_mid_times(const std::vector<double>& d, const std::vector<double>& gap) {
  std::vector<double> t(d.size());
  double a = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    a += gap[i];
    t[i] = a + 0.5 * d[i];
    a += d[i];
  }
  return t;
}

// Whole-log wander (noise_model.h): block means of a 3000 s record whose bias wanders as a random walk the
// model does not carry (its K = 0, a small flicker). The REML raise must find the random walk near its true K
// and pass the residual checks; a bias STEP or a slow SINE of similar size on the same white noise must fail
// them (one jump; correlated innovations), so that such an axis stays "unexplained" in the diagnosis.
TEST(DiagnosisNoiseModel, WhiteningOfARandomWalkIsTheExactLikelihoodOfItsBlockMeans) {
  // Block means of white noise + a random walk, blocks of unequal length with gaps (as poses are cut): the
  // filter's Σ log S + ν²/S must equal the dense Gaussian −2 log L of the same means. The dense covariance, for
  // blocks [a_i, a_i + d_i] and the walk started at a_0 with prior variance p0:
  //   Cov(mean_i, mean_j) = p0 + K² (t_i − a_0)        (block i wholly before block j, t_i its mid time)
  //   Var(mean_i)         = p0 + K² (t_i − a_0 − d_i/6) + white
  StochasticModel m;
  m.N = 2e-3;
  m.K = 3e-4;
  const double p0 = 1e-6;
  const std::vector<double> d = {30.0, 30.0, 12.0, 5.0, 30.0, 2.5, 8.0, 30.0};
  const std::vector<double> gap = {0.0, 0.0, 4.0, 0.0, 17.0, 0.5, 0.0, 60.0};
  const int n = static_cast<int>(d.size());
  const std::vector<double> t = block_mid_times(d, gap);
  Eigen::MatrixXd C(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto ui = static_cast<std::size_t>(std::min(i, j));
      C(i, j) = p0 + m.K * m.K * (t[ui] - (t[0] - 0.5 * d[0]));
      if (i == j) C(i, j) += -m.K * m.K * d[ui] / 6.0 + m.white_var(d[ui]);
    }
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd rows(n, 1);
  for (int i = 0; i < n; ++i) rows(i, 0) = 1e-3 * n01(rng);
  Eigen::MatrixXd innov(n, 1);
  Eigen::VectorXd S(n);
  whiten_segment(m, t, d, rows, p0, innov, S);
  double kf = 0.0;
  for (int i = 0; i < n; ++i) kf += std::log(S[i]) + innov(i, 0) * innov(i, 0) / S[i];
  const Eigen::LLT<Eigen::MatrixXd> llt(C);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::VectorXd y = rows.col(0);
  double dense = y.dot(llt.solve(y));
  for (int i = 0; i < n; ++i) dense += 2.0 * std::log(llt.matrixL()(i, i));
  EXPECT_NEAR(kf, dense, 1e-9 * std::fabs(dense));
}

// The same, with every state the filter carries: a single Gauss-Markov bias, a flicker bank, the random walk and a
// per-segment bias, over blocks whose spacing and duration repeat in runs and change between them (the filter
// recomputes a state's transition only where they change). The filter's model of a block mean is α_g g(t_i) + e_i
// per GM state g (g at the block's mid time, Var e_i = σ_g² (vm_i − α_i²)), so its dense covariance is
//   Σ_g σ_g² (α_i α_j e^{−|t_i − t_j|/T_g} + δ_ij (vm_i − α_i²)) + the random walk's (above) + s² [same segment].
TEST(DiagnosisNoiseModel, WhiteningWithEveryStateIsTheExactLikelihoodOfItsBlockMeans) {
  StochasticModel m;
  m.N = 2e-3;
  m.K = 1e-4;
  m.gm_sigma = 3e-3;
  m.gm_tau_s = 40.0;
  m.bank_tau_s = flicker_bank_taus(1.0, 400.0);
  m.bank_sigma = 1e-3;
  m.bank_sigma_lik = 2e-3;
  m.seg_bias_var = 4e-6;
  const double p0 = 1e-6;
  const std::vector<double> d = {4.0, 4.0, 4.0, 10.0, 10.0, 2.5, 4.0, 4.0, 30.0, 1.0, 1.0, 1.0, 6.0};
  const std::vector<double> gap = {0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 3.0, 1.0, 20.0, 0.0, 0.0, 0.0, 2.0};
  const std::vector<int> seg = {0, 0, 0, 1, 1, 1, 2, 2, 3, 4, 4, 4, 5};
  const int n = static_cast<int>(d.size());
  const std::vector<double> t = block_mid_times(d, gap);
  const auto gm = m.gm_states();
  ASSERT_EQ(gm.size(), 1u + m.bank_tau_s.size());
  Eigen::MatrixXd C(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto ui = static_cast<std::size_t>(i), uj = static_cast<std::size_t>(j);
      const auto um = static_cast<std::size_t>(std::min(i, j));
      double c = p0 + m.K * m.K * (t[um] - (t[0] - 0.5 * d[0]));
      if (i == j) c += -m.K * m.K * d[ui] / 6.0 + m.white_var(d[ui]);
      for (const auto& g : gm) {
        double ai = 1, vi = 1, aj = 1, vj = 1;
        gm_block(d[ui], g.second, ai, vi);
        gm_block(d[uj], g.second, aj, vj);
        c += g.first * ai * aj * std::exp(-std::fabs(t[ui] - t[uj]) / g.second);
        if (i == j) c += g.first * (vi - ai * ai);
      }
      if (seg[ui] == seg[uj]) c += m.seg_bias_var;
      C(i, j) = c;
    }
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd rows(n, 2);
  for (int i = 0; i < n; ++i) {
    rows(i, 0) = 3e-3 * n01(rng);
    rows(i, 1) = 1.0;
  }
  Eigen::MatrixXd innov(n, 2);
  Eigen::VectorXd S(n);
  whiten_segment(m, t, d, rows, p0, innov, S, nullptr, &seg);
  const Eigen::LLT<Eigen::MatrixXd> llt(C);
  ASSERT_EQ(llt.info(), Eigen::Success);
  // −2 log L of column 0, and the GLS cross term of the two columns (the filter is linear in the data).
  double kf = 0.0, kf01 = 0.0;
  for (int i = 0; i < n; ++i) {
    kf += std::log(S[i]) + innov(i, 0) * innov(i, 0) / S[i];
    kf01 += innov(i, 0) * innov(i, 1) / S[i];
  }
  const Eigen::VectorXd y = rows.col(0), one = rows.col(1);
  double dense = y.dot(llt.solve(y));
  for (int i = 0; i < n; ++i) dense += 2.0 * std::log(llt.matrixL()(i, i));
  EXPECT_NEAR(kf, dense, 1e-9 * std::fabs(dense));
  EXPECT_NEAR(kf01, one.dot(llt.solve(y)), 1e-9 * std::sqrt(one.dot(llt.solve(one)) * y.dot(llt.solve(y))));
}

// White noise N and a faint flicker bank up to the n blocks' span, blocks of dur_s back to back: the dwells' model
// a whole-log wander search starts from.
StochasticModel faint_flicker_model(double N, int n, double dur_s, std::vector<double>& t, std::vector<double>& d) {
  StochasticModel m;
  m.N = N;
  m.bank_tau_s = flicker_bank_taus(0.05, n * dur_s);
  m.bank_sigma = m.bank_sigma_lik = 1e-6;
  t.resize(static_cast<std::size_t>(n));
  d.assign(static_cast<std::size_t>(n), dur_s);
  for (int i = 0; i < n; ++i) t[static_cast<std::size_t>(i)] = dur_s * (i + 0.5);
  return m;
}

// Block means [y | 1] of n blocks of dur_s: 0.3, a flicker bank of state σ s over m.bank_tau_s (each state a
// first-order Gauss-Markov process stepped per block), white noise of density N, and extra(i, rng) where given
// (drawn after the bank's steps and before the white noise).
Eigen::MatrixXd flicker_bank_rows(const StochasticModel& m, int n, double dur_s, double N, double s, std::uint64_t seed,
                                  const std::function<double(int, std::mt19937_64&)>& extra = nullptr) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<double> x(m.bank_tau_s.size());
  for (double& xi : x) xi = s * n01(rng);
  Eigen::MatrixXd rows(n, 2);
  for (int i = 0; i < n; ++i) {
    double bias = 0;
    for (std::size_t g = 0; g < x.size(); ++g) {
      const double phi = std::exp(-dur_s / m.bank_tau_s[g]);
      if (i > 0) x[g] = phi * x[g] + s * std::sqrt(1.0 - phi * phi) * n01(rng);
      bias += x[g];
    }
    if (extra) bias += extra(i, rng);
    rows(i, 0) = 0.3 + bias + N / std::sqrt(dur_s) * n01(rng);
    rows(i, 1) = 1.0;
  }
  return rows;
}

// Rows [z | 1] of n blocks of dur_s: 0.3 + bias(i, w_i) + white block noise, where w is a random walk of K
// (unit/√s) drawn from `seed`, in that order per block (the bias function decides whether the walk is in it).
template <class Bias>
Eigen::MatrixXd walk_rows(int n, double dur_s, double N, double K, std::uint64_t seed, Bias bias) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd rows(n, 2);
  double rw = 0;
  for (int i = 0; i < n; ++i) {
    rw += K * std::sqrt(dur_s) * n01(rng);
    rows(i, 0) = 0.3 + bias(i, rw) + N / std::sqrt(dur_s) * n01(rng);
    rows(i, 1) = 1.0;  // the bias column the model fits
  }
  return rows;
}

TEST(DiagnosisNoiseModel, WholeLogWanderFindsARandomWalkAndRejectsAStepAndASine) {
  const int n = 600;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4;  // white density; random walk, unit/√s
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  auto run = [&](int kind, std::uint64_t seed) {
    const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, K_true, seed, [&](int i, double rw) {
      double bias = 0;
      if (kind == 0) bias = rw;
      if (kind == 1) bias = i >= n / 2 ? 0.02 : 0.0;                           // a step of ~45 block σ
      if (kind == 3 && i == n / 2) bias = 0.02;                                 // one outlying block of the same size
      if (kind == 2) bias = 0.01 * std::sin(2.0 * M_PI * t[static_cast<std::size_t>(i)] / 500.0);  // 500 s period
      return bias;
    });
    return whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
  };
  auto best = [](const std::array<WholeLogWander, 3>& l) { return l[0].gain >= l[1].gain ? l[0] : l[1]; };
  int found = 0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const WholeLogWander w = best(run(0, seed));
    EXPECT_EQ(w.kind, WholeLogWander::kRandomWalk) << seed;
    EXPECT_GT(w.gain, 3.84) << seed;
    EXPECT_LT(w.max_abs_z, 6.0) << seed;
    EXPECT_GT(w.whiteness_p, 1e-6) << seed;
    EXPECT_GT(w.line_p, 1e-3) << seed << ": a random walk's own innovations carry no line";
    if (w.kind == WholeLogWander::kRandomWalk && w.K > K_true / 2.0 && w.K < 2.0 * K_true) ++found;
  }
  EXPECT_GE(found, 4) << "K within a factor 2 of the truth";
  const auto step = run(1, 7), sine = run(2, 7), spike = run(3, 7);
  int raised = 0;
  for (const auto& l : step)
    if (l.kind != WholeLogWander::kNone) {
      ++raised;
      EXPECT_GT(l.max_abs_z, 6.0) << "a step is one jump, not wander";
      EXPECT_GT(l.jump_persist_z, 3.0) << "and a level step fits it better than one outlying block";
    }
  for (int i = 0; i < 2; ++i) {  // the flicker and random-walk lines (the model has no floor line: point = upper)
    const WholeLogWander& l = spike[static_cast<std::size_t>(i)];
    EXPECT_GT(l.max_abs_z, 6.0) << "one outlying block is as large an innovation as the step";
    EXPECT_LT(l.jump_persist_z, 3.0) << "but one outlying block fits it at least as well as a step";
  }
  for (const auto& l : sine)
    if (l.kind != WholeLogWander::kNone) {
      ++raised;
      EXPECT_LT(l.line_p, 1e-6) << "a sine stays one line through the whitening";
      EXPECT_NEAR(l.line_period_s, 500.0, 25.0);
    }
  EXPECT_GE(raised, 2) << "the likelihood must want a raise for both (else the checks are not exercised)";
}

// A residual that grows with the input is not a bias wander (WholeLogWander::hetero_*, Options::wander_max_hetero_p):
// a scale factor that moves with time over the log shows only on the blocks where the table turns, and the raised
// walk that takes it leaves innovations small on the still blocks and large on the turning ones. A true walk adds
// the same variance everywhere. Covariate: the block's rotation speed (every third block turns at 1-3 rad/s).
TEST(DiagnosisNoiseModel, AWanderWhoseSpreadFollowsTheInputIsNotWander) {
  const int n = 600;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4;
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  Eigen::MatrixXd cov(n, 1);
  for (int i = 0; i < n; ++i) cov(i, 0) = i % 3 == 0 ? 1.0 + (i / 3) % 3 : 0.0;
  auto best = [](const std::array<WholeLogWander, 3>& l) { return l[0].gain >= l[1].gain ? l[0] : l[1]; };
  int checked = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const Eigen::MatrixXd walk = walk_rows(n, dur_s, N, K_true, seed, [](int, double rw) { return rw; });
    const WholeLogWander w = best(whole_log_wander(m, t, d, walk, 0.0, n * dur_s, 1e6, nullptr, &cov));
    ASSERT_NE(w.kind, WholeLogWander::kNone) << seed;
    EXPECT_GT(w.hetero_p, 1e-4) << seed << ": a walk's innovations do not follow the rotation speed";
    EXPECT_LT(w.hetero_ratio, 2.0) << seed;
    // A scale error of 2e-3 at the start to −2e-3 at the end, on the turning blocks only: ±4 mrad/s at 2 rad/s.
    const Eigen::MatrixXd aged = walk_rows(n, dur_s, N, 0.0, seed, [&](int i, double) {
      return 2e-3 * (1.0 - 2.0 * i / static_cast<double>(n)) * cov(i, 0);
    });
    const WholeLogWander a = best(whole_log_wander(m, t, d, aged, 0.0, n * dur_s, 1e6, nullptr, &cov));
    if (a.kind == WholeLogWander::kNone) continue;
    ++checked;
    EXPECT_LT(a.hetero_p, 1e-10) << seed;
    EXPECT_GT(a.hetero_ratio, 4.0) << seed;
  }
  EXPECT_GE(checked, 3) << "the likelihood must want a raise for the ageing scale (else the check is not exercised)";
}

// Two cycles of a slow sinusoid against a random walk (periodic_bias, Options::wander_sinusoid_margin). The walk's
// whitening differences a slow sinusoid down to what its innovations hardly show, and the walk's likelihood gain
// is large; the sinusoid fitted beside the columns under the model's own level gains far more. A true random walk
// is the other way round: one sinusoid takes only a part of its spread over every period.
TEST(DiagnosisNoiseModel, TwoCyclesOfASinusoidAreToldFromARandomWalk) {
  const int n = 360;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4, period_s = 800.0;  // 1800 s: 2.25 cycles
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  auto gains = [&](int kind, std::uint64_t seed, double& period_found) {
    const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, kind == 0 ? K_true : 0.0, seed, [&](int i, double rw) {
      return kind == 0 ? rw : 4e-3 * std::sin(2.0 * M_PI * t[static_cast<std::size_t>(i)] / period_s + 0.3 * seed);
    });
    const auto l = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
    const double raise = std::max(l[0].gain, l[1].gain);
    const PeriodicBias pb = periodic_bias(m, t, d, rows, 0.0, n * dur_s);
    period_found = pb.period_s;
    EXPECT_EQ(pb.n_periods, 71);  // 1.5 to 25 cycles, 3 per cycle of the log
    EXPECT_GT(raise, 25.0) << seed << ": the likelihood wants a raise for both (else the rule is not exercised)";
    return pb.gain - raise;
  };
  const double margin = Options{}.wander_sinusoid_margin;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    double p_walk = 0, p_sine = 0;
    EXPECT_LT(gains(0, seed, p_walk), 0.0) << seed << ": a random walk is likelier as a walk than as a sinusoid";
    EXPECT_GT(gains(1, seed, p_sine), margin) << seed;
    EXPECT_NEAR(p_sine, period_s, 0.05 * period_s) << seed;
  }
}

// A line that runs only part of the time against a random walk (PeriodicBias::mod_*, Options::wander_modulated_chi2):
// an 85 s oscillation on while a slow square wave of 700 s is low (a compressor that runs while the chamber
// cools), 12 block σ (`unseen9` ooc-compressor-1 has 20-50). The walk raised for it gains more than the constant sinusoid
// does; the sinusoid with its own amplitude and phase in each stretch of the log, beside the raise, is far past the
// bar. Beside a true random walk the same columns at its best period stay under it (10 seeds).
TEST(DiagnosisNoiseModel, ALineThatRunsPartOfTheTimeIsToldFromARandomWalk) {
  const int n = 360;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4, sigma_b = N / std::sqrt(dur_s), period_s = 85.0;
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  const Options o;
  auto run = [&](int kind, std::uint64_t seed, double& p_group, double& p_bar, double& period_found) {
    const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, kind == 0 ? K_true : 0.0, seed, [&](int i, double rw) {
      const double ti = t[static_cast<std::size_t>(i)];
      const bool on = std::sin(2.0 * M_PI * ti / 700.0 + 0.7 * static_cast<double>(seed)) < 0.0;
      return kind == 0 ? rw : on ? 12.0 * sigma_b * std::sin(2.0 * M_PI * ti / period_s + 0.3 * static_cast<double>(seed)) : 0.0;
    });
    const auto l = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
    const WholeLogWander& raise = l[0].gain >= l[1].gain ? l[0] : l[1];
    EXPECT_GT(raise.gain, 25.0) << kind << " " << seed << ": the likelihood wants a raise (else the rule is not exercised)";
    const PeriodicBias pb = periodic_bias(m, t, d, rows, 0.0, n * dur_s);
    EXPECT_GE(pb.mod_windows, 2) << kind << " " << seed;
    period_found = pb.mod_period_s;
    const Eigen::MatrixXd cols = modulated_sinusoid(t, d, pb.mod_period_s, pb.mod_windows);
    EXPECT_EQ(cols.cols(), 2 * pb.mod_windows);
    const InputBias g = input_group_bias(m, t, d, rows.leftCols(2), 0.0, n * dur_s, raise, cols);
    p_group = chi2_sf(g.gain, g.n_functions);
    p_bar = 0.5 * chi2_sf(o.wander_modulated_chi2, 1.0) / pb.n_periods;
    if (kind == 1) EXPECT_GT(raise.gain, pb.gain) << seed << ": the constant sinusoid alone loses to the walk (the case asked)";
  };
  int walks_past = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    double pg = 1, pb = 0, period = 0;
    run(0, seed, pg, pb, period);
    walks_past += pg < pb;
    if (seed > 5) continue;
    run(1, seed, pg, pb, period);
    EXPECT_LT(pg, pb * 1e-3) << seed << ": the modulated line is far past the bar";
    EXPECT_NEAR(period, period_s, 0.05 * period_s) << seed;
  }
  EXPECT_EQ(walks_past, 0) << "a random walk is not a line that runs part of the time";
}

// A linear drift and a warm-up against a random walk (trend_bias, Options::wander_trend_chi2). A walk raised for a
// line reaches almost the line's likelihood, so the two are not compared head to head: the walk is re-fitted
// beside the shape, and the shape's likelihood ratio is χ²(1) for a true walk (8 settling times: the largest of
// 8 correlated χ²(1)) and large for a drift or a transient, whose increments do not average to zero. The drift:
// 25 block σ over the log; the warm-up: 40 block σ at the start, τ 300 s; as the `unseen` suite's cases.
TEST(DiagnosisNoiseModel, ADriftAndAWarmUpAreToldFromARandomWalk) {
  const int n = 360;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4, sigma_b = N / std::sqrt(dur_s), tau_s = 300.0;
  const double slope = 25.0 * sigma_b / (n * dur_s);
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  auto run = [&](int kind, std::uint64_t seed) {
    const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, kind == 0 ? K_true : 0.0, seed, [&](int i, double rw) {
      const double ti = t[static_cast<std::size_t>(i)];
      return kind == 0 ? rw : kind == 1 ? slope * ti : 40.0 * sigma_b * std::exp(-ti / tau_s);
    });
    const auto l = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
    const WholeLogWander& raise = l[0].gain >= l[1].gain ? l[0] : l[1];
    EXPECT_GT(raise.gain, 25.0) << kind << " " << seed << ": the likelihood wants a raise (else the rule is not exercised)";
    return trend_bias(m, t, d, rows, 0.0, n * dur_s, raise);
  };
  const double limit = Options{}.wander_trend_chi2;
  int walks_over_4 = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const TrendBias w = run(0, seed), l = run(1, seed), e = run(2, seed);
    EXPECT_EQ(w.n_shapes, 9);  // the line and 8 settling times
    EXPECT_LT(std::max(w.gain, w.settle_gain), limit) << seed << ": a random walk's increments average to zero";
    walks_over_4 += w.gain > 3.84;
    EXPECT_GT(l.gain, limit) << seed << ": a drift's do not";
    EXPECT_GT(l.gain, l.settle_gain) << seed << ": and a line is the likelier shape";
    EXPECT_NEAR(l.slope_per_s, slope, 0.1 * slope) << seed;
    EXPECT_GT(e.settle_gain, limit) << seed << ": nor a warm-up's";
    EXPECT_GT(e.settle_gain, e.gain) << seed << ": and a transient is the likelier shape";
    EXPECT_GT(e.settle_tau_s, tau_s / std::sqrt(2.0)) << seed;
    EXPECT_LT(e.settle_tau_s, tau_s * std::sqrt(2.0)) << seed;
  }
  EXPECT_LE(walks_over_4, 3) << "a line's chi2(1) exceeds 3.84 in 5 % of walks (80 seeds: 8)";
}

// A bias that follows a logged input against the random walk a raise would take it for (input_bias,
// Options::wander_follows_chi2). The input: a chamber that ramps and soaks, so |dT/dt| is a bump per ramp (the
// `unseen4` suite's abs_temp_rate, here 6 block σ at the ramp rate); beside it 39 other functions of the same inputs
// and of a table that turns (dT/dt itself, T, T², the angle's sin and cos, their lags, products). Each function's
// likelihood ratio beside the re-fitted walk is χ²(1) under a true walk, so the largest of 40 stays under the bar
// (25 + 2 ln 40 = 32.4); the bump's is far above it, and it is the function named.
TEST(DiagnosisNoiseModel, AnInputDrivenBiasIsToldFromARandomWalk) {
  const int n = 600;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4, sigma_b = N / std::sqrt(dur_s);
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  // Chamber: 200 s soaks between 300 s ramps at 0.05 °C/s, up and down; the table turns by 7° per block.
  std::vector<double> T(static_cast<std::size_t>(n)), Tdot(static_cast<std::size_t>(n)), ang(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double ti = t[static_cast<std::size_t>(i)], ph = std::fmod(ti, 1000.0);
    const double rate = ph < 200.0 ? 0.0 : ph < 500.0 ? 0.05 : ph < 700.0 ? 0.0 : -0.05;
    Tdot[static_cast<std::size_t>(i)] = rate;
    T[static_cast<std::size_t>(i)] = (i ? T[static_cast<std::size_t>(i - 1)] : 25.0) + rate * dur_s;
    ang[static_cast<std::size_t>(i)] = 0.122 * i;
  }
  const int F = 40, bump = 0;
  Eigen::MatrixXd fn(n, F);
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    int k = 0;
    fn(i, k++) = std::fabs(Tdot[u]);  // the one the bias follows
    fn(i, k++) = Tdot[u];
    fn(i, k++) = T[u];
    fn(i, k++) = T[u] * T[u];
    for (int h = 1; h <= 4; ++h) {
      fn(i, k++) = std::sin(h * ang[u]);
      fn(i, k++) = std::cos(h * ang[u]);
    }
    for (int lag = 1; lag <= 14; ++lag) {
      const auto v = static_cast<std::size_t>(std::max(0, i - lag * 3));
      fn(i, k++) = std::sin(ang[v]) * (lag % 2 ? 1.0 : T[v]);
      fn(i, k++) = lag % 3 ? Tdot[v] : std::cos(ang[v]);
    }
    EXPECT_EQ(k, F);
  }
  auto run = [&](bool input, std::uint64_t seed) {
    const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, K_true, seed, [&](int i, double rw) {
      return rw + (input ? 6.0 * sigma_b * std::fabs(Tdot[static_cast<std::size_t>(i)]) / 0.05 : 0.0);
    });
    const auto l = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
    const WholeLogWander& raise = l[0].gain >= l[1].gain ? l[0] : l[1];
    EXPECT_GT(raise.gain, 25.0) << input << " " << seed << ": the likelihood wants a raise (else the rule is not exercised)";
    return input_bias(m, t, d, rows, 0.0, n * dur_s, raise, fn);
  };
  const double bar = Options{}.wander_follows_chi2 + 2.0 * std::log(static_cast<double>(F));
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const InputBias w = run(false, seed), b = run(true, seed);
    EXPECT_EQ(w.n_functions, F);
    EXPECT_LT(w.gain, bar) << seed << ": a random walk follows none of the inputs";
    EXPECT_GT(b.gain, bar) << seed << ": a bias in |dT/dt| does";
    EXPECT_EQ(b.best, bump) << seed;
  }
  // No raise, nothing asked; a zero column is not counted.
  Eigen::MatrixXd fz = fn;
  fz.col(3).setZero();
  const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, K_true, 1, [](int, double rw) { return rw; });
  EXPECT_EQ(input_bias(m, t, d, rows, 0.0, n * dur_s, WholeLogWander{}, fn).best, -1);
  const auto l = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
  EXPECT_EQ(input_bias(m, t, d, rows, 0.0, n * dur_s, l[0].gain >= l[1].gain ? l[0] : l[1], fz).n_functions, F - 1);
}

// The cells' standard error: the O(n) sum against the double sum of block_covariance, on a model with every
// correlated term (GM, a flicker bank, a random walk with its prior, a per-segment bias) over irregular blocks in
// two segments. The per-segment bias is block_covariance's within a segment and absent across.
TEST(DiagnosisNoiseModel, WeightedSumVarianceIsTheDoubleSumOfBlockCovariances) {
  StochasticModel m;
  m.N = 2e-3;
  m.gm_sigma = 3e-4;
  m.gm_tau_s = 40.0;
  m.bank_tau_s = flicker_bank_taus(1.0, 3000.0);
  m.bank_sigma = m.bank_sigma_lik = 1e-4;
  m.K = 5e-6;
  m.seg_bias_var = 4e-8;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const int n = 60;
  std::vector<double> t, d, u, diag;
  std::vector<int> seg;
  double now = 12.0;
  for (int i = 0; i < n; ++i) {
    d.push_back(0.5 + 9.5 * U(rng));
    now += 0.5 * d.back() + (i == n / 2 ? 400.0 : 2.0 * U(rng));
    t.push_back(now);
    now += 0.5 * d.back();
    seg.push_back(i < n / 2 ? 0 : 1);
    u.push_back(0.2 + U(rng));
    diag.push_back(block_covariance(m, t.back(), d.back(), t.back(), d.back(), true, 0.0, 1e-9) * (1.0 + U(rng)));
  }
  const double rw0 = 1e-9, t_start = 0.0;
  double brute = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto I = static_cast<std::size_t>(i), J = static_cast<std::size_t>(j);
      double c = i == j ? diag[I] : block_covariance(m, t[I], d[I], t[J], d[J], false, t_start, rw0);
      if (i != j && seg[I] != seg[J]) c -= m.seg_bias_var;
      brute += u[I] * u[J] * c;
    }
  const double fast = weighted_sum_variance(m, t, d, seg, u, diag, t_start, rw0);
  EXPECT_NEAR(fast, brute, 1e-9 * std::fabs(brute));
  // Independent blocks: the variance of a weighted mean is Σ u² diag, as the cells had it.
  StochasticModel w;
  w.N = 2e-3;
  double white = 0;
  for (int i = 0; i < n; ++i) white += u[static_cast<std::size_t>(i)] * u[static_cast<std::size_t>(i)] * diag[static_cast<std::size_t>(i)];
  EXPECT_NEAR(weighted_sum_variance(w, t, d, seg, u, diag, t_start, 0.0), white, 1e-12 * white);
  EXPECT_GT(fast, 1.5 * white) << "the shared slow bias must count (else the comparison proves nothing)";
}

// The dwells' point estimate of a long flicker is short of the truth, their upper level above it (varied9
// null-tactical-2: a 300 s bias instability read B 3.4e-6, upper 4.9e-6, truth 5.8e-6). The likelihood carries
// the upper level and no raise above it is likelier, but the held-out verdict judged the point, and gyro.z was
// named unexplained at χ²/dof 5.8 on a sensor with nothing beyond the model. The whole log's flicker between the
// two is the verdict's floor (the third line): found where the truth lies between them, with its gain over the
// point; not found (or not material) where the point is the truth; and a raise of the floor only.
TEST(DiagnosisNoiseModel, TheWholeLogsFlickerBetweenThePointAndTheUpperLevelIsTheVerdictsFloor) {
  const int n = 600;
  const double dur_s = 5.0, N = 1e-3, s_true = 2e-3;  // white density; flicker bank state σ
  std::vector<double> t, d;
  StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  m.bank_tau_s = flicker_bank_taus(20.0, n * dur_s);  // states longer than a block: their block means are their values
  auto rows_of = [&](double s, std::uint64_t seed) { return flicker_bank_rows(m, n, dur_s, N, s, seed); };
  m.bank_sigma = 0.5 * s_true;      // the dwells' point estimate
  m.bank_sigma_lik = 2.0 * s_true;  // and their upper level
  int found = 0, quiet = 0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const auto lines = whole_log_wander(m, t, d, rows_of(s_true, seed), 0.0, n * dur_s, 1e6);
    const WholeLogWander& f = lines[2];
    EXPECT_EQ(lines[0].kind, WholeLogWander::kNone) << seed << ": nothing above the likelihood's level";
    if (f.kind != WholeLogWander::kFlicker) continue;
    EXPECT_TRUE(f.below_likelihood);
    EXPECT_GT(f.bank_sigma, m.bank_sigma);
    EXPECT_LE(f.bank_sigma, m.bank_sigma_lik * (1.0 + 1e-12));
    EXPECT_GE(f.gain_seen, f.gain);
    double rw0 = 0;
    const StochasticModel v = with_wander(m, &f, n * dur_s, 0.0, rw0);
    EXPECT_EQ(v.bank_sigma, f.bank_sigma) << "the verdict's floor is raised";
    EXPECT_EQ(std::max(v.bank_sigma, v.bank_sigma_lik), m.bank_sigma_lik) << "the likelihood keeps its own level";
    if (f.gain_seen > 3.84 && f.ratio > 1.2 && f.bank_sigma > 0.5 * s_true * 1.4 && f.bank_sigma < 2.0 * s_true) ++found;
  }
  EXPECT_GE(found, 4) << "the floor raised from the point toward the truth, material, in 4 of 5 logs";
  for (std::uint64_t seed = 11; seed <= 15; ++seed) {
    const auto lines = whole_log_wander(m, t, d, rows_of(0.5 * s_true, seed), 0.0, n * dur_s, 1e6);
    if (!(lines[2].kind == WholeLogWander::kFlicker && lines[2].gain_seen > 3.84 && lines[2].ratio > 1.2)) ++quiet;
  }
  EXPECT_GE(quiet, 4) << "where the point is the truth, no material floor in 4 of 5 logs";
}

// The verdict's floor is asked the raise's input check too (WholeLogWander::hetero_* on lines[2]; diagnose.cpp
// assess_wander refuses a floor whose innovations' spread follows the inputs: `varied37` ooc-w_cubed-1, where the
// floor took a gyro.y bias in |w|^3 from held-out chi2/dof 6.83 to 2.43 and the axis went unnamed, its innovations'
// spread 16x larger where the table turned fast). Here the floor's flicker beside a spread that grows with the
// rotation speed (segments at rest and at 1, 2, 3 rad/s): measured p 3e-26 to 1e-17, ratio 10 to 20. The same flicker
// alone: no such spread.
TEST(DiagnosisNoiseModel, TheVerdictsFloorIsAskedWhetherItsSpreadFollowsTheInput) {
  const int n = 600;
  const double dur_s = 5.0, N = 1e-3, s_true = 2e-3;
  std::vector<double> t, d;
  StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  m.bank_tau_s = flicker_bank_taus(20.0, n * dur_s);
  m.bank_sigma = 0.5 * s_true;
  m.bank_sigma_lik = 2.0 * s_true;
  Eigen::MatrixXd speed(n, 1);  // segments of 20 blocks at rest or turning at 1, 2 or 3 rad/s
  for (int i = 0; i < n; ++i) speed(i, 0) = (i / 20) % 4;
  auto rows_of = [&](double spread, std::uint64_t seed) {
    return flicker_bank_rows(m, n, dur_s, N, s_true, seed, [&](int i, std::mt19937_64& rng) {
      return spread * speed(i, 0) * std::normal_distribution<double>()(rng);
    });
  };
  int floors = 0, inputs = 0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const WholeLogWander quiet = whole_log_wander(m, t, d, rows_of(0.0, seed), 0.0, n * dur_s, 1e6, nullptr, &speed)[2];
    if (quiet.kind == WholeLogWander::kFlicker) {
      ++floors;
      EXPECT_TRUE(quiet.hetero_p > 1e-6 || quiet.hetero_ratio < 4.0)
          << seed << ": a flicker's spread does not follow the speed (p " << quiet.hetero_p << ", ratio " << quiet.hetero_ratio << ")";
    }
    const WholeLogWander spread = whole_log_wander(m, t, d, rows_of(2e-3, seed), 0.0, n * dur_s, 1e6, nullptr, &speed)[2];
    ASSERT_EQ(spread.kind, WholeLogWander::kFlicker) << seed << ": the floor is found (else the check is not exercised)";
    EXPECT_TRUE(spread.below_likelihood);
    std::printf("seed %d: flicker alone p %.2g ratio %.2g; with the spread p %.2g ratio %.2g\n", static_cast<int>(seed), quiet.hetero_p,
                quiet.hetero_ratio, spread.hetero_p, spread.hetero_ratio);
    inputs += spread.hetero_p < 1e-10 && spread.hetero_ratio >= 4.0;
  }
  EXPECT_GE(floors, 3) << "the flicker alone gives floors to ask";
  EXPECT_GE(inputs, 4) << "the spread growing with the speed beneath the floor fails the input check in 4 of 5 logs";
}

// Short dwells read the start of a random walk as flicker (its Allan deviation at their few-second lengths looks
// like a floor). The whole log's walk must then be raised jointly with that flicker: raised beside it held, K
// came out 36 % short on varied4 stoch-automotive-7 accel.y (1.58e-4 for blindgen's 2.48e-4, the dwells' flicker
// B 1.67e-3) and the under-read wander left accel.temp_rate its evidence. Here a pure walk under a model whose
// flicker matches the walk's Allan deviation at 30 s.
TEST(DiagnosisNoiseModel, AWalkTheDwellsReadAsFlickerIsRaisedWithoutThatFlicker) {
  const int n = 600;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4;
  std::vector<double> t, d;
  StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  const double B_dwells = K_true * std::sqrt(30.0 / 3.0) / 0.664;  // flicker floor 0.664 B = the walk's σ_A(30 s)
  m.bank_sigma = m.bank_sigma_lik = B_dwells / flicker_B_of_sigma(1.0, m.bank_tau_s);
  m.flicker_B = m.flicker_B_upper = B_dwells;
  int near = 0, lowered = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const Eigen::MatrixXd rows = walk_rows(n, dur_s, N, K_true, seed, [](int, double rw) { return rw; });
    const WholeLogWander w = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6)[1];
    ASSERT_EQ(w.kind, WholeLogWander::kRandomWalk) << seed;
    near += w.K > K_true / 1.5 && w.K < 1.5 * K_true;
    lowered += w.bank_sigma < 0.5 * m.bank_sigma;
    // with_wander applies the walk with its own flicker: the one rule for every re-run under the raise
    double rw0 = 0;
    const StochasticModel mw = with_wander(m, &w, n * dur_s, 0.0, rw0);
    EXPECT_EQ(mw.K, w.K);
    EXPECT_EQ(mw.bank_sigma, w.bank_sigma);
    EXPECT_NEAR(rw0, w.K * w.K * n * dur_s / 6.0, 1e-12 * rw0);
  }
  EXPECT_GE(near, 5) << "K within a factor 1.5 of the truth";
  EXPECT_GE(lowered, 5) << "the flicker the dwells read is given up for the walk";
}

// The periodic-bias check must not fire on wander whose shape differs from the model's. A random walk beside a
// strong 60 s Gauss–Markov bias, over 3000 blocks, under a model of white noise and a little flicker: the raised
// walk whitens the slow part, the Gauss–Markov leaves the innovations correlated at lags of a few blocks, and
// Ljung–Box, with thousands of blocks, calls that correlation decisive (the old periodic test: varied2
// stoch-automotive-4 accel.z, named unexplained at 12.3). Its spectrum is smooth: no line.
TEST(DiagnosisNoiseModel, AWanderOfAnotherShapeIsNotAPeriodicBias) {
  const int n = 3000;
  const double dur_s = 5.0, N = 1e-3, K_true = 2e-4, gm_sigma = 1.5e-3, gm_tau_s = 60.0;
  std::vector<double> t, d;
  const StochasticModel m = faint_flicker_model(N, n, dur_s, t, d);
  int lb_fails = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    Eigen::MatrixXd rows(n, 2);
    double rw = 0, gm = 0;
    const double a = std::exp(-dur_s / gm_tau_s);
    for (int i = 0; i < n; ++i) {
      rw += K_true * std::sqrt(dur_s) * n01(rng);
      gm = a * gm + gm_sigma * std::sqrt(1.0 - a * a) * n01(rng);
      rows(i, 0) = 0.3 + rw + gm + N / std::sqrt(dur_s) * n01(rng);
      rows(i, 1) = 1.0;
    }
    const auto l = whole_log_wander(m, t, d, rows, 0.0, n * dur_s, 1e6);
    const WholeLogWander& w = l[0].gain >= l[1].gain ? l[0] : l[1];
    ASSERT_NE(w.kind, WholeLogWander::kNone) << seed;
    lb_fails += w.whiteness_p < 1e-6;
    EXPECT_GT(w.line_p, 1e-4) << seed << ": smooth colour, no line";
  }
  EXPECT_GE(lb_fails, 2) << "the case must be one Ljung-Box refuses (else it does not exercise the change)";
}

TEST(DiagnosisNoiseModel, SpectralLineFalseAlarmIsCalibratedOnWhiteNoise) {
  // Irregular block times (segments of blocks with gaps), as a campaign gives them.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u01;
  std::vector<double> t;
  double now = 0;
  while (t.size() < 600) {
    const int blocks = 1 + static_cast<int>(6 * u01(rng));
    for (int b = 0; b < blocks; ++b) t.push_back(now += 2.0 + 8.0 * u01(rng));
    now += 30.0 * u01(rng);
  }
  const int n = static_cast<int>(t.size()), trials = 400;
  int below_1pct = 0, below_10pct = 0;
  Eigen::VectorXd e(n);
  for (int k = 0; k < trials; ++k) {
    for (int i = 0; i < n; ++i) e[i] = n01(rng);
    const SpectralLine l = line_power_spectrum(t, e);
    below_1pct += l.false_alarm_p < 0.01;
    below_10pct += l.false_alarm_p < 0.1;
  }
  // Baluev's bound is close to exact at small false-alarm rates; allow the binomial spread of 400 trials (3σ)
  // above the nominal rate.
  EXPECT_LE(below_1pct, 4 + 3 * 2);
  EXPECT_LE(below_10pct, 40 + 3 * 6);
  EXPECT_GE(below_10pct, 10) << "not so conservative that it never fires";
  // A sine of 0.4 σ amplitude, period 700 s, is found at its period.
  for (int i = 0; i < n; ++i) e[i] = n01(rng) + 0.4 * std::sin(2.0 * M_PI * t[static_cast<std::size_t>(i)] / 700.0 + 1.0);
  const SpectralLine l = line_power_spectrum(t, e);
  EXPECT_LT(l.false_alarm_p, 1e-6);
  EXPECT_NEAR(l.period_s, 700.0, 20.0);
  // A log of 40000 blocks, where the search is bounded (coarser grid, lower top frequency): a slow line is still
  // found at its period, and white noise alone still is not a line.
  const int n_long = 40000;
  std::vector<double> t_long(static_cast<std::size_t>(n_long));
  Eigen::VectorXd e_long(n_long), w_long(n_long);
  for (int i = 0; i < n_long; ++i) {
    t_long[static_cast<std::size_t>(i)] = 1.0 * i;
    w_long[i] = n01(rng);
    e_long[i] = w_long[i] + 0.1 * std::sin(2.0 * M_PI * i / 2000.0);
  }
  const SpectralLine ll = line_power_spectrum(t_long, e_long);
  EXPECT_LT(ll.false_alarm_p, 1e-6);
  EXPECT_NEAR(ll.period_s, 2000.0, 60.0);
  EXPECT_GT(line_power_spectrum(t_long, w_long).false_alarm_p, 1e-3);
}

// line_power_spectrum advances cos/sin by recurrence and sums two grid frequencies per pass: its power must be the
// largest least-squares sinusoid power over its grid computed directly (std::cos/sin at each frequency), with an
// odd number of grid frequencies (the last one summed alone) and an even one.
TEST(DiagnosisNoiseModel, SpectralLineIsTheLargestPowerOnItsGridComputedDirectly) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u01;
  bool odd = false, even = false;
  for (int n = 120; n < 140 && !(odd && even); ++n) {
    std::vector<double> t;
    double now = 0;
    while (static_cast<int>(t.size()) < n) t.push_back(now += 0.5 + 2.0 * u01(rng));
    Eigen::VectorXd e(n);
    for (int i = 0; i < n; ++i) e[i] = n01(rng) + 0.3 * std::sin(t[static_cast<std::size_t>(i)] / 9.0);
    // The grid as documented: 2/D .. 1/(2 median spacing), oversampled 4× against 1/D (n × F is far below the bound).
    std::vector<double> dt;
    for (int i = 1; i < n; ++i) dt.push_back(t[static_cast<std::size_t>(i)] - t[static_cast<std::size_t>(i - 1)]);
    std::sort(dt.begin(), dt.end());
    const double med = dt[dt.size() / 2], span = t.back() - t.front();
    const double f_lo = 2.0 / span, df = 1.0 / (4.0 * span);
    const int F = static_cast<int>((0.5 / med - f_lo) / df) + 1;
    (F % 2 ? odd : even) = true;
    const Eigen::VectorXd ec = e.array() - e.mean();
    const double var = ec.squaredNorm() / (n - 1);
    double best = 0, best_period = 0;
    for (int k = 0; k < F; ++k) {
      const double f = f_lo + k * df;
      double C = 0, S = 0, CC = 0, SS = 0, CS = 0;
      for (int i = 0; i < n; ++i) {
        const double ph = 2.0 * M_PI * f * (t[static_cast<std::size_t>(i)] - t.front());
        const double c = std::cos(ph), sn = std::sin(ph);
        C += ec[i] * c;
        S += ec[i] * sn;
        CC += c * c;
        SS += sn * sn;
        CS += c * sn;
      }
      const double pw = (SS * C * C - 2.0 * CS * C * S + CC * S * S) / (CC * SS - CS * CS) / (2.0 * var);
      if (pw > best) {
        best = pw;
        best_period = 1.0 / f;
      }
    }
    const SpectralLine l = line_power_spectrum(t, e);
    EXPECT_NEAR(l.power, best, 1e-8 * best) << "n " << n << ", F " << F;
    EXPECT_NEAR(l.period_s, best_period, 1e-9 * best_period) << "n " << n << ", F " << F;
  }
  EXPECT_TRUE(odd && even) << "both parities of the grid exercised";
}

// Stuck bits (output_bits.h): healthy quantised outputs of every kind a log has never show one, whatever their
// noise against the step; a bit forced to 0 or 1 is found at its place, with the noise carrying the output across
// its neighbours or not by much.
TEST(DiagnosisStuckBits, HealthyWordsShowNoneAndAForcedBitIsFound) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> n01;
  const double lsb = 1e-3;
  // rows of noise sigma (counts) about means that change every dwell (clusters), optionally a bit forced
  auto run = [&](double sigma, const std::vector<double>& means, int force_bit, bool force_high, int shift = 0) {
    OutputBitCounter c(lsb);
    for (int pass = 0; pass < 20; ++pass)
      for (const double m : means)
        for (int i = 0; i < 2000; ++i) {
          auto code = static_cast<std::int64_t>(std::llround(m + sigma * n01(rng)));
          code = static_cast<std::int64_t>(static_cast<std::uint64_t>(code) << shift);  // a left-justified word
          if (force_bit >= 0) {
            const std::uint64_t bit = std::uint64_t{1} << force_bit;
            code = static_cast<std::int64_t>(force_high ? (static_cast<std::uint64_t>(code) | bit) : (static_cast<std::uint64_t>(code) & ~bit));
          }
          c.add(static_cast<double>(code) * lsb);
        }
    return c.finish();
  };
  // Healthy: fine and coarse noise against the step, about zero and far from it, two clusters far apart whose codes
  // share every bit but the sign's (16884 = 0x41F4 and −15884 = 0x...C1F4: a pose change is not a neighbouring code),
  // a word whose four lowest bits are always 0.
  for (const double sigma : {0.3, 2.0, 6.5, 40.0, 3000.0})
    for (const auto& means : {std::vector<double>{0.0}, std::vector<double>{12345.6}, std::vector<double>{-700.0, 900.0, 16000.0}}) {
      const StuckBits h = run(sigma, means, -1, false);
      EXPECT_EQ(h.bit, -1) << "sigma " << sigma << " means " << means.front() << ": bit " << h.bit;
    }
  EXPECT_EQ(run(1.0, {16884.0, -15884.0}, -1, false).bit, -1);
  EXPECT_EQ(run(3.0, {20.0, 2068.0}, -1, false).bit, -1) << "two clusters 2048 apart: bit 11 moves only between them";
  EXPECT_EQ(run(3.0, {100.0}, -1, false, 4).bit, -1) << "a left-justified word is not stuck";
  // Forced bits: at 0, at 1, under the noise and well above it, near zero (the sign extension moving every high bit)
  // and away from it.
  struct Case { double sigma, mean; int bit; bool high; };
  for (const Case& k : {Case{6.5, 3.0, 4, false}, Case{6.5, 3.0, 2, true}, Case{2.0, 5000.0, 3, false}, Case{40.0, -20000.0, 7, false},
                        Case{1.5, 300.0, 1, true}}) {
    const StuckBits f = run(k.sigma, {k.mean, k.mean + 37.0, k.mean - 81.0}, k.bit, k.high);
    EXPECT_EQ(f.bit, k.bit) << "sigma " << k.sigma << " mean " << k.mean;
    EXPECT_EQ(f.high, k.high) << "bit " << k.bit;
    EXPECT_EQ(f.mask, std::uint64_t{1} << k.bit);
  }
  // Not a quantised output (no step): nothing is asked.
  OutputBitCounter none(0.0);
  none.add(1.0);
  EXPECT_EQ(none.finish().rows, 0);
}

// The bit-sliced counts against a plain count of every changed bit: noise of a few counts to thousands, jumps between
// clusters, codes of either sign up to 2^40, runs of equal codes, and more rows than a flush holds (65535).
TEST(DiagnosisStuckBits, BitSlicedCountsAreThePlainCounts) {
  std::mt19937_64 rng(31);
  std::normal_distribution<double> n01;
  std::uniform_int_distribution<int> pick(0, 99);
  const double lsb = 0.5;
  OutputBitCounter c(lsb);
  std::array<long long, 64> tog{}, near{};
  std::int64_t prev = 0;
  double level = 0;
  const int rows = 200000;
  for (int i = 0; i < rows; ++i) {
    const int p = pick(rng);
    if (p == 0) level = std::ldexp(n01(rng), 40);                        // a far jump, either sign
    else if (p < 5) level += 3000.0 * n01(rng);                          // a pose change
    const double sigma = p % 3 == 0 ? 0.2 : p % 3 == 1 ? 4.0 : 900.0;   // repeated codes, a few counts, many
    const auto code = static_cast<std::int64_t>(std::llround(level + sigma * n01(rng)));
    c.add(static_cast<double>(code) * lsb);
    if (i > 0) {
      const std::uint64_t ch = static_cast<std::uint64_t>(code) ^ static_cast<std::uint64_t>(prev);
      const std::int64_t d = code - prev;
      const std::uint64_t ad = static_cast<std::uint64_t>(d < 0 ? -d : d);
      for (int b = 0; b < 64; ++b)
        if ((ch >> b) & 1u) {
          ++tog[static_cast<std::size_t>(b)];
          if (b < 63 && ad < (std::uint64_t{1} << b)) ++near[static_cast<std::size_t>(b)];
        }
    }
    prev = code;
  }
  long long total = 0;
  for (int b = 0; b < 64; ++b) {
    EXPECT_EQ(c.toggles(b), tog[static_cast<std::size_t>(b)]) << "bit " << b;
    EXPECT_EQ(c.near_toggles(b), near[static_cast<std::size_t>(b)]) << "bit " << b;
    total += tog[static_cast<std::size_t>(b)];
  }
  EXPECT_GT(tog[0], 65535) << "the planes were flushed";
  EXPECT_GT(near[45], 0) << "near changes of a high bit were counted";
  EXPECT_GT(total, 500000);
}

// The pipeline names a stuck bit's axis on that basis and selects nothing for it: a consumer-like gyro whose bit 4 is
// stuck at 0 on static tilts read as a flicker 13x the sensor's on blindgen's stuck_bit-2 (stop 64).
TEST(DiagnosisPipeline, AStuckBitIsNamedAsTheWordNotThePhysics) {
  std::mt19937_64 rng(23);
  std::normal_distribution<double> n01;
  const double a_lsb = 6e-4, g_lsb = 1.33e-4;
  const auto log = static_pose_log(two_axis_tilts(), 3, 8.0, [&](int, const Pose& f, double* y) {
    for (int j = 0; j < 3; ++j) {
      y[j] = a_lsb * static_cast<double>(std::llround((f[static_cast<std::size_t>(j)] + 4e-3 * n01(rng)) / a_lsb));
      auto code = std::llround((3e-4 + 8.7e-4 * n01(rng)) / g_lsb);
      if (j == 1) code = static_cast<long long>(static_cast<std::uint64_t>(code) & ~std::uint64_t{16});
      y[3 + j] = g_lsb * static_cast<double>(code);
    }
  });
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  ASSERT_EQ(r.unexplained.size(), 1u);
  EXPECT_EQ(r.unexplained[0].axis, "gyro.y");
  EXPECT_EQ(r.unexplained[0].basis, "stuck_bit");
  EXPECT_EQ(r.stuck_bits[4].bit, 4);
  for (int a = 0; a < kNumAxes; ++a)
    if (a != 4) EXPECT_EQ(r.stuck_bits[static_cast<std::size_t>(a)].bit, -1) << axis_name(a);
  for (const auto& st : r.selected) EXPECT_NE(st.sensor, "gyro") << st.effect;
}

TEST(DiagnosisNoiseModel, OutputStepIsFoundOnALatticeOnly) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  const double step = 0.02, lsb = 0.0012;  // a coarse step, the values then re-rounded to a finer LSB
  std::vector<double> coarse, continuous, fine;
  double prev_c = 0, prev_x = 0, prev_f = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = 9.3 + 0.3 * std::sin(i * 1e-3) + 0.004 * n01(rng);
    const double c = lsb * std::round(step * std::round(x / step) / lsb);
    const double f = 1e-4 * std::round(x / 1e-4);  // a step 40x below the noise: found, and harmless
    if (i > 0) {
      coarse.push_back(std::fabs(c - prev_c));
      continuous.push_back(std::fabs(x - prev_x));
      fine.push_back(std::fabs(f - prev_f));
    }
    prev_c = c, prev_x = x, prev_f = f;
  }
  EXPECT_NEAR(output_step(coarse, 4e-7 * 10.0), step, 0.06 * step);
  EXPECT_EQ(output_step(continuous, 4e-7 * 10.0), 0.0);
  EXPECT_NEAR(output_step(fine, 4e-7 * 10.0), 1e-4, 1e-6);
  EXPECT_EQ(output_step(std::vector<double>(50, step), 0.0), 0.0) << "too few steps to tell";
}

TEST(DiagnosisNoiseModel, RoundingBiasVarianceMatchesTheExactMeanOfTheRoundedNoise) {
  // Mean of round((x + n)/Δ)·Δ − x for n ~ N(0, σ²), by summing the rounding cells' Gaussian probabilities; its
  // variance over x uniform in one step, against the closed form.
  const double step = 1.0;
  for (double sigma : {0.0, 0.1, 0.2, 0.35, 0.6, 1.0}) {
    const int nx = 400;
    double v = 0;
    for (int i = 0; i < nx; ++i) {
      const double x = (i + 0.5) / nx * step;
      double mean = 0;
      if (sigma == 0.0) {
        mean = step * std::round(x / step);
      } else {
        for (int j = -12; j <= 12; ++j) {
          const double lo = ((j - 0.5) * step - x) / sigma, hi = ((j + 0.5) * step - x) / sigma;
          mean += j * step * 0.5 * (std::erfc(-hi / std::sqrt(2.0)) - std::erfc(-lo / std::sqrt(2.0)));
        }
      }
      v += (mean - x) * (mean - x) / nx;
    }
    EXPECT_NEAR(quantization_mean_bias_var(step, sigma), v, 2e-3 * step * step / 12.0 + 0.01 * v) << "sigma " << sigma;
  }
  EXPECT_NEAR(quantization_mean_bias_var(0.5, 0.0), 0.25 / 12.0, 1e-4);
  EXPECT_LT(quantization_mean_bias_var(1.0, 1.0), 1e-15);
}

TEST(DiagnosisPipeline, OneAxisFarAboveItsNoiseDoesNotHideTheOthersEffects) {
  // gyro.x and gyro.y carry a real g-sensitivity; gyro.z a bias that flips between the two passes over the same
  // poses (no catalog effect has it: same pose, same temperature, another value) at ~100 times its noise. The
  // g-sensitivity's fold fits mispredict gyro.z by a fraction of that axis's huge excess; summed raw over the
  // axes, that outweighed its gain on x and y and the real effect was lost with the axis named unexplained.
  const double g = 9.80665;
  auto make_log = [&](double flip_rad_s) {
    std::mt19937_64 rng(17);
    std::normal_distribution<double> n01;
    return static_pose_log(two_axis_tilts(), 2, 8.0, [&](int pass, const Pose& f, double* y) {
      for (int j = 0; j < 3; ++j) y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
      y[3] = 2e-4 * f[2] / g + 5e-4 * n01(rng);  // g-sensitivity gx ← f_z, gy ← f_x
      y[4] = -1.5e-4 * f[0] / g + 5e-4 * n01(rng);
      y[5] = (pass == 0 ? flip_rad_s : -flip_rad_s) + 5e-4 * n01(rng);
    });
  };
  // (With Options::heldout_axis_scale = false, the sums before stop 24, g_sensitivity is lost on this log.)
  VectorSource src(make_log(2e-3));
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  bool gsens = false, z_named = false;
  for (const auto& st : r.selected) gsens = gsens || (st.sensor == "gyro" && st.effect == "g_sensitivity");
  for (const auto& u : r.unexplained) z_named = z_named || u.axis == "gyro.z";
  EXPECT_TRUE(gsens) << "the real g-sensitivity of gyro.x/y";
  EXPECT_TRUE(z_named) << "gyro.z named unexplained";
  for (const auto& u : r.unexplained) EXPECT_EQ(u.axis, "gyro.z");
  // The g-sensitivity's components on gyro.z take part of the flipping bias there: flagged, not findings; those
  // on the explained axes are not flagged (report.cpp on_unexplained_axis).
  const auto j = to_json(r);
  int flagged = 0, plain = 0;
  for (const auto& p : j["parameters"]) {
    if (p["name"].get<std::string>().rfind("gyro.g_sensitivity.", 0) != 0) continue;
    const bool f = p.value("on_unexplained_axis", false);
    EXPECT_EQ(f, p["axis"] == "gyro.z") << p["name"];
    (f ? flagged : plain) += 1;
  }
  EXPECT_GT(flagged, 0);
  EXPECT_GT(plain, 0);
  const std::string text = summary_text(r);
  EXPECT_NE(text.find("[gyro.z] = "), std::string::npos);
  EXPECT_NE(text.find("(axis unexplained: takes part of the out-of-catalog residual there; not a finding)"), std::string::npos);
}

// A log written by hand, not by the simulator: 100 Hz, 60 s stretches of what a rate table and a bench do to a
// sample's neighbourhood. Static dwells (white noise), a ramp (a table accelerating: slope, no curvature), kinks (the
// rate starting and stopping), steps whose first row is caught on the way, a 0.5 Hz sine of large curvature with ten times the noise (the
// table vibrating while it turns), an axis quantised to a count coarser than its noise, a two-sample burst and a
// knock on every axis at once. Glitches are put on single samples of some axes, among all of these. The filter must
// find exactly those (each, and nothing else), tell the knock's as shared, and replay each on the line through its
// neighbours.
TEST(DiagnosisGlitches, IsolatedSamplesAreFoundAmongRampsKinksStepsAndVibrationAndNothingElse) {
  std::mt19937_64 rng(61);
  std::normal_distribution<double> n01;
  const double fs = 100.0, sigma = 1e-3;
  const int n = 60000;  // 600 s
  std::vector<Sample> log;
  std::vector<std::array<double, 6>> clean;
  for (int i = 0; i < n; ++i) {
    const double t = i / fs;
    Sample s = referenced_sample(t, i / 500);
    const int part = (i / 6000) % 5;  // 60 s each: 0 static, 1 ramp with kinks, 2 steps, 3 vibrating sine, 4 static
    double signal = 0.0, noise = sigma;
    const double u = std::fmod(t, 60.0);
    if (part == 1) signal = u < 10 ? 0.0 : u < 50 ? 0.02 * (u - 10) : 0.8;  // kinks at 10 s and 50 s
    if (part == 2) {  // a step every 7 s, its first row caught 30 % of the way (the pose changing within a row)
      signal = 0.5 * std::floor(u / 7.0);
      if (u >= 7.0 && std::fmod(u, 7.0) < 0.5 / fs) signal -= 0.35;
    }
    if (part == 3) {
      signal = 1.5 * std::sin(2.0 * M_PI * 0.5 * t);
      noise = 10.0 * sigma;
    }
    std::array<double, 6> y{};
    for (int a = 0; a < 6; ++a) y[static_cast<std::size_t>(a)] = (a == 2 ? 0.3 : 1.0) * signal + noise * n01(rng);
    // accel.z (a = 2): an output quantised to 3 sigma with its noise beneath the count
    y[2] = 3.0 * sigma * std::round(y[2] / (3.0 * sigma));
    for (int a = 0; a < 6; ++a) s.y[a] = y[static_cast<std::size_t>(a)];
    clean.push_back(y);
    log.push_back(s);
  }
  // a two-sample burst on gyro.x (rows 1500, 1501) and a knock on all six axes at row 56789 (a quiet stretch): 40 sigma each
  for (int r : {1500, 1501}) log[static_cast<std::size_t>(r)].y[3] += 40 * sigma;
  for (int a = 0; a < 6; ++a) log[56789].y[a] += (a % 2 ? -40 : 40) * sigma * (a == 2 ? 3.0 : 1.0);
  // glitches: row, axis, size in sigma (of a static row; the vibrating sine's are 10x larger, so 300 there)
  const std::vector<std::tuple<int, int, double>> glitches = {
      {700, 0, 30},     {3000, 1, -25},   {6000 + 1000, 4, 50},  {36000 + 1000, 5, 30},  // kinks at rows 7000 and 37000
      {6000 + 5000, 0, -40}, {12000 + 704, 1, 30},  {12000 + 1405, 4, 60},  // two steps' fifth and sixth rows
      {18000 + 1234, 3, 300}, {18000 + 3456, 0, -300}, {24000 + 100, 2, 20}, {24000 + 4000, 5, 25}};
  for (const auto& [r, a, z] : glitches) log[static_cast<std::size_t>(r)].y[a] += z * sigma * (a == 2 ? 3.0 : 1.0);
  VectorSource raw(log);
  GlitchFilterSource f(raw, Options{}.glitch_z);
  std::array<long long, 6> want{};
  for (const auto& [r, a, z] : glitches) ++want[static_cast<std::size_t>(a)];
  for (int a = 0; a < 6; ++a) ++want[static_cast<std::size_t>(a)];  // the knock
  for (int a = 0; a < 6; ++a) {
    EXPECT_EQ(f.summary()[static_cast<std::size_t>(a)].count, want[static_cast<std::size_t>(a)]) << axis_name(a);
    EXPECT_EQ(f.summary()[static_cast<std::size_t>(a)].shared, 1) << axis_name(a) << ": the knock, and only it, is shared";
  }
  // The replayed log: each glitch (and the knock) replaced on the line through its neighbours, within that line's noise;
  // every other row as it was.
  f.rewind();
  Sample s;
  std::size_t i = 0;
  std::set<std::pair<std::size_t, int>> hit;
  for (const auto& [r, a, z] : glitches) hit.insert({static_cast<std::size_t>(r), a});
  for (int a = 0; a < 6; ++a) hit.insert({56789, a});
  while (f.next(s)) {
    for (int a = 0; a < 6; ++a) {
      if (hit.count({i, a})) {
        const double tol = 10.0 * sigma * (a == 2 ? 3.0 : 1.0) * ((i / 6000) % 5 == 3 ? 10.0 : 1.0);
        EXPECT_NEAR(s.y[a], clean[i][static_cast<std::size_t>(a)], tol) << "row " << i << " " << axis_name(a);
      } else {
        EXPECT_EQ(s.y[a], log[i].y[a]) << "row " << i << " " << axis_name(a) << " must replay untouched";
      }
    }
    ++i;
  }
  EXPECT_EQ(i, log.size());
  // The first pass hands the log on while it searches (the diagnosis's pass 0 reads it so): row for row what the
  // replay gives, and the same summary once it has reached the end.
  std::vector<Sample> replay;
  f.rewind();
  while (f.next(s)) replay.push_back(s);
  auto same_rows = [&](GlitchFilterSource& g, const char* what) {
    std::size_t k = 0;
    Sample r;
    while (g.next(r)) {
      ASSERT_LT(k, replay.size()) << what;
      for (int a = 0; a < 6; ++a) ASSERT_EQ(r.y[a], replay[k].y[a]) << what << ": row " << k << " " << axis_name(a);
      ASSERT_EQ(r.t_s, replay[k].t_s) << what << ": row " << k;
      ++k;
    }
    EXPECT_EQ(k, replay.size()) << what;
    for (int a = 0; a < 6; ++a) EXPECT_EQ(g.summary()[static_cast<std::size_t>(a)].count, want[static_cast<std::size_t>(a)]) << what << " " << axis_name(a);
  };
  GlitchFilterSource streamed(raw, Options{}.glitch_z);
  streamed.rewind();
  same_rows(streamed, "first pass");
  // A pass left halfway and rewound searches again from the start.
  GlitchFilterSource restarted(raw, Options{}.glitch_z);
  restarted.rewind();
  for (int k = 0; k < 30000 && restarted.next(s); ++k) {
  }
  restarted.rewind();
  same_rows(restarted, "restarted");
  // Rows without a reference (a hand-held log's moving part: 70 s here, away from every glitch) hold each axis'
  // stretch open; past a look-ahead bound (2000 rows here) each axis judges what it holds. Same glitches, and the
  // rows handed on as the replay gives them (the no-reference rows included).
  std::vector<Sample> gap = log;
  for (std::size_t r = 40000; r < 47000; ++r) gap[r].has_ref = false;
  VectorSource raw_gap(gap);
  for (std::size_t bound : {GlitchFilterSource::kMaxBufferedRows, std::size_t{2000}}) {
    GlitchFilterSource g(raw_gap, Options{}.glitch_z, bound);
    g.rewind();
    std::size_t k = 0;
    while (g.next(s)) {
      for (int a = 0; a < 6; ++a) ASSERT_EQ(s.y[a], replay[k].y[a]) << "bound " << bound << ": row " << k << " " << axis_name(a);
      ++k;
    }
    EXPECT_EQ(k, gap.size());
    for (int a = 0; a < 6; ++a) EXPECT_EQ(g.summary()[static_cast<std::size_t>(a)].count, want[static_cast<std::size_t>(a)]) << "bound " << bound << " " << axis_name(a);
  }
  // Off: the log replays as it is.
  GlitchFilterSource off(raw, 0.0);
  EXPECT_EQ(off.total(), 0);
}

// Static tilts (three passes of two_axis_tilts, 8 s each) with white noise of 2e-3 m/s² and 5e-4 rad/s per sample:
// the clean log a filter test corrupts.
std::vector<Sample> white_tilt_log(unsigned seed) {
  std::mt19937_64 rng(seed);
  return static_pose_log(two_axis_tilts(), 3, 8.0, [&](int, const Pose& f, double* y) {
    Sample s;
    white_static_outputs(s, f, 2e-3, 5e-4, rng);
    for (int a = 0; a < 6; ++a) y[a] = s.y[a];
  });
}

// The same glitches in a diagnosis: static tilts with white noise, and single samples of accel.y set 60 sigma off
// about once every 20 s. The axis is named for them (basis "glitches"), nothing is selected, and the fit is the
// clean log's: the bias and the white noise the glitches would have pulled and inflated come out as without them.
TEST(DiagnosisPipeline, GlitchesNameTheirAxisAndLeaveTheFitAsTheCleanLogs) {
  const std::vector<Sample> clean_log = white_tilt_log(62);
  std::vector<Sample> glitched = clean_log;
  int injected = 0;
  for (std::size_t i = 1000; i + 3 < glitched.size(); i += 1999, ++injected) glitched[i].y[1] += (injected % 2 ? -60.0 : 60.0) * 2e-3;
  VectorSource a_src(clean_log), b_src(glitched);
  const Options o;
  const DiagnosisResult clean = diagnose(a_src, basic_model(), o);
  const DiagnosisResult r = diagnose(b_src, basic_model(), o);
  EXPECT_EQ(clean.glitches[1].count, 0);
  EXPECT_TRUE(clean.unexplained.empty());
  EXPECT_EQ(r.glitches[1].count, injected);
  EXPECT_EQ(r.glitches[1].shared, 0);
  for (int a = 0; a < 6; ++a)
    if (a != 1) EXPECT_EQ(r.glitches[static_cast<std::size_t>(a)].count, 0) << axis_name(a);
  ASSERT_EQ(r.unexplained.size(), 1u);
  EXPECT_EQ(r.unexplained[0].axis, "accel.y");
  EXPECT_EQ(r.unexplained[0].basis, "glitches");
  EXPECT_TRUE(r.selected.empty());
  EXPECT_NEAR(r.stoch[1].N, clean.stoch[1].N, 1e-3 * clean.stoch[1].N) << "the white noise is the clean log's";
  const auto lines = verdict_lines(r);
  ASSERT_GE(lines.size(), 2u);
  EXPECT_NE(lines[1].find("departs from the model in " + std::to_string(injected) + " isolated samples"), std::string::npos) << lines[1];
  // Without the filter the glitches inflate the white noise the verdict reports.
  Options off = o;
  off.glitch_z = 0;
  VectorSource c_src(glitched);
  const DiagnosisResult raw = diagnose(c_src, basic_model(), off);
  EXPECT_GT(raw.stoch[1].N, 1.05 * clean.stoch[1].N);
}

// Dropouts (dropouts.h): runs of rows reading a failed read's word (0, −1 LSB) far from their neighbours are bridged
// on the line between them, on the search pass and on the replay alike, and nothing else is touched: a gyro at rest
// reading 0 honestly, a consumer accelerometer's noise reading 0 at 2.5 σ from its level, a sine through zero, a
// coarse output that sits at 0, an outage longer than kMaxRun rows.
TEST(DiagnosisDropouts, FailedReadsAreBridgedAndHealthyZerosLeftAlone) {
  std::mt19937_64 rng(65);
  std::normal_distribution<double> n01;
  const double a_lsb = 6e-4, g_lsb = 1.33e-4;
  const int n = 60000;
  auto q = [](double v, double lsb) { return lsb * std::round(v / lsb); };
  std::vector<Sample> log(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    Sample& s = log[static_cast<std::size_t>(i)];
    s.t_s = 0.01 * i;
    s.has_ref = true;
    s.segment = i / 6000;
    s.y[0] = q(9.81 + 0.004 * n01(rng), a_lsb);                                  // 1 g, quiet: failed reads of 0
    s.y[1] = q(-0.1 + 0.039 * n01(rng), a_lsb);                                  // 2.5 σ from 0
    s.y[2] = q(3.0 * std::sin(2.0 * M_PI * s.t_s / 7.0) + 0.004 * n01(rng), a_lsb);  // through 0
    s.y[3] = q(2e-4 + 8.7e-4 * n01(rng), g_lsb);                                 // at rest: reads 0 one row in seven
    s.y[4] = q(0.5 + 1e-4 * n01(rng), g_lsb);                                    // turning: failed reads of 0 and −1 LSB
    s.y[5] = q(1e-4 * n01(rng), 5.0 * g_lsb);                                    // coarse, at 0
  }
  struct Run {
    int axis, start, len;
    double v;
  };
  const std::vector<Run> runs = {{0, 1000, 1, 0.0}, {0, 5000, 3, 0.0}, {0, 20000, 12, 0.0}, {4, 30000, 5, -g_lsb}, {4, 40000, 1, 0.0}};
  std::vector<Sample> bad = log;
  for (const Run& r : runs)
    for (int k = 0; k < r.len; ++k) bad[static_cast<std::size_t>(r.start + k)].y[r.axis] = r.v;
  const int outage = 50000, outage_len = DropoutFilterSource::kMaxRun + 5;
  for (int k = 0; k < outage_len; ++k) bad[static_cast<std::size_t>(outage + k)].y[0] = 0.0;
  VectorSource clean_src(log), bad_src(bad);
  DropoutFilterSource clean(clean_src, {a_lsb, g_lsb}), f(bad_src, {a_lsb, g_lsb});
  for (int pass = 0; pass < 2; ++pass) {  // the search, then the replay
    clean.rewind();
    f.rewind();
    Sample a, b;
    int i = 0;
    while (f.next(b)) {
      ASSERT_TRUE(clean.next(a));
      const auto ui = static_cast<std::size_t>(i);
      for (int ax = 0; ax < kNumAxes; ++ax) {
        EXPECT_EQ(a.y[ax], log[ui].y[ax]) << "clean row " << i << " axis " << ax;
        double want = bad[ui].y[ax];
        for (const Run& r : runs)
          if (r.axis == ax && i >= r.start && i < r.start + r.len) {
            const double y0 = bad[static_cast<std::size_t>(r.start - 1)].y[ax], y1 = bad[static_cast<std::size_t>(r.start + r.len)].y[ax];
            want = y0 + (y1 - y0) * (i - r.start + 1) / (r.len + 1.0);
          }
        EXPECT_DOUBLE_EQ(b.y[ax], want) << "pass " << pass << " row " << i << " axis " << ax;
      }
      ++i;
    }
    EXPECT_EQ(i, n);
    EXPECT_FALSE(clean.next(a));
  }
  for (int ax = 0; ax < kNumAxes; ++ax) EXPECT_EQ(clean.summary()[static_cast<std::size_t>(ax)].runs, 0) << axis_name(ax);
  const auto& S = f.summary();
  EXPECT_EQ(S[0].runs, 3);
  EXPECT_EQ(S[0].rows, 16);
  EXPECT_EQ(S[0].longest, 12);
  EXPECT_EQ(S[0].value, 0.0);
  EXPECT_NEAR(S[0].first_t_s, 10.0, 1e-9);
  EXPECT_EQ(S[4].runs, 2);
  EXPECT_EQ(S[4].rows, 6);
  EXPECT_EQ(S[4].value, -g_lsb) << "the first run's value";
  EXPECT_EQ(S[4].other_runs, 1) << "the run that read 0 after one that read -1 LSB";
  EXPECT_EQ(S[4].other_value, 0.0);
  EXPECT_EQ(S[0].other_runs, 0);
  for (int ax : {1, 2, 3, 5}) EXPECT_EQ(S[static_cast<std::size_t>(ax)].runs, 0) << axis_name(ax);
  // Off: the log as it is.
  VectorSource off_src(bad);
  DropoutFilterSource off(off_src, {a_lsb, g_lsb}, false);
  Sample b;
  for (int i = 0; off.next(b); ++i) ASSERT_EQ(b.y[0], bad[static_cast<std::size_t>(i)].y[0]);
}

// The pipeline bridges an accelerometer's failed reads, names the axis on that basis and keeps the clean log's noise
// model; without the bridge the same rows inflate the noise (blindgen's `zero_burst`: "steps from segment to segment").
TEST(DiagnosisPipeline, DropoutsAreBridgedAndNameTheirAxis) {
  const std::vector<Sample> clean_log = white_tilt_log(66);
  std::vector<Sample> bad = clean_log;
  long long far_runs = 0, far_rows = 0;
  for (std::size_t i = 700, k = 0; i + 20 < bad.size(); i += 1733, ++k) {
    const std::size_t len = 2 + k % 9;
    const double fz = std::fabs(bad[i].f[2]);
    ASSERT_FALSE(fz > 0.008 && fz < 0.1) << "a run neither clearly far (50 σ) nor within the noise";
    if (fz >= 0.1) ++far_runs, far_rows += static_cast<long long>(len);
    for (std::size_t j = 0; j < len; ++j) bad[i + j].y[2] = 0.0;
  }
  ASSERT_GT(far_runs, 10);
  VectorSource a_src(clean_log), b_src(bad), c_src(bad);
  const Options o;
  const DiagnosisResult clean = diagnose(a_src, basic_model(), o);
  const DiagnosisResult r = diagnose(b_src, basic_model(), o);
  EXPECT_TRUE(clean.unexplained.empty());
  for (int a = 0; a < kNumAxes; ++a) EXPECT_EQ(clean.dropouts[static_cast<std::size_t>(a)].runs, 0) << axis_name(a);
  EXPECT_EQ(r.dropouts[2].runs, far_runs);
  EXPECT_EQ(r.dropouts[2].rows, far_rows);
  ASSERT_EQ(r.unexplained.size(), 1u);
  EXPECT_EQ(r.unexplained[0].axis, "accel.z");
  EXPECT_EQ(r.unexplained[0].basis, "dropouts");
  EXPECT_TRUE(r.selected.empty());
  EXPECT_NEAR(r.stoch[2].N, clean.stoch[2].N, 0.02 * clean.stoch[2].N) << "the white noise is the clean log's";
  const auto lines = verdict_lines(r);
  ASSERT_GE(lines.size(), 3u);
  EXPECT_NE(lines[2].find("reads exactly 0 m/s^2 in " + std::to_string(far_runs) + " runs"), std::string::npos) << lines[2];
  // Runs of both failed words are counted apart, the first run's word first (the filter's own counts are tested in
  // DiagnosisDropouts.FailedReadsAreBridgedAndHealthyZerosLeftAlone).
  DiagnosisResult two = r;
  two.dropouts[2].other_runs = 2;
  two.dropouts[2].other_value = -6e-4;
  const std::string both = verdict_lines(two)[2];
  EXPECT_NE(both.find("reads exactly 0 m/s^2 in " + std::to_string(far_runs - 2) + " runs and -0.0006 m/s^2 in 2, of up to "),
            std::string::npos)
      << both;
  EXPECT_NE(both.find("away from them:"), std::string::npos) << both;
  Options off = o;
  off.dropouts = false;
  const DiagnosisResult raw = diagnose(c_src, basic_model(), off);
  EXPECT_GT(raw.stoch[2].N, 1.05 * clean.stoch[2].N);
}

TEST(DiagnosisPipeline, PeriodicBiasBelowTheHeldOutThresholdIsStillNamed) {
  // On the blind `varied` ooc-periodic case the static soaks read a slow periodic gyro bias as rate random walk,
  // whose floor then kept the held-out chi2/dof at 2.0. The held-out threshold is lifted out of reach here, so
  // only the whole-log wander check can name the axis: it must for a sine (correlated innovations under any
  // raised wander), and must not for a bias that really is a random walk, nor for white noise.
  auto make_log = [](int kind) {
    std::mt19937_64 rng(23);
    std::normal_distribution<double> n01;
    double rw = 0.0;
    long i = 0;  // sample count: static_pose_log's time is 100 Hz without gaps
    return static_pose_log(two_axis_tilts(), 6, 8.0, [&](int, const Pose& f, double* y) {
      const double t_s = 0.01 * static_cast<double>(i++);
      rw += 1e-5 * std::sqrt(0.01) * n01(rng);  // K = 1e-5 rad/s/√s
      const double bias_y = kind == 1 ? 1e-4 * std::sin(2.0 * M_PI * t_s / 400.0) : kind == 2 ? rw : 0.0;
      for (int j = 0; j < 3; ++j) {
        y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
        y[3 + j] = (j == 1 ? bias_y : 0.0) + 5e-4 * n01(rng);
      }
    });
  };
  Options o;
  o.unexplained_chi2_dof = 1e9;
  for (int kind = 0; kind < 3; ++kind) {
    VectorSource src(make_log(kind));
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    const Unexplained* u = nullptr;
    for (const auto& x : r.unexplained)
      if (x.axis == "gyro.y") u = &x;
    if (kind == 1) {
      ASSERT_NE(u, nullptr) << "the periodic bias must be named";
      EXPECT_EQ(u->basis, "wander");
      EXPECT_EQ(r.wander[4].beyond_reason, "periodic");
      EXPECT_LT(r.wander[4].measured.line_p, o.wander_max_line_p);
      EXPECT_NEAR(r.wander[4].measured.line_period_s, 400.0, 40.0) << "the line is the sine's";
      EXPECT_EQ(r.unexplained.size(), 1u);
    } else {
      EXPECT_TRUE(r.unexplained.empty()) << (kind == 2 ? "a random walk is noise" : "white noise");
    }
  }
}

// An accelerometer whose suspension creeps: after each pose change its z output keeps moving towards the new
// input with τ 12 s (y = f + c·(lp_τ(f) − f), the `unseen4` suite's creep). Dwells of 8 s hold it, so the static
// dwells read it as flicker and a raise takes the rest; the held-out threshold is lifted out of reach, so only the
// whole-log checks can name it. It must be named on input_bias (Wander::follows), the memory of f_z leading the
// signature; with the same random walk and no creep the axis is noise.
TEST(DiagnosisPipeline, ACreepingOutputIsNamedOnTheInputItRemembers) {
  auto make_log = [](bool creep) {
    std::mt19937_64 rng(31);
    std::normal_distribution<double> n01;
    double rw = 0.0, lp = 0.0;
    bool first = true;
    const double a = 1.0 - std::exp(-0.01 / 12.0);
    return static_pose_log(two_axis_tilts(), 6, 8.0, [&](int, const Pose& f, double* y) {
      rw += 5e-6 * std::sqrt(0.01) * n01(rng);  // K = 5e-6 m/s²/√s
      lp = first ? f[2] : lp + a * (f[2] - lp);
      first = false;
      for (int j = 0; j < 3; ++j) {
        y[j] = f[static_cast<std::size_t>(j)] + (j == 2 ? rw + (creep ? 1e-4 * (lp - f[2]) : 0.0) : 0.0) + 2e-3 * n01(rng);
        y[3 + j] = 5e-4 * n01(rng);
      }
    });
  };
  Options o;
  o.unexplained_chi2_dof = 1e9;
  for (const bool creep : {false, true}) {
    VectorSource src(make_log(creep));
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    const Unexplained* u = nullptr;
    for (const auto& x : r.unexplained)
      if (x.axis == "accel.z") u = &x;
    if (!creep) {
      EXPECT_TRUE(r.unexplained.empty()) << "a random walk is noise";
      continue;
    }
    ASSERT_NE(u, nullptr) << "the creep must be named";
    EXPECT_EQ(u->basis, "wander");
    EXPECT_EQ(r.wander[2].beyond_reason, "follows");
    EXPECT_EQ(r.wander[2].follows_input.rfind("f_z low-passed", 0), 0u) << r.wander[2].follows_input;
    ASSERT_FALSE(u->signature.empty());
    EXPECT_EQ(u->signature.front().input.rfind("f_z low-passed", 0), 0u) << u->signature.front().input;
    EXPECT_TRUE(r.selected.empty());
  }
}

// A gyro bias that is a random walk, the whole log 6× longer than what its 8 s dwells show: the whole-log wander
// is adopted, and the axis is noise. The held-out χ²/dof on marginal segment variances is not a fair judge of that:
// the segments share one slow bias, so Σ r²/σ² has a few effective degrees of freedom and exceeds 3 per segment
// on 3 of these 12 seeds (1, 4, 6: 4.6, 5.3, 4.8), and each was named unexplained beside its adopted wander
// (blind suites: 6 of ~100 stochastic-only logs). The claim is now also judged on the GLS fit under the adopted
// wander (Gap::chi2_dof_wander). Control: the same walk plus a bias ∝ f_x³ (no catalog effect has it) is not
// adopted as wander and stays unexplained.
TEST(DiagnosisPipeline, ARandomWalkBiasIsNotCalledUnexplained) {
  auto make_log = [](unsigned seed, double cubic_rad_s) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    double rw = 0.0;
    return static_pose_log(two_axis_tilts(), 6, 8.0, [&](int, const Pose& f, double* y) {
      rw += 1e-5 * std::sqrt(0.01) * n01(rng);  // K = 1e-5 rad/s/√s
      const double fx = f[0] / 9.80665;
      for (int j = 0; j < 3; ++j) {
        y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
        y[3 + j] = (j == 1 ? rw + cubic_rad_s * fx * fx * fx : 0.0) + 5e-4 * n01(rng);
      }
    });
  };
  const Options o;
  int exercised = 0;
  for (unsigned seed : {1u, 4u, 6u}) {
    VectorSource src(make_log(seed, 0.0));
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    ASSERT_TRUE(r.wander[4].adopted) << seed;
    std::printf("seed %u: marginal %.3f, under the wander %.3f\n", seed, r.gap_after.chi2_dof[4], r.gap_after.chi2_dof_wander[4]);
    exercised += r.gap_after.chi2_dof[4] > o.unexplained_chi2_dof;
    EXPECT_LT(r.gap_after.chi2_dof_wander[4], 1.5) << seed << ": measured 0.78-0.92";
    EXPECT_TRUE(r.unexplained.empty()) << seed;
    EXPECT_TRUE(r.selected.empty()) << seed;
  }
  // The marginal held-out χ² must exceed 3 on some of them, else the GLS rule is not exercised. Since stop 38 the
  // walk is raised jointly with the dwells' flicker, which reads it larger: seed 6's marginal χ²/dof fell from 4.8
  // to 2.6 (seed 1 and 4 stay above 3).
  EXPECT_GE(exercised, 2) << "the marginal held-out chi2 above 3 on at least two seeds";
  VectorSource src(make_log(4u, 3e-4));
  const DiagnosisResult r = diagnose(src, basic_model(), o);
  EXPECT_FALSE(r.wander[4].adopted);
  ASSERT_EQ(r.unexplained.size(), 1u);
  EXPECT_EQ(r.unexplained[0].axis, "gyro.y");
  EXPECT_GT(r.unexplained[0].chi2_dof_after, 30.0) << "measured 292";
}

// Static tilts (6 passes of 8 s) whose gyro.y carries a random-walk bias of K rad/s/√s and a g-sensitivity
// g · f_x; white noise 2e-3 m/s² and 5e-4 rad/s per 100 Hz sample. The two tests below share it.
std::vector<Sample> walk_beside_g_sensitivity_log(unsigned seed, double g, double K) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  double rw = 0.0;
  return static_pose_log(two_axis_tilts(), 6, 8.0, [&](int, const Pose& f, double* y) {
    rw += K * std::sqrt(0.01) * n01(rng);
    for (int j = 0; j < 3; ++j) {
      y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
      y[3 + j] = (j == 1 ? rw + g * f[0] : 0.0) + 5e-4 * n01(rng);
    }
  });
}

// A random-walk gyro.y bias (K 3e-6 rad/s/√s, far more than the 8 s dwells show by the end of the log) beside a
// real gyro g-sensitivity, y += 2e-5 · f_x. The walk's level is given (Options::wander_K, what diagnose() adopts
// after a first pass), so the unexplained check is what is exercised. It used to judge gyro.y on the dwells' noise,
// where the walk keeps the axis above 3 with the effect in, and withdrew the effect for "leaving gyro.y
// unexplained". Measured before, on seeds 1, 4, 6: withdrawn and gyro.y unexplained (held-out χ²/dof 4.2, 6.4,
// 4.1). At g = 1e-5 it was withdrawn on six of twelve seeds while the verdict called gyro.y at noise, so the log's
// one effect was reported nowhere. Blind varied random-0 lost a true gyro.scale_asymmetry this way (LR 213 under
// the wander). Now the check judges an axis by the verdict's rule; gyro.y reads 2.3, 3.8, 2.2, and 0.54, 0.74,
// 0.40 under the wander.
TEST(DiagnosisPipeline, AnAxisAtNoiseUnderAGivenWanderKeepsItsEffect) {
  const double g = 2e-5, K = 3e-6;
  for (unsigned seed : {1u, 4u, 6u}) {
    VectorSource src(walk_beside_g_sensitivity_log(seed, g, K));
    Options o;
    o.wander_K[4] = K;
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    ASSERT_TRUE(r.wander[4].adopted) << seed;
    EXPECT_TRUE(r.unexplained.empty()) << seed;
    ASSERT_EQ(r.selected.size(), 1u) << seed;
    EXPECT_EQ(r.selected[0].sensor + "." + r.selected[0].effect, "gyro.g_sensitivity") << seed;
    EXPECT_LT(r.gap_after.chi2_dof_wander[4], 1.5) << seed;
  }
}

// The same log with the walk's level NOT given: diagnose() must find it on the whole log itself. The wander is
// adopted on the final model, and the unexplained check ran before, on the dwells' noise: without the effect the
// residual follows f_x (the effect's own column), so no wander was carried, gyro.y stayed above 3 with the effect
// in, and the effect was withdrawn for "leaving gyro.y unexplained" (`varied37` random-1). The check now asks the
// wander the final model would carry with the effect in (diagnose.cpp, `carried`). Measured before, on
// seeds 1, 4, 6: nothing selected, no wander carried, gyro.y named unexplained at held-out χ²/dof 15.2, 41.4, 11.1.
// Now: the effect kept, the walk adopted, gyro.y 1.03, 0.69, 0.88 in the GLS fit under it.
TEST(DiagnosisPipeline, AnEffectIsJudgedUnderTheWanderItWouldLeave) {
  const double g = 2e-5, K = 3e-6;
  for (unsigned seed : {1u, 4u, 6u}) {
    VectorSource src(walk_beside_g_sensitivity_log(seed, g, K));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    std::printf("seed %u: gyro.y held-out chi2/dof %.2f, under the wander %.2f, adopted %d, selected %zu, unexplained %zu\n", seed,
                r.gap_after.chi2_dof[4], r.gap_after.chi2_dof_wander[4], r.wander[4].adopted ? 1 : 0, r.selected.size(),
                r.unexplained.size());
    EXPECT_TRUE(r.wander[4].adopted) << seed;
    EXPECT_TRUE(r.unexplained.empty()) << seed;
    EXPECT_EQ(r.selected.size(), 1u) << seed;
    if (!r.selected.empty()) EXPECT_EQ(r.selected[0].sensor + "." + r.selected[0].effect, "gyro.g_sensitivity") << seed;
  }
}

// basic_model() plus the accelerometer's bias_temp orders 1 and 2.
BaseModel basic_model_with_accel_bias_temp() {
  BaseModel base = basic_model();
  for (auto id : imuforge::model::effect_params(imuforge::model::Sensor::kAccel, imuforge::model::Effect::kBiasTemp)) {
    const auto& c = imuforge::model::param_info(id).component;
    if (c.size() > 3 && (c.substr(c.size() - 2) == "t1" || c.substr(c.size() - 2) == "t2")) base.params.push_back(id);
  }
  base.effect_names.push_back("accel.bias_temp");
  return base;
}

// A log whose last segment is one long soak at temperatures no other segment reaches (varied13 null-consumer-3:
// 1200 s alone over 32-52 °C). Its fold is withheld whole, so the other folds' bias_temp is extrapolated to it,
// and Σ r²/v per segment counted that extrapolation's error as misfit: the axis was named unexplained on a log
// with nothing beyond the model. The predictive χ² (estimator::HeldOut::chi2_pred) judges the withheld means
// against their covariance with the fit's uncertainty in it. 72 tilts of 8 s over 10-30 °C, then 900 s at one
// pose over 30-50 °C; accel.x bias 1e-3 (T − 25) + 4e-5 (T − 25)², in the model (bias_temp t1, t2). Measured on
// seeds 1-6: Σ r²/v 6.6, 1.9, 0.91, 9.7, 22.9, 1.4 per segment (three named); predictive 0.83-1.26.
TEST(DiagnosisPipeline, ALongSoakWithheldWholeIsNotMisfit) {
  const BaseModel base = basic_model_with_accel_bias_temp();
  auto run = [&](unsigned seed, bool predictive) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    const std::vector<Pose> tilts = two_axis_tilts();
    auto log = static_pose_log(tilts, 3, 8.0, [&](int, const Pose&, double*) {});
    const std::size_t n_tilts = log.size();
    const int last_seg = log.back().segment + 1;
    for (int i = 0; i < 90000; ++i) {
      Sample s = referenced_sample(static_cast<double>(log.size()) / 100.0, last_seg);
      for (int j = 0; j < 3; ++j) s.f[j] = tilts[5][static_cast<std::size_t>(j)], s.w[j] = 0.0;
      log.push_back(s);
    }
    for (std::size_t k = 0; k < log.size(); ++k) {
      Sample& s = log[k];
      s.temp_C = k < n_tilts ? 10.0 + 20.0 * static_cast<double>(k) / static_cast<double>(n_tilts)
                             : 30.0 + 20.0 * static_cast<double>(k - n_tilts) / static_cast<double>(log.size() - n_tilts);
      const double dT = s.temp_C - 25.0;
      for (int j = 0; j < 3; ++j) {
        s.y[j] = s.f[j] + 2e-3 * n01(rng) + (j == 0 ? 1e-3 * dT + 4e-5 * dT * dT : 0.0);
        s.y[3 + j] = 5e-4 * n01(rng);
      }
    }
    VectorSource src(log);
    Options o;
    o.heldout_predictive = predictive;
    return diagnose(src, base, o);
  };
  int exercised = 0;
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    const DiagnosisResult before = run(seed, false), now = run(seed, true);
    std::printf("seed %u: accel.x held-out chi2/dof %.2f as sum r2/v, %.2f predictive\n", seed, before.gap_after.chi2_dof[0],
                now.gap_after.chi2_dof[0]);
    if (before.gap_after.chi2_dof[0] > Options{}.unexplained_chi2_dof) {
      ++exercised;
      EXPECT_FALSE(before.unexplained.empty()) << seed << ": the old reading named the axis";
    }
    EXPECT_LT(now.gap_after.chi2_dof[0], 1.6) << seed;
    EXPECT_TRUE(now.unexplained.empty()) << seed;
    EXPECT_TRUE(now.selected.empty()) << seed;
  }
  EXPECT_GE(exercised, 2) << "the extrapolation must exceed the threshold as Σ r²/v on some seeds, else nothing is tested";
}

// The selection judges on the dwells' noise. Where the whole log shows a larger bias wander (adopted), an effect
// it selected must stay significant under that wander, with the re-tested effects as the family (blind suites:
// a tactical accelerometer with a 300 s Gauss-Markov bias took accel.cross_coupling at p 3e-5 on the dwells'
// noise, p 0.014 under its wander). Static tilts, temperature soaks and ramps, accel.x offset c·Ṫ (temp_rate).
// The wander is given through Options::wander_K, the level diagnose() adopts after its first pass.
TEST(DiagnosisPipeline, AnEffectMustStaySignificantUnderTheAdoptedWander) {
  const BaseModel base = basic_model_with_accel_bias_temp();
  // (time fraction, °C): soaks and ramps of 20-40 °C over ~230 s
  const std::vector<std::pair<double, double>> knots = {{0, 25}, {0.1, 25}, {0.25, 5}, {0.4, 5}, {0.6, 45}, {0.75, 45}, {0.9, 15}, {1.0, 15}};
  auto run = [&](double c_temp_rate, double wander_K) {
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n01;
    auto log = static_pose_log(two_axis_tilts(), 8, 8.0, [&](int, const Pose& f, double* y) {
      for (int j = 0; j < 3; ++j) {
        y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
        y[3 + j] = 5e-4 * n01(rng);
      }
    });
    double T_prev = 0;
    for (std::size_t k = 0; k < log.size(); ++k) {
      const double x = static_cast<double>(k) / static_cast<double>(log.size());
      std::size_t i = 0;
      while (i + 2 < knots.size() && x > knots[i + 1].first) ++i;
      const double u = (x - knots[i].first) / (knots[i + 1].first - knots[i].first);
      log[k].temp_C = knots[i].second + u * (knots[i + 1].second - knots[i].second);
      const double Tdot_C_s = k ? (log[k].temp_C - T_prev) * 100.0 : 0.0;
      T_prev = log[k].temp_C;
      log[k].y[0] += c_temp_rate * Tdot_C_s;
    }
    VectorSource src(log);
    Options o;
    o.wander_K[0] = wander_K;  // NaN: none given
    return diagnose(src, base, o);
  };
  auto has = [](const DiagnosisResult& r, bool selected) {
    bool in = false;
    if (selected)
      for (const auto& st : r.selected) in = in || (st.sensor == "accel" && st.effect == "temp_rate");
    else
      for (const auto& w : r.withdrawn_by_check) in = in || w.first == "accel.temp_rate";
    return in;
  };
  const double none = std::numeric_limits<double>::quiet_NaN();
  {
    const auto r = run(1e-3, none);  // 0.09 mm/s² per °C/s of ramp: ~1.2 dwell σ, over many dwells
    EXPECT_TRUE(has(r, true)) << "the dwells' noise selects it (else the test is not exercised)";
  }
  {
    const auto r = run(1e-3, 1e-4);  // under a random walk of 1e-4 m/s²/√s it cannot be told from the wander
    ASSERT_TRUE(r.wander[0].adopted);
    EXPECT_FALSE(has(r, true));
    EXPECT_TRUE(has(r, false)) << "withdrawn, and said so (measured p 0.82)";
  }
  {
    const auto r = run(1e-2, 1e-4);  // ten times larger: stands above the wander (measured p 2e-10)
    EXPECT_TRUE(has(r, true));
    EXPECT_FALSE(has(r, false));
  }
}

// A first-step candidate far past the level in-sample whose held-out shrink is ≤ 0 is a contradiction; the
// ranking says how it resolved against the final model (diagnose.cpp scores it again there). The two readings:
// gone against the final model (its first-step gain was the signal of effects selected later: blind random-36
// gyro.g2_sensitivity, -log10 p 746 at step 1, held-out shrink -19 %, p 0.44 against the final model), or
// still there with nothing on withheld segments. The computation runs on every blind log (68 such candidates
// on 327 logs); this pins what a reader of diagnosis.json and the text report is told.
TEST(DiagnosisReport, InSampleGainWithoutHeldOutGainIsExplained) {
  DiagnosisResult r;
  r.alpha = 0.001;
  auto cand = [](const char* effect, double p, double shrink, double final_p, double final_shrink) {
    CandidateScore c;
    c.sensor = "gyro";
    c.effect = effect;
    c.p_value = p;
    c.score = -std::log10(p);
    c.heldout_shrink_pct = shrink;
    c.final_p = final_p;
    c.final_shrink_pct = final_shrink;
    return c;
  };
  r.ranking = {cand("g2_sensitivity", 1e-300, -19.0, 0.44, -2.0), cand("misalign_temp", 1e-20, -5.0, 1e-9, -3.0),
               cand("scale_asymmetry", 0.5, -1.0, -1.0, std::numeric_limits<double>::quiet_NaN())};
  const auto j = to_json(r);
  const auto& rk = j["ranking"];
  ASSERT_EQ(rk.size(), 3u);
  EXPECT_EQ(rk[0]["outcome"].get<std::string>().rfind("not selected: in-sample gain only, the signal of effects selected later", 0), 0u)
      << rk[0]["outcome"];
  EXPECT_DOUBLE_EQ(rk[0]["final_model_p"].get<double>(), 0.44);
  EXPECT_NE(rk[1]["outcome"].get<std::string>().find("none on withheld segments"), std::string::npos) << rk[1]["outcome"];
  EXPECT_EQ(rk[2]["outcome"], "not selected");
  EXPECT_FALSE(rk[2].contains("final_model_p"));
  EXPECT_NE(summary_text(r).find("the signal of effects selected later"), std::string::npos);
}

// A gyro bias instability whose correlation time (300 s) is far past the 8 s dwells: their Allan curve shows
// no flicker (point estimate 0), so the held-out verdict carried white noise only, while the likelihood carried
// the flicker's upper limit, and the whole-log search started from that limit found no raise: the segment means
// stood at held-out χ²/dof 1.7-2.2 on these seeds (3.2 on `varied` single-accel.cross_coupling, named
// unexplained). The search now starts from what the dwells show, and the whole log's wander is adopted.
TEST(DiagnosisPipeline, AWanderTheDwellsCannotSeeIsFoundOnTheWholeLog) {
  for (unsigned seed : {5u, 7u}) {
    const double sigma_rad_s = 2e-5, tau_s = 300.0;
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    double gm = sigma_rad_s * n01(rng);
    const double phi = std::exp(-0.01 / tau_s), q = sigma_rad_s * std::sqrt(1 - phi * phi);
    auto log = static_pose_log(two_axis_tilts(), 6, 8.0, [&](int, const Pose& f, double* y) {
      gm = phi * gm + q * n01(rng);
      for (int j = 0; j < 3; ++j) {
        y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
        y[3 + j] = (j == 0 ? gm : 0.0) + 5e-4 * n01(rng);
      }
    });
    VectorSource src(log);
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    ASSERT_EQ(r.stoch[3].flicker_B, 0.0) << seed << ": the dwells show no flicker (else the test is not exercised)";
    EXPECT_TRUE(r.wander[3].adopted) << seed;
    EXPECT_GT(r.wander[3].measured.ratio, 1.2) << seed;
    EXPECT_LT(r.gap_after.chi2_dof[3], 1.2) << seed << ": measured 0.63 and 0.57 (2.25 and 1.67 before)";
    EXPECT_TRUE(r.unexplained.empty()) << seed;
    EXPECT_TRUE(r.selected.empty()) << seed;
  }
}

TEST(DiagnosisPipeline, SaturatedSamplesAreLeftOutNotCalledUnexplained) {
  // A rate dwell beyond the gyro's range: the output sits at its limit while the reference goes past it (the
  // project's own simulator mirroring a blind schedule drove gyro.z to 2.32 rad/s on a 2.18 rad/s part, and
  // gyro.z read "unexplained" at held-out chi2/dof 1e4). Those samples say only that the input is beyond the
  // limit: they are left out, with a warning, and the axis is at its noise. Without a clamp nothing is left out.
  const double limit = 1.2;
  // mode 0: clamped; 1: plain; 2: a coarse quantiser (step 2.5e-3) on an output 2 % low in scale, whose top
  // level repeats at the highest dwell with the reference 2 % beyond it (blind stoch-consumer-3): not a clamp.
  // mode 3: clamped as 0, but the negative side only in one smooth overshoot to −1.23 in the middle of one
  // −1.1 dwell (9 samples past the limit; a composite rate crossing the range between two steps on the simulate
  // source's null-consumer-3, each sample 40σ off): too few to be a limit alone, the same limit as the
  // positive side's.
  // mode 4: as 3, but the overshoot is a smooth bump to −1.206 (0.5 % past the limit, 31 samples there; the
  // simulate source's null-consumer-6, a gyro 0.3 % low in scale): under the 1 % a limit needs on its own, the
  // same limit as the positive side's.
  auto make_log = [&](int mode) {
    std::mt19937_64 rng(29);
    std::normal_distribution<double> n01;
    const std::vector<Pose> poses = two_axis_tilts();
    const double rates[] = {0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5};
    std::vector<Sample> log;
    int seg = 0;
    for (int pass = 0; pass < 3; ++pass)
      for (std::size_t k = 0; k < poses.size(); ++k, ++seg) {
        const double wz = rates[k % 7];
        for (int i = 0; i < 600; ++i) {
          Sample smp = referenced_sample(static_cast<double>(log.size()) / 100.0, seg);
          for (int j = 0; j < 3; ++j) smp.f[j] = poses[k][static_cast<std::size_t>(j)], smp.w[j] = 0.0;
          smp.w[2] = wz;
          if (mode == 3 && wz == -1.5)
            smp.w[2] = -1.1 - (pass == 1 && k == 6 ? 0.13 * std::max(0.0, 1.0 - std::fabs(i - 300.0) / 20.0) : 0.0);
          if (mode == 4 && wz == -1.5)
            smp.w[2] = -1.1 - (pass == 1 && k == 6 && std::fabs(i - 300.0) < 100.0 ? 0.053 * (1.0 + std::cos(M_PI * (i - 300.0) / 100.0)) : 0.0);
          for (int j = 0; j < 3; ++j) {
            smp.y[j] = smp.f[j] + 2e-3 * n01(rng);
            smp.y[3 + j] = smp.w[j] + 5e-4 * n01(rng);
          }
          if (mode == 0 || mode >= 3) smp.y[5] = std::clamp(smp.y[5], -limit, limit);
          if (mode == 2) smp.y[5] = 2.5e-3 * std::round((0.98 * smp.w[2] + 5e-4 * n01(rng)) / 2.5e-3);
          log.push_back(smp);
        }
      }
    return log;
  };
  auto saturation_warning = [](const DiagnosisResult& r) {
    for (const auto& w : r.warnings)
      if (w.find("saturated, left out") != std::string::npos) return w;
    return std::string();
  };
  for (int mode : {0, 3, 4}) {
    VectorSource src(make_log(mode));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    const std::string w = saturation_warning(r);
    EXPECT_NE(w.find("gyro.z"), std::string::npos) << w;
    if (mode >= 3) EXPECT_NE(w.find("(1.2, -1.2)"), std::string::npos) << "both sides of the one limit: " << w;
    EXPECT_TRUE(r.unexplained.empty()) << mode;
    EXPECT_TRUE(r.selected.empty()) << mode;
    EXPECT_LT(r.gap_after.chi2_dof[5], 3.0) << mode;
  }
  for (int mode = 1; mode <= 2; ++mode) {
    VectorSource src(make_log(mode));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    EXPECT_TRUE(saturation_warning(r).empty()) << mode;
    if (mode == 1) EXPECT_TRUE(r.unexplained.empty());
  }
}

TEST(DiagnosisPipeline, CoarseOutputStepIsNoiseNotAnEffect) {
  // An accelerometer axis rounded to a step 7x its noise: each pose's mean is off by where f_x falls between two
  // steps (up to ~0.3 step, tens of its white σ). No catalog effect has that form and it is not wander either:
  // it is the output's resolution, and the diagnosis must say so instead of "unexplained" or an effect.
  const double fs = 100.0, dwell_s = 8.0, step = 0.02, sigma = 0.15 * step;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  const std::vector<Sample> log = static_pose_log(two_axis_tilts(), 2, dwell_s, [&](int, const Pose& f, double* y) {
    y[0] = step * std::round((f[0] + sigma * n01(rng)) / step);
    y[1] = f[1] + 2e-3 * n01(rng);
    y[2] = f[2] + 2e-3 * n01(rng);
    for (int j = 0; j < 3; ++j) y[3 + j] = 5e-4 * n01(rng);
  });
  std::map<int, std::pair<double, int>> seg_err;  // per pose visit: Σ (output − f_x), samples: the rounding bias
  for (const auto& smp : log) {
    seg_err[smp.segment].first += smp.y[0] - smp.f[0];
    ++seg_err[smp.segment].second;
  }
  std::vector<double> pose_err;
  for (const auto& [seg, e] : seg_err) pose_err.push_back(e.first / e.second);
  double rms = 0;
  for (double e : pose_err) rms += e * e / static_cast<double>(pose_err.size());
  ASSERT_GT(std::sqrt(rms), 10.0 * sigma / std::sqrt(dwell_s * fs)) << "the log must carry the rounding bias";
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  EXPECT_NEAR(r.quant[0].step, step, 1e-6);
  EXPECT_NEAR(r.quant[0].noise_sigma, sigma, 0.25 * sigma);
  EXPECT_EQ(r.quant[1].step, 0.0) << "a continuous axis has no step";
  for (const auto& st : r.selected) ADD_FAILURE() << "selected " << st.sensor << "." << st.effect;
  for (const auto& u : r.unexplained) ADD_FAILURE() << "unexplained " << u.axis;
  bool said = false;
  for (const auto& line : verdict_lines(r)) said = said || (line.rfind("accel.x", 0) == 0 && line.find("output step") != std::string::npos);
  EXPECT_TRUE(said) << "the verdict names the output step";
}

TEST(DiagnosisPipeline, CoarseOutputStepKeepsAnEffectFarBeyondItsStaircase) {
  // The output-step check withdraws an effect whose change of the fit on a coarsely rounded axis is within twice
  // the rounding staircase's σ (~2e-4 at 0.4 step of noise). A real k2 on that axis (6e-4 per m/s², within the
  // plausible range) changes the fit by tens of staircase σ across the tilts: it must stay selected, nothing else.
  // (At 0.15 step of noise, σ 3.5e-3, a k2 of 4e-4 changes the fit by 1.3 σ and is withdrawn, though 24 distinct
  // tilts would make it significant against a staircase drawn once per input: the check does not count distinct
  // inputs; docs/diagnosis.md, Limits.)
  const double step = 0.02, sigma = 0.4 * step, k2 = 6e-4;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  const std::vector<Sample> log = static_pose_log(two_axis_tilts(), 2, 8.0, [&](int, const Pose& f, double* y) {
    y[0] = step * std::round((f[0] + k2 * f[0] * f[0] + sigma * n01(rng)) / step);
    y[1] = f[1] + 2e-3 * n01(rng);
    y[2] = f[2] + 2e-3 * n01(rng);
    for (int j = 0; j < 3; ++j) y[3 + j] = 5e-4 * n01(rng);
  });
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  ASSERT_TRUE(r.quant[0].coarse()) << "the axis must be one the output-step check acts on";
  bool nonlin = false;
  for (const auto& st : r.selected) {
    if (st.sensor == "accel" && st.effect == "scale_nonlinearity") nonlin = true;
    else ADD_FAILURE() << "selected " << st.sensor << "." << st.effect;
  }
  EXPECT_TRUE(nonlin) << "the real k2 of accel.x";
  for (const auto& w : r.withdrawn_by_check) ADD_FAILURE() << "withdrawn " << w.first << ": " << w.second;
  for (const auto& u : r.unexplained) ADD_FAILURE() << "unexplained " << u.axis;
  if (::testing::Test::HasFailure()) {
    for (const auto& w : r.warnings) std::printf("warning: %s\n", w.c_str());
    std::printf("%s\n", summary_text(r).c_str());
  }
}

TEST(DiagnosisPipeline, FindsInjectedGSensitivityAndReportsUnexcitable) {
  using namespace diagtest;
  // Short rich campaign at one plateau: temperature effects cannot be excited.
  json camp = rich_campaign({25.0}, 10.0);
  json extra = {{"gyro.g_sensitivity", {{"xz", 2e-4}}}};
  auto data = simulate(camp, base_sensor(false, extra), 3);
  VectorSource src(data);
  Options o;
  DiagnosisResult r = diagnose(src, basic_model(), o);
  ASSERT_FALSE(r.ranking.empty());
  EXPECT_EQ(r.ranking[0].effect, "g_sensitivity");
  EXPECT_EQ(r.ranking[0].sensor, "gyro");
  ASSERT_FALSE(r.selected.empty());
  EXPECT_EQ(r.selected[0].effect, "g_sensitivity");
  bool temp_unexcitable = false;
  for (const auto& c : r.ranking)
    if (c.effect == "bias_temp" && !c.excitable) temp_unexcitable = true;
  EXPECT_TRUE(temp_unexcitable) << "a single plateau cannot excite bias_temp";
  EXPECT_GT(r.gap_before.gap[3], 0.0);
  EXPECT_LT(std::max(0.0, r.gap_after.gap[3]), 0.2 * r.gap_before.gap[3]);
  // Outputs: required keys, self-contained HTML.
  auto j = to_json(r);
  for (const char* k : {"gap_before", "ranking", "selected", "gap_after"}) EXPECT_TRUE(j.contains(k)) << k;
  for (const char* k : {"effect", "sensor", "score", "p_value", "delta_bic", "heldout_shrink_pct", "magnitude"})
    EXPECT_TRUE(j["ranking"][0].contains(k)) << k;
  const std::string html = report_html(r);
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("src="), std::string::npos);
  EXPECT_EQ(html.find("href="), std::string::npos);
  // Every warning is in sight under the verdict, not only inside the collapsed text.
  r.warnings.push_back("a caveat <with> markup");
  const std::string html2 = report_html(r);
  const auto caveats = html2.find("Caveats (" + std::to_string(r.warnings.size()) + ")");
  ASSERT_NE(caveats, std::string::npos);
  EXPECT_LT(caveats, html2.find("Full text summary"));
  EXPECT_NE(html2.find("<li>a caveat &lt;with&gt; markup</li>"), std::string::npos);
  r.warnings.pop_back();
  EXPECT_NE(summary_text(r).find("g_sensitivity"), std::string::npos);
  // Every excitable candidate says what this log could have seen: 5σ per component, positive.
  ASSERT_TRUE(j["ranking"][0].contains("min_detectable_5sigma"));
  ASSERT_EQ(j["ranking"][0]["min_detectable_5sigma"].size(), j["ranking"][0]["magnitude"].size());
  for (const auto& m : j["ranking"][0]["min_detectable_5sigma"]) EXPECT_GT(m["value"].get<double>(), 0.0) << m.dump();
  // The text's magnitudes of a selected effect are the final joint fit's (item 3), not the ranking's.
  const std::string txt = summary_text(r);
  EXPECT_NE(txt.find("magnitude of gyro.g_sensitivity (final joint fit)"), std::string::npos);
  for (const auto& p : r.final_params)
    if (p.name == "gyro.g_sensitivity.xz") {
      char want[128];
      std::snprintf(want, sizeof want, "%s [%s] = %.4g +/- %.2g", p.name.c_str(), p.axis.c_str(), p.value, p.sigma);
      EXPECT_NE(txt.find(want), std::string::npos) << want << "\n" << txt;
    }
}

// A temperature polynomial enters as `"gyro.misalign_temp": {}` would in a model file: its six slopes (order 1),
// not the 18 columns of all three powers, so what is selected and reported is what its user then adds. The
// cubic's fold fits extrapolate: it lost real slopes their held-out gain and spoiled later candidates' (stop 42).
TEST(DiagnosisPipeline, ATemperaturePolynomialEntersAtTheModelFilesDefaultOrder) {
  using namespace diagtest;
  const double xy = 3e-5, zx = -2e-5;  // rad/°C
  auto data = simulate(rich_campaign({10.0, 25.0, 40.0}, 10.0), base_sensor(true, {{"gyro.misalign_temp", {{"xy.t1", xy}, {"zx.t1", zx}}}}), 11);
  VectorSource src(data);
  Options o;
  const DiagnosisResult r = diagnose(src, thermal_base(), o);
  bool selected = false;
  for (const auto& st : r.selected) selected |= st.sensor == "gyro" && st.effect == "misalign_temp";
  ASSERT_TRUE(selected) << summary_text(r);
  int slopes = 0;
  for (const auto& p : r.final_params) {
    if (p.name.rfind("gyro.misalign_temp.", 0) != 0) continue;
    EXPECT_EQ(p.name.substr(p.name.size() - 3), ".t1") << p.name;
    ++slopes;
    const double truth = p.name == "gyro.misalign_temp.xy.t1" ? xy : p.name == "gyro.misalign_temp.zx.t1" ? zx : 0.0;
    EXPECT_LT(std::fabs(p.value - truth), 3.0 * p.sigma) << p.name << " = " << p.value << " +/- " << p.sigma << ", truth " << truth;
  }
  EXPECT_EQ(slopes, 6) << summary_text(r);
  for (const auto& c : r.ranking)
    if (c.sensor == "gyro" && c.effect == "misalign_temp") EXPECT_LE(c.dof, 6);
}

TEST(DiagnosisPipeline, RejectsBadInput) {
  VectorSource empty({});
  EXPECT_THROW(diagnose(empty, basic_model(), Options{}), DiagnosisError);
  std::vector<Sample> back(3);
  back[0].t_s = 1;
  back[1].t_s = 2;
  back[2].t_s = 1.5;
  VectorSource b(back);
  EXPECT_THROW(diagnose(b, basic_model(), Options{}), DiagnosisError);
  std::vector<Sample> noref(100);
  for (int i = 0; i < 100; ++i) noref[static_cast<std::size_t>(i)].t_s = i * 0.01;
  VectorSource nr(noref);
  EXPECT_THROW(diagnose(nr, basic_model(), Options{}), DiagnosisError);
}

// Every output axis is compared with its own reference axis (y − u, u = f for accel.x…z, ω for gyro.x…z).
// Hand-made log: faces for the accelerometer, rotations about x, y and z at different rates for the gyro,
// a known bias and scale, white noise. The basic model must recover exactly those, and no cross terms.
// It catches a GCC 12 -fsanitize=undefined miscompilation of `(a < 3 ? f : w)[a % 3]` (see nominal_input in
// host/diagnosis/diagnose.cpp): the sanitizer build subtracted ω_z from every gyro axis, which the model
// absorbs as scale 1 and misalignment −1 on gyro.x and gyro.y.
TEST(DiagnosisPipeline, NominalInputPerAxis) {
  const double bias[6] = {0.01, -0.02, 0.03, 1e-3, -2e-3, 3e-3};
  const double scale[6] = {2e-3, -1e-3, 1.5e-3, 1e-3, -2e-3, 1.5e-3};
  const double sigma[6] = {1e-3, 1e-3, 1e-3, 1e-4, 1e-4, 1e-4};
  const double g = 9.80665;
  const double faces[6][3] = {{g, 0, 0}, {-g, 0, 0}, {0, g, 0}, {0, -g, 0}, {0, 0, g}, {0, 0, -g}};
  const double rates[4][3] = {{5e-5, -3e-5, 4e-5}, {0.7, 0, 0}, {0, -1.1, 0}, {0, 0, 1.6}};
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  const double fs = 10.0;
  int i = 0;
  for (int seg = 0; seg < 24; ++seg) {
    const double* f = faces[seg % 6];
    const double* w = rates[(seg / 6) % 4];
    for (int k = 0; k < 100; ++k, ++i) {
      Sample s = referenced_sample(i / fs, seg);
      for (int j = 0; j < 3; ++j) {
        s.f[j] = f[j];
        s.w[j] = w[j];
      }
      for (int a = 0; a < 6; ++a) {
        const double u = a < 3 ? f[a] : w[a - 3];
        s.y[a] = (1.0 + scale[a]) * u + bias[a] + sigma[a] * n01(rng);
      }
      log.push_back(s);
    }
  }
  VectorSource src(log);
  Options o;
  o.max_steps = 0;
  DiagnosisResult r = diagnose(src, basic_model(), o);
  int checked = 0;
  for (const auto& p : r.final_params) {
    const int a = (p.name.rfind("accel.", 0) == 0 ? 0 : 3) + (p.axis.back() - 'x');
    double truth = 0.0;
    if (p.name.find(".bias.") != std::string::npos) truth = bias[a];
    else if (p.name.find(".scale.") != std::string::npos) truth = scale[a];
    // Misalignments are zero; 6σ plus a floor well below the 1.0 a wrong reference axis produces.
    EXPECT_NEAR(p.value, truth, 6.0 * p.sigma + 1e-6) << p.name << " on " << p.axis;
    ++checked;
  }
  EXPECT_EQ(checked, 24) << "bias, scale and misalignment of both triads";
  // The held-out residual of the basic model is white noise: no axis keeps a gap of a wrong reference.
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_before.rms[static_cast<std::size_t>(a)], 10.0 * sigma[a]) << axis_name(a);
}

// A dwell cut into parts by reference gaps (a hand-held pose of several still parts in reference-free mode, a
// dropout) is one withholdable group: its parts share one reference, so fitting one part and "withholding"
// another is no withholding. Two faces cut into three parts each are two segments, too few to withhold.
TEST(DiagnosisPipeline, PartsOfOneSegmentAreOneWithholdableGroup) {
  const double g = 9.80665;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  auto make = [&](int faces_n) {
    std::vector<Sample> log;
    int i = 0;
    for (int seg = 0; seg < faces_n; ++seg)
      for (int part = 0; part < 3; ++part)
        for (int k = 0; k < 140; ++k, ++i) {
          Sample s;
          s.t_s = i / 10.0;
          s.temp_C = 25.0;
          s.has_ref = k < 100;  // 4 s without reference between the parts
          s.segment = s.has_ref ? seg : -1;
          const int ax = seg % 3;
          s.f[ax] = (seg / 3) % 2 ? -g : g;
          for (int a = 0; a < 6; ++a) s.y[a] = (a < 3 ? s.f[a] : 0.0) + (a < 3 ? 1e-3 : 1e-4) * n01(rng);
          log.push_back(s);
        }
    return log;
  };
  {
    VectorSource src(make(2));
    DiagnosisResult r = diagnose(src, basic_model(), Options{});
    EXPECT_EQ(r.n_units, 2) << "three parts of each of two faces";
    EXPECT_TRUE(r.selected.empty());
    EXPECT_TRUE(std::isnan(r.gap_before.chi2_dof[0])) << "nothing can be withheld";
    bool said = false;
    for (const auto& w : r.warnings) said = said || w.find("nothing can be withheld") != std::string::npos;
    EXPECT_TRUE(said);
  }
  {
    VectorSource src(make(6));
    DiagnosisResult r = diagnose(src, basic_model(), Options{});
    EXPECT_EQ(r.n_units, 6) << "three parts of each of six faces";
    EXPECT_TRUE(std::isfinite(r.gap_before.chi2_dof[0]));
  }
}

// An output filter (a MEMS part's digital low-pass) colours the noise over a few samples; the Allan curve's short
// end bends flat. That is not a bias instability nor a rate random walk: against white noise alone both
// "improve" the fit by orders of magnitude (a hand-held MPU-6050 read B = 4e-3 rad/s). Hand-made static log:
// six faces of 200 s at 100 Hz, every axis white noise through a first-order low-pass (pole 0.6, ≈ 2 samples);
// on gyro.z a slow Gauss-Markov drift (τ = 40 s) is added, which must still be found.
TEST(DiagnosisPipeline, OutputFilterIsNotABiasInstability) {
  const double g = 9.80665, fs = 100.0, pole = 0.6;
  std::mt19937_64 rng(23);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  double e[6] = {0, 0, 0, 0, 0, 0}, drift = 0.0;
  const double sig[6] = {2e-2, 2e-2, 2e-2, 2e-3, 2e-3, 2e-3};
  const double drift_tau_s = 40.0, drift_sigma = 3e-4, phi = std::exp(-1.0 / (fs * drift_tau_s));
  int i = 0;
  for (int seg = 0; seg < 6; ++seg)
    for (int k = 0; k < 20000; ++k, ++i) {
      Sample s = referenced_sample(i / fs, seg);
      s.f[seg % 3] = (seg / 3) ? -g : g;
      drift = phi * drift + drift_sigma * std::sqrt(1.0 - phi * phi) * n01(rng);
      for (int a = 0; a < 6; ++a) {
        e[a] = pole * e[a] + (1.0 - pole) * sig[a] * n01(rng);
        s.y[a] = (a < 3 ? s.f[a] : 0.0) + e[a] + (a == 5 ? drift : 0.0);
      }
      log.push_back(s);
    }
  VectorSource src(log);
  Options o;
  o.max_steps = 0;
  DiagnosisResult r = diagnose(src, basic_model(), o);
  for (const auto& st : r.stochastic) {
    if (std::getenv("TRACE_STOCH"))
      std::printf("%s %s %.3g p=%.3g filt=%d sig=%d\n", st.axis.c_str(), st.effect.c_str(), st.value, st.p_value, st.against_filter, st.significant);
    if (st.effect != "bias_instability" && st.effect != "rate_random_walk") continue;
    if (st.axis == "gyro.z" && st.effect == "bias_instability") {
      EXPECT_TRUE(st.significant) << "the 40 s drift on gyro.z is a bias instability (p " << st.p_value << ")";
    } else if (st.axis != "gyro.z") {
      EXPECT_FALSE(st.significant) << st.axis << " " << st.effect << " = " << st.value << " (p " << st.p_value
                                   << "): the output filter read as drift";
    }
  }
}

// Magnitudes that hinge on what the campaign cannot separate are flagged. Rate dwells at two magnitudes
// (±100, ±300 °/s, as campaign-eol) barely tell scale asymmetry a·min(ω, 0) from k2·ω²; with both in the
// sensor, when only the asymmetry is selected, its magnitude absorbs k2 and its σ does not cover the truth.
// The diagnosis must then name that dependence (magnitude_sensitivity, a warning), not report the σ bare.
TEST(DiagnosisPipeline, MagnitudeThatHingesOnAnUnseparatedEffectIsFlagged) {
  using namespace diagtest;
  json steps = json::array();
  const double faces[6][2] = {{0, 0}, {0, 180}, {0, 90}, {180, 90}, {90, 90}, {270, 90}};
  for (auto& f : faces) steps.push_back(pos(f[0], f[1], 0, 3));
  const double rate_pos[3][2] = {{0, 0}, {90, 90}, {0, 90}};
  for (auto& rp : rate_pos) {
    steps.push_back(pos(rp[0], rp[1], 0, 1));
    for (double r : {100.0, -100.0, 300.0, -300.0}) steps.push_back(rate(r, 4));
    steps.push_back(rate(0.0, 1));
  }
  json camp = rich_campaign({25.0}, 50.0);
  camp["phases"][0]["steps"] = steps;
  const json extra = {{"gyro.scale_asymmetry", {{"x", 4e-4}, {"y", -3e-4}, {"z", 5e-4}}},
                      {"gyro.scale_nonlinearity", {{"x.k2", 1.2e-4}, {"y.k2", -1.2e-4}}}};
  auto data = simulate(camp, base_sensor(false, extra), 5);
  VectorSource src(data);
  DiagnosisResult r = diagnose(src, basic_model(), Options{});
  std::set<std::string> sel;
  for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
  ASSERT_TRUE(sel.count("gyro.scale_asymmetry") || sel.count("gyro.scale_nonlinearity")) << "the signature is strong";
  if (sel.count("gyro.scale_asymmetry") && sel.count("gyro.scale_nonlinearity")) {
    GTEST_SKIP() << "both selected on this seed: nothing hinges on an unselected effect";
  }
  // Whichever was selected, a selected component that is off the truth by more than 3σ must be flagged with
  // the other one as the alternative.
  const std::map<std::string, double> truth = {
      {"gyro.scale_asymmetry.x", 4e-4}, {"gyro.scale_asymmetry.y", -3e-4}, {"gyro.scale_asymmetry.z", 5e-4},
      {"gyro.scale_nonlinearity.x.k2", 1.2e-4}, {"gyro.scale_nonlinearity.y.k2", -1.2e-4}};
  const bool asym = sel.count("gyro.scale_asymmetry") > 0;
  const std::string mine = asym ? "gyro.scale_asymmetry." : "gyro.scale_nonlinearity.";
  const std::string other = asym ? "gyro.scale_nonlinearity" : "gyro.scale_asymmetry";
  int off = 0, flagged = 0;
  for (const auto& p : r.final_params) {
    if (p.name.rfind(mine, 0) != 0) continue;
    const auto it = truth.find(p.name);
    const double t = it == truth.end() ? 0.0 : it->second;
    if (std::fabs(p.value - t) <= 3.0 * p.sigma) continue;
    ++off;
    bool f = false;
    for (const auto& v : r.sensitivity) f = f || (v.name == p.name && v.alternative == other);
    flagged += f ? 1 : 0;
    EXPECT_TRUE(f) << p.name << " = " << p.value << " +/- " << p.sigma << " (truth " << t << ") is not flagged";
  }
  std::printf("selected:");
  for (const auto& x : sel) std::printf(" %s", x.c_str());
  std::printf("; its components off the truth by > 3 sigma: %d, flagged: %d\n", off, flagged);
  EXPECT_GT(off, 0) << "this campaign is meant to bias the one selected (else the test checks nothing)";
  // Reported whole per (effect, alternative): at least one component of it moved by > 3σ.
  std::map<std::string, double> max_shift;
  for (const auto& v : r.sensitivity) {
    const std::string eff = v.name.substr(0, v.name.find('.', v.name.find('.') + 1)) + " / " + v.alternative;
    max_shift[eff] = std::max(max_shift[eff], v.shift_sigma);
    EXPECT_LT(v.p_alternative, 0.5);
  }
  for (const auto& [k, m] : max_shift) EXPECT_GT(m, 3.0) << k;
}

// An ambiguous pair is judged on the components the data need. A true accelerometer u² on x alone, seen on the
// six faces and two 45° tilts, where |u| (scale_asymmetry) and u² (scale_nonlinearity) differ only at the tilts:
// both are significant alone, neither beside the other. Counted whole, the nonlinearity paid 2 for each of its
// five columns that fit nothing (the u³ terms, the u² of y and z) against the asymmetry's two, and the
// asymmetry, which fits the signature worse, was chosen on 7 of these 8 seeds (stop 49). The control: a true
// asymmetry of the same even part on the same poses stays an asymmetry.
TEST(DiagnosisPipeline, AnAmbiguousPairIsJudgedOnTheComponentsTheDataNeed) {
  const double g = 9.80665, c45 = g * std::sqrt(0.5);
  const std::vector<Pose> poses = {{g, 0, 0}, {-g, 0, 0}, {0, g, 0}, {0, -g, 0}, {0, 0, g}, {0, 0, -g}, {c45, 0, c45}, {-c45, 0, c45}};
  const int seeds = 8;
  for (const bool true_nonlinear : {true, false}) {
    const std::string truth = true_nonlinear ? "accel.scale_nonlinearity" : "accel.scale_asymmetry";
    const std::string other = true_nonlinear ? "accel.scale_asymmetry" : "accel.scale_nonlinearity";
    int right = 0, wrong = 0, ambiguous = 0;
    for (int seed = 1; seed <= seeds; ++seed) {
      std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
      std::normal_distribution<double> n01;
      auto log = static_pose_log(poses, 4, 5.0, [&](int, const Pose& f, double* y) {
        for (int j = 0; j < 3; ++j) y[j] = f[static_cast<std::size_t>(j)] + 0.01 * n01(rng), y[3 + j] = 1e-3 * n01(rng);
        // 2.9e-3 m/s² at 1 g either way: k2 = 3e-5 1/(m/s²), or the asymmetry's even part a|u|/2 with a = 6e-4
        y[0] += true_nonlinear ? 3e-5 * f[0] * f[0] : 6e-4 * std::min(f[0], 0.0);
      });
      VectorSource src(log);
      const DiagnosisResult r = diagnose(src, basic_model(), Options{});
      std::set<std::string> sel;
      for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
      right += sel.count(truth) && !sel.count(other);
      wrong += sel.count(other) > 0;
      std::printf("%s, seed %d: selected %s%s;", truth.c_str(), seed, sel.count(truth) ? "it" : "",
                  sel.count(other) ? " the other" : "");
      for (const auto& am : r.ambiguous) {
        ambiguous += am.chosen == truth || am.chosen == other;
        std::printf(" ambiguous %s over %s (LR %.1f on %d, %.1f on %d, dAIC %.1f)", am.chosen.c_str(), am.alternative.c_str(),
                    am.lr_chosen, am.dof_chosen, am.lr_alternative, am.dof_alternative, am.delta_aic);
      }
      std::printf("\n");
      EXPECT_LE(r.ambiguous.size(), 1u) << "one entry per pair";
      // The ranking table says it on both rows.
      const auto j = to_json(r);  // named: a range-for over to_json(r)["ranking"] would outlive the temporary
      for (const auto& am : r.ambiguous)
        for (const auto& c : j["ranking"]) {
          const std::string key = c["sensor"].get<std::string>() + "." + c["effect"].get<std::string>();
          const std::string oc = c.value("outcome", std::string());  // only excitable candidates have one
          if (key == am.chosen) EXPECT_EQ(oc.rfind("selected, ambiguous with " + am.alternative, 0), 0u) << oc;
          if (key == am.alternative) EXPECT_EQ(oc.rfind("not selected: ambiguous with " + am.chosen, 0), 0u) << oc;
        }
    }
    if (true_nonlinear) EXPECT_GE(ambiguous, seeds / 2) << "the campaign is meant to leave the pair ambiguous (else the tie-break is not tested)";
    EXPECT_GE(right, seeds - 1) << truth;
    EXPECT_EQ(wrong, 0) << truth;
  }
}

// The reference of segment k at tau seconds into it, for the clock tests: a face of the cube every 4 segments,
// and segment kinds cycling static, rate about the vertical, (a sine about the vertical | the opposite constant
// rate), tumble about a horizontal axis (gravity turns in the body).
void cycling_reference(int k, double tau, bool with_sine, double* f, double* w) {
  const double g = 9.80665;
  const double faces[6][3] = {{0, 0, -g}, {0, 0, g}, {0, -g, 0}, {0, g, 0}, {-g, 0, 0}, {g, 0, 0}};
  const int face = (k / 4) % 6, vert = face / 2;  // the axis gravity lies along
  const double sgn = (k / 24) % 2 ? -1.0 : 1.0, r = 0.5 + 0.5 * ((k / 4) % 3);
  for (int j = 0; j < 3; ++j) f[j] = faces[face][j], w[j] = 0.0;
  switch (k % 4) {
    case 1: w[vert] = sgn * r; break;
    case 2: w[vert] = with_sine ? 1.2 * std::cos(2.0 * M_PI * 0.5 * tau) : -0.7 * sgn * r; break;
    case 3: {
      const int ax = (vert + 1) % 3, m = (vert + 2) % 3;  // rotate about ax: gravity moves from vert to m
      const double th = sgn * r * tau;
      w[ax] = sgn * r;
      const double fv = faces[face][vert];
      f[vert] = fv * std::cos(th);
      f[m] = fv * std::sin(th);
      break;
    }
    default: break;
  }
}

// Reference (f, ω) at time t of n_seg segments of seg_s: segment k = floor(t / seg_s) (clamped), the cycle of
// cycling_reference with sines.
auto cycling_with_sines(double seg_s, int n_seg) {
  return [seg_s, n_seg](double t, double* f, double* w) {
    const int k = std::clamp(static_cast<int>(std::floor(t / seg_s)), 0, n_seg - 1);
    cycling_reference(k, t - k * seg_s, true, f, w);
  };
}

// A log of n_seg segments of seg_s at 100 Hz whose outputs read ref (t, f, ω) at t − δ_s(t), exactly, with
// δ_s = lat_s + ppm_s·1e-6·t per sensor {accel, gyro}, plus white noise sigma_s per sample.
template <class Ref>
std::vector<Sample> clocked_log(Ref ref, double seg_s, int n_seg, const double lat[2], const double ppm[2],
                                const double sigma[2], unsigned seed) {
  const double fs = 100.0;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  const int n = static_cast<int>(n_seg * seg_s * fs);
  for (int i = 0; i < n; ++i) {
    Sample s = referenced_sample(i / fs, static_cast<int>(std::floor(i / fs / seg_s)));
    ref(s.t_s, s.f, s.w);
    for (int si = 0; si < 2; ++si) {
      double f[3], w[3];
      ref(s.t_s - lat[si] - ppm[si] * 1e-6 * s.t_s, f, w);
      for (int j = 0; j < 3; ++j) s.y[3 * si + j] = (si == 0 ? f[j] : w[j]) + sigma[si] * n01(rng);
    }
    log.push_back(s);
  }
  return log;
}

// Instantaneous steps into motion (a sine or a tumble starting from rest) with a clock error that grows to
// several sample intervals: the first samples after each step read the old input, which no linearised timing
// term describes (docs/diagnosis.md § timing, "lag probe"). Hand-made log, independent of host/sim: the output
// is the reference function evaluated at t − δ(t), exactly. The diagnosis must find both clocks (one late,
// one early), re-evaluate the reference there, and leave no axis above its noise.
TEST(DiagnosisPipeline, ClockErrorOfSeveralSamplesAtInstantaneousSteps) {
  const double seg_s = 4.0;
  const int n_seg = 120;
  const double lat[2] = {0.0, 1e-3}, ppm[2] = {-30.0, 50.0};  // accel early, gyro late: -14 ms, +25 ms at the end
  const double sigma[2] = {1e-3, 5e-4};  // per sample at 100 Hz: the automotive class (ARW 0.34 °/√h ≈ 7e-4 rad/s)
  const auto ref = cycling_with_sines(seg_s, n_seg);
  const std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lat, ppm, sigma, 5);
  VectorSource src(log);
  DiagnosisResult r = diagnose(src, basic_model(), Options{});
  const double t_end = n_seg * seg_s;
  for (int si = 0; si < 2; ++si) {
    const auto i = static_cast<std::size_t>(si);
    // Within a fifth of a sample at both ends (the ±1-sample exclusion at each shifted step needs < 1).
    EXPECT_NEAR(r.timing_shift_latency_s[i], lat[si], 2e-3) << si;
    EXPECT_NEAR(r.timing_shift_latency_s[i] + r.timing_shift_ppm[i] * 1e-6 * t_end, lat[si] + ppm[si] * 1e-6 * t_end, 2e-3)
        << si;
  }
  bool said = false;
  for (const auto& w : r.warnings) said = said || w.find("reads the reference steps") != std::string::npos;
  EXPECT_TRUE(said);
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
}

// The same kind of log without sines: static faces, constant rates and tumbles, and pose changes that fall
// anywhere within a row interval (segments of 4.0037 s). The gyro's rate is constant within every segment, so
// only the reference steps show its clock; the linear timing term is excited by nothing but the Earth rate
// turning in the body (σ ~0.1 s). Moving the shift on that "correction" diverged (blind logs with no sines:
// the gyro clock driven to ±1 s and ±1000 ppm, held-out χ²/dof 10⁷). Now the shift stays where the steps put it,
// the timing is reported from the steps with their σ, and every axis is at its noise. Second case: a lag below
// one sample throughout, which the steps show only as a sign: nothing to refine, nothing moves.
// A rate table accelerates finitely: at the start and the end of each acceleration of a trapezoidal rate profile
// (8.7 rad/s², 500 °/s²) the tangential specific force ω̇ × r of a sensor off the axis steps, between the 100 Hz
// rows of the reference. While gravity turns fast in the body the neighbouring rows change by as much, so the
// step test (reference_step) does not see it, and the reference interpolated at a shifted time reads across it.
// On the simulate source's random-19 (a clock drifting to 12 ms) that left accel axes at held-out χ²/dof 11–13,
// "unexplained", and per-axis latencies 7σ apart. The kink test (step_lag.h, reference_kink) leaves those samples
// out. Hand-made log: the output is the continuous profile at t − δ, exactly.
TEST(DiagnosisPipeline, KinksOfATrapezoidalRateProfileDoNotBiasTheLatency) {
  const double seg_s = 4.0, acc = 8.7, g = 9.80665;
  const double arm[3] = {0.05, -0.03, 0.04};  // the sensor's offset from the rotation axis, m
  const int n_seg = 120;
  auto ref = [&](double t, double* f, double* w) {
    const int k = std::clamp(static_cast<int>(std::floor(t / seg_s)), 0, n_seg - 1);
    const double tau = t - k * seg_s;
    const int ax = (k / 2) % 3, m = (ax + 1) % 3, v = (ax + 2) % 3;  // rotate about ax: gravity turns in (m, v)
    for (int j = 0; j < 3; ++j) f[j] = 0.0, w[j] = 0.0;
    f[v] = g;
    if (k % 2 == 0) return;  // a static pose
    // Up to r from 0.5 s, back to rest from 3.0 s: angle, rate and acceleration of the trapezoid.
    const double r = ((k / 6) % 2 ? -1.0 : 1.0) * (1.0 + 0.5 * ((k / 2) % 3)), tr = std::fabs(r) / acc, a = r / tr;
    auto ramp = [&](double t0, double& th, double& om, double& al) {
      const double x = tau - t0;
      if (x <= 0) return;
      if (x < tr) th += 0.5 * a * x * x, om += a * x, al += a;
      else th += 0.5 * a * tr * tr + r * (x - tr), om += r;
    };
    double th = 0, om = 0, al = 0, th2 = 0, om2 = 0, al2 = 0;
    ramp(0.5, th, om, al);
    ramp(3.0, th2, om2, al2);
    th -= th2, om -= om2, al -= al2;
    w[ax] = om;
    f[m] = -g * std::sin(th);
    f[v] = g * std::cos(th);
    // Specific force of the offset point, ω̇ × r + ω × (ω × r) with ω = om along ax: the tangential part steps
    // by α·r where the acceleration starts and stops, while gravity turns by up to 0.34 m/s² per row.
    const double e[3] = {ax == 0 ? 1.0 : 0.0, ax == 1 ? 1.0 : 0.0, ax == 2 ? 1.0 : 0.0};
    const double exr[3] = {e[1] * arm[2] - e[2] * arm[1], e[2] * arm[0] - e[0] * arm[2], e[0] * arm[1] - e[1] * arm[0]};
    for (int j = 0; j < 3; ++j) f[j] += al * exr[j] + om * om * (e[j] * arm[ax] - arm[j]);
  };
  // The accelerometer reads 1.5 ms late, the gyro on time: a step read across by linear interpolation is off by
  // 15 % of it, ~50 σ of one sample.
  const double lat[2] = {1.5e-3, 0.0}, ppm[2] = {0.0, 0.0}, sigma[2] = {1.5e-3, 3.5e-4};
  const std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lat, ppm, sigma, 13);
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  // Without the kink rule: latencies 1.526, 1.489, 1.464 ms (± 3–4 µs) and held-out χ²/dof 7.2, 12.3, 2.8.
  int reported = 0;
  for (const auto& pe : r.final_params) {
    if (pe.name != "accel.timing.latency_s") continue;
    ++reported;
    EXPECT_LT(std::fabs(pe.value - lat[0]), 3.0 * pe.sigma) << pe.axis << " " << pe.value << " +/- " << pe.sigma;
  }
  EXPECT_EQ(reported, 3);
  ASSERT_EQ(r.selected.size(), 1u);
  EXPECT_EQ(r.selected[0].sensor + "." + r.selected[0].effect, "accel.timing");
  EXPECT_TRUE(r.unexplained.empty());
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
}

// A clock that drifts past a second on a table that accelerates smoothly into every move: no reference step for
// the step probe, and a linearised timing term cannot start from a shift far longer than a move's acceleration
// (the simulate source's single-gyro.timing-1s, −420 ppm and 1.84 s by the end: the linear iteration converged
// to −0.38 s and +64 ppm, every gyro axis "unexplained" at held-out χ²/dof 800–5400). The lag probe on the motion
// (step_lag.h, probe_motion_lag) reads the shift off every moving stretch and seeds the re-evaluation. Hand-made
// log: static poses and 90° turns with a raised-cosine rate (no step, no kink), the output the continuous
// reference at t − δ, exactly. The gyro runs 900 ppm fast: 1.13 s early by the end; the accelerometer is on time.
std::vector<Sample> smooth_turns_log(int n_seg, double seg_s, const double ppm[2], unsigned seed) {
  const double g = 9.80665, turn_s = 1.0, theta = 0.5 * M_PI;
  const double f0[3] = {0.48 * g, 0.6 * g, 0.64 * g};  // a direction every axis's turn moves
  auto ref = [&](double t, double* f, double* w) {
    const int k = std::clamp(static_cast<int>(std::floor(t / seg_s)), 0, n_seg - 1);
    const double tau = t - k * seg_s - 1.0;  // the turn of an odd segment runs 1 s .. 4 s into it
    // Turn m (segment 2m+1) about axis (m/2) mod 3 goes out by θ when m is even and back when m is odd: the
    // even segment after it holds the pose it left (f0 after every pair).
    double th = 0, om = 0;
    int axk = 0;
    if (k % 2 == 1) {
      const int m = k / 2;
      axk = (m / 2) % 3;
      const double x = std::clamp(tau / turn_s, 0.0, 1.0);
      const double prof = x - std::sin(2.0 * M_PI * x) / (2.0 * M_PI);  // 0 → 1, rate and its slope 0 at both ends
      const double rate = tau > 0 && tau < turn_s ? (1.0 - std::cos(2.0 * M_PI * x)) / turn_s : 0.0;
      th = m % 2 == 0 ? theta * prof : theta * (1.0 - prof);
      om = m % 2 == 0 ? theta * rate : -theta * rate;
    } else if (k >= 2) {
      const int m = k / 2 - 1;
      axk = (m / 2) % 3;
      th = m % 2 == 0 ? theta : 0.0;
    }
    const double e[3] = {axk == 0 ? 1.0 : 0.0, axk == 1 ? 1.0 : 0.0, axk == 2 ? 1.0 : 0.0};
    // Gravity in the body after a rotation by th about e (Rodrigues, the body turning by +th).
    const double c = std::cos(th), sn = std::sin(th), ef = f0[axk];
    const double exf[3] = {e[1] * f0[2] - e[2] * f0[1], e[2] * f0[0] - e[0] * f0[2], e[0] * f0[1] - e[1] * f0[0]};
    for (int j = 0; j < 3; ++j) {
      f[j] = c * f0[j] - sn * exf[j] + (1.0 - c) * ef * e[j];
      w[j] = e[j] * om;
    }
  };
  const double lat[2] = {0.0, 0.0}, sigma[2] = {1e-3, 5e-4};
  return clocked_log(ref, seg_s, n_seg, lat, ppm, sigma, seed);
}

TEST(DiagnosisPipeline, AClockDriftingPastASecondOnSmoothMotionIsReadOffTheMotion) {
  const int n_seg = 210;
  const double seg_s = 6.0, ppm[2] = {0.0, -900.0}, t_end = n_seg * seg_s;
  const std::vector<Sample> log = smooth_turns_log(n_seg, seg_s, ppm, 17);
  {
    VectorSource src(log);
    const auto steps = probe_step_lag(src, 100.0, t_end);
    EXPECT_EQ(steps[1].n_steps, 0) << "no step: the step probe has nothing to read";
    VectorSource src2(log);
    const auto m = probe_motion_lag(src2, 100.0, t_end);
    ASSERT_TRUE(m[1].valid);
    EXPECT_NEAR(m[1].ppm, ppm[1], 3.0 * m[1].sigma_ppm + 1.0);
    EXPECT_NEAR(m[1].latency_s, 0.0, 3.0 * m[1].sigma_latency_s + 2e-3);
    EXPECT_GE(m[1].n_steps - m[1].n_outliers, 100);
    ASSERT_TRUE(m[0].valid);
    EXPECT_LT(m[0].max_abs_s, 5e-3) << "the accelerometer is on time";
  }
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  EXPECT_NEAR(r.timing_shift_latency_s[1] + r.timing_shift_ppm[1] * 1e-6 * t_end, ppm[1] * 1e-6 * t_end, 2e-3);
  EXPECT_NEAR(r.timing_shift_latency_s[1], 0.0, 2e-3);
  EXPECT_EQ(r.timing_shift_latency_s[0], 0.0);
  EXPECT_EQ(r.timing_shift_ppm[0], 0.0);
  // 1.13 s early by the end: what `diagnose --emit-model` sizes the solver's dwell guard by.
  EXPECT_NEAR(max_timing_shift_s(r), std::abs(ppm[1]) * 1e-6 * t_end, 0.01);
  bool said = false;
  for (const auto& w : r.warnings) said = said || w.find("follows the reference's motion") != std::string::npos;
  EXPECT_TRUE(said);
  std::set<std::string> sel;
  for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
  EXPECT_EQ(sel, std::set<std::string>{"gyro.timing"});
  EXPECT_TRUE(r.unexplained.empty());
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
}

TEST(DiagnosisPipeline, GyroClockWithoutMotionWithinSegmentsKeepsTheStepsShift) {
  const double seg_s = 4.0037;
  const int n_seg = 120;
  auto ref = [&](double t, double* f, double* w) {
    const int k = std::clamp(static_cast<int>(std::floor(t / seg_s)), 0, n_seg - 1);
    const double tau = t - k * seg_s;
    cycling_reference(k, tau, false, f, w);
    // The Earth rate (45° latitude, one direction per segment), turning in the body about the rotation axis:
    // the only motion within a segment that the gyro's linear timing term sees.
    const double We = 7.292115e-5;
    double e[3] = {We * 0.7071 * std::cos(0.7 * k), We * 0.7071 * std::sin(0.7 * k), We * 0.7071};
    for (int a = 0; a < 3; ++a)
      if (w[a] != 0.0) {
        const int p = (a + 1) % 3, q = (a + 2) % 3;
        const double ang = -w[a] * tau, ep = e[p], eq = e[q];
        e[p] = std::cos(ang) * ep - std::sin(ang) * eq;
        e[q] = std::sin(ang) * ep + std::cos(ang) * eq;
      }
    for (int j = 0; j < 3; ++j) w[j] += e[j];
  };
  auto run = [&](double lat_s, double ppm) {
    const double lats[2] = {0.0, lat_s}, ppms[2] = {0.0, ppm}, sigma[2] = {1e-3, 5e-4};
    const std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lats, ppms, sigma, 11);
    VectorSource src(log);
    return diagnose(src, basic_model(), Options{});
  };
  const double t_end = n_seg * seg_s;
  {
    const double lat = 2e-3, ppm = 60.0;  // 2 ms to 31 ms: three samples by the end
    const DiagnosisResult r = run(lat, ppm);
    EXPECT_NEAR(r.timing_shift_latency_s[1], lat, 10e-3);
    EXPECT_NEAR(r.timing_shift_latency_s[1] + r.timing_shift_ppm[1] * 1e-6 * t_end, lat + ppm * 1e-6 * t_end, 10e-3);
    bool selected = false, said = false;
    for (const auto& st : r.selected)
      selected = selected || (st.sensor == "gyro" && st.effect == "timing" && st.from_reference_steps);
    for (const auto& w : r.warnings) said = said || w.find("cannot refine the timing") != std::string::npos;
    EXPECT_TRUE(selected);
    EXPECT_TRUE(said);
    // The steps' line and its σ (which carries the unknown place of each change within its row interval).
    int reported = 0;
    for (const auto& pe : r.final_params) {
      const double truth = pe.name == "gyro.timing.ppm" ? ppm : pe.name == "gyro.timing.latency_s" ? lat : NAN;
      if (std::isnan(truth)) continue;
      ++reported;
      EXPECT_GT(pe.sigma, 0.0) << pe.name;
      EXPECT_LT(std::fabs(pe.value - truth), 3.0 * pe.sigma) << pe.name << " " << pe.value << " +/- " << pe.sigma;
    }
    EXPECT_EQ(reported, 2);
    for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
  }
  {
    // Below a sample throughout: the steps show the lag only by the side they are misread on (about 40 % read
    // late, none early). Nothing to refine and nothing moves, but the timing is selected on that evidence, its
    // magnitude the steps' line with a σ that covers where in the row interval each change fell.
    const DiagnosisResult r = run(4e-3, 0.0);
    EXPECT_LT(std::fabs(r.timing_shift_latency_s[1]), 10e-3);
    EXPECT_LT(std::fabs(r.timing_shift_ppm[1]), 100.0);
    for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
    bool selected = false;
    for (const auto& st : r.selected) {
      EXPECT_NE(st.sensor + "." + st.effect, "accel.timing");
      selected = selected || (st.sensor == "gyro" && st.effect == "timing" && st.from_reference_steps);
    }
    EXPECT_TRUE(selected);
    int reported = 0;
    for (const auto& pe : r.final_params) {
      if (pe.name != "gyro.timing.latency_s") continue;
      ++reported;
      EXPECT_GT(pe.value, 0.0);
      EXPECT_LT(std::fabs(pe.value - 4e-3), 3.0 * pe.sigma) << pe.value << " +/- " << pe.sigma;
    }
    EXPECT_EQ(reported, 1);
  }
}

// A latency of a twentieth of a sample, on sines that run whole periods between instantaneous steps: the
// samples at the steps are left out, and over a segment the timing regressor u̇ averages to (u_end − u_start) / T
// = 0, so the withheld segments' MEANS cannot see it while every block within a sine does (varied5 random-2:
// 0.49 ms at 100 Hz, ΔBIC −6e4, held-out shrink −2 % on segment means, not selected). Judged on the withheld
// segments' blocks, it is selected, its magnitude within 3σ of the truth; the accelerometer's is not.
// A twentieth of a sample misreads about 5 of the ~90 steps, one way: since stop 39 enough for the steps' sign
// rule (kStepLagDecisiveCount), which keeps the timing in the model where the segment means alone would not.
TEST(DiagnosisPipeline, ASubSampleLatencyOnWholeSinePeriodsIsJudgedOnTheBlocks) {
  const double seg_s = 4.0037;  // steps fall anywhere within a row interval; 2.0 periods of the 0.5 Hz sine
  const int n_seg = 120;
  const auto ref = cycling_with_sines(seg_s, n_seg);
  const double lat = 0.5e-3;
  const double lats[2] = {0.0, lat}, ppms[2] = {0.0, 0.0}, sigma[2] = {1e-3, 5e-4};
  const std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lats, ppms, sigma, 23);
  for (const bool blocks : {true, false}) {
    VectorSource src(log);
    Options o;
    o.timing_heldout_blocks = blocks;
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    bool gyro_timing = false;
    for (const auto& st : r.selected) {
      EXPECT_NE(st.sensor + "." + st.effect, "accel.timing");
      gyro_timing = gyro_timing || (st.sensor == "gyro" && st.effect == "timing" && !st.from_reference_steps);
    }
    double shrink = NAN, gain = NAN;
    for (const auto& c : r.ranking)
      if (c.sensor == "gyro" && c.effect == "timing") {
          shrink = c.heldout_shrink_pct;
          gain = c.heldout_chi2_gain;
        }
    if (!blocks) {
      // What the segment means say (the defect this guards against): an in-sample LR of ~6e4 and a held-out
      // gain below the 2·dof the selection asks for, so not selected on them; the timing stays only on the steps'
      // one-sided misreadings, and the warnings say so.
      EXPECT_LT(gain, 12.0);
      bool by_steps = false;
      for (const auto& w : r.warnings) by_steps = by_steps || w.find("reference steps late (a lag below one sample)") != std::string::npos;
      EXPECT_TRUE(by_steps);
      EXPECT_EQ(gyro_timing, by_steps);
      // The evidence as diagnosis.json reports it: read late at kStepLagDecisiveCount steps or more, none early;
      // the accelerometer, without a lag, misreads none.
      EXPECT_GE(r.step_reading[1].n_late, kStepLagDecisiveCount);
      EXPECT_EQ(r.step_reading[1].n_early, 0);
      EXPECT_EQ(r.step_reading[1].sign, 1);
      EXPECT_GT(r.step_reading[0].n_steps, 20);
      EXPECT_EQ(r.step_reading[0].n_late + r.step_reading[0].n_early, 0);
      continue;
    }
    EXPECT_TRUE(gyro_timing);
    EXPECT_GT(gain, 1000.0);
    EXPECT_GT(shrink, 50.0);
    int reported = 0;
    for (const auto& pe : r.final_params) {
      if (pe.name != "gyro.timing.latency_s") continue;
      ++reported;
      EXPECT_LT(std::fabs(pe.value - lat), 3.0 * pe.sigma) << pe.axis << " " << pe.value << " +/- " << pe.sigma;
      EXPECT_LT(pe.sigma, 0.2 * lat) << pe.axis;
    }
    EXPECT_EQ(reported, 3);
    for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
  }
}

// The diagnosis of a mounted_rate_log without the mount estimate (max_mount_iterations 0) and with it. Without, it
// selects `effect` and `defect(result, selection)` holds; with, `effect` is selected alone, no axis is unexplained
// and the rotation about each axis of `about` is within 3σ (+ 0.02 mrad) of delta_rad.
template <class Defect>
void expect_mount_estimated(const std::vector<Sample>& log, const std::array<double, 3>& delta_rad, const std::string& effect,
                            const std::vector<std::size_t>& about, Defect defect) {
  for (const int iterations : {0, 4}) {
    VectorSource src(log);
    Options o;
    o.max_mount_iterations = iterations;
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    std::set<std::string> sel;
    for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
    EXPECT_TRUE(sel.count(effect)) << iterations;
    if (iterations == 0) {
      EXPECT_TRUE(defect(r, sel)) << "without the estimate: " << r.unexplained.size() << " unexplained, " << sel.size() << " selected";
      continue;
    }
    EXPECT_EQ(sel, std::set<std::string>{effect});
    EXPECT_GT(r.mount_iterations, 0);
    for (const std::size_t m : about)
      EXPECT_LT(std::fabs(r.mount_rotation_rad[m] - delta_rad[m]), 3.0 * r.mount_est.sigma_rad[m] + 2e-5)
          << m << ": " << r.mount_rotation_rad[m] << " +/- " << r.mount_est.sigma_rad[m];
    EXPECT_TRUE(r.unexplained.empty());
  }
}

// The mount-rotation tests' fixture: 240 segments of 4 s at 100 Hz, static faces alternating with rate runs about x,
// y, z and the diagonals, at ±(rate0_rad_s + step_rad_s·{0…3}); the case rotated by delta_rad. gyro(wc) gives the
// gyro's noise-free output from the input in the case wc = u + δ × u; white noise is added (1e-3 m/s², 1e-4 rad/s).
template <class Gyro>
std::vector<Sample> mounted_rate_log(const std::array<double, 3>& delta_rad, unsigned seed, double rate0_rad_s, double step_rad_s,
                                     Gyro gyro) {
  const double seg_s = 4.0037, fs = 100.0, g = 9.80665;
  const int n_seg = 240;
  const double axes[6][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.7071, 0, 0.7071}, {0.7071, 0.7071, 0}, {0, 0.7071, 0.7071}};
  const double faces[6][3] = {{0, 0, -g}, {0, 0, g}, {0, -g, 0}, {0, g, 0}, {-g, 0, 0}, {g, 0, 0}};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  const int n = static_cast<int>(n_seg * seg_s * fs);
  for (int i = 0; i < n; ++i) {
    const int k = static_cast<int>(std::floor(i / fs / seg_s));
    Sample s = referenced_sample(i / fs, k);
    for (int j = 0; j < 3; ++j) s.f[j] = faces[(k / 2) % 6][j], s.w[j] = 0.0;
    if (k % 2) {  // a rate run: axis k/2 mod 6
      const double r = (rate0_rad_s + step_rad_s * ((k / 12) % 4)) * ((k / 2) % 2 ? -1.0 : 1.0);
      for (int j = 0; j < 3; ++j) s.w[j] = r * axes[(k / 2 + k / 24) % 6][j];
    }
    const std::array<double, 3> wc{s.w[0] + delta_rad[1] * s.w[2] - delta_rad[2] * s.w[1],
                                   s.w[1] + delta_rad[2] * s.w[0] - delta_rad[0] * s.w[2],
                                   s.w[2] + delta_rad[0] * s.w[1] - delta_rad[1] * s.w[0]};
    const std::array<double, 3> y = gyro(wc);
    for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 1e-3 * n01(rng);
    for (int j = 0; j < 3; ++j) s.y[3 + j] = y[static_cast<std::size_t>(j)] + 1e-4 * n01(rng);
    log.push_back(s);
  }
  return log;
}

// The case sits rotated on the fixture by δ = (0, 0.5, −0.3) mrad, unknown to it, and the gyro has a cross-coupling
// c_xz = c_zx = 3e-3 1/(rad/s) acting on the input in the case, u + δ × u. Read against the fixture's frame the
// cross-coupling leaves c·δ·u² terms (varied5: false scale_nonlinearity / scale_asymmetry beside a selected
// cross-coupling in 4 of 25 random cases). Hand-made log, independent of host/sim: rate runs of 2–8 rad/s
// about x, y, z and the diagonals between static poses. With the rotation estimated from the cross-coupling's
// quadratic terms, the cross-coupling is selected alone and the rotation about y and z is found within 3σ.
TEST(DiagnosisPipeline, ACrossCouplingSeenThroughAMountRotationIsNotANonlinearity) {
  const std::array<double, 3> delta{0.0, 0.5e-3, -0.3e-3};
  const double c = 3e-3;
  const std::vector<Sample> log = mounted_rate_log(delta, 31, 2.0, 2.0, [&](const std::array<double, 3>& wc) {
    return std::array<double, 3>{wc[0] + c * wc[0] * wc[2], wc[1], wc[2] + c * wc[2] * wc[0]};
  });
  // What the fixture's frame makes of it (the defect this guards against): something more than the coupling (here
  // a scale_asymmetry; with the rotation estimated, 0.49 and −0.31 mrad ± 0.01 and 0.06 about y and z, the
  // cross_coupling stands alone).
  expect_mount_estimated(log, delta, "gyro.cross_coupling", {0, 1, 2}, [](const DiagnosisResult&, const std::set<std::string>& sel) {
    return sel.count("gyro.scale_asymmetry") || sel.count("gyro.scale_nonlinearity");
  });
}

// The same fixture, a case rotated by δ = (0.4, −0.3, 0) mrad, and a gyro.z scale nonlinearity k3 = 1.2e-4
// 1/(rad/s)² acting on the input in the case: k3 (u_z + (δ × u)_z)³ leaves 3 k3 u_z² (δ_x u_y − δ_y u_x) against the
// fixture's frame, a product of three inputs no catalog effect has (`varied17` random-27: gyro.z at held-out χ²/dof
// 6.5, growing with the rate, at 1401 °/s on a 0.3 mrad mount). Rate runs of 4–22 rad/s about x, y, z and the
// diagonals. With the rotation estimated from the nonlinearity's terms as well as the cross-coupling's, the
// nonlinearity is selected alone, no axis is left unexplained, and the rotation about x and y (the ones the
// cubic's terms carry) is found within 3σ. Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, ACubicSeenThroughAMountRotationLeavesNoAxisUnexplained) {
  const std::array<double, 3> delta{0.4e-3, -0.3e-3, 0.0};
  const double k3 = 1.2e-4;
  const std::vector<Sample> log = mounted_rate_log(delta, 37, 4.0, 6.0, [&](const std::array<double, 3>& wc) {
    return std::array<double, 3>{wc[0], wc[1], wc[2] + k3 * wc[2] * wc[2] * wc[2]};
  });
  // What the fixture's frame makes of it (the defect this guards against): an axis left unexplained or an effect
  // more than the cubic.
  expect_mount_estimated(log, delta, "gyro.scale_nonlinearity", {0, 1}, [](const DiagnosisResult& r, const std::set<std::string>& sel) {
    return !r.unexplained.empty() || sel.size() > 1;
  });
}

// A log whose segment column carries no schedule (−1 on every row: what the format writes when none is known)
// could not be scored at all: the folds withhold whole segments. ReferenceSegmentSource cuts segments where the
// reference steps or kinks, and the diagnosis then says what it says on the same log with its schedule; so it
// does on a coarse schedule split at those cuts. A log whose segments end at every step passes unchanged.
TEST(DiagnosisPipeline, SegmentsAreCutAtTheReferenceStepsWhenTheLogHasNoSchedule) {
  const double seg_s = 4.0037;
  const int n_seg = 96;
  const auto ref = cycling_with_sines(seg_s, n_seg);
  const double lats[2] = {0.0, 0.0}, ppms[2] = {0.0, 0.0}, sigma[2] = {1e-3, 5e-4};
  std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lats, ppms, sigma, 29);
  // A g-sensitivity for the diagnosis to find: 2e-4 (rad/s)/(m/s²) from f_x onto gyro.y.
  for (auto& s : log) s.y[4] += 2e-4 * s.f[0];
  {
    VectorSource inner(log);
    ReferenceSegmentSource segs(inner);
    EXPECT_FALSE(segs.derived());
    EXPECT_EQ(segs.logged_segments(), 3);  // counted up to 3
  }
  const DiagnosisResult logged = [&] {
    VectorSource src(log);
    return diagnose(src, basic_model(), Options{});
  }();
  {
    // A coarse schedule (one number per 24 dwells, as a generator numbering plateaus might write): each logged
    // segment is split at the steps within it, and the diagnosis says what it says on the fine schedule.
    std::vector<Sample> coarse = log;
    for (auto& s : coarse) s.segment /= 24;
    VectorSource inner(coarse);
    ReferenceSegmentSource segs(inner);
    EXPECT_FALSE(segs.derived());
    EXPECT_EQ(segs.split_segments(), n_seg - n_seg / 24);
    const DiagnosisResult r = diagnose(segs, basic_model(), Options{});
    std::set<std::string> a, b;
    for (const auto& st : logged.selected) a.insert(st.sensor + "." + st.effect);
    for (const auto& st : r.selected) b.insert(st.sensor + "." + st.effect);
    EXPECT_EQ(a, b);
  }
  for (auto& s : log) s.segment = -1;
  VectorSource inner(log);
  {
    VectorSource bare(log);
    const DiagnosisResult r = diagnose(bare, basic_model(), Options{});
    EXPECT_TRUE(r.selected.empty());  // nothing can be withheld
  }
  ReferenceSegmentSource segs(inner);
  ASSERT_TRUE(segs.derived());
  EXPECT_EQ(segs.logged_segments(), 0);
  // Every segment boundary of the cycle is a step or a kink of the reference, and nothing within a segment is.
  EXPECT_EQ(segs.derived_segments(), n_seg);
  const DiagnosisResult r = diagnose(segs, basic_model(), Options{});
  std::set<std::string> a, b;
  for (const auto& st : logged.selected) a.insert(st.sensor + "." + st.effect);
  for (const auto& st : r.selected) b.insert(st.sensor + "." + st.effect);
  EXPECT_EQ(a, b);
  EXPECT_TRUE(b.count("gyro.g_sensitivity"));
  Sample s;
  segs.rewind();
  int last = -1;
  while (segs.next(s)) {
    EXPECT_GE(s.segment, last);
    last = s.segment;
  }
  EXPECT_EQ(last, n_seg - 1);
}

// A clock read early by more than a sample at the end of the log: the last samples read input that comes after
// the last reference row. Held at that row (as the reference was until stop 30), a sine in the last segment is
// off by up to its rate of change times the lag (here 1.2π rad/s² × 83 ms ≈ 0.3 rad/s over eight samples): varied4
// random-1 (−95 ppm, 0.12 s by the end) had its last block 670 σ off, the clock fitted 23 σ from its truth and
// every gyro axis "unexplained" at held-out χ²/dof 23–50. Those samples have no reference and are left out.
TEST(DiagnosisPipeline, AClockReadingPastTheLastReferenceRowIsNotComparedWithAHeldReference) {
  const double seg_s = 4.5;  // the log ends where the sine's rate changes fastest (1.2 cos(π τ) at τ = 4.5 s)
  const int n_seg = 123;  // segment 122 is a sine (cycling_reference: k % 4 == 2)
  const auto ref = cycling_with_sines(seg_s, n_seg);
  const double lat[2] = {0.0, 0.0}, ppm[2] = {0.0, -150.0}, sigma[2] = {1e-3, 5e-4};
  const std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lat, ppm, sigma, 17);
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  const double t_end = n_seg * seg_s;
  EXPECT_NEAR(r.timing_shift_latency_s[1] + r.timing_shift_ppm[1] * 1e-6 * t_end, ppm[1] * 1e-6 * t_end, 2e-3);
  for (const auto& pe : r.final_params)
    if (pe.name == "gyro.timing.ppm") EXPECT_LT(std::fabs(pe.value - ppm[1]), 3.0 * pe.sigma) << pe.value << " +/- " << pe.sigma;
  EXPECT_TRUE(r.unexplained.empty());
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 3.0) << axis_name(a);
}

// The lag probe's line through the steps is a fit to the steps the clock explains: a few steps the output
// misreads by many samples for another reason (here the output holds the old input for 30 samples after every
// tenth step, as a fixture transient would) must not lift the scatter above a sample and lose the clock. On
// varied4 random-2 one such step among 232 did that, and a 24 ppm accelerometer clock (0.23 s by the end) was
// left "unexplained" at held-out χ²/dof 3e4.
TEST(DiagnosisPipeline, StepsMisreadForAnotherReasonDoNotHideTheClock) {
  const double seg_s = 4.0;
  const int n_seg = 120;
  const auto ref = cycling_with_sines(seg_s, n_seg);
  const double lat[2] = {0.0, 0.0}, ppm[2] = {40.0, 0.0}, sigma[2] = {1e-3, 5e-4};
  std::vector<Sample> log = clocked_log(ref, seg_s, n_seg, lat, ppm, sigma, 23);
  const int per_seg = static_cast<int>(seg_s * 100.0);
  int spoiled = 0;
  for (int k = 10; k < n_seg; k += 10) {
    const int i0 = k * per_seg + 10;  // past the clock's own lag (≤ 2 samples)
    const Sample held = log[static_cast<std::size_t>(i0 - 20)];
    if (std::fabs(held.f[0] - log[static_cast<std::size_t>(i0)].f[0]) + std::fabs(held.f[1] - log[static_cast<std::size_t>(i0)].f[1]) +
            std::fabs(held.f[2] - log[static_cast<std::size_t>(i0)].f[2]) < 2.0)
      continue;
    for (int i = i0 - 10; i < i0 + 20; ++i)
      for (int j = 0; j < 3; ++j) log[static_cast<std::size_t>(i)].y[j] = held.y[j];
    ++spoiled;
  }
  ASSERT_GE(spoiled, 3);
  VectorSource src(log);
  const std::array<StepLag, 2> lag = probe_step_lag(src, 100.0, n_seg * seg_s);
  EXPECT_TRUE(lag[0].valid);
  EXPECT_GE(lag[0].n_outliers, 1);
  EXPECT_LE(lag[0].n_outliers, spoiled);
  EXPECT_NEAR(lag[0].ppm, ppm[0], 3.0 * lag[0].sigma_ppm + 1.0);
  EXPECT_LE(lag[0].rms_s, 0.01);
}

// Temperature hysteresis needs two turns of the temperature history. With one turn the hysteresis column is one
// offset between two stretches of the log, which any slow drift gives too, so the candidate is reported as not
// excitable (not selected, not ruled out); with two it is an alternation and is found. Hand-made static log,
// the accelerometer x output offset by h·d (d = ±1 after heating / cooling).
TEST(DiagnosisPipeline, HysteresisOnOneTurnMustStandAboveTheWholeLogWander) {
  // With one turn of the temperature, the hysteresis column is one offset between two stretches of the log, and
  // a slow drift that differs between them looks the same to the dwells' noise model (varied blind suite: a
  // one-turn schedule under a 60 s Gauss-Markov gyro bias selected gyro.temp_hysteresis at p = 1e-4). The
  // candidate is tested again under the largest bias wander the whole log supports without it: a drift falls to
  // noise there, a real hysteresis (one jump at the turn) does not. Two turns need no such test.
  const double fs = 100.0, dwell_s = 8.0;
  const std::vector<Pose> poses = two_axis_tilts();
  auto run = [&](const std::vector<double>& knots_C, double h, double drift_total) {
    const int n_dwell = 3 * static_cast<int>(poses.size());
    const int n = static_cast<int>(n_dwell * dwell_s * fs);
    const double legs = static_cast<double>(knots_C.size() - 1);
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n01;
    imuforge::model::HysteresisTracker tracker(0.5);
    std::vector<Sample> log;
    for (int i = 0; i < n; ++i) {
      const int k = static_cast<int>(i / (dwell_s * fs));
      Sample s = referenced_sample(i / fs, k);
      const double x = legs * i / n;  // piecewise-linear temperature through the knots
      const int leg = std::min(static_cast<int>(x), static_cast<int>(legs) - 1);
      s.temp_C = knots_C[static_cast<std::size_t>(leg)] + (x - leg) * (knots_C[static_cast<std::size_t>(leg) + 1] - knots_C[static_cast<std::size_t>(leg)]);
      const double d = tracker.update(s.temp_C);
      const Pose& f = poses[static_cast<std::size_t>(k) % poses.size()];
      for (int j = 0; j < 3; ++j) {
        s.f[j] = f[static_cast<std::size_t>(j)];
        s.y[j] = s.f[j] + 1e-3 * n01(rng);
        s.y[3 + j] = 5e-4 * n01(rng);
      }
      s.y[0] += h * d + drift_total * i / n;  // the drift is not a function of T: the temperature turns
      log.push_back(s);
    }
    VectorSource src(log);
    return diagnose(src, basic_model(), Options{});
  };
  auto hysteresis = [](const DiagnosisResult& r) {
    const CandidateScore* c = nullptr;
    for (const auto& x : r.ranking)
      if (x.sensor == "accel" && x.effect == "temp_hysteresis") c = &x;
    bool sel = false;
    for (const auto& st : r.selected) sel = sel || (st.sensor == "accel" && st.effect == "temp_hysteresis");
    return std::make_pair(sel, c);
  };
  {
    const auto r = run({25.0, 5.0, 45.0, 10.0}, 2e-4, 0.0);  // cooling, heating, cooling: three runs of d
    const auto [sel, c] = hysteresis(r);
    EXPECT_TRUE(sel);
    ASSERT_NE(c, nullptr);
    EXPECT_LT(c->one_turn_p, 0.0) << "two turns: not tested";
  }
  {
    const auto r = run({25.0, 5.0, 45.0}, 2e-4, 0.0);  // cooling, then heating: one turn, a real hysteresis
    const auto [sel, c] = hysteresis(r);
    EXPECT_TRUE(sel) << "a hysteresis of ~6 block sigma is one jump at the turn";
    ASSERT_NE(c, nullptr);
    EXPECT_GE(c->one_turn_p, 0.0);
    EXPECT_LT(c->one_turn_p, 1e-4) << "still far above the selection level (measured 2.5e-8)";
  }
  {
    const auto r = run({25.0, 5.0, 45.0}, 0.0, 6e-4);  // one turn, no hysteresis, a linear drift in time
    const auto [sel, c] = hysteresis(r);
    EXPECT_FALSE(sel) << "a drift differing between the two stretches";
    ASSERT_NE(c, nullptr);
    EXPECT_LT(c->p_value, 1e-4) << "the dwells' noise alone calls it significant (else the test is not exercised)";
    EXPECT_GE(c->one_turn_p, 0.01) << "measured 0.94 (p 3.7e-5 under the dwells' noise)";
  }
}

// A soak in which the temperature turns: the gyro's temp_hysteresis flips inside that one static segment, a bias
// step of 2h in the middle of the longest Allan record. Kept in the record, the step read as bias instability of
// that axis, and the dwells' noise model then hid the effect that made it (varied blind suite, mixed-w_cubed: a
// consumer gyro.z hysteresis of 4e-4 rad/s flipped on a 70 °C ramp, the axis read flicker B 8.7e-5 against 2e-5
// on x and y, and the hysteresis was never significant). An axis whose static run holds a hysteresis step above
// its white scatter now has that record cut at the step (docs/diagnosis.md § 2). Hand-made log, white noise
// only: cooling tilts, the soak (15 -> 13 -> 17 °C), heating tilts; h on gyro.z only.
TEST(DiagnosisPipeline, AHysteresisFlipInsideASoakIsNotReadAsBiasInstability) {
  const double fs = 100.0, dwell_s = 8.0, soak_s = 600.0, h = 1.5e-4;
  const std::vector<Pose> poses = two_axis_tilts();
  std::mt19937_64 rng(5);
  imuforge::model::HysteresisTracker tracker(0.5);
  std::vector<Sample> log;
  int seg = 0;
  auto add = [&](const Pose& f, double T0_C, double T1_C, double dur_s, double Tturn_C) {
    // temperature T0 -> Tturn -> T1 (piecewise linear; Tturn = T0 for a straight leg)
    const int n = static_cast<int>(dur_s * fs);
    const double a = std::fabs(Tturn_C - T0_C), b = std::fabs(T1_C - Tturn_C), frac = a / std::max(a + b, 1e-12);
    for (int i = 0; i < n; ++i) {
      const double x = static_cast<double>(i) / n;
      const double T = x < frac ? T0_C + (Tturn_C - T0_C) * x / frac : Tturn_C + (T1_C - Tturn_C) * (x - frac) / (1 - frac);
      Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
      s.temp_C = T;
      const double d = tracker.update(T);
      white_static_outputs(s, f, 1e-3, 3e-4, rng);
      s.y[5] += h * d;
      log.push_back(s);
    }
    ++seg;
  };
  const double step_C = 10.0 / static_cast<double>(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k)  // cooling 25 -> 15
    add(poses[k], 25.0 - step_C * static_cast<double>(k), 25.0 - step_C * static_cast<double>(k + 1), dwell_s, 25.0 - step_C * static_cast<double>(k));
  add(poses[0], 15.0, 17.0, soak_s, 13.0);  // the soak: the turn at 13 °C flips d inside it
  const double up_C = 18.0 / static_cast<double>(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k)  // heating 17 -> 35
    add(poses[k], 17.0 + up_C * static_cast<double>(k), 17.0 + up_C * static_cast<double>(k + 1), dwell_s, 17.0 + up_C * static_cast<double>(k));
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  // White noise only. With the step in the record gyro.z read flicker B 1.27e-4 (gyro.x 3.0e-6) and the hysteresis
  // was not selected; cut at the step, gyro.z reads 0 (gyro.x 3.0e-6).
  const double Bz = r.stoch[5].flicker_B;
  EXPECT_LT(Bz, 0.25 * h) << "gyro.z flicker B " << Bz << ": a step of 2h inside the soak's Allan record";
  bool sel = false;
  for (const auto& st : r.selected) sel = sel || (st.sensor == "gyro" && st.effect == "temp_hysteresis");
  EXPECT_TRUE(sel);
  for (const auto& p : r.final_params)
    if (p.name == "gyro.temp_hysteresis.z") {
      ASSERT_GT(p.sigma, 0.0);
      EXPECT_NEAR(p.value, h, 3.0 * p.sigma) << "measured 1.4997e-4 +/- 1.6e-6";
    }
}

// A bias step the catalog does not have (a jump of the sensor's own bias, not a hysteresis flip) inside a soak
// must not read as bias instability either: left in the soak's Allan record, it raised the dwells' noise until the
// axis was "at noise" (varied8 ooc-bias_step-0: a 3.3e-3 m/s² accel.z step read as flicker B 1.1e-3, 40x the other
// axes'). The run is cut at its most likely level step, and the axis is named unexplained. The same log as above,
// with the soak's temperature straight (no turn, so no hysteresis state changes in it) and gyro.z stepping by s.
TEST(DiagnosisPipeline, ABiasStepInsideASoakIsNotReadAsBiasInstability) {
  const double fs = 100.0, dwell_s = 8.0, soak_s = 600.0, step = 3e-4;
  const std::vector<Pose> poses = two_axis_tilts();
  std::mt19937_64 rng(7);
  std::vector<Sample> log;
  int seg = 0;
  bool stepped = false;
  auto add = [&](const Pose& f, double T0_C, double T1_C, double dur_s, bool step_here) {
    const int n = static_cast<int>(dur_s * fs);
    for (int i = 0; i < n; ++i) {
      Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
      s.temp_C = T0_C + (T1_C - T0_C) * static_cast<double>(i) / n;
      white_static_outputs(s, f, 1e-3, 3e-4, rng);
      stepped = stepped || (step_here && i >= static_cast<int>(0.37 * n));
      if (stepped) s.y[5] += step;
      log.push_back(s);
    }
    ++seg;
  };
  const double step_C = 10.0 / static_cast<double>(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k)  // cooling 25 -> 15
    add(poses[k], 25.0 - step_C * static_cast<double>(k), 25.0 - step_C * static_cast<double>(k + 1), dwell_s, false);
  add(poses[0], 15.0, 17.0, soak_s, true);
  const double up_C = 18.0 / static_cast<double>(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k)  // heating 17 -> 35
    add(poses[k], 17.0 + up_C * static_cast<double>(k), 17.0 + up_C * static_cast<double>(k + 1), dwell_s, false);
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  const double Bz = r.stoch[5].flicker_B, Bx = r.stoch[3].flicker_B;
  EXPECT_LT(Bz, 0.1 * step) << "gyro.z flicker B " << Bz << " (gyro.x " << Bx << "): the step inside the soak's Allan record";
  bool named = false;
  for (const auto& u : r.unexplained) named = named || u.axis == "gyro.z";
  EXPECT_TRUE(named) << "a bias step is no catalog effect: gyro.z must be named unexplained";
  for (const auto& u : r.unexplained) EXPECT_EQ(u.axis, "gyro.z") << "only the stepped axis";
}

// temp_hysteresis's threshold is the sensor's own: profiled, not assumed (docs/diagnosis.md § temp_hysteresis).
// Hand-made static log, the accelerometer x output offset by h·d(t) with d built at 0.3 °C (blindgen's tactical
// sensor) from a noise-free die temperature; the logged temperature carries 0.02 °C of white noise. The history
// reverses by 0.15, 0.25, 0.4, 0.6 and 1.0 °C between long moves, so each grid threshold turns d on a different
// set of reversals and only 0.3 °C turns it on exactly the true ones. Profiled, the threshold is 0.3 °C and h is
// read within 3σ; at the catalog's 0.5 °C (given), the reversal of 0.4 °C is missed and h is read short.
TEST(DiagnosisPipeline, HysteresisThresholdIsProfiledNotAssumed) {
  const double fs = 100.0, dwell_s = 8.0, h = 2e-4, thr_true_C = 0.3;
  const std::vector<Pose> poses = two_axis_tilts();
  // Piecewise-linear temperature: long moves with a small reversal after each, cooling then heating.
  const std::vector<double> knots_C = {25, 15, 15.15, 12, 12.25, 9, 9.4, 6, 6.6, 3, 4, 0,
                                       10, 9.85, 14, 13.75, 18, 17.6, 22, 21.4, 26, 25, 30};
  double travel_C = 0;
  for (std::size_t i = 1; i < knots_C.size(); ++i) travel_C += std::fabs(knots_C[i] - knots_C[i - 1]);
  const int n_dwell = 36 * static_cast<int>(poses.size());
  const int n = static_cast<int>(n_dwell * dwell_s * fs);
  std::mt19937_64 rng(21);
  std::normal_distribution<double> n01;
  imuforge::model::HysteresisTracker tracker(thr_true_C);
  std::vector<Sample> log;
  std::size_t leg = 1;
  double leg_start = 0;  // travel at the start of the current leg
  for (int i = 0; i < n; ++i) {
    const int k = static_cast<int>(i / (dwell_s * fs));
    Sample s = referenced_sample(i / fs, k);
    const double x = travel_C * i / n;  // constant pace along the path
    while (leg + 1 < knots_C.size() && x > leg_start + std::fabs(knots_C[leg] - knots_C[leg - 1])) {
      leg_start += std::fabs(knots_C[leg] - knots_C[leg - 1]);
      ++leg;
    }
    const double dT = knots_C[leg] - knots_C[leg - 1];
    const double die_C = knots_C[leg - 1] + (dT > 0 ? 1.0 : -1.0) * std::min(x - leg_start, std::fabs(dT));
    const double d = tracker.update(die_C);
    s.temp_C = die_C + 0.02 * n01(rng);
    const Pose& f = poses[static_cast<std::size_t>(k) % poses.size()];
    for (int j = 0; j < 3; ++j) {
      s.f[j] = f[static_cast<std::size_t>(j)];
      s.y[j] = s.f[j] + 1e-3 * n01(rng);
      s.y[3 + j] = 5e-4 * n01(rng);
    }
    s.y[0] += h * d;
    log.push_back(s);
  }
  auto hysteresis_x = [](const DiagnosisResult& r) {
    bool sel = false;
    for (const auto& st : r.selected) sel = sel || (st.sensor == "accel" && st.effect == "temp_hysteresis");
    ParamEstimate pe;
    pe.sigma = -1;
    for (const auto& p : r.final_params)
      if (p.name == "accel.temp_hysteresis.x") pe = p;
    return std::make_pair(sel, pe);
  };
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  EXPECT_FALSE(r.hysteresis_threshold_given);
  EXPECT_DOUBLE_EQ(r.hysteresis_threshold_C, thr_true_C);
  ASSERT_FALSE(r.hysteresis_profile.empty());
  EXPECT_GT(r.hysteresis_effective_tests, 1.0) << "the reversals make the grid's columns differ: the choice costs";
  EXPECT_LE(r.hysteresis_effective_tests, static_cast<double>(r.hysteresis_profile.size()));
  const auto [sel, pe] = hysteresis_x(r);
  ASSERT_TRUE(sel);
  ASSERT_GT(pe.sigma, 0.0);
  EXPECT_NEAR(pe.value, h, 3.0 * pe.sigma);
  // The profile's likelihood ratios (measured 231, 434, 727, 282, 90, 75 at 0.1 … 1.2 °C): the truth is the peak.
  for (const auto& [thr_C, lr] : r.hysteresis_profile)
    if (thr_C != thr_true_C)
      for (const auto& [t2, lr2] : r.hysteresis_profile)
        if (t2 == thr_true_C) EXPECT_LT(lr, lr2) << thr_C;
  for (const auto& c : r.ranking)
    if (c.sensor == "accel" && c.effect == "temp_hysteresis")
      EXPECT_NEAR(c.score, -chi2_log10_sf(c.lr, c.dof) - std::log10(r.hysteresis_effective_tests), 1e-9) << "the choice is paid for";
  // temp_hysteresis in the base model: the threshold is chosen once, against the base model without it.
  {
    BaseModel with_h = basic_model();
    for (const auto id : imuforge::model::effect_params(imuforge::model::Sensor::kAccel, imuforge::model::Effect::kTempHysteresis))
      with_h.params.push_back(id);
    with_h.effect_names.push_back("accel.temp_hysteresis");
    VectorSource src3(log);
    const DiagnosisResult rb = diagnose(src3, with_h, Options{});
    EXPECT_DOUBLE_EQ(rb.hysteresis_threshold_C, thr_true_C);
    EXPECT_FALSE(rb.hysteresis_profile.empty());
    const auto [selb, peb] = hysteresis_x(rb);
    EXPECT_FALSE(selb) << "in the model, not a finding";
    ASSERT_GT(peb.sigma, 0.0);
    EXPECT_NEAR(peb.value, h, 3.0 * peb.sigma);
  }
  // The catalog's threshold, given: no profile, and the 0.4 °C reversal is missed.
  Options at_default;
  at_default.hysteresis_threshold_C = 0.5;
  VectorSource src2(log);
  const DiagnosisResult r5 = diagnose(src2, basic_model(), at_default);
  EXPECT_TRUE(r5.hysteresis_threshold_given);
  EXPECT_TRUE(r5.hysteresis_profile.empty());
  const auto [sel5, pe5] = hysteresis_x(r5);
  ASSERT_TRUE(sel5);
  EXPECT_GT(std::fabs(pe5.value - h), 3.0 * pe5.sigma) << "at 0.5 °C, h is read short (measured 1.37e-4 ± 3.7e-6; profiled 2.007e-4 ± 3.4e-6)";
}

// A gyro bias that flips with the direction of rotation and saturates within a few °/s (no polynomial in ω of the
// catalog has that shape): the axis is named unexplained and its signature reads the direction of rotation. The
// signature correlates each input with the held-out residual after the model's own share of that input is taken
// out (residual_signature): the scale factor takes the part of sign(ω) that is linear in ω, and the raw direction
// no longer matches what is left (positive at the low rates, negative at the high ones). Hand-made log, independent
// of host/sim: static tilts, then constant rates about the vertical axis (f along the spin axis), ±5 to ±150 °/s.
TEST(DiagnosisPipeline, ABiasThatFlipsWithTheRotationIsNamedByItsDirection) {
  const double g = 9.80665, c_rad_s = 2e-3, w0_rad_s = 2.0 * M_PI / 180.0, fs = 100.0;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  int seg = 0;
  auto run = [&](const Pose& f, const std::array<double, 3>& w, double dur_s) {
    for (int i = 0; i < static_cast<int>(dur_s * fs); ++i) {
      Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
      for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = w[static_cast<std::size_t>(j)];
      for (int j = 0; j < 3; ++j) {
        s.y[j] = s.f[j] + 2e-3 * n01(rng);
        s.y[3 + j] = s.w[j] + 5e-4 * n01(rng);
      }
      s.y[5] += c_rad_s * (s.w[2] > 0 ? 1.0 : s.w[2] < 0 ? -1.0 : 0.0) * (1.0 - std::exp(-std::fabs(s.w[2]) / w0_rad_s));
      log.push_back(s);
    }
    ++seg;
  };
  for (int pass = 0; pass < 2; ++pass) {
    for (const Pose& f : two_axis_tilts()) run(f, {0.0, 0.0, 0.0}, 6.0);
    for (int k = 0; k < 3; ++k)
      for (const double r_dps : {5.0, 20.0, 60.0, 150.0})
        for (const double sgn : {1.0, -1.0}) {
          Pose f{0.0, 0.0, 0.0};
          std::array<double, 3> w{0.0, 0.0, 0.0};
          f[static_cast<std::size_t>(k)] = g;
          w[static_cast<std::size_t>(k)] = sgn * r_dps * M_PI / 180.0;
          run(f, w, 8.0);
        }
  }
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  const Unexplained* u = nullptr;
  for (const auto& x : r.unexplained)
    if (x.axis == "gyro.z") u = &x;
  ASSERT_NE(u, nullptr) << "gyro.z must be named unexplained";
  ASSERT_FALSE(u->signature.empty());
  EXPECT_EQ(u->signature[0].input, "sign(w_z)");
  EXPECT_GT(u->signature[0].correlation, 0.8);
  // Nothing is selected, and the report's residual plot is drawn for the unexplained axis against the function
  // itself.
  EXPECT_TRUE(r.selected.empty());
  EXPECT_EQ(r.plot_axis, "gyro.z");
  EXPECT_EQ(r.plot_variable, "sign(w_z)");
  EXPECT_FALSE(r.scatter.empty());
  for (const auto& x : r.unexplained) EXPECT_EQ(x.axis.rfind("gyro.z", 0), 0u) << x.axis << " is at its noise";
}

// An accelerometer scale factor that moves with the die's temperature rate (a gradient across the die while it heats
// or cools bends the suspension): accel.x reads c·f_x·Ṫ. No catalog effect has it (temp_rate is a bias in Ṫ,
// scale_temp a scale in T), so the axis is named unexplained, and its signature reads the input times Ṫ (stop 64;
// before, unseen13's tdot_scale read "f_x from 259 s on"). Hand-made log: the two-axis tilts, the die's
// temperature piecewise linear through cooling and heating legs.
TEST(DiagnosisPipeline, AScaleMovingWithTheTemperatureRateIsNamedByTheInputTimesTheRate) {
  const double fs = 100.0, dwell_s = 8.0, c_per_C_s = 4e-3;
  const std::vector<Pose> poses = two_axis_tilts();
  const std::vector<double> knots_C = {25.0, 5.0, 45.0, 10.0, 40.0};
  const int n_dwell = 5 * static_cast<int>(poses.size());
  const int n = static_cast<int>(n_dwell * dwell_s * fs);
  const double legs = static_cast<double>(knots_C.size() - 1), leg_s = n / fs / legs;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  for (int i = 0; i < n; ++i) {
    const int k = static_cast<int>(i / (dwell_s * fs));
    Sample s = referenced_sample(i / fs, k);
    const double x = legs * i / n;
    const auto leg = static_cast<std::size_t>(std::min(static_cast<int>(x), static_cast<int>(legs) - 1));
    s.temp_C = knots_C[leg] + (x - static_cast<double>(leg)) * (knots_C[leg + 1] - knots_C[leg]);
    const double Tdot_C_s = (knots_C[leg + 1] - knots_C[leg]) / leg_s;
    const Pose& f = poses[static_cast<std::size_t>(k) % poses.size()];
    for (int j = 0; j < 3; ++j) {
      s.f[j] = f[static_cast<std::size_t>(j)];
      s.y[j] = s.f[j] + 1e-3 * n01(rng);
      s.y[3 + j] = 5e-4 * n01(rng);
    }
    s.y[0] += c_per_C_s * s.f[0] * Tdot_C_s;
    log.push_back(s);
  }
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  const Unexplained* u = nullptr;
  for (const auto& x : r.unexplained)
    if (x.axis == "accel.x") u = &x;
  ASSERT_NE(u, nullptr) << "accel.x must be named unexplained";
  ASSERT_FALSE(u->signature.empty());
  EXPECT_EQ(u->signature[0].input, "f_x*Tdot");
  EXPECT_GT(std::fabs(u->signature[0].correlation), 0.8);
  for (const auto& x : r.unexplained) EXPECT_EQ(x.axis, "accel.x") << x.axis << " is at its noise";
}

// A gyro whose y and z axes carry a true scale nonlinearity (k2 ω², k3 ω³) and whose x axis carries a bias in the
// rotation speed |ω| (rectified drive or bearing coupling: no catalog effect has it) on a rate table about eight spin
// axes at two speeds, and sines. scale_nonlinearity's x components take part of |ω| (its square and cube on the x
// spins), and the effect passes every earlier check on the strength of y and z; what the x components leave is no
// function of their own signal, so the form check does not see them. Beside the x residual's leading function
// (the signature's first entry, |w|) as a free column they are not significant, and that function still is: a
// stand-in on gyro.x (docs/diagnosis.md § 5, "Stand-in check"), withdrawn there, and the effect kept on y and z,
// where it is the sensor's own. Modelled on `varied17` mixed-w_cubed, where such x components had held gyro.x's
// held-out χ²/dof down to 28 (40.5 without them). Fails with the check off. Hand-made log, independent of host/sim.
// The log, its gyro.x bias c_speed·|ω| (1e-4 in this test; the next one shares the log at another size):
std::vector<Sample> speed_bias_log(double c_speed) {
  const double g = 9.80665, fs = 100.0;
  const double k2y = -1.2e-4, k2z = -1.1e-4, k3z = -1.9e-4;  // blindgen's mixed-w_cubed sizes
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  int seg = 0;
  // A segment at specific force f, turning at w·sin(2π t / period_s) (period_s = 0: at w throughout).
  auto run = [&](const Pose& f, const std::array<double, 3>& w, double dur_s, double period_s = 0.0) {
    for (int i = 0; i < static_cast<int>(dur_s * fs); ++i) {
      Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
      const double k = period_s > 0 ? std::sin(2.0 * M_PI * i / fs / period_s) : 1.0;
      for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = k * w[static_cast<std::size_t>(j)];
      for (int j = 0; j < 3; ++j) {
        s.y[j] = s.f[j] + 2e-3 * n01(rng);
        s.y[3 + j] = s.w[j] + 1e-4 * n01(rng);
      }
      const double speed = std::sqrt(s.w[0] * s.w[0] + s.w[1] * s.w[1] + s.w[2] * s.w[2]);
      s.y[3] += c_speed * speed;
      s.y[4] += k2y * s.w[1] * s.w[1];
      s.y[5] += k2z * s.w[2] * s.w[2] + k3z * s.w[2] * s.w[2] * s.w[2];
      log.push_back(s);
    }
    ++seg;
  };
  const std::array<std::array<double, 3>, 8> dirs{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {0, 1, 1}, {1, -1, 0}, {1, 1, 1}, {-1, 1, 2}}};
  for (const Pose& f : two_axis_tilts()) run(f, {0.0, 0.0, 0.0}, 6.0);
  for (const auto& d : dirs) {
    const double nn = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const std::array<double, 3> n{d[0] / nn, d[1] / nn, d[2] / nn};
    for (const double r_dps : {100.0, 1300.0})
      for (const double sgn : {1.0, -1.0}) {
        const double w_rad_s = sgn * r_dps * M_PI / 180.0;
        run({g * n[0], g * n[1], g * n[2]}, {w_rad_s * n[0], w_rad_s * n[1], w_rad_s * n[2]}, 8.0);
      }
    const double a_rad_s = 300.0 * M_PI / 180.0;
    run({g * n[0], g * n[1], g * n[2]}, {a_rad_s * n[0], a_rad_s * n[1], a_rad_s * n[2]}, 16.0, 4.0);
  }
  return log;
}

TEST(DiagnosisPipeline, ComponentsThatOnlyStandInForTheUnexplainedFunctionAreWithdrawn) {
  const std::vector<Sample> log = speed_bias_log(1e-4);
  VectorSource src(log);
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  const bool selected = std::any_of(r.selected.begin(), r.selected.end(),
                                    [](const Step& st) { return st.sensor + "." + st.effect == "gyro.scale_nonlinearity"; });
  EXPECT_TRUE(selected) << "the sensor's own nonlinearity on y and z";
  const Unexplained* u = nullptr;
  for (const auto& x : r.unexplained)
    if (x.axis == "gyro.x") u = &x;
  ASSERT_NE(u, nullptr) << "gyro.x must be named unexplained";
  std::string sig;
  for (const auto& e : u->signature) sig += e.input + " " + std::to_string(e.correlation) + "; ";
  for (const auto id : imuforge::model::effect_params(imuforge::model::Sensor::kGyro, imuforge::model::Effect::kScaleNonlinearity)) {
    const std::string name = imuforge::model::param_info(id).name;
    if (name.find("scale_nonlinearity.x.") != std::string::npos)
      EXPECT_EQ(r.final_ids.count(id), 0u) << name << ": a stand-in for what gyro.x follows: " << sig;
    if (name == "gyro.scale_nonlinearity.y.k2" || name == "gyro.scale_nonlinearity.z.k2" || name == "gyro.scale_nonlinearity.z.k3")
      EXPECT_EQ(r.final_ids.count(id), 1u) << name << ": the sensor's own";
  }
  const bool warned = std::any_of(r.warnings.begin(), r.warnings.end(), [](const std::string& w) {
    return w.rfind("gyro.scale_nonlinearity kept on gyro.y, gyro.z", 0) == 0 && w.find("stand-in") != std::string::npos;
  });
  EXPECT_TRUE(warned) << "the stand-in check trimmed it (the form check does not see it on this log)";
  for (const auto& x : r.unexplained) EXPECT_EQ(x.axis, "gyro.x") << x.axis << " is at its noise";
}

// The same log with the |ω| bias 50× smaller and the held-out threshold lifted out of reach: gyro.x can be named only
// by the whole-log wander's `follows` check, after selection (docs/diagnosis.md § 5, "Stand-ins on an axis named
// for what it follows"). The stand-in check asks that question first, and what stands in for |w| on x (the
// scale_nonlinearity's x components, and a scale_asymmetry) is withdrawn under the raise |w| beat, the
// nonlinearity kept on y and z. Before stop 55 such an axis kept its stand-ins (`varied23` ooc-abs_rate-1:
// accel.size_effect and cross_coupling beside an accel.y bias in |ω|). Fails with the check off.
TEST(DiagnosisPipeline, StandInsOnAnAxisNamedForWhatItFollowsAreWithdrawn) {
  VectorSource src(speed_bias_log(2e-6));
  Options o;
  o.unexplained_chi2_dof = 1e9;
  const DiagnosisResult r = diagnose(src, basic_model(), o);
  std::string warn;
  for (const auto& w : r.warnings) warn += w + "\n";
  std::printf("wander gyro.x: %s follows %s LR %.1f; selected %zu\n%s", r.wander[3].beyond_reason.c_str(),
              r.wander[3].follows_input.c_str(), r.wander[3].follows.gain, r.selected.size(), warn.c_str());
  const Unexplained* u = nullptr;
  for (const auto& x : r.unexplained)
    if (x.axis == "gyro.x") u = &x;
  ASSERT_NE(u, nullptr) << "gyro.x must be named";
  EXPECT_EQ(u->basis, "wander");
  EXPECT_EQ(r.wander[3].beyond_reason, "follows");
  for (const auto id : imuforge::model::effect_params(imuforge::model::Sensor::kGyro, imuforge::model::Effect::kScaleNonlinearity)) {
    const std::string name = imuforge::model::param_info(id).name;
    if (name.find("scale_nonlinearity.x.") != std::string::npos)
      EXPECT_EQ(r.final_ids.count(id), 0u) << name << ": a stand-in for what gyro.x follows";
    if (name == "gyro.scale_nonlinearity.y.k2" || name == "gyro.scale_nonlinearity.z.k2" || name == "gyro.scale_nonlinearity.z.k3")
      EXPECT_EQ(r.final_ids.count(id), 1u) << name << ": the sensor's own";
  }
  EXPECT_NE(warn.find("a stand-in for what gyro.x follows"), std::string::npos) << warn;
}

// An accelerometer k2 f_x² (and 0.7 of it on y) beside a misalignment that moves with temperature, on tilted static
// poses at four chamber temperatures. With |f| = g on every pose, IEEE 1293's cross-axis squares K_pp f_p² +
// K_oo f_o² at K_pp = K_oo are the same signature, with more components. The catalog effect the sensor has must be
// the one selected: a selected effect that an unselected one nested in its span, with fewer components, can replace
// (the richer one's extra terms not significant beside it) is replaced (docs/diagnosis.md § 5, "A nested
// equivalent"). Without that pass seed 5 selects the cross-axis squares. Hand-made log, independent of host/sim.
// The tilted static poses (two_axis_tilts, 6 s each at 100 Hz) at 10, 25, 40 and 25 °C, white noise of 2e-3 m/s²
// and 5e-4 rad/s, a misalignment of 2e-4 rad/°C (accel.x from f_y) and whatever `add` puts on each sample.
template <class Add>
std::vector<Sample> tilted_thermal_log(unsigned seed, Add add) {
  const double fs = 100.0, mt = 2e-4;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  int seg = 0;
  for (const double T : {10.0, 25.0, 40.0, 25.0})
    for (const Pose& f : two_axis_tilts()) {
      for (int i = 0; i < static_cast<int>(6.0 * fs); ++i) {
        Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
        s.temp_C = T;
        for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = 0.0;
        for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = 5e-4 * n01(rng);
        s.y[0] += mt * (T - 25.0) * s.f[1];
        add(s);
        log.push_back(s);
      }
      ++seg;
    }
  return log;
}

TEST(DiagnosisPipeline, AnAccelerometerK2IsNotReadAsTheCrossAxisSquares) {
  const double k2 = 3e-4;  // 1/(m/s²)
  for (unsigned seed = 1; seed <= 8; ++seed) {
    VectorSource src(tilted_thermal_log(seed, [&](Sample& s) {
      s.y[0] += k2 * s.f[0] * s.f[0];
      s.y[1] += 0.7 * k2 * s.f[1] * s.f[1];
    }));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    std::set<std::string> sel;
    for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
    EXPECT_TRUE(sel.count("accel.scale_nonlinearity")) << "seed " << seed;
    EXPECT_FALSE(sel.count("accel.cross_axis_nonlinearity")) << "seed " << seed;
    EXPECT_TRUE(sel.count("accel.misalign_temp")) << "seed " << seed;
  }
}

// The sensor has both: a k2 f_x² on accel.x and one of IEEE 1293's cross-axis squares on accel.z (K 4e-4 on f_x²),
// beside a misalignment that moves with temperature, on the tilted static poses of the test above. With |f| = g the
// cross-axis effect alone fits all of it (x.yy = x.zz = −k2, the bias taking k2 g²), and k2 is never significant
// beside it; nor is k2 alone a nested equivalent (it has no z.xx). Both effects must be selected: the fitted squares
// on x are equal within their noise, so one k2 column takes their place there (docs/diagnosis.md § 5, "k2 within
// the cross-axis squares"), and the cross-axis effect keeps z.xx; k2 within 4σ of the truth. Without that step
// every seed selects the cross-axis squares alone (`varied29` mixed-angle2, random-22: a true k2 missed).
// Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, AK2BesideCrossAxisSquaresIsSelectedWithThem) {
  const double k2 = 3e-4, kzxx = 4e-4;  // 1/(m/s²)
  for (unsigned seed = 1; seed <= 4; ++seed) {
    VectorSource src(tilted_thermal_log(seed, [&](Sample& s) {
      s.y[0] += k2 * s.f[0] * s.f[0];
      s.y[2] += kzxx * s.f[0] * s.f[0];
    }));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    std::set<std::string> sel;
    for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
    EXPECT_TRUE(sel.count("accel.scale_nonlinearity")) << "seed " << seed;
    EXPECT_TRUE(sel.count("accel.cross_axis_nonlinearity")) << "seed " << seed;
    bool k2_seen = false, squares_on_x = false;
    for (const auto& pe : r.final_params) {
      if (pe.name == "accel.scale_nonlinearity.x.k2") {
        k2_seen = true;
        EXPECT_LT(std::fabs(pe.value - k2), 4.0 * pe.sigma) << "seed " << seed << ": " << pe.value << " +/- " << pe.sigma;
      }
      squares_on_x = squares_on_x || pe.name == "accel.cross_axis_nonlinearity.x.yy" || pe.name == "accel.cross_axis_nonlinearity.x.zz";
    }
    EXPECT_TRUE(k2_seen) << "seed " << seed;
    EXPECT_FALSE(squares_on_x) << "seed " << seed << ": k2 takes their place";
  }
}

// A gyro bias that goes with f_y³ (a cubic g-sensitivity: no catalog effect has it). On the ±1 g faces it equals
// the linear g_sensitivity (f³ = g²·f); on the tilts it departs. The catalog's g_sensitivity removes most of
// it, which must not pass for an explanation: its form check (docs/diagnosis.md § 5) withdraws it and the
// axis is named unexplained, following f_y^3. The control, the same log with a LINEAR g-sensitivity of equal
// size at 1 g, must select g_sensitivity and withdraw nothing. Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, CubicGSensitivityIsNotReadAsLinear) {
  const double g = 9.80665, amp_rad_s = 3e-3;
  std::vector<Pose> poses;  // gravity in the body, tilted in steps of 30° about x, then about y
  for (int k = 0; k < 12; ++k) {
    const double th = k * M_PI / 6.0;
    poses.push_back({0.0, g * std::sin(th), g * std::cos(th)});
    poses.push_back({g * std::sin(th), 0.0, g * std::cos(th)});
  }
  auto make_log = [&](bool cubic) {
    std::mt19937_64 rng(11);
    std::normal_distribution<double> n01;
    return static_pose_log(poses, 2, 8.0, [&](int, const Pose& f, double* y) {
      const double fy = f[1] / g;
      const double bias_y = amp_rad_s * (cubic ? fy * fy * fy : fy);
      for (int j = 0; j < 3; ++j) {
        y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
        y[3 + j] = (j == 1 ? bias_y : 0.0) + 5e-4 * n01(rng);
      }
    });
  };
  auto selected = [](const DiagnosisResult& r) {
    std::set<std::string> sel;
    for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
    return sel;
  };
  auto form_warning = [](const DiagnosisResult& r) {
    for (const auto& w : r.warnings)
      if (w.find("the catalog form does not fit") != std::string::npos) return true;
    return false;
  };
  {
    VectorSource src(make_log(true));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    EXPECT_EQ(selected(r).count("gyro.g_sensitivity"), 0u) << "a cubic read as the linear g-sensitivity";
    EXPECT_TRUE(form_warning(r));
    const Unexplained* u = nullptr;
    for (const auto& x : r.unexplained)
      if (x.axis == "gyro.y") u = &x;
    ASSERT_NE(u, nullptr) << "gyro.y must be named unexplained";
    ASSERT_FALSE(u->signature.empty());
    EXPECT_EQ(u->signature[0].input, "f_y^3");
    EXPECT_GT(std::fabs(u->signature[0].correlation), 0.8);
    // The ranking says what became of it (its "significant" is the first step's).
    bool said = false;
    const auto j = to_json(r);  // a named copy: a range over a temporary's member would dangle
    for (const auto& e : j["ranking"])
      if (e["sensor"] == "gyro" && e["effect"] == "g_sensitivity")
        said = e.value("outcome", std::string()) == "withdrawn: its form does not fit";
    EXPECT_TRUE(said);
  }
  {
    VectorSource src(make_log(false));
    const DiagnosisResult r = diagnose(src, basic_model(), Options{});
    EXPECT_EQ(selected(r).count("gyro.g_sensitivity"), 1u);
    EXPECT_FALSE(form_warning(r));
    EXPECT_TRUE(r.unexplained.empty());
  }
}

// The form check withdraws per axis when the effect stands on its other axes by itself (diagnose.cpp, functional
// form): a true linear g-sensitivity of gyro.z beside the cubic on gyro.y keeps g_sensitivity, without its gyro.y
// components, and gyro.y is still named (`unseen2` mixed-cross_w2 lost a true misalign_temp this way).
TEST(DiagnosisPipeline, AFormThatFailsOnOneAxisIsWithdrawnThereOnly) {
  const double g = 9.80665, amp_rad_s = 3e-3;
  std::vector<Pose> poses;
  for (int k = 0; k < 12; ++k) {
    const double th = k * M_PI / 6.0;
    poses.push_back({0.0, g * std::sin(th), g * std::cos(th)});
    poses.push_back({g * std::sin(th), 0.0, g * std::cos(th)});
  }
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  VectorSource src(static_pose_log(poses, 2, 8.0, [&](int, const Pose& f, double* y) {
    const double fy = f[1] / g, fx = f[0] / g;
    for (int j = 0; j < 3; ++j) y[j] = f[static_cast<std::size_t>(j)] + 2e-3 * n01(rng);
    y[3] = 5e-4 * n01(rng);
    y[4] = amp_rad_s * fy * fy * fy + 5e-4 * n01(rng);
    y[5] = amp_rad_s * fx + 5e-4 * n01(rng);
  }));
  const DiagnosisResult r = diagnose(src, basic_model(), Options{});
  bool selected = false;
  for (const auto& st : r.selected) selected = selected || st.sensor + "." + st.effect == "gyro.g_sensitivity";
  EXPECT_TRUE(selected) << "the true g-sensitivity of gyro.z was withdrawn with the stand-in on gyro.y";
  bool kept_warning = false;
  for (const auto& w : r.warnings) kept_warning = kept_warning || w.find("gyro.g_sensitivity kept on") != std::string::npos;
  EXPECT_TRUE(kept_warning);
  bool y_component = false, zx = false;
  for (const auto& pe : r.final_params) {
    y_component = y_component || pe.name.rfind("gyro.g_sensitivity.y", 0) == 0;
    if (pe.name == "gyro.g_sensitivity.zx") {
      zx = true;
      EXPECT_NEAR(pe.value, amp_rad_s / g, 4.0 * pe.sigma);
    }
  }
  EXPECT_FALSE(y_component) << "its components on gyro.y stand in for the cubic there";
  EXPECT_TRUE(zx);
  bool y_named = false, z_named = false;
  for (const auto& u : r.unexplained) {
    y_named = y_named || u.axis == "gyro.y";
    z_named = z_named || u.axis == "gyro.z";
  }
  EXPECT_TRUE(y_named);
  EXPECT_FALSE(z_named);
}
// The rate table's axis errors (Options::table, docs/diagnosis.md "Fixture errors"). A sensor with nothing beyond the
// base model on a three-axis table whose axes are tilted and whose encoder zeros are offset by 0.01–0.03°: the log's
// reference, computed with the nominal geometry, is off by a pose-dependent rotation (up to 5e-3 m/s² at 1 g) that no
// sensor effect has. Diagnosed without the table, the accelerometer's held-out gap stands far above its noise; with the
// table known, the errors are estimated (each one the campaign determines within 4 σ of the truth), the re-evaluated
// reference leaves every axis at its noise, and nothing is selected. At 50 Hz the errors' derivative is evaluated at
// every sample; at 400 Hz once per group of 4 (the midpoint rule of run_pass1's DerivativeGroup): a group weighted
// wrongly, or evaluated away from its middle, biases the derivative and with it every estimate.
TEST(DiagnosisPipeline, TableAxisErrorsAreEstimatedNotReadAsSensorEffects) {
  using diagtest::json;
  // tilt_a, tilt_b, zero per axis (deg), innermost first: the simulator's true geometry.
  const double err_deg[3][3] = {{0.02, -0.015, 0.01}, {-0.012, 0.025, -0.02}, {0.018, 0.01, 0.03}};
  json axes = json::array();
  for (const auto& e : err_deg) axes.push_back({{"tilt_a_deg", e[0]}, {"tilt_b_deg", e[1]}, {"zero_deg", e[2]}});
  for (const double fs_hz : {50.0, 400.0}) {
    SCOPED_TRACE(fs_hz);
    json campaign = diagtest::rich_campaign({25.0}, fs_hz);
    campaign["simulation"]["fixture_errors"] = {{"axes", axes}};
    // An automotive-grade noise density (the examples' ADIS16470 class: 6e-4 m/s²/√Hz), as a white noise per sample
    // that keeps the block means' noise the same at both rates: at the tests' usual 2e-3 at 50 Hz this short
    // campaign's block means would hide errors of this size.
    const double na = 4e-4 * std::sqrt(fs_hz / 50.0), ng = 4e-5 * std::sqrt(fs_hz / 50.0);
    const json sensor = diagtest::base_sensor(false, {{"accel.white_noise", {{"x", na}, {"y", na}, {"z", na}}},
                                                      {"gyro.white_noise", {{"x", ng}, {"y", ng}, {"z", ng}}}});
    const std::vector<Sample> log = diagtest::simulate(campaign, sensor, 11, true);

    const auto c = imuforge::io::campaign_from_json(campaign);
    double worst_without = 0;
    for (const bool known : {false, true}) {
      if (!known && fs_hz != 50.0) continue;  // the gap without the table is the same at any rate
      VectorSource src(log);
      Options o;
      if (known) o.table = table_of_campaign(c, 3, "rich");
      const DiagnosisResult r = diagnose(src, basic_model(), o);
      std::set<std::string> sel;
      for (const auto& st : r.selected) sel.insert(st.sensor + "." + st.effect);
      if (!known) {
        for (int a = 0; a < 3; ++a) worst_without = std::max(worst_without, r.gap_before.chi2_dof[static_cast<std::size_t>(a)]);
        EXPECT_FALSE(r.fixture_known);
        continue;
      }
      EXPECT_TRUE(r.fixture_known);
      EXPECT_GT(r.fixture_iterations, 0);
      // The verdict says what it is judged against (a person reading "at noise" must know the reference was changed).
      EXPECT_NE(summary_text(r).find("Judged against the reference re-evaluated at the rate table's axis errors"), std::string::npos);
      EXPECT_NE(report_html(r).find("Judged against the reference re-evaluated"), std::string::npos);
      EXPECT_TRUE(sel.empty()) << *sel.begin();
      EXPECT_TRUE(r.unexplained.empty());
      for (int a = 0; a < kNumAxes; ++a) EXPECT_LT(r.gap_after.chi2_dof[static_cast<std::size_t>(a)], 2.0) << axis_name(a);
      ASSERT_EQ(r.fixture_est.n, 9);
      int determined = 0;
      for (int m = 0; m < 9; ++m) {
        const auto um = static_cast<std::size_t>(m);
        const double truth = err_deg[m / 3][m % 3] * M_PI / 180.0, sig = r.fixture_est.sigma_rad[um];
        if (!(sig < 0.3 * o.fixture_prior_rad)) continue;  // held by the prior: the campaign cannot separate it
        ++determined;
        EXPECT_LT(std::fabs(r.fixture_error_rad[um] - truth), 4.0 * sig) << m << ": " << r.fixture_error_rad[um] << " +/- " << sig << " vs " << truth;
      }
      EXPECT_GE(determined, 4);
    }
    if (fs_hz == 50.0) EXPECT_GT(worst_without, 5.0);
  }
}

// A chamber profile (die temperature at t_s): 25 °C, down at 2 °C/min to 10, settling towards 5 (τ 300 s), up at
// 2 °C/min back to 25. It passes 8 °C three times: cooling, settling and heating.
double cool_settle_heat_C(double t_s) {
  if (t_s < 100.0) return 25.0;
  if (t_s < 550.0) return 25.0 - (t_s - 100.0) / 30.0;
  if (t_s < 1200.0) return 5.0 + 5.0 * std::exp(-(t_s - 550.0) / 300.0);
  const double T1 = 5.0 + 5.0 * std::exp(-650.0 / 300.0);
  return std::min(T1 + (t_s - 1200.0) / 30.0, 25.0);
}

// The tests below: a log with an out-of-catalog term off and on, diagnosed with the held-out threshold out of reach
// (as in the tests above). Off: nothing selected or named (a bias walk is wander). On: nothing selected, and gyro.x
// alone named, by the whole-log wander's `follows` check, for a function whose name starts with `named_for`.
template <class Make>
void expect_gyro_x_named_for(Make make, double amp, const BaseModel& base, const std::string& named_for) {
  Options o;
  o.unexplained_chi2_dof = 1e9;
  for (const double a : {0.0, amp}) {
    VectorSource src(make(a));
    const DiagnosisResult r = diagnose(src, base, o);
    std::printf("%.1e: gyro.x wander '%s' follows '%s' LR %.1f; %zu unexplained\n", a, r.wander[3].beyond_reason.c_str(),
                r.wander[3].follows_input.c_str(), r.wander[3].follows.gain, r.unexplained.size());
    EXPECT_TRUE(r.selected.empty());
    if (a == 0.0) {
      EXPECT_TRUE(r.unexplained.empty()) << "a bias walk is wander";
      continue;
    }
    ASSERT_EQ(r.unexplained.size(), 1u);
    EXPECT_EQ(r.unexplained[0].axis, "gyro.x");
    EXPECT_EQ(r.wander[3].beyond_reason, "follows");
    EXPECT_EQ(r.wander[3].follows_input.rfind(named_for, 0), 0u) << r.wander[3].follows_input;
  }
}

// A gyro.x bias bump about one die temperature (Gaussian, 2.5 °C wide, 10 block σ high) on a chamber that cools
// through it, settles near it and heats back through it, beside a bias random walk: no polynomial in T has the
// bump, and the whole log's wander would take it for a walk 20× the dwells' and leave the axis at noise (`unseen5`
// ooc-temp_bump-1, stop 56). No single hat of T matches its shape (the best, LR 12, is far under the bar); the
// curve the hats draw together does (input_group_bias: LR 73 on 10 dof, p 1e-11), and the axis is named for it by
// the wander's `follows` check (the held-out threshold is lifted out of reach, as in the tests above). With the
// bump off the walk is wander (the hats' LR 4.5 on 10 dof) and nothing is named. Fails without the group test.
// Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, ABiasBumpAtOneTemperatureIsNamedForIt) {
  const double fs = 100.0, T0_C = 8.0, width_C = 2.5, K = 1e-7;  // K: rad/s/√s
  const auto temp_at = cool_settle_heat_C;
  auto make = [&](double amp_rad_s) {
    std::mt19937_64 rng(11);
    std::normal_distribution<double> n01;
    std::vector<Sample> log;
    const std::vector<Pose> poses = two_axis_tilts();
    double walk = 0.0;
    for (int seg = 0; seg < 300; ++seg) {
      const Pose& f = poses[static_cast<std::size_t>(seg) % poses.size()];
      for (int i = 0; i < static_cast<int>(6.0 * fs); ++i) {
        Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
        s.temp_C = temp_at(s.t_s);
        walk += K * std::sqrt(1.0 / fs) * n01(rng);
        for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = 0.0;
        for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = 1e-4 * n01(rng);
        s.y[3] += walk + amp_rad_s * std::exp(-0.5 * std::pow((s.temp_C - T0_C) / width_C, 2));
        log.push_back(s);
      }
    }
    return log;
  };
  expect_gyro_x_named_for(make, 4e-5, basic_model(), "a curve in T");
}

// A gyro.x bias that jumps when a rotation stops and settles with τ 8 s (a drive ringing down, a motor's heat),
// beside a bias random walk: the log turns about a vertical body axis, six times back to back (4 s each), then
// holds eight tilted poses for 4–9 s each, the poses changing instantaneously, as blindgen's schedule does. The
// bias takes the transient's mean and the block means read what is left as a wander (`unseen6` ooc-spin_settle:
// left at noise, stop 56). The signature's settling after each turn (Block::settle; LR ~1000) is the function the
// wander's `follows` check finds, and the axis is named for it; with the transient off nothing is named. Without
// those functions the axis is named for |w| (the moving blocks against the still ones, LR 99), which misplaces
// it; the settling after each pose change, restarted at every instantaneous pose change, reads it less well.
// Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, AGyroThatSettlesAfterEachRotationIsNamedForIt) {
  const double fs = 100.0, g = 9.80665, rate_rad_s = 0.6, tau_s = 8.0, K = 1e-7;
  auto make = [&](double amp_rad_s) {
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n01;
    std::uniform_real_distribution<double> u01;
    std::vector<Sample> log;
    const std::vector<Pose> poses = two_axis_tilts();
    double walk = 0.0, t_end = -1.0;
    int seg = 0;
    auto emit = [&](const Pose& f, const std::array<double, 3>& w, double dur_s) {
      for (int i = 0; i < static_cast<int>(dur_s * fs); ++i) {
        Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
        walk += K * std::sqrt(1.0 / fs) * n01(rng);
        for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = w[static_cast<std::size_t>(j)];
        for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = s.w[j] + 1e-4 * n01(rng);
        const bool moving = w[0] != 0.0 || w[1] != 0.0 || w[2] != 0.0;
        if (moving) t_end = s.t_s;
        s.y[3] += walk + (!moving && t_end >= 0.0 ? amp_rad_s * std::exp(-(s.t_s - t_end) / tau_s) : 0.0);
        log.push_back(s);
      }
      ++seg;
    };
    for (int c = 0; c < 20; ++c) {
      for (int m = 0; m < 6; ++m) {
        const int k = (c + m) % 3;
        Pose up{0.0, 0.0, 0.0};
        std::array<double, 3> w{0.0, 0.0, 0.0};
        up[static_cast<std::size_t>(k)] = (m < 3 ? 1.0 : -1.0) * g;
        w[static_cast<std::size_t>(k)] = (m % 2 == 0 ? 1.0 : -1.0) * rate_rad_s;
        emit(up, w, 4.0);
      }
      for (int d = 0; d < 8; ++d) emit(poses[static_cast<std::size_t>(8 * c + d) % poses.size()], {0.0, 0.0, 0.0}, 4.0 + 5.0 * u01(rng));
    }
    return log;
  };
  expect_gyro_x_named_for(make, 2e-4, basic_model(), "settling ");
}

// A gyro.x bias that follows the table motor's heat: the fraction of time turning through a first-order lag (τ 80
// s), rising through each run of rotations and decaying after it, beside a bias random walk. The log turns about
// one body axis held vertical (0.3–1 rad/s, 4 s, either way), two to ten times back to back, between runs of
// four to twelve tilted dwells (4–9 s), the poses changing instantaneously. The bias takes the lag's mean, and
// the settlings after each turn and |w| see only the start of each decay or the turning blocks. Without the
// turning's lag the best function of the library is f_x low-passed at 100 s (LR 14, bar 33) and the axis is left
// at noise, its rest read as a walk 7.6× the dwells' (as `unseen7` ooc-motor_heat-0's accel.z was, stop 57). The
// turning's lag (Block::turn_mem) is the function the wander's `follows` check finds (LR 263), and the axis is
// named for it; with the heat off nothing is named. Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, AGyroThatFollowsTheTableMotorsHeatIsNamedForIt) {
  const double fs = 100.0, g = 9.80665, tau_s = 80.0, K = 1e-7;
  auto make = [&](double amp_rad_s) {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n01;
    std::uniform_real_distribution<double> u01;
    std::vector<Sample> log;
    const std::vector<Pose> poses = two_axis_tilts();
    const double a = 1.0 - std::exp(-1.0 / (fs * tau_s));
    double walk = 0.0, heat = 0.0;
    int seg = 0;
    auto emit = [&](const Pose& f, const std::array<double, 3>& w, double dur_s) {
      const bool moving = w[0] != 0.0 || w[1] != 0.0 || w[2] != 0.0;
      for (int i = 0; i < static_cast<int>(dur_s * fs); ++i) {
        Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
        walk += K * std::sqrt(1.0 / fs) * n01(rng);
        heat += a * ((moving ? 1.0 : 0.0) - heat);
        for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = w[static_cast<std::size_t>(j)];
        for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = s.w[j] + 1e-4 * n01(rng);
        s.y[3] += walk + amp_rad_s * heat;
        log.push_back(s);
      }
      ++seg;
    };
    int pose = 0;
    for (int c = 0; c < 16; ++c) {
      const int n_turns = 2 + static_cast<int>(9.0 * u01(rng));
      for (int m = 0; m < n_turns; ++m) {
        const int k = (c + m) % 3;
        Pose up{0.0, 0.0, 0.0};
        std::array<double, 3> w{0.0, 0.0, 0.0};
        up[static_cast<std::size_t>(k)] = (u01(rng) < 0.5 ? 1.0 : -1.0) * g;
        w[static_cast<std::size_t>(k)] = (u01(rng) < 0.5 ? 1.0 : -1.0) * (0.3 + 0.7 * u01(rng));
        emit(up, w, 4.0);
      }
      const int n_dwells = 4 + static_cast<int>(9.0 * u01(rng));
      for (int d = 0; d < n_dwells; ++d)
        emit(poses[static_cast<std::size_t>(pose++) % poses.size()], {0.0, 0.0, 0.0}, 4.0 + 5.0 * u01(rng));
    }
    return log;
  };
  expect_gyro_x_named_for(make, 2e-4, basic_model(), "turning low-passed");
}

// A gyro.x bias that follows the turns the table has wound up about the vertical since the start (a cable
// without a slip ring, its twist straining the mount), beside a bias random walk. The log turns about one body
// axis held vertical (0.3–1 rad/s, 3–8 s, either way, so the winding wanders up and down) between runs of two to
// eight tilted dwells, the poses changing instantaneously; the bias is 2e-4 rad/s at the largest winding. It holds
// through the dwells after each turn, so the settlings after each turn, the turning's lags and the rates do not
// carry it, and the whole log's wander would take it for a walk. The wound-up rotation (Block::wound_rad) is the
// function the wander's `follows` check finds, and the axis is named for it; with the bias off nothing is named
// (`unseen8` ooc-cable_wrap, stop 59). Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, AGyroThatFollowsTheTurnsWoundUpIsNamedForThem) {
  const double fs = 100.0, g = 9.80665, K = 1e-7;
  auto make = [&](double amp_rad_s) {
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n01;
    std::uniform_real_distribution<double> u01;
    const std::vector<Pose> poses = two_axis_tilts();
    // The schedule first (each turn: its axis, up sign, rate, duration; then the dwells), so that the winding's
    // largest excursion scales the bias.
    struct Seg {
      Pose f;
      std::array<double, 3> w;
      double dur_s;
    };
    std::vector<Seg> segs;
    int pose = 0;
    for (int c = 0; c < 40; ++c) {
      const int k = static_cast<int>(3.0 * u01(rng)) % 3;
      Seg t{{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 3.0 + 5.0 * u01(rng)};
      t.f[static_cast<std::size_t>(k)] = (u01(rng) < 0.5 ? 1.0 : -1.0) * g;
      t.w[static_cast<std::size_t>(k)] = (u01(rng) < 0.5 ? 1.0 : -1.0) * (0.3 + 0.7 * u01(rng));
      segs.push_back(t);
      const int n_dwells = 2 + static_cast<int>(7.0 * u01(rng));
      for (int d = 0; d < n_dwells; ++d)
        segs.push_back({poses[static_cast<std::size_t>(pose++) % poses.size()], {0.0, 0.0, 0.0}, 4.0 + 5.0 * u01(rng)});
    }
    double wound = 0.0, most = 0.0;
    for (const Seg& x : segs) {
      const double up = (x.w[0] * x.f[0] + x.w[1] * x.f[1] + x.w[2] * x.f[2]) / g;  // the rate about the vertical
      wound += up * x.dur_s;
      most = std::max(most, std::fabs(wound));
    }
    std::vector<Sample> log;
    double walk = 0.0;
    wound = 0.0;
    int seg = 0;
    for (const Seg& x : segs) {
      const double up = (x.w[0] * x.f[0] + x.w[1] * x.f[1] + x.w[2] * x.f[2]) / g;
      for (int i = 0; i < static_cast<int>(x.dur_s * fs); ++i) {
        Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
        walk += K * std::sqrt(1.0 / fs) * n01(rng);
        wound += up / fs;
        for (int j = 0; j < 3; ++j) s.f[j] = x.f[static_cast<std::size_t>(j)], s.w[j] = x.w[static_cast<std::size_t>(j)];
        for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = s.w[j] + 1e-4 * n01(rng);
        s.y[3] += walk + amp_rad_s * wound / most;
        log.push_back(s);
      }
      ++seg;
    }
    return log;
  };
  expect_gyro_x_named_for(make, 5e-5, basic_model(), "rotation wound about the vertical (rad)");
}

// The thermal model of the tests below: basic_model() with bias_temp t1 and t2 and scale_temp t1 on both sensors.
BaseModel thermal_base_model() {
  namespace md = imuforge::model;
  BaseModel base = basic_model();
  for (md::Sensor sn : {md::Sensor::kAccel, md::Sensor::kGyro})
    for (md::Effect e : {md::Effect::kBiasTemp, md::Effect::kScaleTemp}) {
      for (md::ParamId id : md::effect_params(sn, e)) {
        const std::string& c = md::param_info(id).component;
        const std::string tail = c.size() > 2 ? c.substr(c.size() - 2) : c;
        if (tail == "t1" || (e == md::Effect::kBiasTemp && tail == "t2")) base.params.push_back(id);
      }
      base.effect_names.push_back(std::string(md::sensor_name(sn)) + (e == md::Effect::kBiasTemp ? ".bias_temp" : ".scale_temp"));
    }
  return base;
}

// The chamber of the two tests below: 25 °C for 300 s, to 55 at 3 °C/min, 900 s held, to 10, 900 s held, back to 25
// and held to 4200 s.
double warm_cool_warm_C(double t) {
  if (t < 300.0) return 25.0;
  if (t < 900.0) return 25.0 + (t - 300.0) / 20.0;
  if (t < 1800.0) return 55.0;
  if (t < 2700.0) return 55.0 - (t - 1800.0) / 20.0;
  if (t < 3600.0) return 10.0;
  return std::min(10.0 + (t - 3600.0) / 20.0, 25.0);
}

// Their log: 4200 s of tilted dwells of 6 s at 100 Hz through warm_cool_warm_C, white noise (2e-3 m/s², 1e-4 rad/s a
// sample), a gyro.x bias random walk of K rad/s/√s, and gyro_x_bias(sample index, temperature) on gyro.x.
std::vector<Sample> tilted_dwells_through_the_chamber(unsigned seed, double K,
                                                      const std::function<double(int, double)>& gyro_x_bias) {
  const double fs = 100.0;
  const int n = static_cast<int>(4200.0 * fs);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<Sample> log;
  const std::vector<Pose> poses = two_axis_tilts();
  double walk = 0.0;
  for (int i = 0; i < n; ++i) {
    const int seg = i / static_cast<int>(6.0 * fs);
    const Pose& f = poses[static_cast<std::size_t>(seg) % poses.size()];
    Sample s = referenced_sample(i / fs, seg);
    s.temp_C = warm_cool_warm_C(s.t_s);
    walk += K * std::sqrt(1.0 / fs) * n01(rng);
    for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = 0.0;
    for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = 1e-4 * n01(rng);
    s.y[3] += walk + gyro_x_bias(i, s.temp_C);
    log.push_back(s);
  }
  return log;
}

// A gyro.x bias in the gradient between the die and a board that lags it by 500 s (the board's copper bending the
// package while the chamber moves the temperature, relaxing as it holds), beside a bias random walk, on
// tilted_dwells_through_the_chamber. The bias is T minus T through a first-order lag of 500 s, 1e-4 rad/s (25 block
// σ) at its largest. The base model's bias_temp takes its part in T, Ṫ (the nearest function before stop 71) reads
// its shape on the ramps only, and the whole log's wander would take the rest for a walk (`unseen17`
// ooc-thermal_gradient: a walk 9x the dwells', the axis left at noise). The die-to-board gradient of the signature
// (Block::T_grad, lags of 1000 and 3000 s: neither of them the bias's own) is what the wander's `follows` check finds;
// with the bias off nothing is named. Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, ABiasInTheDieToBoardGradientIsNamedForIt) {
  const double fs = 100.0, tau_s = 500.0;
  const int n = static_cast<int>(4200.0 * fs);
  std::vector<double> grad(static_cast<std::size_t>(n));
  double lag = warm_cool_warm_C(0.0), most = 0.0;
  const double a = 1.0 - std::exp(-1.0 / (fs * tau_s));
  for (int i = 0; i < n; ++i) {
    const double T = warm_cool_warm_C(i / fs);
    lag += a * (T - lag);
    grad[static_cast<std::size_t>(i)] = T - lag;
    most = std::max(most, std::fabs(T - lag));
  }
  auto make = [&](double amp_rad_s) {
    return tilted_dwells_through_the_chamber(
        71, 1e-7, [&](int i, double) { return amp_rad_s * grad[static_cast<std::size_t>(i)] / most; });
  };
  expect_gyro_x_named_for(make, 1e-4, thermal_base_model(), "T minus T lagged");
}

// A gyro.x bias from a leakage current that doubles every 8 °C (Arrhenius), beside a bias random walk, on
// tilted_dwells_through_the_chamber. The bias is 0 at 10 °C and 1e-4 rad/s at 55 °C. The base model's bias_temp (T
// and T², fitted) takes most of it, and what is left is mostly the next power's shape; the whole log's wander would
// take that for a walk (`unseen18` ooc-temp_exp: the hats of T at LR 49 on 10 dof, under their bar, and the axis left
// at noise). The signature's (T - mean)³ is what the wander's `follows` check finds (LR 54 on 1 dof); with the bias off
// nothing is named. Without the cube this log's bias is named only through the hats together ("a curve in T through
// 10 hats", LR 70 on 10 dof, over their bar of 61); the blind case's, a little weaker against its walk, was under it.
// Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, ABiasCurvedInTemperatureBeyondTheModelsQuadraticIsNamedForTheCube) {
  const double double_C = 8.0, T_lo_C = 10.0, T_hi_C = 55.0;
  const double e0 = std::exp2((T_lo_C - T_hi_C) / double_C);
  auto make = [&](double amp_rad_s) {
    return tilted_dwells_through_the_chamber(72, 1e-7, [&](int, double T) {
      return amp_rad_s * (std::exp2((T - T_hi_C) / double_C) - e0) / (1.0 - e0);
    });
  };
  expect_gyro_x_named_for(make, 1e-4, thermal_base_model(), "(T");
}

// A scatter that appears in the static dwells only while the die's temperature moves is no noise of the sensor
// (TempMotionNoise). Static tilts for 2400 s at 100 Hz: a 600 s soak at 25 C, a ramp to 55 C at 3 C/min, a soak, a
// ramp back. On accel.x a bias sawtooth in T (a coarse temperature sensor's 0.5 C steps, 10 sigma of a sample): the
// soaks never see it, the ramps cross a step every 10 s. Beside it, what must not be named: a stationary
// Gauss-Markov bias on gyro.y (3x the white noise, tau 10 s) that is as colored on a soak as on a ramp, and a large
// bias_temp (T and T^2) on accel.z that the base model carries. Without the sawtooth nothing is named.
TEST(DiagnosisPipeline, ScatterOnlyWhileTheTemperatureMovesIsNamedAndStationaryColoredNoiseIsNot) {
  auto make = [](bool saw) {
    std::mt19937_64 rng(62);
    std::normal_distribution<double> n01;
    const double fs = 100.0, sa = 2e-3, sg = 5e-4, a_gm = std::exp(-1.0 / (fs * 10.0));
    const auto poses = two_axis_tilts();
    std::vector<Sample> log;
    double gm = 0.0;
    const int n = static_cast<int>(2400 * fs);
    for (int i = 0; i < n; ++i) {
      const double t = i / fs;
      const double T = t < 600 ? 25.0 : t < 1200 ? 25.0 + 0.05 * (t - 600) : t < 1800 ? 55.0 : 55.0 - 0.05 * (t - 1800);
      const int seg = i / 2000;  // 20 s per pose
      Sample s = referenced_sample(t, seg);
      s.temp_C = T;
      const Pose& f = poses[static_cast<std::size_t>(seg) % poses.size()];
      gm = a_gm * gm + 3.0 * sg * std::sqrt(1.0 - a_gm * a_gm) * n01(rng);
      for (int j = 0; j < 3; ++j) {
        s.f[j] = f[static_cast<std::size_t>(j)];
        s.y[j] = s.f[j] + sa * n01(rng);
        s.y[3 + j] = sg * n01(rng);
      }
      if (saw) {
        const double x = T / 0.5;
        s.y[0] += 10.0 * sa * 2.0 * (x - std::round(x));
      }
      s.y[2] += 1e-3 * (T - 25.0) + 3e-5 * (T - 25.0) * (T - 25.0);
      s.y[4] += gm;
      log.push_back(s);
    }
    return log;
  };
  const BaseModel base = thermal_base_model();
  VectorSource src(make(true));
  const DiagnosisResult r = diagnose(src, base, Options{});
  EXPECT_TRUE(r.temp_motion[0].flagged) << "ratio " << r.temp_motion[0].ratio << " z " << r.temp_motion[0].z;
  for (int a = 1; a < 6; ++a)
    EXPECT_FALSE(r.temp_motion[static_cast<std::size_t>(a)].flagged)
        << axis_name(a) << ": ratio " << r.temp_motion[static_cast<std::size_t>(a)].ratio << " z " << r.temp_motion[static_cast<std::size_t>(a)].z;
  EXPECT_GT(r.temp_motion[4].moving_s, 500.0) << "both records are there to compare";
  EXPECT_GT(r.temp_motion[4].holding_s, 500.0);
  bool x_named = false;
  for (const auto& u : r.unexplained) {
    EXPECT_EQ(u.axis, "accel.x") << "only the sawtooth's axis is named (" << u.basis << ")";
    x_named = x_named || u.axis == "accel.x";
  }
  EXPECT_TRUE(x_named);
  const auto lines = verdict_lines(r);
  ASSERT_GE(lines.size(), 1u);
  EXPECT_NE(lines[0].find("not explained by any effect in the catalog"), std::string::npos) << lines[0];
  VectorSource quiet(make(false));
  const DiagnosisResult q = diagnose(quiet, base, Options{});
  for (int a = 0; a < 6; ++a) EXPECT_FALSE(q.temp_motion[static_cast<std::size_t>(a)].flagged) << axis_name(a);
  EXPECT_TRUE(q.unexplained.empty());
}

// One accelerometer axis sampled 3 ms after the other two (a multiplexed converter; AxisTiming): the catalog's
// timing is one per triad, so the diagnosis must not report the triad late, and must name the axis. A log of 60
// segments of 20 s: 10 s static, then 5 periods of a 0.5 Hz swing (1 rad/s peak, starting and stopping at its peak
// rate, as the blind generator's steps do) about a tilted body axis, so that every accel axis sees gravity turn. With all three axes 3 ms late instead, the triad's timing is selected and no
// axis is odd.
TEST(DiagnosisPipeline, OneAxisSampledLateIsNamedAndNotReadAsTheTriadsLatency) {
  auto make = [](bool all_late) {
    std::mt19937_64 rng(63);
    std::normal_distribution<double> n01;
    const double fs = 100.0, g = 9.80665, w0 = 2.0 * M_PI * 0.5, A = 1.0, lag_s = 3e-3;
    const double nn = 1.0 / std::sqrt(3.0);
    const double n[3] = {nn, -nn, nn};
    auto theta = [&](double t, double th0) {  // the swing's angle, seg-local time t
      return t < 10.0 ? th0 : th0 + (A / w0) * std::sin(w0 * (t - 10.0));
    };
    auto gravity = [&](double th, int j) {  // gravity (0, 0, g) rotated by −th about n, component j
      const double gv[3] = {0.0, 0.0, g};
      const double c = std::cos(th), sn = std::sin(th), ndg = n[2] * g;
      const double cr[3] = {gv[1] * n[2] - gv[2] * n[1], gv[2] * n[0] - gv[0] * n[2], gv[0] * n[1] - gv[1] * n[0]};  // g × n
      return gv[j] * c + cr[j] * sn + n[j] * ndg * (1.0 - c);
    };
    std::vector<Sample> log;
    for (int seg = 0; seg < 60; ++seg) {
      const double th0 = 0.37 * seg;
      for (int i = 0; i < static_cast<int>(20 * fs); ++i) {
        const double tl = i / fs;
        Sample s = referenced_sample(seg * 20.0 + tl, seg);
        const double th = theta(tl, th0), thl = theta(tl - lag_s, th0);
        const double rate = tl < 10.0 ? 0.0 : A * std::cos(w0 * (tl - 10.0));
        for (int j = 0; j < 3; ++j) {
          s.f[j] = gravity(th, j);
          s.w[j] = rate * n[j];
          const bool late = all_late || j == 1;
          s.y[j] = (late ? gravity(thl, j) : s.f[j]) + 2e-3 * n01(rng);
          s.y[3 + j] = s.w[j] + 5e-4 * n01(rng);
        }
        log.push_back(s);
      }
    }
    return log;
  };
  VectorSource one(make(false));
  const DiagnosisResult r = diagnose(one, basic_model(), Options{});
  for (const auto& st : r.selected) EXPECT_FALSE(st.sensor == "accel" && st.effect == "timing") << "one axis late is not the triad late";
  EXPECT_TRUE(r.axis_timing[1].odd);
  EXPECT_NEAR(r.axis_timing[1].latency_s - r.axis_timing[1].others_s, 3e-3, 5.0 * std::hypot(r.axis_timing[1].sigma_s, r.axis_timing[1].others_sigma_s));
  EXPECT_FALSE(r.axis_timing[0].odd);
  EXPECT_FALSE(r.axis_timing[2].odd);
  ASSERT_EQ(r.unexplained.size(), 1u);
  EXPECT_EQ(r.unexplained[0].axis, "accel.y");
  EXPECT_EQ(r.unexplained[0].basis, "axis_timing");
  const auto lines = verdict_lines(r);
  ASSERT_GE(lines.size(), 2u);
  EXPECT_NE(lines[1].find("an axis sampled at an instant of its own"), std::string::npos) << lines[1];
  VectorSource all(make(true));
  const DiagnosisResult q = diagnose(all, basic_model(), Options{});
  bool timing = false;
  for (const auto& st : q.selected) timing = timing || (st.sensor == "accel" && st.effect == "timing");
  EXPECT_TRUE(timing) << "three axes late are the triad late";
  for (int a = 0; a < 6; ++a) EXPECT_FALSE(q.axis_timing[static_cast<std::size_t>(a)].odd) << axis_name(a);
  EXPECT_TRUE(q.unexplained.empty());
}

// A table that ramps its rate up from rest and back down (as real tables do; the blind generator's steps are
// instantaneous): 40 segments of 8 s held at a tilt, a 2 s (1 − cos) ramp to 0.5 rad/s about the vertical, 4 s
// turning, a 2 s ramp down and 4 s held again. Each dwell must keep a static block (blocks cut where the rate
// crosses the static bar, Options::cut_at_motion_bar): before, the ramp's first samples joined the dwell's block
// (cut only once the rate had moved by block_w_tol), which was then not static: half the dwells were lost to the
// Allan curve and the noise fit (40 static blocks of 80, accel white noise read 8 % low). With the cut, every
// dwell is static, and the white noise the Allan curve gives is the one the log was written with (within 5 %).
TEST(DiagnosisPipeline, DwellsLeftAndReachedBySmoothRampsKeepTheirStaticBlocks) {
  const double fs = 100.0, sa = 2e-3, sg = 5e-4;
  std::mt19937_64 rng(65);
  std::normal_distribution<double> n01;
  const auto poses = two_axis_tilts();
  std::vector<Sample> log;
  for (int seg = 0; seg < 40; ++seg) {
    const Pose& f = poses[static_cast<std::size_t>(seg) % poses.size()];
    for (int i = 0; i < static_cast<int>(20 * fs); ++i) {
      const double tl = i / fs;
      const double ramp = tl < 8.0 ? 0.0 : tl < 10.0 ? 0.5 * (1.0 - std::cos(M_PI * (tl - 8.0) / 2.0)) : tl < 14.0 ? 1.0
                        : tl < 16.0 ? 0.5 * (1.0 + std::cos(M_PI * (tl - 14.0) / 2.0)) : 0.0;
      Sample s = referenced_sample(seg * 20.0 + tl, seg);
      for (int j = 0; j < 3; ++j) {
        s.f[j] = f[static_cast<std::size_t>(j)];  // turning about the gravity vector: f stays
        s.w[j] = 0.5 * ramp * f[static_cast<std::size_t>(j)] / 9.80665;
        s.y[j] = s.f[j] + sa * n01(rng);
        s.y[3 + j] = s.w[j] + sg * n01(rng);
      }
      log.push_back(s);
    }
  }
  for (const bool cut : {false, true}) {
    VectorSource src(log);
    Options o;
    o.cut_at_motion_bar = cut;
    const DiagnosisResult r = diagnose(src, basic_model(), o);
    if (!cut) {
      EXPECT_LE(r.n_static_blocks, 40) << "the defect this guards against: one dwell of each segment lost to its ramp";
      continue;
    }
    EXPECT_GE(r.n_static_blocks, 2 * 40) << "both dwells of every segment";
    for (int a = 0; a < 6; ++a) {
      const double truth = (a < 3 ? sa : sg) / std::sqrt(fs);  // white noise density, unit/√Hz
      EXPECT_NEAR(r.noise[static_cast<std::size_t>(a)].terms.N, truth, 0.05 * truth) << axis_name(a);
    }
    EXPECT_TRUE(r.selected.empty());
    EXPECT_TRUE(r.unexplained.empty());
  }
}

// The log of the two tests below, at 100 Hz: 100 turns about body axis `up` held vertical (either way up, ±0.5 rad/s,
// 3–6 s, either direction, in no regular order: a period would be named before the curve), each followed by one to
// three tilted dwells of 4–9 s; the die at temp_at(t); white noise 2e-3 m/s² and 1e-4 rad/s, and on output `out`
// (3 + gyro axis) a bias random walk of 1e-7 rad/s/√s plus term(sample). Drawn from `seed`.
template <class Temp, class Term>
std::vector<Sample> turns_between_tilts(std::uint64_t seed, int up, int out, Temp temp_at, Term term) {
  const double fs = 100.0, g = 9.80665, K = 1e-7, rate_rad_s = 0.5;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u01;
  std::vector<Sample> log;
  const std::vector<Pose> poses = two_axis_tilts();
  double walk = 0.0;
  int seg = 0;
  auto emit = [&](const Pose& f, double w_up, double dur_s) {
    for (int i = 0; i < static_cast<int>(dur_s * fs); ++i) {
      Sample s = referenced_sample(static_cast<double>(log.size()) / fs, seg);
      s.temp_C = temp_at(s.t_s);
      walk += K * std::sqrt(1.0 / fs) * n01(rng);
      for (int j = 0; j < 3; ++j) s.f[j] = f[static_cast<std::size_t>(j)], s.w[j] = 0.0;
      s.w[up] = w_up;
      for (int j = 0; j < 3; ++j) s.y[j] = s.f[j] + 2e-3 * n01(rng), s.y[3 + j] = s.w[j] + 1e-4 * n01(rng);
      s.y[out] += walk + term(s);
      log.push_back(s);
    }
    ++seg;
  };
  for (int c = 0; c < 100; ++c) {
    Pose vertical{0.0, 0.0, 0.0};
    vertical[static_cast<std::size_t>(up)] = u01(rng) < 0.5 ? g : -g;
    emit(vertical, (u01(rng) < 0.5 ? 1.0 : -1.0) * rate_rad_s, 3.0 + 3.0 * u01(rng));
    const int dwells = 1 + static_cast<int>(3.0 * u01(rng));
    for (int d = 0; d < dwells; ++d) emit(poses[static_cast<std::size_t>(3 * c + d) % poses.size()], 0.0, 4.0 + 5.0 * u01(rng));
  }
  return log;
}

// A gyro.x scale factor that bumps about one die temperature (Gaussian, 2.5 °C wide, 6e-5 high: a drive loop's
// resonance crossing) on the chamber profile of the test above, the log turning about body x held vertical (±0.5
// rad/s, 3–6 s, either way, in no regular order) between one to three tilted dwells, beside a bias random walk;
// the model has the thermal terms (bias_temp t1 t2, scale_temp t1), whose line in T takes none of the bump. No
// single function reaches the bar (the best, ω_x·time, LR 28 against 33), nor do the bias's hats of T together
// (the bump is in the rotating blocks only, of either sign); ω_x times each hat, together (input_group_bias),
// draw it (LR 185 on 10 dof), and the axis is named for a scale curve in T (`unseen6` ooc-scale_bump-0, stop
// 57). At 8e-5 the spread's dependence on the input names the axis first ("input"). With the bump off nothing
// is named. Fails without the scale's group. Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, AScaleBumpAtOneTemperatureIsNamedForIt) {
  const double T0_C = 8.0, width_C = 2.5;
  auto make = [&](double amp) {
    return turns_between_tilts(17, 0, 3, cool_settle_heat_C, [&](const Sample& s) {
      return amp * std::exp(-0.5 * std::pow((s.temp_C - T0_C) / width_C, 2)) * s.w[0];
    });
  };
  const BaseModel base = thermal_base_model();
  expect_gyro_x_named_for(make, 6e-5, base, "a scale curve in T");
}

// A gyro whose mount slips once mid-run: gyro.z reads θ ω_y from then on (a misalignment step of 3e-5 to 7e-5 rad),
// the log turning about body y held vertical (±0.5 rad/s, 3–6 s, either way) between one to three tilted dwells,
// beside a bias random walk, the model with the thermal terms; the chamber cools through the slip and warms part of
// the way back later. gyro.misalign_temp (ω_y (T − T_ref) on gyro.z) takes much of the step and is significant, and
// gyro.z, within the held-out threshold, is named for following ω_y·time (at 5e-5: for a spread growing with the
// input), which does not take the temperature coefficient's place (beside it the coefficient keeps LR 46–91). The
// stand-in check asks the input times a step as well (`unseen9` ooc-mount_slip-1): the step is found within a block
// of the slip, beside it the coefficient has LR 1.8–3.5, and it is withdrawn; gyro.z stays named. With the slip off
// nothing is selected or named. Fails without the step. Hand-made log, independent of host/sim.
TEST(DiagnosisPipeline, AMisalignmentThatStepsMidRunIsNotReadAsATemperatureCoefficient) {
  const double t_slip_s = 800.0;
  // Held at 25 °C, cooled at 4 °C/min through the slip, held at 5 °C, warmed back to 20 °C and held: colder after
  // the slip than before, but not one step of temperature.
  auto temp_at = [](double t_s) {
    return t_s < 600.0 ? 25.0 : t_s < 900.0 ? 25.0 - (t_s - 600.0) / 15.0 : t_s < 1200.0 ? 5.0 : std::min(5.0 + (t_s - 1200.0) / 20.0, 20.0);
  };
  auto make = [&](double theta_rad) {
    return turns_between_tilts(23, 1, 5, temp_at, [&](const Sample& s) { return s.t_s >= t_slip_s ? theta_rad * s.w[1] : 0.0; });
  };
  const BaseModel base = thermal_base_model();
  for (const double theta : {0.0, 3e-5, 5e-5, 7e-5}) {
    VectorSource src(make(theta));
    const DiagnosisResult r = diagnose(src, base, Options{});
    std::string sel, une;
    for (const auto& st : r.selected) sel += st.sensor + "." + st.effect + " ";
    for (const auto& u : r.unexplained) une += u.axis + " ";
    std::printf("theta %.1e: selected [%s] unexplained [%s]\n", theta, sel.c_str(), une.c_str());
    EXPECT_TRUE(r.selected.empty()) << sel;
    if (theta == 0.0) {
      EXPECT_TRUE(r.unexplained.empty()) << une;
      continue;
    }
    EXPECT_EQ(r.unexplained.size(), 1u) << une;
    if (r.unexplained.empty()) continue;
    EXPECT_EQ(r.unexplained[0].axis, "gyro.z");
    // Its signature's first input reads the step, within a few blocks of the slip, ahead of ω_y·time (the
    // residual's own segment means may lead: one block per dwell).
    const auto& sig = r.unexplained[0].signature;
    const auto first = std::find_if(sig.begin(), sig.end(), [](const SignatureEntry& e) { return e.input != "segment"; });
    ASSERT_NE(first, sig.end());
    std::printf("  signature's first input: %s (r %.2f)\n", first->input.c_str(), first->correlation);
    double t0_s = 0;
    ASSERT_EQ(std::sscanf(first->input.c_str(), "w_y from %lf s on", &t0_s), 1) << first->input;
    EXPECT_NEAR(t0_s, t_slip_s, 30.0);
  }
}

}  // namespace diagnosis_diagnosis_unit_test
