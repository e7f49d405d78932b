// The live multi-unit runner (StationRunner, issue 14) on an in-process lab: one fake world per nest,
// the bench's commands broadcast to all of them (one table, one chamber), each unit streamed on its own
// thread. Fast and deterministic enough for ThreadSanitizer (host-tsan preset). Checks that a dead node
// and a refused flash are reported by reason without stopping the others, that every unit gets exactly
// one record and the batch one record naming them, that a crash mid-collection and a resume give the
// same records without duplicates or re-collected segments, and that the tracker steers on the honest
// σ (a σ spec below the fixture's floor is never "met": no early stop).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <chrono>

#include "host/eol/journal.h"
#include "host/eol/runner.h"
#include "host/eol/station_runner.h"
#include "host/io/log.h"
#include "host/records/store.h"
#include "tests/eol/fake_world.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_station_runner {

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
    d = fs::temp_directory_path() / ("imuforge-station-" + records::new_record_id());
    fs::create_directories(d);
    std::ofstream(d / "campaign.json") << kCampaign;
    std::ofstream(d / "model.json") << kModel;
  }
  ~Dir() {
    if (getenv("EOL_KEEP")) return;
    std::error_code ec;
    fs::remove_all(d, ec);
  }
  std::string station(int slots, const nlohmann::json& extra = nlohmann::json::object(), double sigma_scale = 1.0) {
    nlohmann::json s = nlohmann::json::parse(station_json(sigma_scale));
    s["slots"] = nlohmann::json::array();
    for (int k = 1; k <= slots; ++k) s["slots"].push_back({{"name", "slot0" + std::to_string(k)}, {"node_id", k}});
    s.update(extra);
    std::ofstream(d / "station.json") << s.dump(2);
    return (d / "station.json").string();
  }
};

// One fake world per nest; the worlds share the bench's commands. Each world has its own lock: a unit's
// stream thread steps its world while the bench reads world 0 (the fixture clock) from another thread.
struct Lab {
  std::vector<std::unique_ptr<eoltest::FakeWorld>> w;
  std::vector<std::unique_ptr<std::mutex>> mu;
  explicit Lab(int n) {
    for (int k = 0; k < n; ++k) {
      w.push_back(std::make_unique<eoltest::FakeWorld>());
      w.back()->rng.seed(1000 + static_cast<unsigned>(k));
      mu.push_back(std::make_unique<std::mutex>());
    }
  }
};

// The world a unit's stream thread is sampling (set by LabDevice::stream): the bench's clock and air read
// from that thread are that world's, as one physical lab would give them.
thread_local eoltest::FakeWorld* tl_world = nullptr;
thread_local std::mutex* tl_mu = nullptr;

// The bench: commands go to every world. Before each command the worlds are brought to one clock:
// settling streams each unit for its own time, and one lab has one clock. Only the thread that runs the
// station brings them there: it waits while the units stream (StationRunner's per-unit threads), so no
// world is ever stepped under a stream. A unit thread's bench call outside its stream (run_clock() for a
// journal time stamp) reads world 0 as it stands. Before stop 42 such a call synced the worlds too: a unit
// that finished first jumped the others' clocks by seconds to minutes mid-segment, so what a unit collected
// depended on how the threads interleaved.
class LabBench : public Bench {
 public:
  explicit LabBench(Lab& lab) : lab_(lab), owner_(std::this_thread::get_id()) {}
  void sync() {
    if (std::this_thread::get_id() != owner_) return;
    double tmax = 0;
    for (std::size_t k = 0; k < lab_.w.size(); ++k) {
      std::lock_guard<std::mutex> lk(*lab_.mu[k]);
      tmax = std::max(tmax, lab_.w[k]->t);
    }
    for (std::size_t k = 0; k < lab_.w.size(); ++k) {
      std::lock_guard<std::mutex> lk(*lab_.mu[k]);
      if (lab_.w[k]->t < tmax) lab_.w[k]->step(tmax - lab_.w[k]->t);
    }
  }
  std::string describe() const override { return "fake-table + fake-chamber"; }
  template <typename F>
  void all(F&& f) {
    sync();
    for (std::size_t k = 0; k < lab_.w.size(); ++k) {
      std::lock_guard<std::mutex> lk(*lab_.mu[k]);
      eoltest::FakeBench b(*lab_.w[k]);
      f(b);
    }
  }
  template <typename F>
  auto first(F&& f) {
    if (tl_world) {  // from a unit's stream thread: its own world
      std::lock_guard<std::mutex> lk(*tl_mu);
      eoltest::FakeBench b(*tl_world);
      return f(b);
    }
    sync();
    std::lock_guard<std::mutex> lk(*lab_.mu[0]);
    eoltest::FakeBench b(*lab_.w[0]);
    return f(b);
  }
  void set_chamber(double sp, double r) override { all([&](Bench& b) { b.set_chamber(sp, r); }); }
  double chamber_air_C() override { return first([](Bench& b) { return b.chamber_air_C(); }); }
  void command_position(const std::array<double, 3>& a) override { all([&](Bench& b) { b.command_position(a); }); }
  void command_rate(const std::array<double, 3>& r) override {
    sync();
    rate_commands.push_back({lab_.w[0]->ang, r});
    all([&](Bench& b) { b.command_rate(r); });
  }
  // Every rate command with the table angles it was given at (world 0; the worlds share one clock here).
  std::vector<std::pair<std::array<double, 3>, std::array<double, 3>>> rate_commands;
  TableReading table() override { return first([](Bench& b) { return b.table(); }); }
  double time_s() override { return first([](Bench& b) { return b.time_s(); }); }
  void wait(double s) override { all([&](Bench& b) { b.wait(s); }); }

 private:
  Lab& lab_;
  std::thread::id owner_;  // the thread that runs the station (the test's)
};

class LabDevice : public Device {
 public:
  LabDevice(eoltest::FakeWorld& w, std::mutex& mu, std::string serial, bool refuse_flash, int stall_us = 0)
      : w_(w), mu_(mu), inner_(w, std::move(serial)), refuse_(refuse_flash), stall_us_(stall_us) {}
  DeviceInfo identify() override {
    std::lock_guard<std::mutex> lk(mu_);
    return inner_.identify();
  }
  StreamStats stream(double rate_hz, const std::function<bool(const ImuSample&)>& cb) override {
    StreamStats st;
    struct Bind {
      Bind(eoltest::FakeWorld* w, std::mutex* m) { tl_world = w, tl_mu = m; }
      ~Bind() { tl_world = nullptr, tl_mu = nullptr; }
    } bind(&w_, &mu_);
    for (;;) {
      ImuSample s;
      {
        std::lock_guard<std::mutex> lk(mu_);
        w_.step(1.0 / rate_hz);
        s = w_.sample();
      }
      ++st.received;
      if (stall_us_ > 0 && st.received % 20 == 0) std::this_thread::sleep_for(std::chrono::microseconds(stall_us_));
      if (!cb(s)) return st;
    }
  }
  void flash_table(const std::vector<std::uint8_t>& b, std::uint32_t seq) override {
    if (refuse_) throw std::runtime_error("node refused the table (auth failed)");
    std::lock_guard<std::mutex> lk(mu_);
    inner_.flash_table(b, seq);
  }
  std::vector<std::uint8_t> read_table() override {
    std::lock_guard<std::mutex> lk(mu_);
    return inner_.read_table();
  }

 private:
  eoltest::FakeWorld& w_;
  std::mutex& mu_;
  eoltest::FakeDevice inner_;
  bool refuse_;
  int stall_us_;  // a slow node: sleeps this long every 20 samples (another interleaving of the threads)
};

struct Station {
  Lab lab;
  LabBench bench{lab};
  std::set<int> dead, refuse;
  std::map<int, int> stall_us;  // node id -> LabDevice's stall
  explicit Station(int n) : lab(n) {}
  StationRunResult run(StationRunOptions o) {
    StationRunner r(
        o, bench,
        [this](const StationConfig& s) -> std::unique_ptr<Device> {
          if (dead.count(s.can_node_id)) throw std::runtime_error("identify: no response (timeout)");
          const auto k = static_cast<std::size_t>(s.can_node_id - 1);
          return std::make_unique<LabDevice>(*lab.w[k], *lab.mu[k], "SN-" + std::to_string(100 + s.can_node_id),
                                             refuse.count(s.can_node_id) > 0,
                                             stall_us.count(s.can_node_id) ? stall_us.at(s.can_node_id) : 0);
        },
        [] { return std::make_unique<eoltest::FakeTableOps>(); });
    return r.run();
  }
};

StationRunOptions options(const Dir& dir, const std::string& station) {
  StationRunOptions o;
  o.out_dir = (dir.d / "run").string();
  o.campaign_path = (dir.d / "campaign.json").string();
  o.station_path = station;
  o.threads = getenv("ST_THREADS") ? atoi(getenv("ST_THREADS")) : 2;
  o.progress = nullptr;
  return o;
}

// One record per unit, one batch naming them all; no segment journaled twice in any unit.
void expect_records(const StationRunResult& r, const fs::path& run, std::size_t units) {
  auto store = records::open_store(r.db);
  const auto b = store->get_batch(r.batch_id);
  ASSERT_EQ(b.units.size(), units);
  std::set<std::string> ids;
  for (const auto& u : b.units) {
    EXPECT_TRUE(ids.insert(u.calibration_id).second);
    const auto rec = store->get(u.calibration_id);
    EXPECT_EQ(rec.pass, u.pass) << u.slot;
    if (!u.serial.empty()) EXPECT_EQ(store->find_by_serial(u.serial).size(), 1u) << u.serial;
    if (!fs::exists(run / u.slot / "journal.log")) continue;
    std::set<std::string> keys;
    for (const auto& e : read_journal((run / u.slot / "journal.log").string()).entries)
      if (e["type"] == "segment_done" || e["type"] == "verify_segment")
        EXPECT_TRUE(keys.insert(e["key"].get<std::string>()).second) << u.slot << " " << e["key"];
  }
}

// `imuforge run --resume DIR` of a full-schedule station run.
StationRunOptions resume_options(const std::string& out_dir) {
  StationRunOptions ro;
  ro.out_dir = out_dir;
  ro.resume = true;
  ro.early_stop = false;
  ro.threads = 2;
  ro.progress = nullptr;
  return ro;
}

// Rewrites a journal without the lines drop(line, is_last) picks (a crash that lost them).
void drop_lines(const fs::path& file, const std::function<bool(const std::string&, bool last)>& drop) {
  std::vector<std::string> lines;
  {
    std::ifstream f(file);
    for (std::string l; std::getline(f, l);) lines.push_back(l);
  }
  std::ofstream f(file, std::ios::trunc);
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (!drop(lines[i], i + 1 == lines.size())) f << lines[i] << "\n";
}

}  // namespace

TEST(StationRunner, EveryUnitIsFinishedAndFailuresAreReportedByReason) {
  Dir dir;
  Station s(4);
  s.dead = {3};
  s.refuse = {4};
  const StationRunResult r = s.run(options(dir, dir.station(4)));
  ASSERT_EQ(r.units.size(), 4u);
  for (int k : {0, 1}) {
    for (const auto& x : r.units[static_cast<std::size_t>(k)].reasons) ADD_FAILURE() << r.units[static_cast<std::size_t>(k)].slot << ": " << x;
    EXPECT_TRUE(r.units[static_cast<std::size_t>(k)].pass);
    EXPECT_TRUE(fs::exists(r.units[static_cast<std::size_t>(k)].report_path));
    // The table that was flashed is the one recorded.
    EXPECT_FALSE(s.lab.w[static_cast<std::size_t>(k)]->flashed.empty());
  }
  EXPECT_FALSE(r.units[2].pass);
  ASSERT_FALSE(r.units[2].reasons.empty());
  EXPECT_NE(r.units[2].reasons[0].find("no answer from node 3"), std::string::npos) << r.units[2].reasons[0];
  EXPECT_FALSE(r.units[3].pass);
  ASSERT_FALSE(r.units[3].reasons.empty());
  EXPECT_NE(r.units[3].reasons[0].find("refused the table"), std::string::npos) << r.units[3].reasons[0];
  EXPECT_EQ(r.passed, 2);
  expect_records(r, dir.d / "run", 4);
  EXPECT_TRUE(fs::exists(r.batch_report_path));
  // All units were streamed through one campaign: the same segment keys for the two good units.
  auto keys = [&](const std::string& slot) {
    std::vector<std::string> k;
    for (const auto& e : read_journal((dir.d / "run" / slot / "journal.log").string()).entries)
      if (e["type"] == "segment_done") k.push_back(e["key"]);
    return k;
  };
  EXPECT_EQ(keys("slot01"), keys("slot02"));
  EXPECT_FALSE(keys("slot01").empty());
}

// The lab is one deterministic world per nest, so a station run is reproducible whatever the scheduler
// does: the same segments, byte for byte, when one node is slow enough to turn the order in which the
// units finish their segments around. This guards the lab (before stop 42 a unit that finished first
// jumped the others' clocks mid-segment) and the runner (no shared state between the units' streams).
TEST(StationRunner, WhatEachUnitCollectsDoesNotDependOnHowTheThreadsInterleave) {
  auto segments = [](int stall_node) {
    Dir dir;
    Station s(2);
    if (stall_node > 0) s.stall_us[stall_node] = 800;
    auto o = options(dir, dir.station(2));
    o.early_stop = false;
    const StationRunResult r = s.run(o);
    EXPECT_EQ(r.passed, 2);
    std::vector<std::string> v;
    for (const char* slot : {"slot01", "slot02"})
      for (const auto& e : read_journal((dir.d / "run" / slot / "journal.log").string()).entries)
        if (e["type"] == "segment_done" || e["type"] == "verify_segment")
          v.push_back(std::string(slot) + " " + e["key"].get<std::string>() + " " + e["sha256"].get<std::string>());
    return v;
  };
  const auto plain = segments(0);
  ASSERT_FALSE(plain.empty());
  EXPECT_EQ(segments(1), plain) << "node 1 slow";
  EXPECT_EQ(segments(2), plain) << "node 2 slow";
}

TEST(StationRunner, CrashMidCollectionResumesPerUnitWithTheSameRecordsOnce) {
  Dir dir;
  const std::string st = dir.station(3);
  Station s(3);  // the same lab keeps running across the crash, as a real bench would
  s.dead = {2};
  auto o = options(dir, st);
  o.early_stop = false;
  o.crash_after_steps = 12;
  EXPECT_THROW(s.run(o), SimulatedCrash);
  // A crash between two units' journal appends: slot03 lacks the last step slot01 has. The resume must
  // collect it for slot03 only.
  const fs::path run = dir.d / "run";
  drop_lines(run / "slot03" / "journal.log", [](const std::string& l, bool last) {
    if (last) EXPECT_NE(l.find("segment_done"), std::string::npos);
    return last;
  });
  const StationRunOptions ro = resume_options(o.out_dir);
  const StationRunResult r = s.run(ro);
  ASSERT_EQ(r.units.size(), 3u);
  EXPECT_TRUE(r.units[0].pass);
  EXPECT_TRUE(r.units[2].pass);
  EXPECT_FALSE(r.units[1].pass);
  EXPECT_EQ(r.steps_collected, r.steps_total - 12 + 1 + 3) << "the 12 safe steps less the one slot03 lost, plus 3 verification poses";
  expect_records(r, run, 3);
  // Resuming a finished station run reports it again and records nothing new.
  const StationRunResult again = s.run(ro);
  EXPECT_EQ(again.batch_id, r.batch_id);
  EXPECT_EQ(again.steps_collected, 0);
  expect_records(again, run, 3);
}

TEST(StationRunner, TrackerSteersOnTheHonestSigma) {
  // A 0.03° nest tolerance puts a floor of ~5e-4 rad under every misalignment σ: the 4e-4 specs (4× the
  // base station's) are then met by no schedule, so the station must not stop early (it would on the noise-only σ), and the units
  // fail on misalignment σ, by name.
  Dir dir;
  Station s(2);
  const std::string st =
      dir.station(2, {{"fixture_tolerance", {{"axes", {{"tilt_sigma_deg", 0.005}, {"zero_sigma_deg", 0.01}}}, {"mount_sigma_deg", 0.03}}}}, 4.0);
  const StationRunResult r = s.run(options(dir, st));
  EXPECT_FALSE(r.early_stopped);
  for (const auto& u : r.units) {
    EXPECT_FALSE(u.pass) << u.slot;
    bool misalign = false;
    for (const auto& x : u.reasons) misalign |= x.find("misalign") != std::string::npos && x.find("sigma") != std::string::npos;
    EXPECT_TRUE(misalign) << u.slot;
  }
  // The same station without the tolerance does stop early.
  Dir dir2;
  Station s2(2);
  const StationRunResult r2 = s2.run(options(dir2, dir2.station(2, nlohmann::json::object(), 4.0)));
  EXPECT_TRUE(r2.early_stopped);
  // Seen once in host-sanitize under CI (stop 41: passed 1), not reproduced. Its lab then depended on how
  // the threads interleaved (see LabBench); it no longer does, and 120 other noise seeds all pass here. The
  // failing unit's reasons are what the next look needs, should it come back.
  std::string why;
  for (const auto& u : r2.units)
    for (const auto& x : u.reasons) why += u.slot + ": " + x + "; ";
  EXPECT_EQ(r2.passed, 2) << "steps " << r2.steps_collected << "/" << r2.steps_total << "; " << why;
}

// A crash around the second rotation of a CW/CCW pair ("z CCW", commanded while the table still turned
// from "z CW"): the resume must bring the one table back to the state "z CCW" was commanded from
// (TableMotion, host/eol/schedule.h). Three cases:
//  - z CCW was commanded (its table_turning entry is in the station journal) and one unit lacks it (a
//    crash between the units' appends): commanded again at the angle the interrupted run commanded it at;
//  - the same without the entry (a journal written before it existed): from the end of the step before it
//    in the unit that has it (z CW's last row);
//  - z CCW never commanded (crash right after z CW): from the end of the furthest unit's last segment.
// (Without the entry the resume can only take z CW's end. That is not necessarily the interrupted command
// angle: on a real station the table turns on for the host's time between the two segments.)
TEST(StationRunner, ContinuedRotationInFlightResumesAtTheSamePhase) {
  const std::array<double, 3> ccw_dps{-100, 0, 0};  // "z CCW", plateau 0 step 12, after "z CW" (step 11)
  auto angle_at_first = [&](const LabBench& b) {
    for (const auto& c : b.rate_commands)
      if (c.second == ccw_dps) return c.first;
    ADD_FAILURE() << "z CCW never commanded";
    return std::array<double, 3>{};
  };
  struct Case {
    int safe;
    bool keep_entry;
  };
  for (const Case c : {Case{13, true}, Case{13, false}, Case{12, true}}) {
    SCOPED_TRACE("crash after " + std::to_string(c.safe) + " steps" + (c.keep_entry ? "" : ", no table_turning entry"));
    Dir dir;
    const std::string st = dir.station(2);
    Station s(2);
    auto o = options(dir, st);
    o.early_stop = false;
    o.crash_after_steps = c.safe;
    EXPECT_THROW(s.run(o), SimulatedCrash);
    const fs::path run = dir.d / "run";
    if (c.safe == 13)  // slot02 loses its last append ("z CCW")
      drop_lines(run / "slot02" / "journal.log", [&](const std::string& l, bool last) {
        if (last) EXPECT_NE(l.find(step_key(0, 12)), std::string::npos);
        return last;
      });
    if (!c.keep_entry)
      drop_lines(run / "journal.log", [](const std::string& l, bool) { return l.find("table_turning") != std::string::npos; });
    // The end of z CW, from slot01's safe segment.
    std::array<double, 3> cw_end{};
    {
      io::LogReader r((run / "slot01" / "segments" / (step_key(0, 11) + ".bin")).string());
      io::LogRow row;
      while (r.next(row))
        for (std::size_t ax = 0; ax < 2; ++ax) cw_end[ax] = row.table_angle_rad[ax] * 180.0 / M_PI;
    }
    const std::array<double, 3> first_angle = c.safe == 13 ? angle_at_first(s.bench) : std::array<double, 3>{};
    for (auto& w : s.lab.w) w->rate = {0, 0, 0};  // the table stopped while the host was down
    s.bench.rate_commands.clear();
    const StationRunResult r = s.run(resume_options(o.out_dir));
    ASSERT_EQ(r.units.size(), 2u);
    EXPECT_TRUE(r.units[0].pass && r.units[1].pass);
    const std::array<double, 3> a = angle_at_first(s.bench);
    const std::array<double, 3> want = c.safe == 13 && c.keep_entry ? first_angle : cw_end;
    for (std::size_t ax = 0; ax < 2; ++ax)
      EXPECT_LT(std::fabs(std::remainder(a[ax] - want[ax], 360.0)), 1e-6)
          << "axis " << ax << ": z CCW commanded at " << a[ax] << " deg, expected " << want[ax];
  }
}
}  // namespace eol_test_station_runner
