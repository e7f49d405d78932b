// imuforge navigate end to end (library and command). Short Monte Carlo runs on the urban example.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/navigate/candidates.h"
#include "host/navigate/impact.h"
#include "host/navigate/sensitivity.h"
#include "host/sim/trajectory_file.h"
#include "host/sim/vehicle_sim.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace nav_navigate_test {

using namespace imuforge;
namespace fs = std::filesystem;

namespace {

const std::string kSrc = IMUFORGE_SOURCE_DIR;

// The consumer example reduced to the terms table v1 holds, no noise, with 24-bit words (no quantization
// floor): the oracle must then navigate as if the sensor were perfect.
model::SensorModel clean_sensor() {
  model::SensorModel m = model::load_sensor_model(kSrc + "/docs/examples/sensor-consumer.json");
  nlohmann::json j = model::sensor_model_to_json(m);
  nlohmann::json eff = nlohmann::json::object();
  for (auto it = j["effects"].begin(); it != j["effects"].end(); ++it) {
    const std::string e = it.key().substr(it.key().find('.') + 1);
    if (e == "bias" || e == "scale" || e == "misalign" || e == "bias_temp" || e == "scale_temp" || e == "g_sensitivity")
      eff[it.key()] = it.value();
  }
  j["effects"] = eff;
  for (const char* t : {"accel", "gyro"}) {
    j[t]["lsb"] = j[t]["lsb"].get<double>() / 256;
    j[t]["bits"] = 24;
  }
  return model::sensor_model_from_json(j);
}

struct NavSetup {
  sim::TrajectoryFile tf = sim::load_trajectory(kSrc + "/docs/examples/trajectory-urban.json");
  model::SensorModel sensor = clean_sensor();
  sim::VehicleTruth truth = sim::vehicle_truth(tf, sensor);
  navigate::RawFormat fmt = navigate::raw_format(sensor);
  navigate::ImpactOptions opt;
  NavSetup() {
    sim::labelled_span(tf.trajectory, "tunnel", opt.outage_start_s, opt.outage_s);
    opt.runs = 2;
    opt.threads = 1;
    opt.aiding = navigate::Aiding::kPosVelAtt;
  }
};

int run_cli(const std::string& args, std::string* out = nullptr) {
  const std::string log = (fs::temp_directory_path() / "imuforge_nav_cli.txt").string();
  const int rc = std::system((std::string(IMUFORGE_BIN) + " navigate " + args + " > " + log + " 2>&1").c_str());
  if (out) {
    std::ifstream f(log);
    *out = std::string(std::istreambuf_iterator<char>(f), {});
  }
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

}  // namespace

// The oracle of a sensor whose every term the table holds, without noise, is the perfect sensor: the
// firmware kernel (f32) and the navigator leave centimetres after 60 s. Uncompensated is kilometres off.
TEST(Navigate, OracleOfATableExpressibleSensorIsExact) {
  NavSetup s;
  const std::vector<navigate::Candidate> c = {navigate::uncompensated_candidate(s.fmt),
                                              navigate::oracle_candidate(s.sensor, s.fmt, s.truth.temp_C)};
  EXPECT_TRUE(c[1].dropped.empty());
  const navigate::ImpactResult r = navigate::run_impact(s.truth, s.sensor, c, s.opt);
  ASSERT_EQ(r.checkpoints_s, (std::vector<double>{10, 30, 60}));
  EXPECT_LT(r.candidates[1].hpos.back().max, 0.1);
  EXPECT_GT(r.candidates[0].hpos.back().median, 1000.0);
  // Errors grow through the outage.
  EXPECT_LT(r.candidates[0].hpos[0].median, r.candidates[0].hpos[1].median);
  EXPECT_LT(r.candidates[0].hpos[1].median, r.candidates[0].hpos[2].median);
}

// The linear error budget against the navigator: a calibration that is the truth but for a known error on
// a few parameters gives the error the sensitivity J predicts (noise-free, so one run is exact).
TEST(Navigate, SensitivityPredictsTheNavigationErrorOfAKnownResidual) {
  NavSetup s;
  s.opt.runs = 1;
  const navigate::SensitivityResult sens = navigate::sensitivity(s.truth, s.sensor, s.opt, 50.0, 60.0, 0.0);
  ASSERT_FALSE(sens.groups.empty());
  // Residual errors: 5e-3 m/s² on accel.bias.y, 5e-5 rad/s on gyro.bias.x, 1e-3 on gyro.scale.z.
  const std::vector<std::pair<std::string, double>> residual = {
      {"accel.bias.y", 5e-3}, {"gyro.bias.x", 5e-5}, {"gyro.scale.z", 1e-3}};
  const model::ParamSet p = s.sensor.effective_params();
  solver::Estimate e;
  std::vector<double> v;
  Eigen::Vector2d predicted = Eigen::Vector2d::Zero();
  for (const auto& info : model::params()) {
    if (!info.deterministic || !s.sensor.on(info.sensor, info.effect)) continue;
    double x = p[info.id];
    for (const auto& [n, d] : residual)
      if (n == info.name) x -= d;  // the calibration misses d: the sensor keeps +d uncompensated
    e.names.push_back(info.name);
    v.push_back(x);
  }
  for (const auto& [n, d] : residual)
    for (std::size_t i = 0; i < sens.names.size(); ++i)
      if (sens.names[i] == n) predicted += sens.J[i] * d;
  e.value = Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  e.covariance = Eigen::MatrixXd::Zero(e.value.size(), e.value.size());
  const navigate::Candidate cal = navigate::estimate_candidate("biased", "calibration", e, s.sensor.T_ref_C, {}, s.fmt, s.truth.temp_C);
  const navigate::ImpactResult r = navigate::run_impact(s.truth, s.sensor, {cal}, s.opt);
  const double mc = r.candidates[0].hpos.back().median;
  EXPECT_GT(predicted.norm(), 20.0);  // not vacuous
  EXPECT_NEAR(mc, predicted.norm(), 0.05 * predicted.norm()) << "Monte Carlo " << mc << " m, linear budget " << predicted.norm();
  // The budget: a group's σ alone meets the target exactly through its S_g.
  for (const auto& g : sens.groups)
    if (g.m_per_unit > 0) EXPECT_NEAR(g.sigma_alone * g.m_per_unit, 50.0, 1e-9);
}

TEST(Navigate, CommandWritesBothOutputsAndNamesBadInput) {
  if (!fs::exists(IMUFORGE_BIN)) GTEST_SKIP() << "imuforge not built";
  const fs::path dir = fs::temp_directory_path() / "imuforge_nav_test";
  fs::remove_all(dir);
  const std::string traj = kSrc + "/docs/examples/trajectory-urban.json";
  const std::string sensor = kSrc + "/docs/examples/sensor-consumer.json";
  std::string out;
  ASSERT_EQ(run_cli("--trajectory " + traj + " --sensor " + sensor + " --runs 2 --outage 100:30 --spec-m 100 --out " +
                        dir.string(), &out), 0) << out;
  std::ifstream f(dir / "nav.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_EQ(j["format"], "imuforge-nav");
  EXPECT_EQ(j["candidates"].size(), 2u);
  EXPECT_EQ(j["checkpoints_s"], (std::vector<double>{10, 30}));
  EXPECT_TRUE(j.contains("sensitivity"));
  EXPECT_TRUE(fs::exists(dir / "report.html"));
  EXPECT_FALSE(fs::exists(dir / "nav.json.tmp"));

  // Bad input: named, exit 1, nothing written.
  const fs::path dir2 = fs::temp_directory_path() / "imuforge_nav_test2";
  fs::remove_all(dir2);
  EXPECT_EQ(run_cli("--trajectory " + traj + " --sensor " + sensor + " --outage bridge --out " + dir2.string(), &out), 1);
  EXPECT_NE(out.find("no segment labelled 'bridge'"), std::string::npos) << out;
  EXPECT_EQ(run_cli("--trajectory " + traj + " --sensor " + sensor + " --outage 590:60 --out " + dir2.string(), &out), 1);
  EXPECT_NE(out.find("past the trajectory's end"), std::string::npos) << out;
  EXPECT_EQ(run_cli("--trajectory " + traj + " --sensor " + sensor + " --cal /nonexistent/cal.json --out " + dir2.string(), &out), 1);
  EXPECT_NE(out.find("/nonexistent/cal.json"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir2 / "nav.json"));
}

// `imuforge simulate --trajectory`: a log v1 of the vehicle, the truth as reference, no fixture dwells.
TEST(Navigate, SimulateWritesAVehicleLog) {
  if (!fs::exists(IMUFORGE_BIN)) GTEST_SKIP() << "imuforge not built";
  const fs::path log = fs::temp_directory_path() / "imuforge_nav_vehicle.bin";
  const std::string cmd = std::string(IMUFORGE_BIN) + " simulate --quiet --trajectory " + kSrc +
                          "/docs/examples/trajectory-urban.json --sensor " + kSrc +
                          "/docs/examples/sensor-consumer.json --seed 3 --out " + log.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  io::LogReader r(log.string());
  EXPECT_EQ(r.meta().sample_rate_hz, 200.0);
  io::LogRow row;
  long n = 0;
  double fz_sum = 0, raw_z_sum = 0;
  while (r.next(row)) {
    EXPECT_EQ(row.segment, -1);
    if (n < 2000) {  // parked: f = (0, 0, −g) in the body frame
      fz_sum += row.f_ref[2];
      raw_z_sum += row.raw[2] * r.meta().accel_lsb_mps2;
    }
    ++n;
  }
  EXPECT_EQ(n, 119755);
  EXPECT_NEAR(fz_sum / 2000, -r.meta().gravity_mps2, 1e-6);
  EXPECT_NEAR(raw_z_sum / 2000, -r.meta().gravity_mps2, 0.5);  // bias, scale and noise of a consumer part
  fs::remove(log);
}
}  // namespace nav_navigate_test
