// The `imuforge diagnose` command end to end: a simulated log on disk, outputs, exit codes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "tests/diagnosis/sim_helpers.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace diagnosis_diagnosis_cli_test {

namespace fs = std::filesystem;
using namespace diagtest;

namespace {
int run(const std::string& args) {
  const std::string cmd = std::string(IMUFORGE_BIN) + " diagnose " + args + " > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
}  // namespace

TEST(DiagnosisCli, WritesOutputsAndFindsTheEffect) {
  const fs::path dir = fs::temp_directory_path() / ("imuforge-diag-cli-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const auto camp = imuforge::io::campaign_from_json(rich_campaign({25.0}, 10.0));
  const auto sensor = imuforge::model::sensor_model_from_json(base_sensor(false, {{"gyro.g_sensitivity", {{"yz", 3e-4}}}}));
  imuforge::sim::SimOptions so;
  so.seed = 5;
  const std::string log = (dir / "run.bin").string();
  {
    imuforge::io::LogWriter w(log, imuforge::sim::make_log_meta(camp, sensor, so));
    imuforge::sim::simulate(camp, sensor, so, w);
    w.close();
  }
  const std::string model = std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/model-basic.json";
  ASSERT_EQ(run("--log " + log + " --model " + model + " --out " + (dir / "out").string()), 0);
  std::ifstream jf(dir / "out" / "diagnosis.json");
  ASSERT_TRUE(jf.good());
  auto j = nlohmann::json::parse(jf);
  ASSERT_FALSE(j["selected"].empty());
  EXPECT_EQ(j["selected"][0]["effect"], "g_sensitivity");
  EXPECT_EQ(j["ranking"][0]["sensor"], "gyro");
  EXPECT_TRUE(fs::exists(dir / "out" / "report.html"));
  // The log carries the table's angles: without --campaign the diagnosis says what that leaves unestimated.
  auto warns_of_campaign = [](const nlohmann::json& jj) {
    bool said = false;
    for (const auto& w : jj["warnings"]) said = said || w.get<std::string>().find("no --campaign was given") != std::string::npos;
    return said;
  };
  EXPECT_TRUE(warns_of_campaign(j));

  // Usage errors, a bad model or a bad log -> 2 (bad input).
  EXPECT_EQ(run("--model " + model + " --out " + (dir / "o2").string()), 2);
  {
    std::ofstream bad(dir / "bad.json");
    bad << "{\"format\":\"imuforge-model\",\"version\":1,\"effects\":{\"accel.nonsense\":{}}}";
  }
  EXPECT_EQ(run("--log " + log + " --model " + (dir / "bad.json").string() + " --out " + (dir / "o3").string()), 2);
  {
    std::ofstream bad(dir / "bad.csv");
    bad << "# format=imuforge-log\nthis is not a log\n";
  }
  EXPECT_EQ(run("--log " + (dir / "bad.csv").string() + " --model " + model + " --out " + (dir / "o4").string()), 2);

  // --campaign: the table's geometry; its axis errors are estimated (all nine reported, none significant on this
  // simulation's exact table). A missing file or a table whose axes the log does not carry is bad input, named, and
  // leaves no output behind.
  const json cj = rich_campaign({25.0}, 10.0);
  {
    std::ofstream f(dir / "camp.json");
    f << cj.dump();
    json one = cj;
    one["table"]["axes"] = json::array({cj["table"]["axes"][0]});
    for (auto& ph : one["phases"])
      for (auto& st : ph["steps"]) {
        for (const char* k : {"position_deg", "rate_dps", "amplitude_deg", "frequency_hz"})
          if (st.contains(k)) st[k] = json::array({st[k][0]});
      }
    std::ofstream g(dir / "camp1.json");
    g << one.dump();
  }
  ASSERT_EQ(run("--log " + log + " --model " + model + " --campaign " + (dir / "camp.json").string() + " --out " + (dir / "o5").string()), 0);
  {
    std::ifstream f(dir / "o5" / "diagnosis.json");
    const auto jc = nlohmann::json::parse(f);
    ASSERT_TRUE(jc.contains("fixture_errors"));
    EXPECT_EQ(jc["fixture_errors"]["parameters"].size(), 9u);
    EXPECT_EQ(jc["fixture_errors"]["parameters"][0]["name"], "fixture.axis0.tilt_a");
    EXPECT_EQ(jc["selected"][0]["effect"], "g_sensitivity");
    EXPECT_FALSE(warns_of_campaign(jc));
  }
  auto stderr_of = [&](const std::string& args, int& rc) {
    const std::string errf = (dir / "stderr.txt").string();
    const int r = std::system((std::string(IMUFORGE_BIN) + " diagnose " + args + " > /dev/null 2> " + errf).c_str());
    rc = WIFEXITED(r) ? WEXITSTATUS(r) : -1;
    std::ifstream f(errf);
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  };
  int rc = 0;
  const std::string missing = (dir / "nope.json").string();
  std::string err = stderr_of("--log " + log + " --model " + model + " --campaign " + missing + " --out " + (dir / "o6").string(), rc);
  EXPECT_EQ(rc, 2);
  EXPECT_NE(err.find(missing), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "o6"));
  err = stderr_of("--log " + log + " --model " + model + " --campaign " + (dir / "camp1.json").string() + " --out " + (dir / "o7").string(), rc);
  EXPECT_EQ(rc, 2);
  EXPECT_NE(err.find("camp1.json"), std::string::npos) << err;
  EXPECT_NE(err.find("table angle columns"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "o7"));
  if (!std::getenv("KEEP")) fs::remove_all(dir);
}
}  // namespace diagnosis_diagnosis_cli_test
