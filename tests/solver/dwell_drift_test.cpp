// The solver's σ under drift between dwells (docs/calibration.md, "Dwell drift"), by coverage over many
// synthetic runs: a random offset per dwell, and a Gauss-Markov wander along a thermal schedule. Statistical
// (hundreds of solves), so `nosan`: the drift code runs under ASan+UBSan in tests/estimator/drift_test.cpp and in
// solver_fixture_test's solves.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"
#include "tests/solver/synth.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_dwell_drift_test {

using namespace imuforge;
using namespace imuforge::solver;
using synth::sigma_of;
using synth::thermal_spec;

// The drift-widened σ covers: 200 runs with a random offset per dwell on gyro.x (τ = 3e-4 rad/s, 9× σ²/n). The
// parameters acting on gyro.x scatter about the truth by their σ (RMS z within 0.7–1.25); with σ from the white
// static noise alone they scatter ~3× it. Nothing moves on the other channels, and the estimate is the same
// either way.
TEST(DwellDriftCoverage, WidenedSigmaCoversARandomOffsetPerDwell) {
  synth::Config cfg;
  cfg.plateaus_C = {10, 25, 40};
  const auto spec = thermal_spec();
  nlohmann::json off_j = nlohmann::json::parse(std::ifstream(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json"));
  off_j["dwell_scatter"] = false;
  const auto spec_white = synth::unguarded(model::model_spec_from_json(off_j));
  const auto truth = synth::truth_params();
  const Sigma6 sig = sigma_of(cfg);
  const double tau = 3e-4;
  const double lsb = synth::meta(cfg).gyro_lsb_rad_s;
  double zz_wide = 0, zz_white = 0, zz_other = 0;
  int n_x = 0, n_other = 0, adopted_other = 0;
  for (int run = 0; run < 200; ++run) {
    std::mt19937_64 rng(1000 + run);
    std::normal_distribution<double> n01;
    FixtureAccumulator acc(spec, synth::meta(cfg)), acc_white(spec_white, synth::meta(cfg));
    int seg = -1;
    double off = 0.0;
    synth::generate(cfg, truth, 500 + std::uint64_t(run), [&](const io::LogRow& r0) {
      io::LogRow r = r0;
      if (r.segment >= 0) {
        if (r.segment != seg) {
          seg = r.segment;
          off = tau * n01(rng);
        }
        r.raw[3] += static_cast<std::int32_t>(std::lround(off / lsb));
      }
      acc.add(r);
      acc_white.add(r);
    });
    acc.finish();
    acc_white.finish();
    ChannelDrifts drifts;
    const FixtureSolution wide = solve_fixture_widened(acc, sig, nullptr, &drifts);
    const FixtureSolution white = solve_fixture_widened(acc_white, sig);
    ASSERT_TRUE(drifts[3].adopted) << run;
    for (int c = 0; c < kNumChannels; ++c) adopted_other += c != 3 && drifts[size_t(c)].adopted;
    for (size_t i = 0; i < wide.estimate.names.size(); ++i) {
      const std::string& nm = wide.estimate.names[i];
      const auto& pi = model::param_info(model::find_param(nm));
      const double err = wide.estimate.value[long(i)] - truth.get(nm);
      ASSERT_NEAR(wide.estimate.value[long(i)], white.estimate.value[long(i)], 1e-9 * wide.estimate.sigma()[long(i)]) << nm;
      if (pi.sensor == model::Sensor::kGyro && pi.j == 0) {
        zz_wide += std::pow(err / wide.estimate.sigma()[long(i)], 2);
        zz_white += std::pow(err / white.estimate.sigma()[long(i)], 2);
        ++n_x;
      } else {
        zz_other += std::pow(err / wide.estimate.sigma()[long(i)], 2);
        ++n_other;
      }
    }
  }
  const double rms_wide = std::sqrt(zz_wide / n_x), rms_white = std::sqrt(zz_white / n_x), rms_other = std::sqrt(zz_other / n_other);
  RecordProperty("rms_z_widened", std::to_string(rms_wide));
  EXPECT_GT(rms_wide, 0.7);
  EXPECT_LT(rms_wide, 1.25);
  EXPECT_GT(rms_white, 2.0);
  EXPECT_GT(rms_other, 0.8);
  EXPECT_LT(rms_other, 1.25);
  // White channels: a drift adopted past 5.99 by chance now and then (≈ 5 % of 1000 channel fits).
  EXPECT_LT(adopted_other, 100) << adopted_other;
}

// A bias that wanders across the campaign (a Gauss-Markov drift on gyro.x, τ 40 s over a 100 s campaign of five
// plateaus in rising order, stationary σ 3× σ/√n of a dwell mean) moves with the temperature schedule: bias_temp
// takes it, and a per-dwell offset model does not see it. The drift fitted to the dwell means carries it: the
// gyro.x parameters' RMS z stays near 1 (white σ: several).
TEST(DwellDriftCoverage, DriftWidenedSigmaCoversABiasWanderAlongTheSchedule) {
  synth::Config cfg;
  cfg.plateaus_C = {-10, 5, 20, 35, 50};
  const auto spec = thermal_spec();
  const auto truth = synth::truth_params();
  const Sigma6 sig = sigma_of(cfg);
  const double gm_sigma = 3e-4, gm_tau_s = 40.0;
  const double lsb = synth::meta(cfg).gyro_lsb_rad_s;
  double zz_wide = 0, zz_white = 0, zz_bt = 0;
  int n_x = 0, n_bt = 0;
  for (int run = 0; run < 100; ++run) {
    std::mt19937_64 rng(7000 + run);
    std::normal_distribution<double> n01;
    FixtureAccumulator acc(spec, synth::meta(cfg));
    double g = gm_sigma * n01(rng), t_prev = 0.0;
    const double phi_dt = std::exp(-1.0 / cfg.rate_hz / gm_tau_s);
    synth::generate(cfg, truth, 9000 + std::uint64_t(run), [&](const io::LogRow& r0) {
      io::LogRow r = r0;
      for (double t = t_prev; t < r.t_s - 1e-12; t += 1.0 / cfg.rate_hz)
        g = phi_dt * g + gm_sigma * std::sqrt(1 - phi_dt * phi_dt) * n01(rng);
      t_prev = r.t_s;
      if (r.segment >= 0) r.raw[3] += static_cast<std::int32_t>(std::lround(g / lsb));
      acc.add(r);
    });
    acc.finish();
    ChannelDrifts drifts;
    const FixtureSolution wide = solve_fixture_widened(acc, sig, nullptr, &drifts);
    const FixtureSolution white = solve_fixture(acc, sig);
    EXPECT_TRUE(drifts[3].adopted) << run;
    for (size_t i = 0; i < wide.estimate.names.size(); ++i) {
      const std::string& nm = wide.estimate.names[i];
      const auto& pi = model::param_info(model::find_param(nm));
      if (!(pi.sensor == model::Sensor::kGyro && pi.j == 0)) continue;
      const double err = wide.estimate.value[long(i)] - truth.get(nm);
      const double z = err / wide.estimate.sigma()[long(i)];
      zz_wide += z * z;
      zz_white += std::pow(err / white.estimate.sigma()[long(i)], 2);
      ++n_x;
      if (nm.rfind("gyro.bias_temp.", 0) == 0) {
        zz_bt += z * z;
        ++n_bt;
      }
    }
  }
  const double rms_wide = std::sqrt(zz_wide / n_x), rms_white = std::sqrt(zz_white / n_x), rms_bt = std::sqrt(zz_bt / n_bt);
  RecordProperty("rms_z_widened", std::to_string(rms_wide));
  RecordProperty("rms_z_white", std::to_string(rms_white));
  RecordProperty("rms_z_bias_temp", std::to_string(rms_bt));
  EXPECT_GT(rms_white, 2.5);
  EXPECT_GT(rms_wide, 0.5);
  EXPECT_LT(rms_wide, 1.3);
  EXPECT_LT(rms_bt, 1.3);
}
}  // namespace solver_dwell_drift_test
