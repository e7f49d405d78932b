// `imuforge solve --mode fixture+errors` end to end: a simulated log on disk, cal.json, the table, exit
// codes, and the errors a station engineer sees for a campaign or a model file that cannot work.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/sim/simulator.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_solve_cli_test {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace imuforge;

namespace {

struct CmdResult {
  int rc = -1;
  std::string out;  // stdout + stderr
};

CmdResult run(const std::string& args, const fs::path& dir) {
  const fs::path log = dir / "cmd.txt";
  const std::string cmd = std::string(IMUFORGE_BIN) + " solve " + args + " > " + log.string() + " 2>&1";
  CmdResult r;
  const int rc = std::system(cmd.c_str());
  r.rc = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  std::ifstream f(log);
  std::stringstream ss;
  ss << f.rdbuf();
  r.out = ss.str();
  return r;
}

json read_json(const fs::path& p) {
  std::ifstream f(p);
  return json::parse(f);
}

class SolveCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("imuforge-solve-cli-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // campaign-table-cal (optionally without the oblique positions and inner-axis runs) at 20 Hz.
  std::string simulate(bool thin, fs::path& campaign_path) {
    json c = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-table-cal.json");
    c["sample_rate_hz"] = 20;
    if (thin) c["phases"][0]["steps"] = json::array({{{"use", "tumble24"}}, {{"use", "outer_rates"}}});
    campaign_path = dir_ / (thin ? "thin.json" : "campaign.json");
    std::ofstream(campaign_path) << c.dump(1);
    const physics::Campaign camp = io::campaign_from_json(c);
    json s = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
    for (const char* k : {"accel.bias_temp", "accel.scale_temp", "gyro.bias_temp", "gyro.scale_temp"}) s["effects"].erase(k);
    const model::SensorModel sensor = model::sensor_model_from_json(s);
    sim::SimOptions opt;
    opt.seed = 7;
    const std::string log = (dir_ / (thin ? "thin.bin" : "run.bin")).string();
    io::LogWriter w(log, sim::make_log_meta(camp, sensor, opt));
    sim::simulate(camp, sensor, opt, w);
    w.close();
    return log;
  }
  fs::path dir_;
};

const std::string kBody = IMUFORGE_SOURCE_DIR "/docs/examples/model-basic-body.json";

}  // namespace

TEST_F(SolveCli, FixtureErrorsWritesCalAndTableInTheBodyFrame) {
  fs::path camp;
  const std::string log = simulate(false, camp);
  const fs::path cal = dir_ / "cal.json", table = dir_ / "cal.bin";
  const CmdResult r = run("--log " + log + " --model " + kBody + " --mode fixture+errors --campaign " + camp.string() +
                        " --out " + cal.string() + " --table " + table.string() + " --serial 1001",
                    dir_);
  ASSERT_EQ(r.rc, 0) << r.out;
  const json j = read_json(cal);
  EXPECT_EQ(j["mode"], "fixture+errors");
  EXPECT_EQ(j["fixture_errors"]["misalignment_frame"].get<std::string>().rfind("body", 0), 0u);
  EXPECT_FALSE(j["fixture_errors"]["fixed_by_gauge"].empty());
  bool mount = false;
  for (const auto& p : j["parameters"])
    if (p["name"] == "fixture.mount.rx") {
      mount = true;
      EXPECT_TRUE(p["sigma"].is_number());
      EXPECT_LT(p["sigma"].get<double>(), 1e-3);
    }
  EXPECT_TRUE(mount) << "the mount rotation must be estimated in the body frame";
  EXPECT_TRUE(fs::exists(table));
  EXPECT_GT(fs::file_size(table), 0u);
}

TEST_F(SolveCli, ThinCampaignFailsNamingTheCombination) {
  fs::path camp;
  const std::string log = simulate(true, camp);
  const fs::path cal = dir_ / "thin-cal.json";
  const CmdResult r = run("--log " + log + " --model " + kBody + " --mode fixture+errors --campaign " + camp.string() +
                        " --out " + cal.string(),
                    dir_);
  EXPECT_EQ(r.rc, 1) << r.out;
  EXPECT_NE(r.out.find("fixture.axis0.tilt_a"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(cal)) << "no cal.json for a problem that was not solved";
}

TEST_F(SolveCli, BadFixtureNuisanceAndMissingCampaignAreClearErrors) {
  fs::path camp;
  const std::string log = simulate(true, camp);
  json m = read_json(kBody);
  m["fixture_nuisance"] = {{"assume_zero", {"fixture.axis7.tilt_a"}}};
  const fs::path bad = dir_ / "bad-model.json";
  std::ofstream(bad) << m.dump();
  CmdResult r = run("--log " + log + " --model " + bad.string() + " --mode fixture+errors --campaign " + camp.string() +
                  " --out " + (dir_ / "x.json").string(),
              dir_);
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.out.find("fixture.axis7.tilt_a"), std::string::npos) << r.out;
  m["fixture_nuisance"] = {{"mout", false}};
  std::ofstream(bad) << m.dump();
  r = run("--log " + log + " --model " + bad.string() + " --mode fixture+errors --campaign " + camp.string() +
              " --out " + (dir_ / "x.json").string(),
          dir_);
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.out.find("mout"), std::string::npos) << r.out;
  r = run("--log " + log + " --model " + kBody + " --mode fixture+errors --out " + (dir_ / "x.json").string(), dir_);
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.out.find("--campaign"), std::string::npos) << r.out;
  // Stating the tilt as measured makes the thin campaign solvable.
  m["fixture_nuisance"] = {{"assume_zero", {"fixture.axis0.tilt_a"}}};
  std::ofstream(bad) << m.dump();
  r = run("--log " + log + " --model " + bad.string() + " --mode fixture+errors --campaign " + camp.string() +
              " --out " + (dir_ / "x.json").string(),
          dir_);
  EXPECT_EQ(r.rc, 0) << r.out;
  EXPECT_EQ(read_json(dir_ / "x.json")["fixture_errors"]["assumed_zero"], json::array({"fixture.axis0.tilt_a"}));
}

// Honest σ from the command line (docs/calibration.md "Honest σ"): the model states the fixture's
// tolerance; fixture mode needs --campaign for it, writes sigma and sigma_noise, and the σ covers the
// campaign's 0.1° fixture errors that the noise-only σ do not. In fixture+errors mode the parameters it
// estimates are not considered again.
TEST_F(SolveCli, FixtureToleranceGivesHonestSigmaInBothFixtureModes) {
  fs::path camp;
  const std::string log = simulate(false, camp);
  json m = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
  m["fixture_tolerance"] = {{"axes", {{"tilt_sigma_deg", 0.1}, {"zero_sigma_deg", 0.1}}}, {"mount_sigma_deg", 0.1}};
  const fs::path model = dir_ / "model-tol.json", cal = dir_ / "tol-cal.json";
  std::ofstream(model) << m.dump();
  CmdResult r = run("--log " + log + " --model " + model.string() + " --mode fixture --out " + cal.string(), dir_);
  EXPECT_NE(r.rc, 0);
  EXPECT_NE(r.out.find("fixture_tolerance"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--campaign"), std::string::npos) << r.out;
  r = run("--log " + log + " --model " + model.string() + " --mode fixture --campaign " + camp.string() + " --out " +
              cal.string(),
          dir_);
  ASSERT_EQ(r.rc, 0) << r.out;
  const json truth_sensor = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  json j = read_json(cal);
  EXPECT_TRUE(j["fixture_tolerance"]["stated"].get<bool>());
  EXPECT_EQ(j["fixture_tolerance"]["considered"].size(), 3u * 3 + 3);
  double worst_honest = 0, worst_noise = 0;
  for (const auto& p : j["parameters"]) {
    const std::string name = p["name"];
    ASSERT_TRUE(p.contains("sigma_noise")) << name;
    EXPECT_GE(p["sigma"].get<double>(), p["sigma_noise"].get<double>()) << name;
    if (name.find("misalign") == std::string::npos) continue;
    // sensor-matched's misalignments are constants in its "effects"; the log's fixture errors move them.
    const std::string eff = name.substr(0, name.rfind('.')), comp = name.substr(name.rfind('.') + 1);
    const double t = truth_sensor["effects"][eff][comp].get<double>();
    worst_honest = std::max(worst_honest, std::abs(p["value"].get<double>() - t) / p["sigma"].get<double>());
    worst_noise = std::max(worst_noise, std::abs(p["value"].get<double>() - t) / p["sigma_noise"].get<double>());
  }
  EXPECT_LT(worst_honest, 4.0);
  EXPECT_GT(worst_noise, 10.0);
  // fixture+errors, body frame: only what it does not estimate is considered.
  json mb = read_json(kBody);
  mb["fixture_tolerance"] = m["fixture_tolerance"];
  std::ofstream(model) << mb.dump();
  r = run("--log " + log + " --model " + model.string() + " --mode fixture+errors --campaign " + camp.string() +
              " --out " + cal.string(),
          dir_);
  ASSERT_EQ(r.rc, 0) << r.out;
  j = read_json(cal);
  const json fixed = j["fixture_errors"]["fixed_by_gauge"];
  EXPECT_EQ(j["fixture_tolerance"]["considered"], fixed);
  for (const auto& p : j["parameters"]) EXPECT_GE(p["sigma"].get<double>(), p["sigma_noise"].get<double>()) << p["name"];
}
}  // namespace solver_solve_cli_test
