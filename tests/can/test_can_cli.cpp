// The programs end to end: imuforge-vimu as a separate process on the virtual bus, driven by
// `imuforge can ...`; checks exit codes (0 ok, 1 refused table, 3 dead node) and outputs.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include "firmware/table/table.h"
#include "tests/can/vcan_dir.h"
#include "tests/temp_dir.h"

extern char** environ;  // POSIX: declared by no header

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace can_test_can_cli {

namespace {

const std::string kVimu = std::string(IMUFORGE_BINARY_DIR) + "/bin/imuforge-vimu";
const std::string kTool = IMUFORGE_BIN;

struct CmdResult {
  int rc;
  std::string out;
};
CmdResult sh(const std::string& cmd) {
  CmdResult r{-1, ""};
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.out += buf;
  const int st = ::pclose(p);
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string write_table(const std::string& dir, std::uint64_t serial, std::uint32_t seq) {
  imuforge::fw::Table t;
  imuforge::fw::table_init_identity(&t, 0.0024f, 0.0005f, 16, 16);
  t.device_serial = serial;
  t.table_sequence = seq;
  std::uint8_t b[imuforge::fw::kTableMaxSize];
  const int n = imuforge::fw::table_serialize(&t, b, sizeof b);
  const std::string path = dir + "/table_" + std::to_string(serial) + "_" + std::to_string(seq) + ".bin";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(b), n);
  return path;
}

TEST(CanCli, VimuProcessAndImuforgeCan) {
  if (::access(kTool.c_str(), X_OK) != 0 || ::access(kVimu.c_str(), X_OK) != 0) {
    GTEST_SKIP() << "imuforge or imuforge-vimu not built";
  }
  // The tables and the read-back in a directory of the test's own; the bus in the program's (inherited by the
  // imuforge-vimu and imuforge processes it starts).
  const imuforge::testing::TempDir work("imuforge-can-cli-");
  const std::string bus = imuforge::testing::virtual_test_bus("cli");
  pid_t pid = 0;
  const char* argv[] = {kVimu.c_str(), "--bus", bus.c_str(), "--node", "4", "--serial", "31337",
                        "--duration-s", "60", nullptr};
  ASSERT_EQ(::posix_spawn(&pid, kVimu.c_str(), nullptr, nullptr, const_cast<char* const*>(argv), environ), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::string base = kTool + " can --bus " + bus + " --node 4 ";

  CmdResult r = sh(base + "identify");
  EXPECT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("serial 31337"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("table none"), std::string::npos) << r.out;

  const std::string t5 = write_table(work.path, 31337, 5);
  r = sh(base + "flash --table " + t5 + " --dev-key");
  EXPECT_EQ(r.rc, 0) << r.out;
  r = sh(base + "flash --table " + t5 + " --dev-key");  // replay
  EXPECT_EQ(r.rc, 1) << r.out;
  EXPECT_NE(r.out.find("replayed"), std::string::npos) << r.out;
  r = sh(base + "flash --table " + write_table(work.path, 31337, 6) + " --key-hex " + std::string(64, 'a'));
  EXPECT_EQ(r.rc, 1) << r.out;
  EXPECT_NE(r.out.find("authorisation failed"), std::string::npos) << r.out;
  r = sh(base + "flash --table " + write_table(work.path, 4, 7) + " --dev-key");  // another device's table: bad input
  EXPECT_EQ(r.rc, 2) << r.out;

  const std::string back = work.path + "/back.bin";
  r = sh(base + "read-table --out " + back);
  EXPECT_EQ(r.rc, 0) << r.out;
  std::ifstream a(t5, std::ios::binary), b(back, std::ios::binary);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(a), {}), std::string(std::istreambuf_iterator<char>(b), {}));

  r = sh(base + "stream --rate 1000 --seconds 0.5");
  EXPECT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find(" lost 0 incomplete 0 duplicated 0"), std::string::npos) << r.out;
  r = sh(base + "status");
  EXPECT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("active_slot"), std::string::npos) << r.out;
  r = sh(base + "stream --rate 5000");
  EXPECT_EQ(r.rc, 2) << r.out;

  ::kill(pid, SIGTERM);
  int st = 0;
  ::waitpid(pid, &st, 0);
  EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0);
  r = sh(kTool + " can --bus " + bus + " --node 4 --timeout-ms 100 identify");  // node gone
  EXPECT_EQ(r.rc, 3) << r.out;
  EXPECT_NE(r.out.find("did not answer"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace can_test_can_cli
