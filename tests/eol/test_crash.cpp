// Crash consistency of the run journal and records (issue 16): `imuforge run` is killed with SIGKILL at
// seeded random moments and resumed; every time the final record must equal an uninterrupted run's:
// the same parameters within σ/10, no segment journaled twice, no second record, the same segment count.
//
// Each run is a child process (fork) on the in-process lab of fake_world.h, killed by the parent with
// SIGKILL after a seeded random delay in [5 %, 95 %] of an uninterrupted run's wall time (a run that ends
// first shortens that span and its point is drawn again): the kill lands anywhere (mid-segment,
// mid-append, while solving, flashing or recording). The lab runs on across the
// crash (its state, and the device's flash, live in shared memory), and its noise is a function of the
// pose (FakeWorld::noise_per_stream), so the in-flight segment, collected again after the resume,
// carries the same noise; the runner must bring the table to the same state (a rotation continuing
// another: the same phase, TableMotion in host/eol/schedule.h). Whatever differs from the uninterrupted
// run is the runner's doing.
//
// Points: IMUFORGE_CRASH_POINTS (6 in ctest; the benchmark runs 60: `IMUFORGE_CRASH_POINTS=60
// build/host/bin/tests_eol --gtest_filter='Crash.*'`), seed IMUFORGE_CRASH_SEED (1). Prints "kill points survived: S of T".
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <thread>
#include <vector>

#include "host/eol/batch.h"
#include "host/eol/journal.h"
#include "host/eol/station.h"
#include "host/io/campaign_file.h"
#include "host/model/sensor_model.h"
#include "host/io/log.h"
#include "host/eol/runner.h"
#include "host/records/store.h"
#include "tests/eol/fake_world.h"
#include "tests/eol/pg_server.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_crash {

using namespace imuforge;
using namespace imuforge::eol;
namespace fs = std::filesystem;

namespace {

// A short campaign: two plateaus of six poses and two rates (the kill needs somewhere to land, the ctest
// must stay fast).
const char* kCampaign = R"({
  "name": "crash-eol", "sample_rate_hz": 50,
  "site": {"latitude_deg": 45, "height_m": 0},
  "table": {"axes": [{"name": "inner", "axis": "z", "max_rate_dps": 300, "max_accel_dps2": 200},
                     {"name": "outer", "axis": "x", "max_rate_dps": 300, "max_accel_dps2": 200}],
            "settle_s": 1},
  "chamber": {"initial_C": 25, "ramp_limit_C_per_min": 5, "tau_s": 60},
  "sequences": {
    "six": [
      {"type": "position", "label": "z up",   "position_deg": [0, 0],    "dwell_s": 6},
      {"type": "position", "label": "z down", "position_deg": [0, 180],  "dwell_s": 6},
      {"type": "position", "label": "y a",    "position_deg": [0, 90],   "dwell_s": 6},
      {"type": "position", "label": "y b",    "position_deg": [0, -90],  "dwell_s": 6},
      {"type": "position", "label": "x a",    "position_deg": [90, 90],  "dwell_s": 6},
      {"type": "position", "label": "x b",    "position_deg": [-90, 90], "dwell_s": 6},
      {"type": "position", "label": "diag",   "position_deg": [45, 45],  "dwell_s": 6}
    ],
    "rates": [
      {"type": "rate", "label": "z CW",  "rate_dps": [100, 0],  "dwell_s": 6},
      {"type": "rate", "label": "z CCW", "rate_dps": [-100, 0], "dwell_s": 6},
      {"type": "position", "label": "rx home", "position_deg": [0, 0], "dwell_s": 3},
      {"type": "rate", "label": "x CW",  "rate_dps": [0, 100],  "dwell_s": 6},
      {"type": "rate", "label": "x CCW", "rate_dps": [0, -100], "dwell_s": 6},
      {"type": "position", "label": "ry home", "position_deg": [90, 0], "dwell_s": 3},
      {"type": "rate", "label": "y CW",  "rate_dps": [0, 100],  "dwell_s": 6},
      {"type": "rate", "label": "y CCW", "rate_dps": [0, -100], "dwell_s": 6}
    ]
  },
  "phases": [
    {"type": "plateau", "label": "cold", "setpoint_C": 15, "steps": [{"use": "six"}, {"use": "rates"}]},
    {"type": "plateau", "label": "hot",  "setpoint_C": 35, "steps": [{"use": "six"}, {"use": "rates"}]}
  ]
})";

const char* kModel = R"({"name": "t", "T_ref_C": 25, "effects": {
  "accel.bias": {}, "accel.scale": {}, "accel.misalign": {}, "accel.bias_temp": {"order": 1},
  "gyro.bias": {}, "gyro.scale": {}, "gyro.misalign": {}, "gyro.bias_temp": {"order": 1}}})";

const char* kStation = R"({
  "name": "crash-station", "model": "model.json",
  "can": {"bus": "virtual:test", "node_id": 1, "stream_rate_hz": 50},
  "noise": {"accel_mps2": 2e-3, "gyro_rad_s": 2e-4},
  "settle": {"temp_window_s": 60, "temp_slope_C_per_min": 0.1, "temp_band_C": 3},
  "verification": [{"label": "v-zup", "position_deg": [0, 0], "dwell_s": 3}],
  "limits": {"verification": {"accel_mps2": 0.05, "gyro_rad_s": 0.01}}
})";

struct Outcome {
  bool ok = false;
  std::vector<std::string> names;
  std::vector<double> value, sigma;
  int segments_total = 0, segments_resumed = 0;
  std::size_t records = 0;
  std::vector<std::string> segment_keys;
  std::vector<std::string> segment_files;
  std::vector<std::string> segment_kinds;  // "rate" when the segment's reference rate is not zero
  std::string error;
};

// Child: run (or resume) and write the outcome as JSON; the parent reads it.
[[noreturn]] void child_run(RunOptions o, const std::string& result_path, eoltest::LabState* lab) {
  nlohmann::json j;
  try {
    eoltest::FakeWorld w;
    w.noise_per_stream = true;
    if (lab->valid) w.restore(*lab);  // the lab ran on while the host was down
    w.persist = lab;
    eoltest::FakeBench b(w);
    eoltest::FakeDevice dev(w, "SN-42");
    eoltest::FakeTableOps t;
    Runner r(o, b, dev, t);
    RunResult res = r.run();
    j["ok"] = true;
    j["names"] = res.estimate.names;
    std::vector<double> v(res.estimate.value.data(), res.estimate.value.data() + res.estimate.value.size());
    const Eigen::VectorXd s = res.estimate.sigma();
    j["value"] = v;
    j["sigma"] = std::vector<double>(s.data(), s.data() + s.size());
    j["segments_total"] = res.segments_total;
    j["segments_resumed"] = res.segments_resumed;
  } catch (const std::exception& e) {
    j["ok"] = false;
    j["error"] = e.what();
  }
  std::ofstream(result_path) << j.dump();
  std::_Exit(0);
}

Outcome read_outcome(const std::string& result_path, const std::string& out_dir, const std::string& db) {
  Outcome o;
  std::ifstream f(result_path);
  if (!f) {
    o.error = "no result";
    return o;
  }
  const auto j = nlohmann::json::parse(f);
  o.ok = j.value("ok", false);
  o.error = j.value("error", "");
  if (o.ok) {
    o.names = j["names"].get<std::vector<std::string>>();
    o.value = j["value"].get<std::vector<double>>();
    o.sigma = j["sigma"].get<std::vector<double>>();
    o.segments_total = j["segments_total"];
    o.segments_resumed = j["segments_resumed"];
  }
  o.records = records::open_store(db)->find_by_serial("SN-42").size();
  for (const auto& e : read_journal(out_dir + "/journal.log").entries)
    if (e["type"] == "segment_done") {
      o.segment_keys.push_back(e["key"]);
      o.segment_files.push_back(e["file"]);
    }
  // Each segment's kind from its own log: a rotation has a nonzero reference rate.
  for (const auto& file : o.segment_files) {
    io::LogReader lr(out_dir + "/" + file);
    io::LogRow row;
    bool turning = false;
    if (lr.next(row)) turning = std::fabs(row.w_ref[0]) + std::fabs(row.w_ref[1]) + std::fabs(row.w_ref[2]) > 0.1;
    o.segment_kinds.push_back(turning ? "rate" : "static");
  }
  return o;
}

int wait_child(pid_t pid) {
  int st = 0;
  while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
  }
  return st;
}

// A folder holding this file's campaign, model and station.
fs::path input_dir(const std::string& prefix) {
  const fs::path d = fs::temp_directory_path() / (prefix + records::new_record_id());
  fs::create_directories(d);
  std::ofstream(d / "campaign.json") << kCampaign;
  std::ofstream(d / "model.json") << kModel;
  std::ofstream(d / "station.json") << kStation;
  return d;
}

// A full-schedule run (early stop off: the same segments in every run) into d/name, records in `db`
// (default: SQLite d/name.db).
RunOptions run_options(const fs::path& d, const std::string& name, const std::string& db = "") {
  RunOptions o;
  o.out_dir = (d / name).string();
  o.serial = "SN-42";
  o.campaign_path = (d / "campaign.json").string();
  o.station_path = (d / "station.json").string();
  o.db = db.empty() ? (d / (name + ".db")).string() : db;
  o.early_stop = false;
  o.progress = nullptr;
  return o;
}

int env_int(const char* name, int def) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::atoi(v) : def;
}

}  // namespace

TEST(Crash, SigkillAtRandomPointsThenResumeEqualsUninterrupted) {
  const fs::path d = input_dir("imuforge-crash-");
  auto opts = [&](const std::string& name) { return run_options(d, name); };

  // The uninterrupted reference, in a child like the others; its wall time spans the kill moments.
  // The lab's state lives in shared memory: it survives a killed run (as a real lab does).
  void* mem = ::mmap(nullptr, sizeof(eoltest::LabState), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(mem, MAP_FAILED);
  auto* lab = new (mem) eoltest::LabState();
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t rp = ::fork();
  ASSERT_GE(rp, 0);
  if (rp == 0) child_run(opts("ref"), (d / "ref.result").string(), lab);
  wait_child(rp);
  double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Outcome ref = read_outcome((d / "ref.result").string(), opts("ref").out_dir, opts("ref").db);
  ASSERT_TRUE(ref.ok) << ref.error;
  ASSERT_EQ(ref.records, 1u);

  const int points = env_int("IMUFORGE_CRASH_POINTS", 6);
  std::mt19937_64 rng(static_cast<std::uint64_t>(env_int("IMUFORGE_CRASH_SEED", 1)));
  int tried = 0, survived = 0, finished_first = 0, within_tenth = 0;
  int rotations = 0, continued = 0;  // kill points with a rotation in flight; one that continued another
  double worst_ratio = 0, worst_rotation = 0;
  for (int k = 0; k < points; ++k) {
    const std::string name = "kill" + std::to_string(k);
    const RunOptions o = opts(name);
    // A run that ends before its kill (the machine got less busy than during the reference) is not a
    // kill point: its wall time becomes the new span of the kill moments and the point is drawn again.
    double delay_s = 0;
    bool killed = false;
    for (int attempt = 0; attempt < 4 && !killed; ++attempt) {
      fs::remove_all(o.out_dir);
      fs::remove(o.db);
      delay_s = std::uniform_real_distribution<double>(0.05 * wall_s, 0.95 * wall_s)(rng);
      *lab = eoltest::LabState();  // a new device on a lab that starts as the reference's did
      const auto start = std::chrono::steady_clock::now();
      const pid_t pid = ::fork();
      ASSERT_GE(pid, 0);
      if (pid == 0) child_run(o, (d / (name + ".first")).string(), lab);
      int st = 0;
      bool ended = false;
      double elapsed_s = 0;
      while (!ended && (elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()) < delay_s) {
        ended = ::waitpid(pid, &st, WNOHANG) == pid;
        if (!ended) std::this_thread::sleep_for(std::chrono::microseconds(500));
      }
      if (!ended) {
        ::kill(pid, SIGKILL);
        st = wait_child(pid);
      }
      killed = WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL;
      if (!killed) {
        ++finished_first;
        wall_s = elapsed_s;
      }
    }
    if (!killed) continue;
    ++tried;
    // Resume; a kill before the journal's first entry leaves nothing to resume: start again instead,
    // as an operator would.
    RunOptions ro = o;
    const bool has_journal = fs::exists(o.out_dir + "/journal.log") && !read_journal(o.out_dir + "/journal.log").entries.empty();
    if (has_journal) {
      ro.resume = true;
    } else {
      fs::remove_all(o.out_dir);
    }
    const pid_t p2 = ::fork();
    ASSERT_GE(p2, 0);
    if (p2 == 0) child_run(ro, (d / (name + ".result")).string(), lab);
    wait_child(p2);
    const Outcome r = read_outcome((d / (name + ".result")).string(), o.out_dir, o.db);
    bool ok = r.ok;
    EXPECT_TRUE(r.ok) << name << " (killed at " << delay_s << " s): " << r.error;
    EXPECT_EQ(r.records, 1u) << name << ": exactly one record";
    ok = ok && r.records == 1u;
    const std::set<std::string> uniq(r.segment_keys.begin(), r.segment_keys.end());
    EXPECT_EQ(uniq.size(), r.segment_keys.size()) << name << ": a segment journaled twice";
    EXPECT_EQ(r.segment_keys, ref.segment_keys) << name << ": segments differ from the uninterrupted run";
    ok = ok && uniq.size() == r.segment_keys.size() && r.segment_keys == ref.segment_keys;
    if (r.ok) {
      EXPECT_EQ(r.names, ref.names);
      ok = ok && r.names == ref.names;
      // The segment in flight at the kill is collected again, under the uninterrupted run's conditions: a
      // static dwell at the same pose, a rotation that continued another (CW then CCW) from the table state
      // the previous segment left (TableMotion restores it), so the lab's noise meets gravity at the same
      // phase. What remains is the re-settled die temperature: within σ/10 for every kill point.
      const std::size_t in_flight = static_cast<std::size_t>(r.segments_resumed);
      const bool rotation_in_flight = in_flight < ref.segment_kinds.size() && ref.segment_kinds[in_flight] == "rate";
      double worst = 0;
      std::string worst_name;
      bool within = true;
      for (std::size_t i = 0; i < ref.names.size() && i < r.value.size(); ++i) {
        const double ratio = std::fabs(r.value[i] - ref.value[i]) / ref.sigma[i];
        if (ratio > worst) worst_name = ref.names[i];
        worst = std::max(worst, ratio);
        within = within && ratio < 0.1;
        EXPECT_LT(ratio, 0.1) << name << ": " << ref.names[i] << " differs by " << ratio << " σ (in flight: segment "
                              << in_flight << (rotation_in_flight ? ", a rotation)" : ")");
      }
      std::printf("%s: killed at %.2f s, in flight: segment %zu (%s), largest difference %.3g σ (%s)\n", name.c_str(),
                  delay_s, in_flight, in_flight < ref.segment_kinds.size() ? ref.segment_kinds[in_flight].c_str() : "none",
                  worst, worst_name.c_str());
      (rotation_in_flight ? worst_rotation : worst_ratio) = std::max(rotation_in_flight ? worst_rotation : worst_ratio, worst);
      rotations += rotation_in_flight ? 1 : 0;
      continued += rotation_in_flight && in_flight > 0 && ref.segment_kinds[in_flight - 1] == "rate" ? 1 : 0;
      ok = ok && within;
      within_tenth += worst < 0.1 ? 1 : 0;
    }
    survived += ok ? 1 : 0;
  }
  std::printf("kill points survived: %d of %d (%d runs finished before their kill and were drawn again; uninterrupted "
              "run %.2f s wall at the end)\n"
              "parameters within σ/10 of the uninterrupted run: %d of %d; largest difference %.2e σ with no rotation "
              "in flight, %.2e σ with a rotation in flight (%d kill points, %d of them a rotation continuing another)\n",
              survived, tried, finished_first, wall_s, within_tenth, tried, worst_ratio, worst_rotation, rotations,
              continued);
  EXPECT_GT(tried, 0) << "no kill landed inside a run";
  EXPECT_EQ(survived, tried);
  ::munmap(mem, sizeof(eoltest::LabState));
  if (!std::getenv("EOL_KEEP")) fs::remove_all(d);
}

// A PostgreSQL connection dropped in the middle of writing the record (issue 16), two ways: the backend
// terminated from a second connection (pg_terminate_backend), and the server stopped and started again.
// A one-shot trigger holds the insert of the 4th parameter row (pg_sleep) so the drop lands inside the
// record's transaction, deterministically. The run must fail as a peer failure with nothing written
// (the transaction is rolled back), and `--resume` must leave exactly one record, under the id journaled
// before the drop, with the uninterrupted run's parameters (within σ/10) and no row twice.
namespace {

struct InProcessRun {
  RunResult res;
  std::string error;
};

InProcessRun run_in_process(const RunOptions& o, eoltest::FakeWorld& w, eoltest::FakeDevice& dev) {
  InProcessRun out;
  try {
    eoltest::FakeBench b(w);
    eoltest::FakeTableOps t;
    Runner r(o, b, dev, t);
    out.res = r.run();
  } catch (const std::exception& e) {
    out.error = e.what();
  }
  return out;
}

void pg_drop_mid_write(bool stop_server) {
  imuforge::testing::PgServer pg;
  const fs::path d = input_dir("imuforge-pgdrop-");
  auto opts = [&](const std::string& name, const std::string& db) { return run_options(d, name, db); };
  // The uninterrupted reference (SQLite: the back end does not change the record's content).
  eoltest::FakeWorld wref;
  wref.noise_per_stream = true;
  eoltest::FakeDevice dref(wref, "SN-42");
  const InProcessRun ref = run_in_process(opts("ref", (d / "ref.db").string()), wref, dref);
  ASSERT_TRUE(ref.error.empty()) << ref.error;
  const Eigen::VectorXd ref_sigma = ref.res.estimate.sigma();

  records::open_store(pg.url())->ensure_schema();
  pg.psql(
      "CREATE TABLE drop_once (armed BOOLEAN NOT NULL);\n"
      "INSERT INTO drop_once VALUES (true);\n"
      "CREATE FUNCTION hold_mid_write() RETURNS trigger LANGUAGE plpgsql AS $$\n"
      "BEGIN\n"
      "  IF NEW.ord = 3 AND (SELECT armed FROM drop_once) THEN PERFORM pg_sleep(120); END IF;\n"
      "  RETURN NEW;\n"
      "END $$;\n"
      "CREATE TRIGGER hold BEFORE INSERT ON calibration_parameter FOR EACH ROW EXECUTE FUNCTION hold_mid_write();\n");

  eoltest::FakeWorld w;
  w.noise_per_stream = true;
  eoltest::FakeDevice dev(w, "SN-42");
  const RunOptions o = opts("pg", pg.url());
  InProcessRun first;
  std::atomic<bool> first_done{false};
  std::thread runner([&] {
    first = run_in_process(o, w, dev);
    first_done = true;
  });
  // Wait for the record's insert to be held by the trigger, then drop its connection. Whatever happens
  // here, the runner thread is joined before anything can end the test.
  bool held = false;
  std::string drop_error;
  try {
    std::string pid;
    for (int i = 0; i < 6000 && !held && !first_done; ++i) {
      pid = pg.psql("SELECT pid FROM pg_stat_activity WHERE wait_event = 'PgSleep'");
      held = !pid.empty() && pid.find_first_not_of("0123456789") == std::string::npos;
      if (!held) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    if (held && stop_server) {
      pg.stop("fast");  // terminates the backend, rolls its transaction back, shuts down
    } else if (held) {
      // By pid, in a statement of its own: in one WHERE with the filter, PostgreSQL may call
      // pg_terminate_backend before filtering (seen: it ended every backend, its own included).
      const std::string ok = pg.psql("SELECT pg_terminate_backend(" + pid + ")");
      if (ok != "t") drop_error = "pg_terminate_backend(" + pid + ") returned '" + ok + "'";
    }
  } catch (const std::exception& e) {
    drop_error = e.what();
  }
  if (!held && !first_done && drop_error.empty()) drop_error = "timed out waiting for the held insert";
  if (!held) pg.psql("UPDATE drop_once SET armed = false");  // let a held insert (if any) finish
  runner.join();
  ASSERT_TRUE(held) << "the record insert never reached the held row (" << drop_error << "); first run: '"
                    << first.error << "'";
  ASSERT_TRUE(drop_error.empty()) << drop_error;
  EXPECT_NE(first.error.find("records:"), std::string::npos) << "expected a peer failure, got: '" << first.error << "'";
  if (stop_server) pg.start();
  // Nothing of the record was written: the transaction was rolled back with the connection.
  EXPECT_EQ(pg.psql("SELECT count(*) FROM calibration WHERE serial = 'SN-42'"), "0");
  EXPECT_EQ(pg.psql("SELECT count(*) FROM calibration_parameter"), "0");
  std::string journaled_id;
  for (const auto& e : read_journal(o.out_dir + "/journal.log").entries)
    if (e["type"] == "recording") journaled_id = e.value("id", "");
  EXPECT_FALSE(journaled_id.empty()) << "the record id is journaled before the insert";

  pg.psql("UPDATE drop_once SET armed = false");
  RunOptions ro = o;
  ro.resume = true;
  const InProcessRun second = run_in_process(ro, w, dev);
  ASSERT_TRUE(second.error.empty()) << second.error;
  auto store = records::open_store(pg.url());
  const auto found = store->find_by_serial("SN-42");
  ASSERT_EQ(found.size(), 1u) << "exactly one record after the resume";
  EXPECT_EQ(found[0].id, journaled_id);
  EXPECT_EQ(pg.psql("SELECT count(*) FROM calibration"), "1");
  const records::CalibrationRecord rec = store->get(found[0].id);
  const auto& names = ref.res.estimate.names;
  ASSERT_EQ(rec.parameters.size(), ref.res.record.parameters.size()) << "a parameter row missing or twice";
  EXPECT_EQ(pg.psql("SELECT count(*) - count(DISTINCT ord) FROM calibration_parameter"), "0");
  for (std::size_t i = 0; i < rec.parameters.size(); ++i) {
    EXPECT_EQ(rec.parameters[i].name, ref.res.record.parameters[i].name);
  }
  // The estimate behind the record: the resumed run's against the uninterrupted run's, within σ/10.
  ASSERT_EQ(second.res.estimate.names, names);
  for (std::size_t i = 0; i < names.size(); ++i) {
    const double ratio = std::fabs(second.res.estimate.value[static_cast<Eigen::Index>(i)] -
                                   ref.res.estimate.value[static_cast<Eigen::Index>(i)]) /
                         ref_sigma[static_cast<Eigen::Index>(i)];
    EXPECT_LT(ratio, 0.1) << names[i] << " differs by " << ratio << " σ";
  }
  for (std::size_t i = 0; i < rec.parameters.size(); ++i) {
    const auto& a = rec.parameters[i];
    const auto& b = ref.res.record.parameters[i];
    EXPECT_LE(std::fabs(a.value - b.value), 0.1 * b.sigma) << a.name << " (record row)";
  }
  if (!std::getenv("EOL_KEEP")) fs::remove_all(d);
}

}  // namespace

TEST(CrashPostgres, BackendTerminatedMidRecordThenResume) { pg_drop_mid_write(false); }
TEST(CrashPostgres, ServerStoppedMidRecordThenResume) { pg_drop_mid_write(true); }

// The case the random kills reach only by chance: a crash right after the first rotation of a CW/CCW
// pair, so the second (commanded while the table still turned) is the segment in flight. The resumed
// run must collect it at the table phase the uninterrupted run had (TableMotion restores the turning
// table): the same reference angles sample by sample, the same raw counts but for the re-settled die
// temperature, and parameters within σ/10. Before the restore, the phase differed by ~80° and the
// parameters by up to 0.6 σ.
TEST(Crash, ContinuedRotationInFlightIsCollectedAgainAtTheSamePhase) {
  const fs::path d = input_dir("imuforge-crashrot-");
  auto opts = [&](const std::string& name) { return run_options(d, name); };
  eoltest::FakeWorld wref;
  wref.noise_per_stream = true;
  eoltest::FakeDevice dref(wref, "SN-42");
  const InProcessRun ref = run_in_process(opts("ref"), wref, dref);
  ASSERT_TRUE(ref.error.empty()) << ref.error;
  const Eigen::VectorXd ref_sigma = ref.res.estimate.sigma();

  // Plateau 0, steps 7/8 "z CW"/"z CCW" and 13/14 "y CW"/"y CCW" (about the vertical and a horizontal axis).
  for (const int safe : {8, 14}) {
    SCOPED_TRACE("crash after " + std::to_string(safe) + " segments");
    eoltest::FakeWorld w;  // the lab runs on across the crash, its table still turning
    w.noise_per_stream = true;
    eoltest::FakeDevice dev(w, "SN-42");
    const std::string name = "crash" + std::to_string(safe);
    RunOptions o = opts(name);
    o.crash_after_segments = safe;
    const InProcessRun first = run_in_process(o, w, dev);
    ASSERT_NE(first.error.find("simulated crash"), std::string::npos) << first.error;
    w.ang[0] += 123.0;  // and the table stopped somewhere else meanwhile (an operator, a power cycle)
    w.rate = {0, 0, 0};
    RunOptions ro = o;
    ro.crash_after_segments = 0;
    ro.resume = true;
    const InProcessRun second = run_in_process(ro, w, dev);
    ASSERT_TRUE(second.error.empty()) << second.error;
    ASSERT_EQ(second.res.segments_resumed, safe);

    const std::string seg = "segments/" + step_key(0, safe) + ".bin";
    io::LogReader a(opts("ref").out_dir + "/" + seg), b(o.out_dir + "/" + seg);
    io::LogRow ra, rb;
    std::size_t rows = 0, raw_diff = 0;
    double worst_angle_rad = 0;
    while (a.next(ra)) {
      ASSERT_TRUE(b.next(rb)) << "the re-collected segment is shorter";
      for (int ax = 0; ax < 2; ++ax)
        worst_angle_rad = std::max(worst_angle_rad, std::fabs(std::remainder(ra.table_angle_rad[ax] - rb.table_angle_rad[ax], 2 * M_PI)));
      for (int j = 0; j < 6; ++j) raw_diff += static_cast<std::size_t>(std::abs(ra.raw[j] - rb.raw[j]) > 1);
      ++rows;
    }
    EXPECT_GT(rows, 100u);
    EXPECT_LT(worst_angle_rad, 1e-9) << "the table phase of the re-collected rotation differs";
    EXPECT_EQ(raw_diff, 0u) << "raw counts differ by more than one count";
    const auto& names = ref.res.estimate.names;
    ASSERT_EQ(second.res.estimate.names, names);
    for (std::size_t i = 0; i < names.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      EXPECT_LT(std::fabs(second.res.estimate.value[k] - ref.res.estimate.value[k]) / ref_sigma[k], 0.1) << names[i];
    }
  }
  if (!std::getenv("EOL_KEEP")) fs::remove_all(d);
}
}  // namespace eol_test_crash
