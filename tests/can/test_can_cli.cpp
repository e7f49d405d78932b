// The programs end to end: imuforge-vimu as a separate process on the virtual bus, driven by
// `imuforge can ...`; checks exit codes (0 ok, 1 refused table, 3 dead node) and outputs.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>

#include "firmware/table/table.h"

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

// The test's own directory (virtual bus, tables, read-back), removed with its contents when the test ends.
struct TempDir {
  std::string path;
  TempDir() {
    char t[] = "/tmp/imuforge-can-cli-XXXXXX";
    const char* d = ::mkdtemp(t);
    if (!d) throw std::runtime_error(std::string("mkdtemp ") + t + ": " + std::strerror(errno));
    path = d;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

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
  const TempDir work;
  const std::string dir = work.path + "/vcan";
  ::setenv("IMUFORGE_VCAN_DIR", dir.c_str(), 1);
  const std::string bus = "virtual:cli";
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
