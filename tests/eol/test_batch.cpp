// A batch of units (host/eol/batch.h): eight simulated parts with a realistic part-to-part spread, one
// dead (no log), one far from its batch. The dead one fails with its reason and stops nobody; the outlier
// passes its limits but is marked; every other unit passes; the thread pool gives bit-identical results
// to one thread; the report puts the verdict first.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "host/eol/batch.h"
#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "host/sim/simulator.h"

using namespace imuforge;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json read_json(const std::string& p) {
  std::ifstream f(p);
  return json::parse(f);
}

struct Batch {
  fs::path dir;
  physics::Campaign camp;
  model::ModelSpec spec;
  eol::StationConfig st;
  std::vector<eol::BatchUnit> units;
  Batch() {
    dir = fs::temp_directory_path() / ("imuforge-batch-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    json c = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-eol.json");
    c["sample_rate_hz"] = 50;
    c["chamber"]["initial_C"] = 25;
    json plateau = c["phases"][2];
    plateau["setpoint_C"] = 25;
    plateau["soak_s"] = 30;
    plateau["steps"] = json::array({{{"use", "tumble24"}}, {{"use", "rates"}}});
    c["phases"] = json::array({plateau});
    camp = io::campaign_from_json(c);
    spec = model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
    json s = read_json(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
    for (const char* k : {"accel.bias_temp", "accel.scale_temp", "gyro.bias_temp", "gyro.scale_temp"}) s["effects"].erase(k);
    const model::SensorModel base = model::sensor_model_from_json(s);
    json stj = {{"name", "batch-test"},
                {"fixture_tolerance", {{"axes", {{"tilt_sigma_deg", 0.002}, {"zero_sigma_deg", 0.003}}}, {"mount_sigma_deg", 0.01}}}};
    stj["limits"]["parameters"] = {{"accel.scale", {{"abs", 0.05}}}, {"accel.bias", {{"abs", 0.5}}},
                                   {"gyro.bias", {{"abs", 0.5}, {"sigma", 1e-4}}}};
    st = eol::station_from_json(stj, dir.string());
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n01;
    for (int u = 0; u < 8; ++u) {
      const std::string slot = "slot0" + std::to_string(u + 1), serial = "SN-" + std::to_string(100 + u);
      const std::string log = (dir / (slot + ".bin")).string();
      units.push_back({slot, serial, log});
      model::SensorModel m = base;
      for (model::ParamId id : spec.parameters()) {
        const std::string nm = model::param_info(id).name;
        m.params.set(nm, m.params.get(nm) * (1.0 + 0.2 * n01(rng)));
      }
      if (u == 5) m.params.set("accel.scale.x", m.params.get("accel.scale.x") + 0.025);  // the outlier
      if (u == 3) continue;                                                              // dead node: no log
      sim::SimOptions opt;
      opt.seed = 40 + static_cast<std::uint64_t>(u);
      io::LogWriter w(log, sim::make_log_meta(camp, m, opt));
      sim::simulate(camp, m, opt, w);
      w.close();
    }
  }
  ~Batch() { fs::remove_all(dir); }
};

}  // namespace

TEST(Batch, DeadNodeFailsAloneOutlierIsMarkedOthersPass) {
  Batch b;
  eol::BatchOptions o;
  o.threads = 3;
  const eol::BatchOutcome r = eol::solve_batch(b.units, b.st, b.spec, b.camp, o);
  ASSERT_EQ(r.units.size(), 8u);
  for (const auto& u : r.units) {
    std::printf("%s %s:", u.slot.c_str(), u.pass ? "PASS" : "FAIL");
    for (const auto& x : u.outliers) std::printf(" %s", x.c_str());
    std::printf("\n");
  }
  EXPECT_EQ(r.passed, 7);
  for (std::size_t i = 0; i < r.units.size(); ++i) {
    const auto& u = r.units[i];
    EXPECT_EQ(u.slot, b.units[i].slot);
    if (i == 3) {
      EXPECT_FALSE(u.pass);
      EXPECT_FALSE(u.solved);
      ASSERT_FALSE(u.reasons.empty());
      EXPECT_NE(u.reasons[0].find("no calibration"), std::string::npos) << u.reasons[0];
      EXPECT_NE(u.reasons[0].find("slot04.bin"), std::string::npos) << u.reasons[0];
      continue;
    }
    EXPECT_TRUE(u.pass) << u.slot << ": " << (u.reasons.empty() ? "" : u.reasons[0]);
    EXPECT_EQ(u.sigma_noise.size(), u.estimate.value.size()) << "honest σ: the station states a tolerance";
    if (i == 5) {
      EXPECT_TRUE(std::find(u.outliers.begin(), u.outliers.end(), "accel.scale.x") != u.outliers.end());
    } else {
      EXPECT_TRUE(std::find(u.outliers.begin(), u.outliers.end(), "accel.scale.x") == u.outliers.end()) << u.slot;
    }
  }
  // One thread: the same numbers, bit for bit (no shared state between units).
  o.threads = 1;
  const eol::BatchOutcome r1 = eol::solve_batch(b.units, b.st, b.spec, b.camp, o);
  for (std::size_t i = 0; i < r.units.size(); ++i) {
    EXPECT_EQ(r1.units[i].pass, r.units[i].pass);
    if (r.units[i].solved) {
      EXPECT_EQ(r1.units[i].estimate.value, r.units[i].estimate.value);
      EXPECT_EQ(r1.units[i].estimate.covariance, r.units[i].estimate.covariance);
    }
  }
  const std::string html = eol::render_batch_report(r, "test batch");
  const auto verdict = html.find("7 of 8 units PASS"), first_table = html.find("<table");
  ASSERT_NE(verdict, std::string::npos);
  EXPECT_LT(verdict, first_table) << "verdict first";
  EXPECT_NE(html.find("slot04 SN-103</b> FAIL: no calibration"), std::string::npos);
  EXPECT_NE(html.find("slot06 SN-105</b> passes but is far from its batch"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(eol::batch_to_json(r)["units_passed"], 7);
  EXPECT_THROW(eol::solve_batch({}, b.st, b.spec, b.camp), std::invalid_argument);
  EXPECT_THROW(eol::solve_batch({b.units[0], b.units[0]}, b.st, b.spec, b.camp), std::invalid_argument);
}
