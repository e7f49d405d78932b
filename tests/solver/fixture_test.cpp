// Fixture mode on synthetic campaigns generated through the catalog's measurement function.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <random>

#include "host/io/campaign_file.h"
#include "host/model/sensor_model.h"
#include "host/sim/simulator.h"
#include "host/solver/fixture.h"
#include "host/solver/online.h"
#include "host/solver/srif.h"
#include "host/solver/traditional.h"
#include "tests/solver/synth.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_fixture_test {

using namespace imuforge;
using namespace imuforge::solver;

using synth::sigma_of;
using synth::thermal_spec;

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

// The solver builds temp_hysteresis's d(t) at the model file's threshold (what `imuforge diagnose --emit-model`
// writes once its profile chose one), else at the catalog's 0.5 °C: a reversal of 0.4 °C turns d only in the first.
TEST(FixtureMode, HysteresisTrackerTakesTheModelsThreshold) {
  model::ModelSpec spec = thermal_spec();
  auto turns_on_reversal = [](model::HysteresisTracker h) {
    double d = 0;
    for (int i = 0; i <= 2000; ++i) {  // 20 s at 100 Hz: down 2 °C, then back up 0.4 °C
      const double t = i / 100.0;
      d = h.update(t < 10 ? 25.0 - 0.2 * t : 23.0 + 0.04 * (t - 10), t);
    }
    return d > 0;
  };
  EXPECT_FALSE(turns_on_reversal(logged_hysteresis_tracker(spec)));
  spec.hysteresis_threshold_C = 0.3;
  EXPECT_TRUE(turns_on_reversal(logged_hysteresis_tracker(spec)));
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
  const auto spec = synth::unguarded(model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json"));
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

// ---------------------------------------------------------------------------------------------------
// temp_rate in fixture mode: streaming Ṫ and the extended block compression.

TEST(FixtureMode, StreamingTempRateEqualsBatchDefinition) {
  // Irregular time stamps, repeated stamps and missing temperatures: the streaming estimator must give
  // exactly model::temp_rate_centered (the definition of docs/error-model.md), with bounded memory.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<double> t, T;
  double tt = 0;
  for (int i = 0; i < 3000; ++i) {
    tt += u01(rng) < 0.05 ? 0.0 : 0.005 + 0.02 * u01(rng);
    t.push_back(tt);
    T.push_back(u01(rng) < 0.02 ? std::nan("") : 20 + 3 * std::sin(0.3 * tt) + 0.01 * u01(rng));
  }
  const double w = 0.35;
  const std::vector<double> ref = model::temp_rate_centered(t, T, w);
  CenteredTempRate ctr(w);
  std::vector<double> got;
  size_t max_pending = 0;
  io::LogRow r, out;
  double q = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    r.t_s = t[i];
    r.temp_C = T[i];
    r.segment = static_cast<int>(i);
    ctr.push(r);
    max_pending = std::max(max_pending, ctr.pending());
    while (ctr.pop(out, q)) {
      ASSERT_EQ(out.segment, static_cast<int>(got.size()));  // time order kept
      got.push_back(q);
    }
  }
  ctr.close();
  while (ctr.pop(out, q)) got.push_back(q);
  ASSERT_EQ(got.size(), ref.size());
  for (size_t i = 0; i < ref.size(); ++i) ASSERT_EQ(got[i], ref[i]) << i;
  // At most one window's worth of rows is held (≥ 5 ms apart, apart from repeats: ~ 0.35/0.015·1.1).
  EXPECT_LT(max_pending, 60u);
  r.t_s = 1.0;
  CenteredTempRate back(w);
  back.push(r);
  r.t_s = 0.5;
  EXPECT_THROW(back.push(r), SolverError);
}

namespace {
// Basic + thermal + temp_rate spec (model-thermal.json plus "temp_rate" on both triads, or without).
model::ModelSpec thermal_rate_spec(bool with_rate) {
  nlohmann::json j = nlohmann::json::parse(std::ifstream(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json"));
  if (with_rate) {
    j["effects"]["accel.temp_rate"] = nlohmann::json::object();
    j["effects"]["gyro.temp_rate"] = nlohmann::json::object();
  }
  return synth::unguarded(model::model_spec_from_json(j));
}
}  // namespace

TEST(FixtureMode, TempRateBlockCompressionIsExact) {
  // The accumulator's normal equations (block moments incl. the Ṫ cross moments) against a brute-force
  // per-row sum of φφᵀ and φz with φ from model::regressors at each row's own T and Ṫ.
  synth::Config cfg;
  cfg.plateaus_C = {10, 40};
  cfg.samples_per_dwell = 60;
  std::vector<io::LogRow> rows;
  synth::generate(cfg, synth::truth_params(), 4, [&](const io::LogRow& r0) {
    io::LogRow r = r0;
    r.temp_C += 2.0 * std::sin(0.05 * r.t_s) + 0.3 * std::sin(0.7 * r.t_s);  // Ṫ varies inside blocks
    rows.push_back(r);
  });
  const auto spec = thermal_rate_spec(true);
  FixtureAccumulator acc(spec, synth::meta(cfg));
  for (const auto& r : rows) acc.add(r);
  acc.finish();
  Sigma6 one;
  one.fill(1.0);
  const NormalEquations ne = acc.normal_equations(one);
  const auto names = acc.names();
  ASSERT_EQ(names.size(), 48u);

  std::vector<double> t, T;
  for (const auto& r : rows) {
    t.push_back(r.t_s);
    T.push_back(r.temp_C);
  }
  const std::vector<double> q = model::temp_rate_centered(t, T, acc.dTdt_window_s());
  const std::vector<model::ParamId> ids = spec.parameters();
  ASSERT_EQ(ids.size(), names.size());
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(48, 48);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(48);
  model::HysteresisTracker hyst(0.5, model::kLoggedTempSmoothing_s);
  const double lsb[2] = {synth::meta(cfg).accel_lsb_mps2, synth::meta(cfg).gyro_lsb_rad_s};
  Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, 48);
  double max_q = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    const double d = hyst.update(r.temp_C, r.t_s);
    if (r.segment < 0 || !r.has_ref) continue;
    model::MeasureInput in;
    in.f = Eigen::Vector3d(r.f_ref[0], r.f_ref[1], r.f_ref[2]);
    in.w = Eigen::Vector3d(r.w_ref[0], r.w_ref[1], r.w_ref[2]);
    in.T_C = r.temp_C;
    in.Tdot_C_s = q[i];
    in.d = d;
    max_q = std::max(max_q, std::abs(q[i]));
    for (int s = 0; s < 2; ++s) {
      model::regressors(static_cast<model::Sensor>(s), ids, in, spec.T_ref_C, J);
      for (int j = 0; j < 3; ++j) {
        const double z = r.raw[3 * s + j] * lsb[s] - (s ? in.w[j] : in.f[j]);
        h += J.row(j).transpose() * J.row(j);
        g += J.row(j).transpose() * z;
      }
    }
  }
  EXPECT_GT(max_q, 0.1);  // the test really exercises Ṫ
  for (int a = 0; a < 48; ++a) {
    EXPECT_NEAR(ne.rhs[a], g[a], 1e-9 * std::sqrt(h(a, a) * ne.cost) + 1e-12) << names[size_t(a)];
    for (int b = 0; b < 48; ++b)
      EXPECT_NEAR(ne.info(a, b), h(a, b), 1e-9 * std::sqrt(h(a, a) * h(b, b)) + 1e-12)
          << names[size_t(a)] << " x " << names[size_t(b)];
  }
}

namespace {
// A simulated thermal campaign (host/sim): 4 plateaus with the six faces and CW/CCW rates, joined by
// 2 °C/min ramps up and down, so every temperature between 5 and 45 °C is crossed while heating and while
// cooling. 10 Hz keeps it to ~30k rows.
struct SimRun {
  std::vector<io::LogRow> rows;
  io::LogMeta meta;
  model::SensorModel sensor;
};
SimRun simulate_thermal_ramps(bool up_and_down) {
  nlohmann::json c = nlohmann::json::parse(std::ifstream(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-small.json"));
  c["sample_rate_hz"] = 10;
  c["table"]["mount"]["lever_arm_m"] = {0, 0, 0};
  c["simulation"] = {{"temp_noise_C", 0.01}};
  const nlohmann::json steps = {{{"use", "faces6"}}, {{"use", "rates"}}};
  auto plateau = [&](double T) {
    return nlohmann::json{{"type", "plateau"}, {"setpoint_C", T}, {"soak_s", 60}, {"steps", steps}};
  };
  auto ramp = [](double T) { return nlohmann::json{{"type", "ramp"}, {"setpoint_C", T}, {"rate_C_per_min", 2}}; };
  if (up_and_down)
    c["phases"] = {plateau(25), ramp(45), plateau(45), ramp(5), plateau(5), ramp(25), plateau(25)};
  else  // heating only: Ṫ ≥ 0 throughout
    c["phases"] = {plateau(5), ramp(25), plateau(25), ramp(45), plateau(45)};
  c["chamber"]["initial_C"] = up_and_down ? 25 : 5;
  nlohmann::json sj = nlohmann::json::parse(std::ifstream(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json"));
  sj["effects"]["accel.temp_rate"] = {{"x", 0.10}, {"y", -0.08}, {"z", 0.12}};
  sj["effects"]["gyro.temp_rate"] = {{"x", 1.0e-3}, {"y", -1.2e-3}, {"z", 8e-4}};
  SimRun run;
  run.sensor = model::sensor_model_from_json(sj);
  const physics::Campaign camp = io::campaign_from_json(c);
  sim::SimOptions opt;
  opt.seed = 11;
  run.meta = sim::make_log_meta(camp, run.sensor, opt);
  sim::simulate(camp, run.sensor, opt, [&](const io::LogRow& r) { run.rows.push_back(r); });
  return run;
}
}  // namespace

namespace {
struct RateFits {
  FixtureSolution with, without;
  double worst_with = 0, worst_rate = 0, min_rate_snr = 1e300, worst_without = 0;
  std::string worst_without_name;
  Sigma6 sigma{}, static_sigma{};  // true per-sample σ; the accumulator's within-dwell estimate
};
RateFits fit_with_and_without_temp_rate(const SimRun& run) {
  // Per-sample σ: white noise density·√fs plus the output LSB's rounding (lsb²/12, 2 % of the gyro
  // variance here), so χ² is meaningful.
  Sigma6 sig;
  for (int c = 0; c < 6; ++c) {
    const char* sn = c < 3 ? "accel" : "gyro";
    const double wn = run.sensor.params.get(std::string(sn) + ".white_noise." + "xyz"[c % 3]) * std::sqrt(run.meta.sample_rate_hz);
    const double lsb = c < 3 ? run.meta.accel_lsb_mps2 : run.meta.gyro_lsb_rad_s;
    sig[size_t(c)] = std::sqrt(wn * wn + lsb * lsb / 12);
  }
  RateFits f;
  f.sigma = sig;
  auto solve = [&](bool with_rate) {
    FixtureAccumulator acc(thermal_rate_spec(with_rate), run.meta);
    for (const auto& r : run.rows) acc.add(r);
    acc.finish();
    if (with_rate) f.static_sigma = acc.static_noise_sigma();
    return solve_fixture(acc, sig);
  };
  f.with = solve(true);
  f.without = solve(false);
  const auto& e = f.with.estimate;
  for (size_t i = 0; i < e.names.size(); ++i) {
    const double truth = run.sensor.params.get(e.names[i]);
    const double z = (e.value[long(i)] - truth) / e.sigma()[long(i)];
    f.worst_with = std::max(f.worst_with, std::abs(z));
    if (e.names[i].find("temp_rate") != std::string::npos) {
      f.worst_rate = std::max(f.worst_rate, std::abs(z));
      f.min_rate_snr = std::min(f.min_rate_snr, std::abs(truth) / e.sigma()[long(i)]);
    }
  }
  const auto& o = f.without.estimate;
  for (size_t i = 0; i < o.names.size(); ++i) {
    const double z = std::abs(o.value[long(i)] - run.sensor.params.get(o.names[i])) / o.sigma()[long(i)];
    if (z > f.worst_without) {
      f.worst_without = z;
      f.worst_without_name = o.names[i];
    }
  }
  std::printf("%lld samples: with temp_rate worst |error|/σ %.2f (temp_rate %.2f, |truth| ≥ %.0f σ), χ²/N %.4f; "
              "without: worst %.2f (%s), χ²/N %.4f\n",
              f.with.samples, f.worst_with, f.worst_rate, f.min_rate_snr, f.with.chi2 / (6.0 * f.with.samples),
              f.worst_without, f.worst_without_name.c_str(), f.without.chi2 / (6.0 * f.without.samples));
  return f;
}
}  // namespace

TEST(FixtureMode, TempRateRecoveredFromSimulatedRampsAndNeededForFit) {
  // Ramps up AND down: every temperature is crossed at +Ṫ and −Ṫ.
  const RateFits f = fit_with_and_without_temp_rate(simulate_thermal_ramps(true));
  ASSERT_EQ(f.with.estimate.names.size(), 48u);
  EXPECT_GT(f.min_rate_snr, 10.0);  // the campaign really determines temp_rate
  EXPECT_LT(f.worst_rate, 4.0);
  EXPECT_LT(f.worst_with, 4.5);
  // With temp_rate the fit is consistent with the noise (χ² ≈ N); without, the residuals rise by far more
  // than chance (were temp_rate zero, Δχ² would be χ²(6): mean 6). This symmetric campaign keeps the
  // omitted term from biasing the rest (see the heating-only test).
  const double n_obs = 6.0 * static_cast<double>(f.with.samples);
  EXPECT_LT(std::abs(f.with.chi2 - n_obs), 4 * std::sqrt(2 * n_obs));
  EXPECT_GT(f.without.chi2 - f.with.chi2, 1000.0);
  for (int c = 0; c < 6; ++c) EXPECT_GT(f.without.residual_rms[size_t(c)], f.with.residual_rms[size_t(c)]) << c;
  // The static noise estimate pools dwells only: a 40 °C ramp block would inflate it (gyro: ×2.7).
  for (int c = 0; c < 6; ++c) EXPECT_NEAR(f.static_sigma[size_t(c)], f.sigma[size_t(c)], 0.05 * f.sigma[size_t(c)]) << c;
}

TEST(FixtureMode, OmittingTempRateBiasesAHeatingOnlyCampaign) {
  // Heating only: Ṫ ≥ 0 everywhere, so the omitted r·Ṫ leaks into the thermal polynomial.
  const RateFits f = fit_with_and_without_temp_rate(simulate_thermal_ramps(false));
  EXPECT_GT(f.min_rate_snr, 3.0);
  EXPECT_LT(f.worst_with, 4.5);
  EXPECT_GT(f.worst_without, 6.0) << f.worst_without_name;
  EXPECT_GT(f.without.chi2 - f.with.chi2, 100.0);
}

// ---------------------------------------------------------------------------------------------------
// Per-plateau models online: the SRIF grows by the new plateau's slots as plateaus are discovered.

TEST(FixtureMode, RecursivePerPlateauEqualsBatchWithin1e6Sigma) {
  nlohmann::json j = {{"name", "pp"},
                      {"effects", {{"accel.bias", {{"per_plateau", true}}}, {"accel.scale", {{"per_plateau", true}}},
                                   {"accel.misalign", nlohmann::json::object()}, {"gyro.bias", {{"per_plateau", true}}},
                                   {"gyro.scale", nlohmann::json::object()}, {"gyro.misalign", nlohmann::json::object()},
                                   {"gyro.scale_temp", {{"order", 1}}}}}};
  const auto spec = synth::unguarded(model::model_spec_from_json(j));
  synth::Config cfg;
  // Not in temperature order, and the last plateau revisits the first one: discovery order 25, −10, 60.
  cfg.plateaus_C = {25, -10, 60, 25};
  const Sigma6 sig = sigma_of(cfg);
  const auto truth = synth::truth_params();
  const std::uint64_t seed = 12;
  const int dwells = static_cast<int>(cfg.dwells.size());

  OnlineCalibrator oc(spec, synth::meta(cfg), sig);
  Estimate mid;  // after the second plateau (−10 °C), which becomes plateau0 and shifts 25 °C to plateau1
  std::vector<size_t> sizes;
  oc.on_update = [&](const SegmentSummary& s, const Estimate& e) {
    sizes.push_back(e.names.size());
    if (s.segment == 2 * dwells - 1) mid = e;
  };
  synth::generate(cfg, truth, seed, [&](const io::LogRow& r) { oc.add(r); });
  oc.finish();
  ASSERT_EQ(sizes.size(), size_t(4 * dwells));
  // 18 shared slots + 9 per plateau: 27 after plateau 1, 36 after 2, 45 after 3, no more on the revisit.
  EXPECT_EQ(sizes.front(), 27u);
  EXPECT_EQ(sizes[size_t(dwells)], 36u);
  EXPECT_EQ(sizes[size_t(2 * dwells)], 45u);
  EXPECT_EQ(sizes.back(), 45u);

  // At the end: the batch solution of the whole log, same names in the same order.
  const FixtureSolution batch = solve_fixture(oc.accumulator(), sig);
  const Estimate rec = oc.estimate();
  ASSERT_EQ(rec.names, batch.estimate.names);
  EXPECT_EQ(rec.names[size_t(rec.index_of("accel.bias.x@plateau0"))], "accel.bias.x@plateau0");
  EXPECT_NEAR(oc.accumulator().plateaus()[0].T_C, -10.0, 0.5);
  for (size_t i = 0; i < rec.names.size(); ++i) {
    const double s = batch.estimate.sigma()[long(i)];
    EXPECT_LT(std::abs(rec.value[long(i)] - batch.estimate.value[long(i)]), 1e-6 * s) << rec.names[i];
    EXPECT_LT(std::abs(rec.sigma()[long(i)] - s), 1e-6 * s) << rec.names[i];
  }

  // Mid-run: the batch solution of the rows seen so far (the same seed generates the same prefix).
  synth::Config pre = cfg;
  pre.plateaus_C = {25, -10};
  FixtureAccumulator acc_pre(spec, synth::meta(pre));
  synth::generate(pre, truth, seed, [&](const io::LogRow& r) { acc_pre.add(r); });
  acc_pre.finish();
  const FixtureSolution bpre = solve_fixture(acc_pre, sig);
  ASSERT_EQ(mid.names, bpre.estimate.names);
  for (size_t i = 0; i < mid.names.size(); ++i) {
    const double s = bpre.estimate.sigma()[long(i)];
    EXPECT_LT(std::abs(mid.value[long(i)] - bpre.estimate.value[long(i)]), 1e-6 * s) << mid.names[i];
    EXPECT_LT(std::abs(mid.sigma()[long(i)] - s), 1e-6 * s) << mid.names[i];
  }
  // The truth lies within a few σ of the per-plateau bias at the cold plateau (bias(T) of the truth).
  const int k = bpre.estimate.index_of("gyro.bias.z@plateau0");
  ASSERT_GE(k, 0);
  const double tau = acc_pre.plateaus()[0].T_C - 25.0;
  const double tr = truth.get("gyro.bias.z") + truth.get("gyro.bias_temp.z.t1") * tau + truth.get("gyro.bias_temp.z.t2") * tau * tau;
  EXPECT_LT(std::abs(bpre.estimate.value[k] - tr), 5 * bpre.estimate.sigma()[k] + 0.02 * std::abs(tr));
}

// The end-of-line campaign soaks 15–20 min after each chamber step, with the table still: the die
// temperature moves by tens of °C within one static segment. A per-plateau model must not give such a
// segment a plateau of its own (it used to: 8 plateaus, half of them informed by one orientation, and a
// rank-deficient solve). Segments in transit are left out; the four setpoints remain.
TEST(FixtureMode, PerPlateauLeavesTransitSegmentsOut) {
  const physics::Campaign camp = io::load_campaign(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-eol.json");
  const model::SensorModel sensor = model::load_sensor_model(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  sim::SimOptions opt;
  opt.seed = 5;
  opt.sample_rate_hz = 5;
  nlohmann::json j = {{"name", "pp"},
                      {"effects", {{"accel.bias", {{"per_plateau", true}}}, {"accel.scale", {{"per_plateau", true}}}, {"accel.misalign", nlohmann::json::object()},
                                   {"gyro.bias", {{"per_plateau", true}}}, {"gyro.scale", {{"per_plateau", true}}}, {"gyro.misalign", nlohmann::json::object()}}}};
  const auto spec = model::model_spec_from_json(j);
  FixtureAccumulator acc(spec, sim::make_log_meta(camp, sensor, opt));
  sim::simulate(camp, sensor, opt, [&](const io::LogRow& r) { acc.add(r); });
  acc.finish();
  ASSERT_EQ(acc.plateaus().size(), 4u);
  const double setpoints[4] = {-20, 5, 30, 55};
  for (int p = 0; p < 4; ++p) EXPECT_NEAR(acc.plateaus()[size_t(p)].T_C, setpoints[p], 0.5);
  EXPECT_GT(acc.transit_samples(), 0);
  const FixtureSolution sol = solve_fixture(acc, acc.static_noise_sigma());
  EXPECT_EQ(sol.observability.rank, sol.observability.n_params);
  // Each plateau's bias is the sensor's polynomial at the plateau temperature.
  const model::ParamSet& t = sensor.params;
  for (int p = 0; p < 4; ++p) {
    const int i = sol.estimate.index_of("accel.bias.z@plateau" + std::to_string(p));
    ASSERT_GE(i, 0);
    const double tau = acc.plateaus()[size_t(p)].T_C - 25.0;
    const double truth = t.get("accel.bias.z") + t.get("accel.bias_temp.z.t1") * tau + t.get("accel.bias_temp.z.t2") * tau * tau;
    EXPECT_LT(std::abs(sol.estimate.value[i] - truth), 5 * sol.estimate.sigma()[i]) << p;
  }
}

// The dwell guard against a brute-force reading of its definition (fixture.h): a dwell row is left out
// when a row outside its run (maximal stretch of one segment with a reference), within guard_s before it,
// differs from the run's first reference, or one within guard_s after it differs from the run's last.
// Random logs: settles at the next reference, instantaneous changes, rows without a reference, rate
// ramps inside a dwell, irregular time steps, runs shorter than the guard.
TEST(DwellGuard, KeepsExactlyTheRowsItsDefinitionKeeps) {
  const double guard_s = 0.5;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<io::LogRow> rows;
    double t = 0.0;
    int seg = 0;
    double ref = 0.0;
    for (int piece = 0; piece < 40; ++piece) {
      const double kind = u01(rng);
      const int n = 1 + static_cast<int>(u01(rng) * 150);
      const double next_ref = std::round(u01(rng) * 3.0);  // equal to the last one a quarter of the time
      for (int i = 0; i < n; ++i) {
        io::LogRow r;
        t += u01(rng) < 0.05 ? 0.2 : 0.01;
        r.t_s = t;
        if (kind < 0.3) {  // motion: segment −1, reference moving or unknown
          r.segment = -1;
          r.has_ref = u01(rng) < 0.8;
          r.w_ref[2] = ref + (next_ref - ref) * (i + 1) / n;
        } else if (kind < 0.45) {  // settle at the coming reference
          r.segment = -1;
          r.has_ref = true;
          r.w_ref[2] = next_ref;
        } else {  // a dwell, sometimes with a slow ramp (a ramp_rate step)
          r.segment = seg;
          r.has_ref = u01(rng) < 0.98;  // a row without reference splits the run
          r.w_ref[2] = next_ref + (kind > 0.9 ? 1e-3 * i : 0.0);
          r.f_ref[0] = 9.8;
        }
        rows.push_back(r);
      }
      if (kind >= 0.45) ++seg;
      ref = next_ref;
    }
    // Brute force.
    const size_t n = rows.size();
    auto in_dwell = [&](size_t i) { return rows[i].has_ref && rows[i].segment >= 0; };
    auto differs = [&](const io::LogRow& a, const io::LogRow& b) {
      if (!a.has_ref || !b.has_ref) return true;
      for (int k = 0; k < 3; ++k)
        if (std::abs(a.f_ref[k] - b.f_ref[k]) > 2e-3 || std::abs(a.w_ref[k] - b.w_ref[k]) > 2e-4) return true;
      return false;
    };
    std::vector<size_t> first(n), last(n);
    for (size_t i = 0; i < n; ++i)
      first[i] = (i > 0 && in_dwell(i) && in_dwell(i - 1) && rows[i - 1].segment == rows[i].segment) ? first[i - 1] : i;
    for (size_t i = n; i-- > 0;)
      last[i] = (i + 1 < n && in_dwell(i) && in_dwell(i + 1) && rows[i + 1].segment == rows[i].segment) ? last[i + 1] : i;
    std::vector<bool> want(n, true);
    long long want_dropped = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!in_dwell(i)) continue;
      for (size_t j = 0; j < first[i] && want[i]; ++j)
        if (rows[i].t_s - rows[j].t_s <= guard_s && differs(rows[j], rows[first[i]])) want[i] = false;
      for (size_t j = last[i] + 1; j < n && want[i]; ++j)
        if (rows[j].t_s - rows[i].t_s <= guard_s && differs(rows[j], rows[last[i]])) want[i] = false;
      want_dropped += want[i] ? 0 : 1;
    }
    DwellGuard g(guard_s);
    std::vector<double> got_t;
    std::vector<bool> got_keep;
    auto use = [&](const io::LogRow& r, double q, bool keep) {
      EXPECT_EQ(q, r.t_s * 2);  // the Ṫ that came in with the row
      got_t.push_back(r.t_s);
      got_keep.push_back(keep);
    };
    for (const auto& r : rows) g.feed(r, r.t_s * 2, use);
    g.finish(use);
    ASSERT_EQ(got_t.size(), n);
    for (size_t i = 0; i < n; ++i) {
      ASSERT_EQ(got_t[i], rows[i].t_s);
      EXPECT_EQ(got_keep[i], in_dwell(i) ? bool(want[i]) : true) << "trial " << trial << " row " << i;
    }
    EXPECT_EQ(g.dropped(), want_dropped);
    EXPECT_GT(want_dropped, 0);
  }
  DwellGuard off(0.0);
  io::LogRow r;
  r.segment = 0;
  r.has_ref = true;
  int seen = 0;
  off.feed(r, 0.0, [&](const io::LogRow&, double, bool keep) { seen += keep ? 1 : 100; });
  EXPECT_EQ(seen, 1);  // passed through at once
  EXPECT_THROW(DwellGuard(-1.0), SolverError);
  DwellGuard back(0.5);
  r.t_s = 1.0;
  back.push(r, 0.0);
  r.t_s = 0.5;
  EXPECT_THROW(back.push(r, 0.0), SolverError);
}

namespace {
// A rate-table campaign written out here (not by the simulator): six static faces, and at the three
// "axis up" faces a CW and a CCW dwell at 100 °/s, reached at 100 °/s². As in a `rate` step the rate
// dwells start the moment the rate is reached; static dwells follow a 1 s settle. The sensor's stamps are
// off by shift_s (> 0: late, as a latency or a slow clock), so it reads the state at t − shift_s.
struct ShiftedRun {
  std::vector<io::LogRow> rows;
  io::LogMeta meta;
};
ShiftedRun shifted_rate_campaign(double shift_s, std::uint64_t seed) {
  struct Phase {
    double dur_s;
    int segment;  // −1: moving or settling
    bool has_ref;
    Eigen::Vector3d f, w0, w1;  // reference rate ramps from w0 to w1
  };
  const double g = 9.80665, R = 100.0 * M_PI / 180, alpha = 100.0 * M_PI / 180;
  std::vector<Phase> ph;
  int seg = 0;
  for (int k = 0; k < 3; ++k)
    for (double sgn : {1.0, -1.0}) {
      const Eigen::Vector3d f = sgn * g * Eigen::Vector3d::Unit(k), z = Eigen::Vector3d::Zero();
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
      ph.push_back({2.0, -1, false, f, z, z});  // re-orienting: the log has no reference
      ph.push_back({1.0, -1, true, f, z, z});   // settle
      ph.push_back({10.0, seg++, true, f, z, z});
      if (sgn < 0) continue;
      ph.push_back({R / alpha, -1, true, f, z, R * e});
      ph.push_back({10.0, seg++, true, f, R * e, R * e});
      ph.push_back({2 * R / alpha, -1, true, f, R * e, -R * e});
      ph.push_back({10.0, seg++, true, f, -R * e, -R * e});
      ph.push_back({R / alpha, -1, true, f, -R * e, z});
      ph.push_back({1.0, -1, true, f, z, z});
      ph.push_back({10.0, seg++, true, f, z, z});
    }
  auto state = [&](double t, Eigen::Vector3d& f, Eigen::Vector3d& w) -> const Phase& {
    double t0 = 0;
    for (const auto& p : ph) {
      if (t < t0 + p.dur_s || &p == &ph.back()) {
        const double a = std::clamp((t - t0) / p.dur_s, 0.0, 1.0);
        f = p.f;
        w = p.w0 + a * (p.w1 - p.w0);
        return p;
      }
      t0 += p.dur_s;
    }
    return ph.back();
  };
  double total_s = 0;
  for (const auto& p : ph) total_s += p.dur_s;
  ShiftedRun run;
  const double sa = 0.01, sg = 1e-3, fs = 100.0;
  run.meta.serial = "SHIFT";
  run.meta.sample_rate_hz = fs;
  run.meta.accel_lsb_mps2 = sa / 20;
  run.meta.gyro_lsb_rad_s = sg / 20;
  run.meta.accel_bits = run.meta.gyro_bits = 32;
  run.meta.gravity_mps2 = g;
  const Eigen::Vector3d ka(2e-3, -1e-3, 1.5e-3), kg(2e-3, -1.5e-3, 2.5e-3), ba(0.05, -0.03, 0.08), bg(3e-3, -2e-3, 1e-3);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  for (long i = 0; i * (1.0 / fs) < total_s; ++i) {
    const double t = i / fs;
    Eigen::Vector3d f, w, fs_true, ws_true;
    const Phase& p = state(t, f, w);
    state(std::max(0.0, t - shift_s), fs_true, ws_true);
    io::LogRow r;
    r.t_s = t;
    r.segment = p.segment;
    r.has_ref = p.has_ref;
    r.temp_C = 25.0;
    for (int k = 0; k < 3; ++k) {
      r.f_ref[k] = f[k];
      r.w_ref[k] = w[k];
      const double ya = (1 + ka[k]) * fs_true[k] + ba[k] + sa * n01(rng);
      const double yg = (1 + kg[k]) * ws_true[k] + bg[k] + sg * n01(rng);
      r.raw[k] = static_cast<std::int32_t>(std::lround(ya / run.meta.accel_lsb_mps2));
      r.raw[3 + k] = static_cast<std::int32_t>(std::lround(yg / run.meta.gyro_lsb_rad_s));
    }
    run.rows.push_back(r);
  }
  return run;
}

// Worst |gyro.scale − truth| / σ of the basic-model fixture solve, with the given dwell guard.
double worst_gyro_scale_error_sigma(const ShiftedRun& run, double guard_s) {
  nlohmann::json j = nlohmann::json::parse(std::ifstream(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json"));
  j["dwell_guard_s"] = guard_s;
  FixtureAccumulator acc(model::model_spec_from_json(j), run.meta);
  for (const auto& r : run.rows) acc.add(r);
  acc.finish();
  Sigma6 sig{0.01, 0.01, 0.01, 1e-3, 1e-3, 1e-3};
  const FixtureSolution sol = solve_fixture(acc, sig);
  const double truth[3] = {2e-3, -1.5e-3, 2.5e-3};
  double worst = 0;
  for (int k = 0; k < 3; ++k) {
    const int i = sol.estimate.index_of(std::string("gyro.scale.") + "xyz"[k]);
    worst = std::max(worst, std::abs(sol.estimate.value[i] - truth[k]) / sol.estimate.sigma()[i]);
  }
  return worst;
}
}  // namespace

// A sensor whose stamps are 0.2 s late (the automotive example's 20 ppm clock by the end of its campaign)
// or 0.2 s early reads the end of each acceleration into the rate dwell, or the next one into its end.
// Without the guard that is a gyro scale error of ~2e-3 (~100σ here); with the default guard the scale
// comes out within 4σ of the truth.
TEST(DwellGuard, TimingShiftUpToTheGuardDoesNotBiasTheGyroScale) {
  for (double shift_s : {0.2, -0.2, 0.0}) {
    const ShiftedRun run = shifted_rate_campaign(shift_s, 7);
    EXPECT_LT(worst_gyro_scale_error_sigma(run, kDefaultDwellGuard_s), 4.0) << shift_s;
    if (shift_s != 0.0) EXPECT_GT(worst_gyro_scale_error_sigma(run, 0.0), 20.0) << shift_s;
  }
}

// The dwell-mean scatter: 1 within its χ² spread on white noise; 1 + n·τ²/σ² when every dwell carries a
// random offset of σ τ on one axis (bias that wanders between dwells), and only on that axis.
TEST(FixtureMode, DwellScatterReadsARandomOffsetPerDwell) {
  synth::Config cfg;
  cfg.plateaus_C = {10, 25, 40};
  const auto spec = thermal_spec();
  const auto truth = synth::truth_params();
  const Sigma6 sig = sigma_of(cfg);
  const double tau = 3e-4;  // rad/s on gyro.x, σ 1e-3 per sample, 100 samples per dwell: expect 1 + 9
  for (bool offsets : {false, true}) {
    std::mt19937_64 rng(21);
    std::normal_distribution<double> n01;
    FixtureAccumulator acc(spec, synth::meta(cfg));
    const double lsb = synth::meta(cfg).gyro_lsb_rad_s;
    int seg = -1;
    double off = 0.0;
    synth::generate(cfg, truth, 8, [&](const io::LogRow& r0) {
      io::LogRow r = r0;
      if (offsets && r.segment >= 0) {
        if (r.segment != seg) {
          seg = r.segment;
          off = tau * n01(rng);
        }
        r.raw[3] += static_cast<std::int32_t>(std::lround(off / lsb));
      }
      acc.add(r);
    });
    acc.finish();
    const FixtureSolution sol = solve_fixture(acc, sig);
    const SegmentScatter sc = segment_scatter(acc, sol.estimate.value, sig);
    for (int c = 0; c < kNumChannels; ++c) {
      const double spread = 4.0 * std::sqrt(2.0 / sc.dof[size_t(c)]);
      ASSERT_GT(sc.dof[size_t(c)], 30) << c;
      const double want = (offsets && c == 3) ? 1.0 + cfg.samples_per_dwell * tau * tau / (sig[3] * sig[3]) : 1.0;
      EXPECT_NEAR(sc.ratio[size_t(c)] / want, 1.0, spread) << channel_name(c) << " offsets " << offsets;
    }
  }
}

}  // namespace solver_fixture_test
