// Fixture+errors mode on simulated campaigns with an imprecise rate table (the simulator's own table
// kinematics, 0.1° tilt and zero errors on every axis plus a 0.1° mount rotation).
//
// The claim tested (issue: "fixture+errors keeps the misalignment error within 2× its value without
// fixture errors; the traditional method degrades"). Misalignments are compared in their intrinsic form
// (host/model/body_frame.h): accelerometer non-orthogonality and gyro-to-accelerometer misalignment. The
// case-frame misalignments are not identifiable from any table campaign once the mount is unknown, so
// comparing them would test the gauge, not the estimator.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>

#include "host/io/campaign_file.h"
#include "host/model/body_frame.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/sim/simulator.h"
#include "host/solver/fixture.h"
#include "host/solver/fixture_errors.h"
#include "host/solver/traditional.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_fixture_errors_test {

using namespace imuforge;
using namespace imuforge::solver;
using nlohmann::json;

namespace {

json read_json(const std::string& path) {
  std::ifstream f(path);
  return json::parse(f);
}

// docs/examples/campaign-table-cal.json: one plateau at T_ref (so the basic model is the whole truth),
// a tumble, oblique positions and rate runs about the outer and the inner axis. With its 0.1° fixture
// errors or none; 50 Hz keeps the test short. `thin` drops the oblique positions and the inner-axis runs:
// the end-of-line campaign's design, which cannot separate the inner axis's tilt from the misalignments.
json campaign_json(bool fixture_errors, bool thin = false) {
  json c = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-table-cal.json");
  c["sample_rate_hz"] = 50;
  if (!fixture_errors) c["simulation"].erase("fixture_errors");
  if (thin) c["phases"][0]["steps"] = json::array({{{"use", "tumble24"}}, {{"use", "outer_rates"}}});
  return c;
}

// The matched sensor without its temperature terms: bias, scale, full misalignment, white noise.
model::SensorModel basic_sensor() {
  json s = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  for (const char* k : {"accel.bias_temp", "accel.scale_temp", "gyro.bias_temp", "gyro.scale_temp"}) s["effects"].erase(k);
  return model::sensor_model_from_json(s);
}

model::ModelSpec basic_model(bool body_frame) {
  return model::load_model_spec(body_frame ? IMUFORGE_SOURCE_DIR "/docs/examples/model-basic-body.json"
                                           : IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
}

struct SimLog {
  std::string path;
  physics::Campaign campaign;
  model::ParamSet truth;
  ~SimLog() { std::remove(path.c_str()); }
};

std::unique_ptr<SimLog> simulate_with(const json& campaign, const model::SensorModel& sensor, const std::string& tag,
                                      std::uint64_t seed) {
  auto out = std::make_unique<SimLog>();
  out->campaign = io::campaign_from_json(campaign);
  sim::SimOptions opt;
  opt.seed = seed;
  out->path = ::testing::TempDir() + "fixture_errors_" + tag + "_" + std::to_string(seed) + ".bin";
  io::LogWriter w(out->path, sim::make_log_meta(out->campaign, sensor, opt));
  const sim::SimSummary sum = sim::simulate(out->campaign, sensor, opt, w);
  w.close();
  for (auto it = sum.truth["parameters"].begin(); it != sum.truth["parameters"].end(); ++it)
    if (it.value().is_number()) out->truth.set(it.key(), it.value().get<double>());
  return out;
}

std::unique_ptr<SimLog> simulate(bool fixture_errors, std::uint64_t seed, bool thin = false) {
  return simulate_with(campaign_json(fixture_errors, thin), basic_sensor(),
                       std::to_string(fixture_errors) + std::to_string(thin), seed);
}

model::ParamSet to_params(const Estimate& e) {
  model::ParamSet p;
  for (size_t i = 0; i < e.names.size(); ++i)
    if (model::find_param(e.names[i]) >= 0) p.set(e.names[i], e.value[static_cast<long>(i)]);
  return p;
}

// Intrinsic misalignment errors (9) of an estimate against the truth, both in the accelerometer frame.
Eigen::VectorXd intrinsic_error(const model::ParamSet& est, const model::ParamSet& truth) {
  const model::ParamSet e = model::to_accel_body_frame(est).params, t = model::to_accel_body_frame(truth).params;
  const auto& ids = model::intrinsic_misalignment_ids();
  Eigen::VectorXd d(static_cast<long>(ids.size()));
  for (size_t i = 0; i < ids.size(); ++i) d[static_cast<long>(i)] = e[ids[i]] - t[ids[i]];
  return d;
}

double rms(const Eigen::VectorXd& v) { return std::sqrt(v.squaredNorm() / static_cast<double>(v.size())); }

struct FixtureRun {
  FixtureSolution sol;
  TraditionalResult trad;
};
FixtureRun run_fixture(const SimLog& log, const model::ModelSpec& spec) {
  io::LogReader r(log.path);
  FixtureAccumulator acc(spec, r.meta());
  io::LogRow row;
  while (r.next(row)) acc.add(row);
  acc.finish();
  return {solve_fixture(acc, acc.static_noise_sigma()), solve_traditional(acc.segments(), spec.T_ref_C)};
}

}  // namespace

TEST(BodyFrame, LqConversionIsExactAndIdempotent) {
  model::ParamSet p = basic_sensor().params;
  p.set("accel.misalign_temp.xy.t1", 2e-5);
  p.set("gyro.g_sensitivity.xz", 1e-4);
  const model::BodyFrameParams b = model::to_accel_body_frame(p);
  // C is a rotation; the accelerometer is lower triangular in B; the physics is unchanged:
  // (I + M_B)·C == I + M for both triads (at T_ref), and the conversion of B is B itself.
  EXPECT_LT((b.C_body_case * b.C_body_case.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(b.C_body_case.determinant(), 1.0, 1e-14);
  for (const char* c : {"xy", "xz", "yz"}) EXPECT_EQ(b.params.get(std::string("accel.misalign.") + c), 0.0);
  const model::CompiledTriad a0 = model::compile(p, model::Sensor::kGyro, 25), a1 = model::compile(b.params, model::Sensor::kGyro, 25);
  model::MeasureInput in;
  in.w = Eigen::Vector3d(0.3, -1.2, 0.7);
  in.f = Eigen::Vector3d(1.0, 2.0, -9.0);
  in.T_C = 40.0;
  model::MeasureInput inb = in;
  inb.w = b.C_body_case * in.w;
  inb.f = b.C_body_case * in.f;
  EXPECT_LT((model::measure(a0, in) - model::measure(a1, inb)).norm(), 1e-12);
  const model::CompiledTriad c0 = model::compile(p, model::Sensor::kAccel, 25), c1 = model::compile(b.params, model::Sensor::kAccel, 25);
  in.T_C = inb.T_C = 25.0;
  EXPECT_LT((model::measure(c0, in) - model::measure(c1, inb)).norm(), 1e-12);
  const model::BodyFrameParams bb = model::to_accel_body_frame(b.params);
  EXPECT_LT((bb.C_body_case - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  // To first order the intrinsic accel misalignment is the sum of the symmetric pair.
  EXPECT_NEAR(b.params.get("accel.misalign.yx"), p.get("accel.misalign.yx") + p.get("accel.misalign.xy"), 2e-4);
}

// The acceptance claim, on three seeds pooled (27 intrinsic misalignment errors per configuration).
TEST(FixtureErrorsMode, KeepsIntrinsicMisalignmentWithinTwiceTheErrorFreeCase) {
  double ss_clean = 0, ss_fe = 0, ss_fixture_bad = 0, ss_trad_clean = 0, ss_trad_bad = 0;
  int n = 0;
  for (std::uint64_t seed : {11u, 12u, 13u}) {
    const auto clean = simulate(false, seed);
    const auto bad = simulate(true, seed);
    // Reference: the precise fixture, fixture mode, full misalignment.
    const FixtureRun rc = run_fixture(*clean, basic_model(false));
    const Eigen::VectorXd e_clean = intrinsic_error(to_params(rc.sol.estimate), clean->truth);
    const Eigen::VectorXd e_trad_clean = intrinsic_error(to_params(rc.trad.estimate), clean->truth);
    // The imprecise fixture: plain fixture mode, traditional, and fixture+errors in the body frame.
    const FixtureRun rb = run_fixture(*bad, basic_model(false));
    const Eigen::VectorXd e_fixture_bad = intrinsic_error(to_params(rb.sol.estimate), bad->truth);
    const Eigen::VectorXd e_trad_bad = intrinsic_error(to_params(rb.trad.estimate), bad->truth);
    io::LogReader r(bad->path);
    const FixtureErrorsResult fe = solve_fixture_errors(r, basic_model(true), bad->campaign);
    const Eigen::VectorXd e_fe = intrinsic_error(to_params(fe.estimate), bad->truth);
    // The estimated mount rotation absorbs the mount error and the inner axis's zero: it is finite and
    // its σ honest (the gauge-fixed inner-axis parameters are named).
    EXPECT_FALSE(fe.fixed.empty());
    EXPECT_EQ(fe.observability.rank, fe.observability.n_params);
    // Every free parameter within 5σ of its truth where the truth is defined (model parameters, in B).
    const model::ParamSet tb = model::to_accel_body_frame(bad->truth).params;
    const Eigen::VectorXd sig = fe.estimate.sigma();
    for (size_t i = 0; i < fe.estimate.names.size(); ++i) {
      const std::string& nm = fe.estimate.names[i];
      if (model::find_param(nm) < 0) continue;
      EXPECT_LT(std::abs(fe.estimate.value[long(i)] - tb.get(nm)), 5 * sig[long(i)]) << nm << " seed " << seed;
    }
    ss_clean += e_clean.squaredNorm();
    ss_fe += e_fe.squaredNorm();
    ss_fixture_bad += e_fixture_bad.squaredNorm();
    ss_trad_clean += e_trad_clean.squaredNorm();
    ss_trad_bad += e_trad_bad.squaredNorm();
    n += static_cast<int>(e_clean.size());
  }
  const double r_clean = std::sqrt(ss_clean / n), r_fe = std::sqrt(ss_fe / n), r_fix = std::sqrt(ss_fixture_bad / n),
               r_tc = std::sqrt(ss_trad_clean / n), r_tb = std::sqrt(ss_trad_bad / n);
  std::printf("intrinsic misalignment RMS error (rad), 3 seeds:\n"
              "  precise fixture:   fixture %.3g   traditional %.3g\n"
              "  0.1 deg errors:    fixture+errors %.3g   fixture %.3g   traditional %.3g\n",
              r_clean, r_tc, r_fe, r_fix, r_tb);
  EXPECT_LT(r_fe, 2.0 * r_clean);
  // The methods that trust the fixture degrade (by more than the 2× that fixture+errors stays within).
  EXPECT_GT(r_tb, 2.0 * r_tc);
  EXPECT_GT(r_fix, 2.0 * r_clean);
}

// The platform convention (full misalignments of both triads): the mount rotation is the gauge and is
// fixed; the misalignments then carry it, but their intrinsic form is as good as in the body frame.
TEST(FixtureErrorsMode, PlatformConventionFixesTheMountAndKeepsTheIntrinsicForm) {
  const auto clean = simulate(false, 21);
  const auto bad = simulate(true, 21);
  const FixtureRun rc = run_fixture(*clean, basic_model(false));
  const double r_clean = rms(intrinsic_error(to_params(rc.sol.estimate), clean->truth));
  io::LogReader r(bad->path);
  const FixtureErrorsResult fe = solve_fixture_errors(r, basic_model(false), bad->campaign);
  EXPECT_FALSE(fe.mount_estimated);
  for (const char* m : {"fixture.mount.rx", "fixture.mount.ry", "fixture.mount.rz"})
    EXPECT_NE(std::find(fe.fixed.begin(), fe.fixed.end(), m), fe.fixed.end()) << m;
  const double r_fe = rms(intrinsic_error(to_params(fe.estimate), bad->truth));
  std::printf("platform convention: intrinsic misalignment RMS error %.3g (precise fixture %.3g)\n", r_fe, r_clean);
  EXPECT_LT(r_fe, 2.5 * r_clean);  // one seed: a looser factor than the pooled claim above
}

// A campaign that never moves the inner axis against the middle one cannot separate the inner axis's tilt
// from the z-row misalignments: an error naming them, not a silent fix that moves 0.1° into the model.
TEST(FixtureErrorsMode, ThinCampaignIsAnErrorNamingTheInseparableCombination) {
  const auto bad = simulate(true, 31, /*thin=*/true);
  io::LogReader r(bad->path);
  try {
    solve_fixture_errors(r, basic_model(true), bad->campaign);
    FAIL() << "fixture+errors solved a campaign that cannot separate the inner axis tilt";
  } catch (const SolverError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("fixture.axis0.tilt_a"), std::string::npos) << m;
    EXPECT_NE(m.find("gyro.misalign.zx"), std::string::npos) << m;
  }
  // Stating the tilt as a measured (here: wrong, it is 0.1°) fixture property makes it solvable — and shows
  // why it is not done silently: the intrinsic error then carries the 0.1° (1.7e-3 rad).
  FixtureErrorsOptions o;
  o.assume_zero = {"fixture.axis0.tilt_a"};
  const FixtureErrorsResult fe = solve_fixture_errors(r, basic_model(true), bad->campaign, o);
  EXPECT_EQ(fe.assumed_zero, std::vector<std::string>{"fixture.axis0.tilt_a"});
  const Eigen::VectorXd e = intrinsic_error(to_params(fe.estimate), bad->truth);
  EXPECT_GT(e.cwiseAbs().maxCoeff(), 1e-3);
}

// temp_rate with fixture errors: the same streaming Ṫ as fixture mode inside every LM pass. Plateaus at 25
// and 45 °C with the whole table-cal programme, joined by 2 °C/min ramps up and down (Ṫ of both signs).
TEST(FixtureErrorsMode, EstimatesTempRateWithTheThermalModel) {
  json c = campaign_json(true);
  c["sample_rate_hz"] = 10;
  const json steps = c["phases"][0]["steps"];
  auto plateau = [&](double T) { return json{{"type", "plateau"}, {"setpoint_C", T}, {"soak_s", 60}, {"steps", steps}}; };
  auto ramp = [](double T) { return json{{"type", "ramp"}, {"setpoint_C", T}, {"rate_C_per_min", 2}}; };
  c["phases"] = {plateau(25), ramp(45), plateau(45), ramp(5), plateau(5), ramp(25)};
  json sj = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  sj["effects"]["accel.temp_rate"] = {{"x", 0.10}, {"y", -0.08}, {"z", 0.12}};
  sj["effects"]["gyro.temp_rate"] = {{"x", 1.0e-3}, {"y", -1.2e-3}, {"z", 8e-4}};
  const auto log = simulate_with(c, model::sensor_model_from_json(sj), "trate", 41);
  json mj = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json");
  mj["effects"]["accel.misalign"] = {{"components", {"yx", "zx", "zy"}}};
  mj["effects"]["accel.temp_rate"] = json::object();
  mj["effects"]["gyro.temp_rate"] = json::object();
  io::LogReader r(log->path);
  const FixtureErrorsResult fe = solve_fixture_errors(r, model::model_spec_from_json(mj), log->campaign);
  const model::ParamSet tb = model::to_accel_body_frame(log->truth).params;
  const Eigen::VectorXd sig = fe.estimate.sigma();
  double worst = 0, worst_rate = 0;
  for (size_t i = 0; i < fe.estimate.names.size(); ++i) {
    const std::string& nm = fe.estimate.names[i];
    if (model::find_param(nm) < 0) continue;
    const double z = std::abs(fe.estimate.value[long(i)] - tb.get(nm)) / sig[long(i)];
    worst = std::max(worst, z);
    if (nm.find("temp_rate") != std::string::npos) {
      worst_rate = std::max(worst_rate, z);
      EXPECT_GT(std::abs(tb.get(nm)), 5 * sig[long(i)]) << nm << ": the campaign must determine temp_rate";
    }
  }
  std::printf("fixture+errors with temp_rate: %lld samples, worst |error|/σ %.2f (temp_rate %.2f)\n", fe.samples, worst,
              worst_rate);
  EXPECT_LT(worst, 5.0);
}
}  // namespace solver_fixture_errors_test

namespace solver_fixture_errors_test {

// Fixture+errors carries the drift between dwells as fixture mode does (docs/calibration.md, "Dwell drift"): a
// gyro bias instability (Gauss-Markov, τ 200 s, 5e-5 rad/s: ~13× the white noise of a dwell mean) on the
// table-cal campaign with its fixture errors. The gyro bias and scale estimates scatter about the truth by their
// drift σ (RMS z < 1.6 over 6 seeds); by their white σ several times that. The estimate itself is the same.
TEST(FixtureErrorsMode, DriftBetweenDwellsWidensSigmaToCoverABiasInstability) {
  json s = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  for (const char* k : {"accel.bias_temp", "accel.scale_temp", "gyro.bias_temp", "gyro.scale_temp"}) s["effects"].erase(k);
  s["effects"]["gyro.bias_instability"] = {{"x", 5e-5}, {"y", 5e-5}, {"z", 5e-5}, {"tau_s", 200.0}};
  const model::SensorModel sensor = model::sensor_model_from_json(s);
  const model::ModelSpec spec = basic_model(true);
  json mj = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic-body.json");
  mj["dwell_scatter"] = false;
  const model::ModelSpec spec_white = model::model_spec_from_json(mj);
  double zz_drift = 0, zz_white = 0;
  int n = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto log = simulate_with(campaign_json(true), sensor, "drift", seed);
    io::LogReader r(log->path);
    const FixtureErrorsResult fe = solve_fixture_errors(r, spec, log->campaign);
    const FixtureErrorsResult fw = solve_fixture_errors(r, spec_white, log->campaign);
    for (int c = 3; c < 6; ++c) EXPECT_TRUE(fe.drifts[size_t(c)].adopted) << "seed " << seed << " " << channel_name(c);
    for (const char* p : {"gyro.bias.x", "gyro.bias.y", "gyro.bias.z", "gyro.scale.x", "gyro.scale.y", "gyro.scale.z"}) {
      const int i = fe.estimate.index_of(p);
      ASSERT_GE(i, 0) << p;
      ASSERT_NEAR(fe.estimate.value[i], fw.estimate.value[i], 1e-9 * fe.estimate.sigma()[i]) << p;
      // The body-frame model's truth: the scale factors move at second order in the misalignments there.
      const double err = fe.estimate.value[i] - model::to_accel_body_frame(log->truth).params.get(p);
      zz_drift += std::pow(err / fe.estimate.sigma()[i], 2);
      zz_white += std::pow(err / fw.estimate.sigma()[i], 2);
      ++n;
    }
  }
  const double rms_drift = std::sqrt(zz_drift / n), rms_white = std::sqrt(zz_white / n);
  RecordProperty("rms_z_drift", std::to_string(rms_drift));
  RecordProperty("rms_z_white", std::to_string(rms_white));
  EXPECT_LT(rms_drift, 1.6);
  EXPECT_GT(rms_white, 2.5);
}

}  // namespace solver_fixture_errors_test
