// The runner on a deterministic in-process lab (fake_world.h): a whole run, a crash and resume, early
// stopping against the full schedule, a FAIL verdict, and the records it leaves behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "host/eol/journal.h"
#include "host/eol/runner.h"
#include "host/records/store.h"
#include "tests/eol/fake_world.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_runner {

using namespace imuforge;
using namespace imuforge::eol;
namespace fs = std::filesystem;

namespace {

const char* kCampaign = R"({
  "name": "test-eol", "sample_rate_hz": 50,
  "site": {"latitude_deg": 45, "height_m": 0},
  "table": {"axes": [{"name": "inner", "axis": "z", "max_rate_dps": 300, "max_accel_dps2": 200},
                     {"name": "outer", "axis": "x", "max_rate_dps": 300, "max_accel_dps2": 200}],
            "settle_s": 1},
  "chamber": {"initial_C": 25, "ramp_limit_C_per_min": 5, "tau_s": 60},
  "sequences": {
    "six": [
      {"type": "position", "label": "z up",   "position_deg": [0, 0],    "dwell_s": 8},
      {"type": "position", "label": "z down", "position_deg": [0, 180],  "dwell_s": 8},
      {"type": "position", "label": "y a",    "position_deg": [0, 90],   "dwell_s": 8},
      {"type": "position", "label": "y b",    "position_deg": [0, -90],  "dwell_s": 8},
      {"type": "position", "label": "x a",    "position_deg": [90, 90],  "dwell_s": 8},
      {"type": "position", "label": "x b",    "position_deg": [-90, 90], "dwell_s": 8},
      {"type": "position", "label": "diag a", "position_deg": [45, 45],  "dwell_s": 8},
      {"type": "position", "label": "diag b", "position_deg": [135, -45],"dwell_s": 8},
      {"type": "position", "label": "diag c", "position_deg": [-45, 135],"dwell_s": 8},
      {"type": "position", "label": "diag d", "position_deg": [-135, -135],"dwell_s": 8}
    ],
    "rates": [
      {"type": "position", "label": "rz home", "position_deg": [0, 0], "dwell_s": 4},
      {"type": "rate", "label": "z CW",  "rate_dps": [100, 0],  "dwell_s": 8},
      {"type": "rate", "label": "z CCW", "rate_dps": [-100, 0], "dwell_s": 8},
      {"type": "position", "label": "rx home", "position_deg": [0, 0], "dwell_s": 4},
      {"type": "rate", "label": "x CW",  "rate_dps": [0, 100],  "dwell_s": 8},
      {"type": "rate", "label": "x CCW", "rate_dps": [0, -100], "dwell_s": 8},
      {"type": "position", "label": "ry home", "position_deg": [90, 0], "dwell_s": 4},
      {"type": "rate", "label": "y CW",  "rate_dps": [0, 100],  "dwell_s": 8},
      {"type": "rate", "label": "y CCW", "rate_dps": [0, -100], "dwell_s": 8}
    ]
  },
  "phases": [
    {"type": "plateau", "label": "cold", "setpoint_C": 10, "steps": [{"use": "six"}, {"use": "rates"}]},
    {"type": "plateau", "label": "room", "setpoint_C": 25, "steps": [{"use": "six"}, {"use": "rates"}]},
    {"type": "plateau", "label": "hot",  "setpoint_C": 40, "steps": [{"use": "six"}, {"use": "rates"}]}
  ]
})";

const char* kModel = R"({"name": "t", "T_ref_C": 25, "effects": {
  "accel.bias": {}, "accel.scale": {}, "accel.misalign": {}, "accel.bias_temp": {"order": 1},
  "gyro.bias": {}, "gyro.scale": {}, "gyro.misalign": {}, "gyro.bias_temp": {"order": 1}}})";

std::string station_json(double sigma_scale, double accel_bias_abs = 0.5) {
  nlohmann::json s = nlohmann::json::parse(R"({
    "name": "test-station", "model": "model.json",
    "can": {"bus": "virtual:test", "node_id": 1, "stream_rate_hz": 50},
    "noise": {"accel_mps2": 2e-3, "gyro_rad_s": 2e-4},
    "settle": {"temp_window_s": 60, "temp_slope_C_per_min": 0.1, "temp_band_C": 3},
    "verification": [{"label": "v-zup", "position_deg": [0, 0], "dwell_s": 5},
                     {"label": "v-xa", "position_deg": [90, 90], "dwell_s": 5},
                     {"label": "v-zrate", "position_deg": [0, 0], "rate_dps": [50, 0], "dwell_s": 5}]
  })");
  s["limits"]["parameters"] = {
      {"accel.bias", {{"abs", accel_bias_abs}, {"sigma", 1.5e-4 * sigma_scale}}},
      {"accel.scale", {{"abs", 0.01}, {"sigma", 1e-4 * sigma_scale}}},
      {"accel.misalign", {{"abs", 0.01}, {"sigma", 1e-4 * sigma_scale}}},
      {"accel.bias_temp", {{"sigma", 2e-5 * sigma_scale}}},
      {"gyro.bias", {{"abs", 0.01}, {"sigma", 1.5e-5 * sigma_scale}}},
      {"gyro.scale", {{"abs", 0.01}, {"sigma", 1e-4 * sigma_scale}}},
      {"gyro.misalign", {{"abs", 0.01}, {"sigma", 1e-4 * sigma_scale}}},
      {"gyro.bias_temp", {{"sigma", 2e-6 * sigma_scale}}}};
  s["limits"]["verification"] = {{"accel_mps2", 0.01}, {"gyro_rad_s", 0.002}};
  return s.dump(2);
}

struct Dir {
  fs::path d;
  Dir() {
    d = fs::temp_directory_path() / ("imuforge-eol-" + records::new_record_id());
    fs::create_directories(d);
    std::ofstream(d / "campaign.json") << kCampaign;
    std::ofstream(d / "model.json") << kModel;
  }
  ~Dir() {
    if (getenv("EOL_KEEP")) return;
    std::error_code ec;
    fs::remove_all(d, ec);
  }
  std::string station(double sigma_scale, double abs = 0.5, const std::string& name = "station.json") {
    std::ofstream(d / name) << station_json(sigma_scale, abs);
    return (d / name).string();
  }
};

RunOptions opts(const Dir& dir, const std::string& out, const std::string& station) {
  RunOptions o;
  o.out_dir = (dir.d / out).string();
  o.serial = "SN-42";
  o.campaign_path = (dir.d / "campaign.json").string();
  o.station_path = station;
  o.progress = nullptr;
  return o;
}

RunResult run_once(RunOptions o, eoltest::FakeWorld& w) {
  eoltest::FakeBench b(w);
  eoltest::FakeDevice dev(w, "SN-42");
  eoltest::FakeTableOps t;
  Runner r(o, b, dev, t);
  return r.run();
}

std::vector<std::string> segment_keys(const std::string& out) {
  std::vector<std::string> keys;
  for (const auto& e : read_journal(out + "/journal.log").entries)
    if (e["type"] == "segment_done") keys.push_back(e["key"]);
  return keys;
}

}  // namespace

TEST(Runner, FullScheduleRunPassesAndRecords) {
  Dir dir;
  eoltest::FakeWorld w;
  auto o = opts(dir, "full", dir.station(1.0));
  o.early_stop = false;
  RunResult r = run_once(o, w);
  for (const auto& x : r.reasons) ADD_FAILURE() << x;
  EXPECT_TRUE(r.pass);
  EXPECT_EQ(r.segments_collected, r.segments_total);
  EXPECT_FALSE(r.early_stopped);
  // The estimate recovers the true parameters within 4σ.
  for (std::size_t i = 0; i < r.estimate.names.size(); ++i) {
    double truth = w.sensor.params.get(r.estimate.names[i]);
    double v = r.estimate.value[static_cast<Eigen::Index>(i)], s = r.estimate.sigma()[static_cast<Eigen::Index>(i)];
    EXPECT_LT(std::fabs(v - truth), 4 * s + 1e-12) << r.estimate.names[i] << " est " << v << " true " << truth;
  }
  // The record is in the SQLite store with the verdict; the report exists and is self-contained.
  auto store = records::open_store(r.db);
  auto list = store->find_by_serial("SN-42");
  ASSERT_EQ(list.size(), 1u);
  auto rec = store->get(list[0].id);
  EXPECT_TRUE(rec.pass);
  EXPECT_EQ(rec.parameters.size(), r.estimate.names.size());
  EXPECT_GE(rec.verification.size(), 1u + 6 + 6 + 3);  // readback + 2 static poses + gyro of the rate pose
  EXPECT_EQ(rec.table_blob, w.flashed);
  std::ifstream f(r.report_path);
  std::string html((std::istreambuf_iterator<char>(f)), {});
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_NE(html.find("PASS"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("src="), std::string::npos) << "no external resources";
  EXPECT_EQ(html.find("href="), std::string::npos) << "no external resources";
  // Running again into the same folder is refused; --resume of a finished run returns its verdict.
  EXPECT_THROW(run_once(o, w), std::invalid_argument);
  o.resume = true;
  RunResult again = run_once(o, w);
  EXPECT_TRUE(again.pass);
  EXPECT_EQ(again.segments_collected, 0);
  EXPECT_EQ(store->find_by_serial("SN-42").size(), 1u) << "a resumed finished run is not recorded twice";
  // ... and its estimate, as recorded (cal.json): a kill in the run's last moments, then a resume, must not
  // report an empty calibration (eol_crash_test once drew such a kill point).
  ASSERT_EQ(again.estimate.names, r.estimate.names);
  for (Eigen::Index i = 0; i < r.estimate.value.size(); ++i) {
    EXPECT_NEAR(again.estimate.value[i], r.estimate.value[i], 1e-12 * (1.0 + std::fabs(r.estimate.value[i]))) << r.estimate.names[static_cast<std::size_t>(i)];
    EXPECT_NEAR(again.estimate.sigma()[i], r.estimate.sigma()[i], 1e-9 * r.estimate.sigma()[i]) << r.estimate.names[static_cast<std::size_t>(i)];
  }
  EXPECT_EQ(again.record.parameters.size(), r.estimate.names.size());
}

TEST(Runner, ResumeAfterCrashNeverRecollectsAndMatchesUninterrupted) {
  Dir dir;
  std::string st = dir.station(1.0);
  RunResult ref;
  {
    eoltest::FakeWorld w;
    auto o = opts(dir, "ref", st);
    o.early_stop = false;
    ref = run_once(o, w);
  }
  eoltest::FakeWorld w;  // the same lab keeps running across the crash (as a real bench would)
  auto o = opts(dir, "crash", st);
  o.early_stop = false;
  o.crash_after_segments = 23;  // in the middle of the second plateau
  EXPECT_THROW(run_once(o, w), SimulatedCrash);
  // Power loss while appending: leave a torn half line at the end of the journal.
  {
    std::string l = journal_line({{"type", "segment_done"}, {"key", "p1s99"}});
    std::ofstream(o.out_dir + "/journal.log", std::ios::app) << l.substr(0, 20);
  }
  auto before = segment_keys(o.out_dir);
  ASSERT_EQ(before.size(), 23u);
  RunOptions ro;
  ro.out_dir = o.out_dir;
  ro.resume = true;
  ro.progress = nullptr;
  RunResult r = run_once(ro, w);
  EXPECT_EQ(r.segments_resumed, 23);
  EXPECT_EQ(r.segments_collected, r.segments_total - 23);
  auto after = segment_keys(o.out_dir);
  std::set<std::string> uniq(after.begin(), after.end());
  EXPECT_EQ(uniq.size(), after.size()) << "a segment was collected twice";
  EXPECT_EQ(after.size(), static_cast<std::size_t>(r.segments_total));
  for (std::size_t i = 0; i < before.size(); ++i) EXPECT_EQ(after[i], before[i]);
  EXPECT_TRUE(r.pass);
  auto s_ref = ref.estimate.sigma(), s = r.estimate.sigma();
  for (std::size_t i = 0; i < ref.estimate.names.size(); ++i) {
    auto k = static_cast<Eigen::Index>(i);
    EXPECT_LT(std::fabs(r.estimate.value[k] - ref.estimate.value[k]), 3 * std::sqrt(2.0) * s_ref[k])
        << ref.estimate.names[i];
    EXPECT_NEAR(s[k] / s_ref[k], 1.0, 0.2) << ref.estimate.names[i];
  }
}

TEST(Runner, EarlyStopMeetsTheSameSpecInLessCampaignTime) {
  Dir dir;
  RunResult full, early;
  {
    eoltest::FakeWorld w;
    auto o = opts(dir, "full", dir.station(1.0));
    o.early_stop = false;
    full = run_once(o, w);
  }
  ASSERT_TRUE(full.pass);
  // The spec: every parameter's σ within a factor of what the FULL schedule achieves. Both runs meet it.
  auto sf = full.estimate.sigma();
  for (double factor : {1.25, 1.5, 2.0, 3.0}) {
    nlohmann::json st = nlohmann::json::parse(station_json(1.0));
    nlohmann::json lim = nlohmann::json::object();
    for (std::size_t i = 0; i < full.estimate.names.size(); ++i)
      lim[full.estimate.names[i]] = {{"sigma", factor * sf[static_cast<Eigen::Index>(i)]}};
    st["limits"]["parameters"] = lim;
    // The fake lab's noise is exactly the station's nominal noise, so the tracker's σ is the batch σ:
    // compare the schedules at the very same spec, without the margin a real part needs.
    st["early_stop_sigma_fraction"] = 1.0;
    std::string name = "spec" + std::to_string(static_cast<int>(factor * 100));
    std::ofstream(dir.d / (name + ".json")) << st.dump(2);
    eoltest::FakeWorld w;
    early = run_once(opts(dir, name, (dir.d / (name + ".json")).string()), w);
    for (const auto& x : early.reasons) ADD_FAILURE() << factor << ": " << x;
    EXPECT_TRUE(early.pass);
    EXPECT_LE(early.campaign_time_s, full.campaign_time_s);
    auto se = early.estimate.sigma();
    for (std::size_t i = 0; i < early.estimate.names.size(); ++i)
      EXPECT_LE(se[static_cast<Eigen::Index>(i)], factor * sf[static_cast<Eigen::Index>(i)] * (1 + 1e-9))
          << early.estimate.names[i];
    std::printf("[figure] sigma spec = %.2f x full-schedule sigma: full %.0f s (%d segments), early stop %.0f s "
                "(%d segments): %.1f%% shorter\n",
                factor, full.campaign_time_s, full.segments_collected, early.campaign_time_s,
                early.segments_collected, 100.0 * (1.0 - early.campaign_time_s / full.campaign_time_s));
  }
  // The station's own spec (the schedule was designed with margin, as real ones are).
  {
    eoltest::FakeWorld w;
    early = run_once(opts(dir, "station-spec", dir.station(1.0, 0.5, "station2.json")), w);
    EXPECT_TRUE(early.pass);
    EXPECT_TRUE(early.early_stopped);
    EXPECT_LT(early.campaign_time_s, full.campaign_time_s);
    std::printf("[figure] station sigma spec: full %.0f s (%d segments), early stop %.0f s (%d segments): %.1f%% shorter\n",
                full.campaign_time_s, full.segments_collected, early.campaign_time_s, early.segments_collected,
                100.0 * (1.0 - early.campaign_time_s / full.campaign_time_s));
  }
}

TEST(Runner, FailVerdictIsRecordedWithReasons) {
  Dir dir;
  eoltest::FakeWorld w;
  // accel.bias.x is 0.05 m/s²: a 0.03 limit must fail it (and bias.y at -0.03 sits exactly at it).
  auto o = opts(dir, "fail", dir.station(1.0, 0.03));
  RunResult r = run_once(o, w);
  EXPECT_FALSE(r.pass);
  ASSERT_FALSE(r.reasons.empty());
  bool named = false;
  for (const auto& x : r.reasons) named |= x.find("accel.bias.x: |value|") != std::string::npos;
  EXPECT_TRUE(named);
  auto store = records::open_store(r.db);
  auto rec = store->get(r.record_id);
  EXPECT_FALSE(rec.pass);
  EXPECT_EQ(rec.reasons, r.reasons);
}

TEST(Runner, WrongSerialAndChangedInputsAreRefused) {
  Dir dir;
  eoltest::FakeWorld w;
  auto o = opts(dir, "x", dir.station(1.0));
  o.serial = "SN-OTHER";
  EXPECT_THROW(run_once(o, w), std::invalid_argument);
  o.serial = "SN-42";
  o.crash_after_segments = 2;
  EXPECT_THROW(run_once(o, w), SimulatedCrash);
  std::ofstream(o.station_path, std::ios::app) << " ";  // edited after the run started
  RunOptions ro;
  ro.out_dir = o.out_dir;
  ro.resume = true;
  ro.progress = nullptr;
  EXPECT_THROW(run_once(ro, w), std::invalid_argument);
}

// Honest σ (issue 14 item 6): the station states its fixture's tolerance; the batch solve carries it into
// every σ. A 0.03° nest (mount) tolerance is 5.2e-4 rad of misalignment that no table campaign can
// separate, so the 1e-4 misalignment σ limits that pass on noise alone must now fail, by name; cal.json
// keeps both σ.
TEST(Runner, FixtureToleranceWidensSigmaAndDecidesPassFail) {
  Dir dir;
  eoltest::FakeWorld w;
  nlohmann::json st = nlohmann::json::parse(station_json(1.0));
  st["fixture_tolerance"] = {{"axes", {{"tilt_sigma_deg", 0.005}, {"zero_sigma_deg", 0.01}}}, {"mount_sigma_deg", 0.03}};
  std::ofstream(dir.d / "tol.json") << st.dump(2);
  auto o = opts(dir, "tol", (dir.d / "tol.json").string());
  o.early_stop = false;
  RunResult r = run_once(o, w);
  EXPECT_FALSE(r.pass);
  bool misalign_sigma = false;
  for (const auto& x : r.reasons) misalign_sigma |= x.find("misalign") != std::string::npos && x.find("sigma") != std::string::npos;
  EXPECT_TRUE(misalign_sigma) << (r.reasons.empty() ? "" : r.reasons[0]);
  std::ifstream f(o.out_dir + "/cal.json");
  const nlohmann::json cal = nlohmann::json::parse(f);
  EXPECT_TRUE(cal["fixture_tolerance"]["stated"].get<bool>());
  for (const auto& p : cal["parameters"]) {
    ASSERT_TRUE(p.contains("sigma_noise")) << p["name"];
    EXPECT_GE(p["sigma"].get<double>(), p["sigma_noise"].get<double>() * (1 - 1e-9)) << p["name"];
    if (p["name"].get<std::string>().find("misalign") != std::string::npos)
      EXPECT_GT(p["sigma"].get<double>(), 3e-4) << p["name"];
  }
  // A station without a stated tolerance says so in cal.json.
  Dir dir2;
  eoltest::FakeWorld w2;
  auto o2 = opts(dir2, "none", dir2.station(1.0));
  o2.early_stop = false;
  run_once(o2, w2);
  std::ifstream f2(o2.out_dir + "/cal.json");
  EXPECT_FALSE(nlohmann::json::parse(f2)["fixture_tolerance"]["stated"].get<bool>());
}

TEST(Runner, FixtureToleranceIsCheckedBeforeTheRun) {
  Dir dir;
  eoltest::FakeWorld w;
  nlohmann::json st = nlohmann::json::parse(station_json(1.0));
  st["fixture_tolerance"] = {{"axes", nlohmann::json::array({{{"tilt_sigma_deg", 0.005}}})}};  // 1 entry, 2 axes
  std::ofstream(dir.d / "bad.json") << st.dump(2);
  try {
    run_once(opts(dir, "bad", (dir.d / "bad.json").string()), w);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fixture_tolerance.axes lists 1 axes but the table has 2"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.d / "bad" / "journal.log"));
}
}  // namespace eol_test_runner
