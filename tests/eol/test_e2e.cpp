// End to end on the bench simulator: `imuforge demo` with the short campaign (docs/examples/
// campaign-small.json, basic model): bench-sim over Modbus TCP, the virtual IMU on a virtual CAN bus,
// table flashed and read back, verified with the firmware kernel, recorded in SQLite, report written.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>

#include "host/eol/journal.h"
#include "host/records/store.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_e2e {

namespace fs = std::filesystem;

TEST(EndToEnd, ShortCampaignOnTheBenchSimulator) {
  fs::path out = fs::temp_directory_path() / ("imuforge-e2e-" + imuforge::records::new_record_id());
  std::string cmd = std::string(IMUFORGE_BIN) + " demo --quiet --time-scale 20 --out " + out.string() +
                    " --campaign " IMUFORGE_SOURCE_DIR "/docs/examples/campaign-small.json --model " IMUFORGE_SOURCE_DIR
                    "/docs/examples/model-basic.json > " + out.string() + ".stdout 2>&1";
  int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  std::ifstream so(out.string() + ".stdout");
  std::string text((std::istreambuf_iterator<char>(so)), {});
  int code = WEXITSTATUS(rc);
  // Under host-sanitize the children are instrumented too: imuforge demo reports into this output (its
  // exit code 1 would otherwise pass for a FAIL verdict), the bench-sim it starts into bench-sim.log.
  EXPECT_TRUE(fs::exists(out / "bench-sim.log"));
  std::ifstream sl(out / "bench-sim.log");
  const std::string sim_log((std::istreambuf_iterator<char>(sl)), {});
  for (const char* report : {"Sanitizer", "runtime error:"}) {
    EXPECT_EQ(text.find(report), std::string::npos) << "sanitizer report from imuforge demo:\n" << text;
    EXPECT_EQ(sim_log.find(report), std::string::npos) << "sanitizer report from bench-sim:\n" << sim_log;
  }
  // 0 PASS or 1 FAIL are verdicts; anything else is a broken run.
  ASSERT_TRUE(code == 0 || code == 1) << "exit " << code << "\n" << text;
  EXPECT_NE(text.find("demo: report "), std::string::npos) << text;
  EXPECT_TRUE(fs::exists(out / "run" / "report.html"));
  EXPECT_TRUE(fs::exists(out / "run" / "table.bin"));
  auto j = imuforge::eol::read_journal((out / "run" / "journal.log").string());
  ASSERT_FALSE(j.entries.empty());
  EXPECT_EQ(j.entries.back()["type"], "finished");
  auto store = imuforge::records::open_store((out / "records.sqlite").string());
  auto rec = store->get(j.entries.back()["record_id"].get<std::string>());
  EXPECT_EQ(rec.pass, code == 0);
  EXPECT_FALSE(rec.table_blob.empty());
  bool readback_ok = false;
  for (const auto& v : rec.verification) readback_ok |= (v.name == "readback" && v.pass);
  EXPECT_TRUE(readback_ok) << "the table read back over CAN must equal the table written";
  std::printf("%s", text.c_str());
  std::error_code ec;
  fs::remove_all(out, ec);
  fs::remove(out.string() + ".stdout", ec);
}
}  // namespace eol_test_e2e
