// Fixture mode on synthetic campaigns generated through the catalog's measurement function.
#include <gtest/gtest.h>

#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"
#include "host/solver/srif.h"
#include "host/solver/traditional.h"
#include "tests/solver/synth.h"

using namespace imuforge;
using namespace imuforge::solver;

namespace {
model::ModelSpec thermal_spec() { return model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json"); }
Sigma6 sigma_of(const synth::Config& c) {
  Sigma6 s;
  for (int k = 0; k < 6; ++k) s[size_t(k)] = c.sigma[k];
  return s;
}
}  // namespace

TEST(FixtureMode, RecoversThermalModelWithinSigma) {
  synth::Config cfg;
  cfg.plateaus_C = {-10, 25, 60};
  const auto truth = synth::truth_params();
  FixtureAccumulator acc(thermal_spec(), synth::meta(cfg));
  synth::generate(cfg, truth, 5, [&](const io::LogRow& r) { acc.add(r); });
  acc.finish();
  EXPECT_EQ(acc.plateaus().size(), 3u);
  FixtureSolution sol = solve_fixture(acc, sigma_of(cfg));
  const auto& e = sol.estimate;
  ASSERT_EQ(e.names.size(), 42u);  // 2 × (3 bias + 3 scale + 6 misalign + 6 bias_temp + 3 scale_temp)
  double worst = 0;
  for (size_t i = 0; i < e.names.size(); ++i) {
    const double z = (e.value[long(i)] - truth.get(e.names[i])) / e.sigma()[long(i)];
    worst = std::max(worst, std::abs(z));
  }
  EXPECT_LT(worst, 4.5);
  for (int c = 0; c < 6; ++c) EXPECT_NEAR(sol.residual_rms[size_t(c)], cfg.sigma[c], 0.05 * cfg.sigma[c]);
  // The within-dwell noise estimate sees the noise (drift across a dwell is modelled, so it barely leaks in).
  const Sigma6 est = acc.static_noise_sigma();
  for (int c = 0; c < 6; ++c) EXPECT_NEAR(est[size_t(c)], cfg.sigma[c], 0.1 * cfg.sigma[c]);
  EXPECT_EQ(sol.observability.rank, 42);
}

TEST(FixtureMode, SingleTemperatureCannotSeparateTemperatureTerms) {
  synth::Config cfg;
  cfg.plateaus_C = {25};
  cfg.drift_C = 0.0;
  FixtureAccumulator acc(thermal_spec(), synth::meta(cfg));
  synth::generate(cfg, synth::truth_params(), 1, [&](const io::LogRow& r) { acc.add(r); });
  acc.finish();
  try {
    solve_fixture(acc, sigma_of(cfg));
    FAIL() << "solved a campaign without temperature excitation";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("bias_temp"), std::string::npos) << e.what();
  }
}

TEST(FixtureMode, PerPlateauModelReturnsOneValuePerPlateau) {
  synth::Config cfg;
  cfg.plateaus_C = {0, 40};
  nlohmann::json j = {{"name", "pp"},
                      {"effects", {{"accel.bias", {{"per_plateau", true}}}, {"accel.scale", nlohmann::json::object()}, {"accel.misalign", nlohmann::json::object()},
                                   {"gyro.bias", {{"per_plateau", true}}}, {"gyro.scale", nlohmann::json::object()}, {"gyro.misalign", nlohmann::json::object()}}}};
  const auto spec = model::model_spec_from_json(j);
  auto truth = synth::truth_params();
  for (const char* s : {"accel", "gyro"})
    for (const char* c : {"x", "y", "z"}) {
      truth.set(std::string(s) + ".scale_temp." + c + ".t1", 0.0);
      truth.set(std::string(s) + ".bias_temp." + c + ".t2", 0.0);
    }
  FixtureAccumulator acc(spec, synth::meta(cfg));
  synth::generate(cfg, truth, 2, [&](const io::LogRow& r) { acc.add(r); });
  acc.finish();
  FixtureSolution sol = solve_fixture(acc, sigma_of(cfg));
  const int i0 = sol.estimate.index_of("accel.bias.x@plateau0"), i1 = sol.estimate.index_of("accel.bias.x@plateau1");
  ASSERT_GE(i0, 0);
  ASSERT_GE(i1, 0);
  // bias(T) = b + b1 τ + b2 τ² at the plateau temperatures (drift is symmetric about the plateau mean).
  for (int p = 0; p < 2; ++p) {
    const double tau = acc.plateaus()[size_t(p)].T_C - 25.0;
    const double tr = truth.get("accel.bias.x") + truth.get("accel.bias_temp.x.t1") * tau +
                      truth.get("accel.bias_temp.x.t2") * tau * tau;
    const int i = p ? i1 : i0;
    EXPECT_LT(std::abs(sol.estimate.value[i] - tr), 4 * sol.estimate.sigma()[i] + 1e-7) << p;
  }
}

TEST(FixtureMode, RecursiveEqualsBatchWithin1e6Sigma) {
  synth::Config cfg;
  cfg.plateaus_C = {-10, 25, 60};
  const auto spec = thermal_spec();
  FixtureAccumulator acc(spec, synth::meta(cfg));
  const Sigma6 sig = sigma_of(cfg);
  std::unique_ptr<SquareRootInformationFilter> srif;
  int first_complete = -1;
  acc.on_segment = [&](const SegmentSummary& s, const ChannelSet& cs) {
    if (!srif) srif = std::make_unique<SquareRootInformationFilter>(acc.names());
    const NormalEquations ne = acc.segment_normal_equations(cs, sig);
    srif->add_information(ne.info, ne.rhs);
    if (first_complete < 0 && srif->complete()) first_complete = s.segment;
  };
  synth::generate(cfg, synth::truth_params(), 9, [&](const io::LogRow& r) { acc.add(r); });
  acc.finish();
  const FixtureSolution batch = solve_fixture(acc, sig);
  const Estimate rec = srif->estimate();
  EXPECT_GE(first_complete, 20);  // temperature terms need the second plateau (segments 20+)
  for (size_t i = 0; i < rec.names.size(); ++i) {
    EXPECT_LT(std::abs(rec.value[long(i)] - batch.estimate.value[long(i)]), 1e-6 * batch.estimate.sigma()[long(i)])
        << rec.names[i];
    EXPECT_LT(std::abs(rec.sigma()[long(i)] - batch.estimate.sigma()[long(i)]), 1e-6 * batch.estimate.sigma()[long(i)]);
  }
}

TEST(FixtureMode, TraditionalMatchesInverseOnCleanData) {
  synth::Config cfg;
  cfg.plateaus_C = {25};
  cfg.drift_C = 0.0;
  auto truth = synth::truth_params();
  const auto spec = model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
  FixtureAccumulator acc(spec, synth::meta(cfg));
  synth::generate(cfg, truth, 4, [&](const io::LogRow& r) { acc.add(r); });
  acc.finish();
  const TraditionalResult tr = solve_traditional(acc.segments(), 25.0);
  const FixtureSolution inv = solve_fixture(acc, sigma_of(cfg));
  ASSERT_EQ(tr.estimate.names.size(), 24u);
  for (size_t i = 0; i < tr.estimate.names.size(); ++i) {
    const int k = inv.estimate.index_of(tr.estimate.names[i]);
    ASSERT_GE(k, 0);
    // At T_ref with exact axis-aligned references the baseline is unbiased, just less efficient.
    EXPECT_LT(std::abs(tr.estimate.value[long(i)] - truth.get(tr.estimate.names[i])), 6 * inv.estimate.sigma()[k])
        << tr.estimate.names[i];
  }
}
