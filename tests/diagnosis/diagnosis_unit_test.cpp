#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "host/diagnosis/stats.h"
#include "tests/diagnosis/sim_helpers.h"

using namespace imuforge::diagnosis;

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
  EXPECT_NE(summary_text(r).find("g_sensitivity"), std::string::npos);
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
