// Honest σ under fixture tolerance (host/solver/consider.h), issue 14 item 6.
//
// Monte Carlo: the end-of-line campaign's design (docs/examples/campaign-eol.json: 24-position tumble and
// CW/CCW rate runs; one plateau at T_ref here, 50 Hz, so a seed takes well under a second), each seed
// another fixture drawn from the stated tolerance and another sensor. `fixture` mode trusts the nominal
// table; its noise-only σ must then fail the NEES test by far (the issue: z up to 206), and the σ with
// the fixture considered must pass it. solver_bench_consider runs the full campaign with more seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "consider_mc.h"
#include "host/solver/consider.h"
#include "host/solver/fixture_errors.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_consider_test {

using namespace imuforge;
using nlohmann::json;

namespace {

const json kTolerance = {{"axes", {{"tilt_sigma_deg", 0.005}, {"zero_sigma_deg", 0.01}}}, {"mount_sigma_deg", 0.03}};

json short_eol_campaign() {
  json c = mc::read_json_file(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-eol.json");
  c["sample_rate_hz"] = 50;
  c["chamber"]["initial_C"] = 25;
  json plateau = c["phases"][2];  // the 30 °C plateau's step list, at T_ref and without the long soak
  plateau["setpoint_C"] = 25;
  plateau["soak_s"] = 30;
  plateau["steps"] = json::array({{{"use", "tumble24"}}, {{"use", "rates"}}});
  c["phases"] = json::array({plateau});
  return c;
}

model::SensorModel basic_sensor() {
  json s = mc::read_json_file(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  for (const char* k : {"accel.bias_temp", "accel.scale_temp", "gyro.bias_temp", "gyro.scale_temp"}) s["effects"].erase(k);
  return model::sensor_model_from_json(s);
}

model::ModelSpec basic_model_with_tolerance() {
  json m = mc::read_json_file(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
  m["fixture_tolerance"] = kTolerance;
  return model::model_spec_from_json(m);
}

}  // namespace

TEST(FixtureTolerance, ParsesBothFormsAndNamesBadKeys) {
  const solver::FixtureTolerance t = solver::fixture_tolerance_from_json(kTolerance, 3, "m");
  EXPECT_NEAR(t.sigma_of("fixture.axis2.tilt_b"), 0.005 * M_PI / 180, 1e-15);
  EXPECT_NEAR(t.sigma_of("fixture.axis0.zero"), 0.01 * M_PI / 180, 1e-15);
  EXPECT_NEAR(t.sigma_of("fixture.mount.rz"), 0.03 * M_PI / 180, 1e-15);
  EXPECT_EQ(t.sigma_of("fixture.axis3.zero"), 0.0);
  EXPECT_EQ(t.sigma_of("accel.bias.x"), 0.0);
  const json per_axis = {{"axes", json::array({{{"tilt_sigma_deg", 1}}, {{"zero_sigma_deg", 2}}})}, {"mount_sigma_deg", {1, 2, 3}}};
  const solver::FixtureTolerance p = solver::fixture_tolerance_from_json(per_axis, 2, "m");
  EXPECT_EQ(p.sigma_of("fixture.axis0.zero"), 0.0);
  EXPECT_NEAR(p.sigma_of("fixture.axis1.zero"), 2 * M_PI / 180, 1e-15);
  EXPECT_NEAR(p.sigma_of("fixture.mount.ry"), 2 * M_PI / 180, 1e-15);
  auto msg = [](const json& j, int axes) {
    try {
      solver::fixture_tolerance_from_json(j, axes, "model 'x.json'");
    } catch (const solver::SolverError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(msg(per_axis, 3).find("lists 2 axes but the table has 3"), std::string::npos);
  EXPECT_NE(msg({{"mount_sigma_deg", -1}}, 3).find("model 'x.json': fixture_tolerance.mount_sigma_deg"), std::string::npos);
  EXPECT_NE(msg({{"axes", {{"tilt_deg", 1}}}}, 3).find("unknown key 'tilt_deg'"), std::string::npos);
  EXPECT_NE(msg({{"mount", 1}}, 3).find("unknown key 'mount'"), std::string::npos);
}

// The case, with fixtures drawn from the tolerance: NEES of the honest covariance inside its 95 %
// interval, no parameter beyond 4.5σ; the noise-only σ far outside.
TEST(FixtureTolerance, ConsiderCovarianceCoversTheFixtureOverMonteCarlo) {
  const json base = short_eol_campaign();
  const model::SensorModel sensor = basic_sensor();
  const model::ModelSpec spec = basic_model_with_tolerance();
  mc::Stats honest, noise;
  double max_z = 0, max_z_noise = 0;
  std::string worst;
  constexpr int kSeeds = 12;
  for (int s = 0; s < kSeeds; ++s) {
    json c = base;
    mc::draw_fixture_errors(c, kTolerance, 1000u + static_cast<std::uint64_t>(s));
    const mc::ConsiderDraw d = mc::consider_draw(c, sensor, spec, 1000u + static_cast<std::uint64_t>(s), ::testing::TempDir());
    honest.add(d.honest, d.truth);
    noise.add(d.noise_only, d.truth);
    const Eigen::VectorXd sh = d.honest.sigma(), sn = d.noise_only.sigma();
    for (long i = 0; i < sh.size(); ++i) {
      const double err = d.honest.value[i] - d.truth.get(d.honest.names[size_t(i)]);
      // The fixture only ever adds variance.
      EXPECT_GE(sh[i], sn[i] * (1 - 1e-12)) << d.honest.names[size_t(i)];
      if (std::abs(err) / sh[i] > max_z) {
        max_z = std::abs(err) / sh[i];
        worst = d.honest.names[size_t(i)];
      }
      max_z_noise = std::max(max_z_noise, std::abs(err) / sn[i]);
    }
  }
  std::printf("honest σ: NEES %.2f (95%% interval %.2f..%.2f, %ld parameters, %d seeds), max |z| %.2f (%s)\n",
              honest.nees(), honest.nees_lo(), honest.nees_hi(), honest.n(), kSeeds, max_z, worst.c_str());
  std::printf("noise-only σ: NEES %.1f, max |z| %.1f\n", noise.nees(), max_z_noise);
  EXPECT_GT(honest.nees(), honest.nees_lo());
  EXPECT_LT(honest.nees(), honest.nees_hi());
  EXPECT_LT(max_z, 4.5) << worst;
  // The check can fail: without the fixture the σ are far too small.
  EXPECT_GT(noise.nees(), 5 * noise.nees_hi());
}

// A fixture stated perfect (zero tolerance) changes nothing.
TEST(FixtureTolerance, ZeroToleranceLeavesTheCovarianceUnchanged) {
  json c = short_eol_campaign();
  mc::draw_fixture_errors(c, kTolerance, 7);
  json m = mc::read_json_file(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
  m["fixture_tolerance"] = {{"axes", {{"tilt_sigma_deg", 0}, {"zero_sigma_deg", 0}}}, {"mount_sigma_deg", 0}};
  const mc::ConsiderDraw d = mc::consider_draw(c, basic_sensor(), model::model_spec_from_json(m), 7, ::testing::TempDir());
  EXPECT_EQ((d.honest.covariance - d.noise_only.covariance).norm(), 0.0);
}
}  // namespace solver_consider_test
