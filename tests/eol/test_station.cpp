// The live multi-unit runner (issue 14) end to end on the bench simulator: `imuforge demo --slots N`
// (bench-sim serving N virtual IMUs, one dead node), the short campaign, SQLite records. Checks what a
// station needs from a batch run, not the calibration quality (test_e2e.cpp / test_runner.cpp do that):
// every unit has exactly one record, the dead node is reported by its reason and never stops the others,
// the batch record names every unit's record, and a crash mid-collection resumed per unit gives the
// same records without duplicates and without re-collecting a segment.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "host/eol/demo.h"
#include "host/eol/journal.h"
#include "host/eol/runner.h"
#include "host/records/store.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_station {

namespace fs = std::filesystem;
using imuforge::eol::DemoOptions;

namespace {

struct Dir {
  fs::path d = fs::temp_directory_path() / ("imuforge-station-" + imuforge::records::new_record_id());
  ~Dir() {
    std::error_code ec;
    fs::remove_all(d, ec);
  }
};

DemoOptions demo_options(const fs::path& out, int slots) {
  DemoOptions o;
  o.out_dir = out.string();
  o.self_exe = IMUFORGE_BIN;
  o.examples_dir = IMUFORGE_SOURCE_DIR "/docs/examples";
  o.campaign = IMUFORGE_SOURCE_DIR "/docs/examples/campaign-small.json";
  o.model = IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json";
  o.time_scale = 20;
  o.quiet = true;
  o.slots = slots;
  o.threads = 2;
  return o;
}

// A TCP port free now (bound to 0, then released): the crashed and the resumed demo serve bench-sim on
// the same port, so their station files are identical (the resume checks the station file's SHA-256).
int free_port() {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    if (fd >= 0) close(fd);
    return 0;
  }
  close(fd);
  return ntohs(a.sin_port);
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f);
}

// Every unit of the batch: one record per serial, the batch naming exactly those records.
void expect_one_record_per_unit(const fs::path& out, const fs::path& run, int slots, const std::string& dead_slot) {
  // Under host-sanitize the bench-sim child is instrumented too and reports into its log.
  {
    EXPECT_TRUE(fs::exists(out / "bench-sim.log"));
    std::ifstream sl(out / "bench-sim.log");
    const std::string sim_log((std::istreambuf_iterator<char>(sl)), {});
    for (const char* report : {"Sanitizer", "runtime error:"})
      EXPECT_EQ(sim_log.find(report), std::string::npos) << "sanitizer report from bench-sim:\n" << sim_log;
  }
  auto store = imuforge::records::open_store((out / "records.sqlite").string());
  const auto sj = imuforge::eol::read_journal((run / "journal.log").string());
  ASSERT_EQ(sj.entries.back()["type"], "finished");
  const std::string batch_id = sj.entries.back()["batch_id"];
  const auto batch = store->get_batch(batch_id);
  ASSERT_EQ(static_cast<int>(batch.units.size()), slots);
  std::set<std::string> ids;
  for (const auto& u : batch.units) {
    EXPECT_TRUE(ids.insert(u.calibration_id).second) << "record named twice: " << u.calibration_id;
    const auto rec = store->get(u.calibration_id);  // throws if the batch names a record that is not there
    EXPECT_EQ(rec.pass, u.pass) << u.slot;
    if (u.slot == dead_slot) {
      EXPECT_FALSE(u.pass);
      ASSERT_FALSE(u.reasons.empty());
      EXPECT_NE(u.reasons[0].find("no answer from node"), std::string::npos) << u.reasons[0];
      continue;
    }
    // A unit that answered went the whole way: table flashed, read back identical, verified, reported.
    EXPECT_EQ(store->find_by_serial(u.serial).size(), 1u) << "serial " << u.serial << " recorded more than once";
    EXPECT_FALSE(rec.table_blob.empty()) << u.slot;
    bool readback_ok = false;
    int verified = 0;
    for (const auto& v : rec.verification) {
      readback_ok |= v.name == "readback" && v.pass;
      verified += v.name.find("ver-") == 0;
    }
    EXPECT_TRUE(readback_ok) << u.slot;
    EXPECT_GT(verified, 0) << u.slot << ": no verification residuals";
    EXPECT_TRUE(fs::exists(run / u.slot / "report.html")) << u.slot;
    // Each unit's journal: no segment journaled twice (never re-collected).
    const auto uj = imuforge::eol::read_journal((run / u.slot / "journal.log").string());
    std::set<std::string> keys;
    for (const auto& e : uj.entries)
      if (e["type"] == "segment_done" || e["type"] == "verify_segment")
        EXPECT_TRUE(keys.insert(e["key"].get<std::string>()).second) << u.slot << " " << e["key"];
    EXPECT_EQ(uj.entries.back()["type"], "finished") << u.slot;
  }
  EXPECT_TRUE(fs::exists(run / "batch-report.html"));
  const auto bj = read_json(run / "batch.json");
  EXPECT_EQ(bj["units_total"].get<int>(), slots);
}

}  // namespace

TEST(StationRun, FourUnitsOneDeadNodeOnTheBenchSimulator) {
  Dir dir;
  DemoOptions o = demo_options(dir.d, 4);
  o.dead_slots = {3};
  const int code = imuforge::eol::run_demo(o);
  EXPECT_EQ(code, 1) << "a dead node is a failed unit: the batch cannot pass";
  expect_one_record_per_unit(dir.d, dir.d / "run", 4, "slot03");
}

TEST(StationRun, CrashMidCollectionAndResumeGiveTheSameRecordsOnce) {
  Dir dir;
  DemoOptions o = demo_options(dir.d, 3);
  o.dead_slots = {2};
  o.crash_after_steps = 4;
  o.tcp_port = free_port();
  ASSERT_GT(o.tcp_port, 0);
  EXPECT_THROW(imuforge::eol::run_demo(o), imuforge::eol::SimulatedCrash);
  const fs::path run = dir.d / "run";
  ASSERT_TRUE(fs::exists(run / "slot01" / "journal.log"));
  int safe_before = 0;
  for (const auto& e : imuforge::eol::read_journal((run / "slot01" / "journal.log").string()).entries)
    safe_before += e["type"] == "segment_done";
  EXPECT_GE(safe_before, 3);
  // The lab power-cycles (a new bench-sim, the same parts) and the run resumes from the journals.
  DemoOptions r = demo_options(dir.d, 3);
  r.dead_slots = {2};
  r.resume_run_dir = run.string();
  r.tcp_port = o.tcp_port;
  imuforge::eol::run_demo(r);
  expect_one_record_per_unit(dir.d, run, 3, "slot02");
  // The resumed unit replayed its safe segments instead of collecting them again.
  const auto uj = imuforge::eol::read_journal((run / "slot01" / "journal.log").string());
  int resumed_marks = 0;
  for (const auto& e : uj.entries) resumed_marks += e["type"] == "finished";
  EXPECT_EQ(resumed_marks, 1);
}
}  // namespace eol_test_station
