// A batch of units (host/eol/batch.h): eight simulated parts with a realistic part-to-part spread, one
// dead (no log), one far from its batch. The dead one fails with its reason and stops nobody; the outlier
// passes its limits but is marked; every other unit passes; the thread pool gives bit-identical results
// to one thread; the report puts the verdict first.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sys/wait.h>

#include "host/eol/batch.h"
#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "host/records/store.h"
#include "host/sim/simulator.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_batch {

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
  EXPECT_NE(html.find("slot04 (serial SN-103)</b> FAIL: no calibration"), std::string::npos);
  EXPECT_NE(html.find("slot06 (serial SN-105)</b> passes but is far from its batch"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(eol::batch_to_json(r)["units_passed"], 7);
  // Records: one per unit (the dead one too, with its reason) and the batch naming them.
  auto store = records::open_store((b.dir / "records.sqlite").string());
  const std::string bid = eol::record_batch(*store, r, {"batch-test", "eol", std::string(64, '0'), "t0", "t1"});
  const records::BatchRecord br = store->get_batch(bid);
  EXPECT_EQ(br.units_passed, 7);
  ASSERT_EQ(br.units.size(), 8u);
  const records::CalibrationRecord dead = store->get(br.units[3].calibration_id);
  EXPECT_EQ(dead.serial, "SN-103");
  EXPECT_FALSE(dead.pass);
  EXPECT_EQ(dead.reasons, r.units[3].reasons);
  EXPECT_TRUE(dead.parameters.empty());
  const records::CalibrationRecord odd = store->get(br.units[5].calibration_id);
  EXPECT_TRUE(odd.pass);
  EXPECT_EQ(odd.parameters.size(), b.spec.parameters().size());
  EXPECT_EQ(br.units[5].outliers, r.units[5].outliers);
  EXPECT_THROW(eol::solve_batch({}, b.st, b.spec, b.camp), std::invalid_argument);
  EXPECT_THROW(eol::solve_batch({b.units[0], b.units[0]}, b.st, b.spec, b.camp), std::invalid_argument);
}

// The station's slots (issue 14 item 1): parsed and checked before anything runs — names and node ids
// unique, the bus budget of every bus under its limit (with what would fit); a slot's own mount tolerance
// is the one its unit's σ carries.
TEST(Batch, StationSlotsAreCheckedAndCarryTheirNest) {
  json st = {{"name", "s"}, {"can", {{"bus", "socketcan:can0"}, {"stream_rate_hz", 200}}}};
  json slots = json::array();
  for (int k = 0; k < 8; ++k) slots.push_back({{"node_id", k + 1}});
  st["slots"] = slots;
  const eol::StationConfig ok = eol::station_from_json(st, ".");
  ASSERT_EQ(ok.slots.size(), 8u);
  EXPECT_EQ(ok.slots[7].name, "slot08");
  EXPECT_EQ(ok.slots[7].bus, "socketcan:can0");
  auto refused = [](const json& j) {
    try {
      eol::station_from_json(j, ".");
    } catch (const eol::StationError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  json over = st;  // 16 units at 200 Hz on one classic bus: 129.6 %
  for (int k = 8; k < 16; ++k) over["slots"].push_back({{"node_id", k + 1}});
  const std::string m = refused(over);
  EXPECT_NE(m.find("bus socketcan:can0: 16 units at 200 Hz take 129.6 %"), std::string::npos) << m;
  EXPECT_NE(m.find("or 2 buses"), std::string::npos) << m;
  EXPECT_NE(m.find("or CAN FD"), std::string::npos) << m;
  for (int k = 8; k < 16; ++k) over["slots"][static_cast<std::size_t>(k)]["bus"] = "socketcan:can1";
  EXPECT_EQ(refused(over), "") << "two buses of 8 fit";
  json fd = st;
  fd["slots"] = over["slots"];
  for (auto& sl : fd["slots"]) sl.erase("bus");
  fd["can"]["fd"] = true;
  EXPECT_EQ(refused(fd), "") << "CAN FD carries 16";
  json fd_bad = fd;
  fd_bad["can"]["fd"] = "yes";
  EXPECT_NE(refused(fd_bad).find("station: can.fd: "), std::string::npos) << refused(fd_bad);
  json fd_1k = fd;  // 16 units at 1 kHz on CAN FD: 67.5 % fits; on classic CAN the refusal proposes FD
  fd_1k["can"]["stream_rate_hz"] = 1000;
  EXPECT_EQ(refused(fd_1k), "");
  fd_1k["can"]["fd"] = false;
  EXPECT_NE(refused(fd_1k).find("or CAN FD (4 samples per 64-byte frame, 1000/5000 kbit/s): 67.5 %"), std::string::npos)
      << refused(fd_1k);
  json dup = st;
  dup["slots"][1]["node_id"] = 1;
  EXPECT_NE(refused(dup).find("node 1 is used twice on socketcan:can0"), std::string::npos);
  json bad = st;
  bad["slots"][0]["mount_sigma"] = 1;
  EXPECT_NE(refused(bad).find("slots[0].mount_sigma: unknown key"), std::string::npos);

  // Two units of the same log: slot02's nest is stated 10× looser; its misalignment σ follows.
  Batch b;
  json stj = {{"name", "batch-test"},
              {"fixture_tolerance", {{"axes", {{"tilt_sigma_deg", 0.002}, {"zero_sigma_deg", 0.003}}}, {"mount_sigma_deg", 0.01}}},
              {"slots", {{{"name", "slot01"}, {"node_id", 1}}, {{"name", "slot02"}, {"node_id", 2}, {"mount_sigma_deg", 0.1}}}}};
  const eol::StationConfig s2 = eol::station_from_json(stj, b.dir.string());
  const eol::BatchOutcome r =
      eol::solve_batch({{"slot01", "A", b.units[0].log_path}, {"slot02", "B", b.units[0].log_path}}, s2, b.spec, b.camp);
  const int k = r.units[0].estimate.index_of("gyro.misalign.xy");
  ASSERT_GE(k, 0);
  const double s01 = r.units[0].estimate.sigma()[k], s02 = r.units[1].estimate.sigma()[k];
  EXPECT_GT(s02, 5 * s01);
  EXPECT_EQ(r.units[0].estimate.value, r.units[1].estimate.value);
}

namespace {
int run_cmd(const std::string& args, std::string& out, const fs::path& dir) {
  const fs::path log = dir / "cmd.txt";
  const int rc = std::system((std::string(IMUFORGE_BIN) + " " + args + " > " + log.string() + " 2>&1").c_str());
  std::ifstream f(log);
  out.assign(std::istreambuf_iterator<char>(f), {});
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
}  // namespace

// The commands a station engineer types: `imuforge batch` (exit 1 when a unit fails, every output
// written, records) and `imuforge can budget` (exit 1 above the limit, saying what fits).
TEST(Batch, CommandLine) {
  Batch b;
  json stj = {{"name", "cli-batch"}, {"model", IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json"},
              {"fixture_tolerance", {{"mount_sigma_deg", 0.01}}}};
  std::ofstream(b.dir / "station.json") << stj.dump();
  json c = io::campaign_to_json(b.camp);
  std::ofstream(b.dir / "campaign.json") << c.dump();
  std::string args = "batch --station " + (b.dir / "station.json").string() + " --campaign " + (b.dir / "campaign.json").string() +
                     " --out " + (b.dir / "out").string() + " --db " + (b.dir / "rec.sqlite").string() + " --threads 2";
  for (int k = 0; k < 4; ++k) args += " --unit " + b.units[static_cast<std::size_t>(k)].slot + ":" + b.units[static_cast<std::size_t>(k)].serial + ":" + b.units[static_cast<std::size_t>(k)].log_path;
  std::string out;
  EXPECT_EQ(run_cmd(args, out, b.dir), 1) << out;  // slot04 has no log
  EXPECT_NE(out.find("batch: 3 of 4 units pass"), std::string::npos) << out;
  EXPECT_NE(out.find("slot04   SN-103       FAIL  no calibration"), std::string::npos) << out;
  EXPECT_NE(out.find("batch record"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(b.dir / "out" / "slot01" / "cal.json"));
  {
    // The unit's cal.json says how its dwell means scatter, as `imuforge solve` does (docs/calibration.md).
    std::ifstream cf(b.dir / "out" / "slot01" / "cal.json");
    const json cal = json::parse(cf);
    ASSERT_TRUE(cal.contains("dwell_scatter")) << cal.dump();
    EXPECT_TRUE(cal["dwell_scatter"]["widened"].get<bool>());
    for (const char* ch : {"accel.x", "gyro.z"}) {
      ASSERT_TRUE(cal["dwell_scatter"].contains(ch)) << ch;
      EXPECT_GT(cal["dwell_scatter"][ch]["dof"].get<int>(), 0) << ch;
      EXPECT_GT(cal["dwell_scatter"][ch]["ratio"].get<double>(), 0.0) << ch;
    }
  }
  EXPECT_FALSE(fs::exists(b.dir / "out" / "slot04"));
  EXPECT_TRUE(fs::exists(b.dir / "out" / "batch-report.html"));
  std::ifstream bj(b.dir / "out" / "batch.json");
  EXPECT_EQ(json::parse(bj)["units_passed"], 3);
  EXPECT_EQ(run_cmd("batch --station " + (b.dir / "station.json").string() + " --campaign x.json --out o --unit nocolons", out, b.dir), 2)
      << out;
  EXPECT_EQ(run_cmd("can budget --units 16 --rate 200", out, b.dir), 1) << out;
  EXPECT_NE(out.find("or 2 buses at 200 Hz (8 units per bus)"), std::string::npos) << out;
  EXPECT_EQ(run_cmd("can budget --units 16 --rate 200 --fd", out, b.dir), 0) << out;
  EXPECT_EQ(run_cmd("can budget --units 16 --rate 200 --buses 2", out, b.dir), 0) << out;
}
}  // namespace eol_test_batch
