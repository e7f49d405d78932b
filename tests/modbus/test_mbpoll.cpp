// The real Modbus client `mbpoll` against the `imuforge bench-sim` process, reading and writing the
// registers exactly as docs/modbus.md describes them: over TCP, over bench-sim's own pty, and over RTU
// through a `socat` pty pair. Also: the bench-sim process killed mid-campaign and started again.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "host/fixture/fixture.h"
#include "tests/temp_dir.h"

extern char** environ;  // POSIX: declared by no header

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace modbus_test_mbpoll {

namespace {

// A child process with its stdout on a pipe.
struct Child {
  pid_t pid = -1;
  int out = -1;
  Child() = default;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() { stop(SIGTERM); }
  void start(const std::vector<std::string>& argv) {
    int p[2];
    ASSERT_EQ(pipe(p), 0);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, p[1], 1);
    posix_spawn_file_actions_addclose(&fa, p[0]);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ASSERT_EQ(posix_spawnp(&pid, args[0], &fa, nullptr, args.data(), environ), 0) << argv[0];
    posix_spawn_file_actions_destroy(&fa);
    close(p[1]);
    out = p[0];
  }
  // Read one line from stdout within timeout_s ("" on timeout or EOF).
  std::string line(double timeout_s) {
    std::string s;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      pollfd pf{out, POLLIN, 0};
      if (poll(&pf, 1, 50) <= 0) continue;
      char c;
      if (read(out, &c, 1) != 1) break;
      if (c == '\n') return s;
      s += c;
    }
    return "";
  }
  void stop(int sig) {
    if (pid > 0) {
      kill(pid, sig);
      int st;
      waitpid(pid, &st, 0);
      pid = -1;
    }
    if (out >= 0) close(out);
    out = -1;
  }
};

struct Ready {
  int port = -1;
  std::string rtu;
};

Ready start_bench(Child& c, std::vector<std::string> extra) {
  std::vector<std::string> argv = {IMUFORGE_BIN, "bench-sim"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  c.start(argv);
  const std::string l = c.line(20.0);
  Ready r;
  std::smatch m;
  if (std::regex_search(l, m, std::regex("^ready tcp=([^ ]+) rtu=([^ ]+)"))) {
    const std::string tcp = m[1];
    if (tcp != "-") r.port = std::stoi(tcp.substr(tcp.rfind(':') + 1));
    if (m[2] != "-") r.rtu = m[2];
  }
  EXPECT_FALSE(l.empty()) << "bench-sim did not announce readiness";
  return r;
}

struct ShellResult {
  int rc;
  std::string out;
};

ShellResult sh(const std::string& cmd) {
  ShellResult r{-1, ""};
  FILE* f = popen((cmd + " 2>&1").c_str(), "r");
  if (!f) return r;
  char buf[512];
  while (fgets(buf, sizeof buf, f)) r.out += buf;
  const int st = pclose(f);
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string mb_tcp(int port) { return "mbpoll -m tcp -p " + std::to_string(port) + " -a 1 -0 -1 -o 2 "; }
std::string mb_rtu() { return "mbpoll -m rtu -b 115200 -P none -a 1 -0 -1 -o 2 "; }

// Value of register `ref` in mbpoll's output ("[1002]: \t3"), or a sentinel.
long long value_at(const std::string& out, int ref) {
  std::smatch m;
  const std::regex re("\\[" + std::to_string(ref) + "\\]:\\s*(-?[0-9]+)");
  if (std::regex_search(out, m, re)) return std::stoll(m[1]);
  return -999999999;
}

// Poll a register until it reads `want` (the bench runs at a high time scale; bounded wait, not timed).
bool wait_value(const std::string& read_cmd, int ref, long long want, double timeout_s = 20.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (value_at(sh(read_cmd).out, ref) == want) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

}  // namespace

TEST(ModbusMbpoll, TcpRegistersAsDocumented) {
  Child b;
  const Ready r = start_bench(b, {"--tcp-port", "0", "--time-scale", "200"});
  ASSERT_GT(r.port, 0);
  const std::string mb = mb_tcp(r.port);
  const std::string H = " 127.0.0.1";
  ShellResult x = sh(mb + "-r 1002" + H);
  ASSERT_EQ(x.rc, 0) << x.out;
  EXPECT_EQ(value_at(x.out, 1002), 3);  // axes
  // Axis 0 to +45 deg: mode=1, command=450000 (int32 high word first = 6, 56784), cmd_seq=1, one FC16.
  x = sh(mb + "-r 1100 127.0.0.1 1 6 56784 1");
  ASSERT_EQ(x.rc, 0) << x.out;
  const std::string angle0 = mb + "-t 4:int -B -r 1110" + H;
  EXPECT_TRUE(wait_value(angle0, 1110, 450000));
  EXPECT_TRUE(wait_value(mb + "-r 1114" + H, 1114, 3));  // in_position | settled
  EXPECT_EQ(value_at(sh(mb + "-r 1104" + H).out, 1104), 1);  // seq_ack
  // A negative command as a 32-bit value, then the sequence number that applies it.
  x = sh(mb + "-t 4:int -B -r 1101 127.0.0.1 -- -125000");
  ASSERT_EQ(x.rc, 0) << x.out;
  EXPECT_EQ(value_at(sh(angle0).out, 1110), 450000);  // staged only: the axis has not moved
  ASSERT_EQ(sh(mb + "-r 1103 127.0.0.1 2").rc, 0);
  EXPECT_TRUE(wait_value(angle0, 1110, -125000));
  // Chamber: ramp 5.00 degC/min (u16, 0.01), setpoint 40.000 degC (int32, 0.001).
  ASSERT_EQ(sh(mb + "-r 2004 127.0.0.1 500").rc, 0);
  ASSERT_EQ(sh(mb + "-t 4:int -B -r 2002 127.0.0.1 40000").rc, 0);
  x = sh(mb + "-t 4:int -B -r 2000 -c 2" + H);
  EXPECT_EQ(value_at(x.out, 2002), 40000);
  // The air heats, never beyond the setpoint (time runs 200x; bounded wait).
  long long air = 0;
  for (int i = 0; i < 200 && air <= 25500; ++i) {
    air = value_at(sh(mb + "-t 4:int -B -r 2000" + H).out, 2000);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_GT(air, 25500);
  EXPECT_LT(air, 40000);
  // Refusals arrive as Modbus exceptions.
  x = sh(mb + "-r 1110 127.0.0.1 5");
  EXPECT_NE(x.rc, 0);
  EXPECT_NE(x.out.find("Illegal data address"), std::string::npos) << x.out;
  x = sh(mb + "-r 1100 127.0.0.1 7");
  EXPECT_NE(x.rc, 0);
  EXPECT_NE(x.out.find("Illegal data value"), std::string::npos) << x.out;
}

TEST(ModbusMbpoll, RtuOnBenchSimPty) {
  Child b;
  const Ready r = start_bench(b, {"--no-tcp", "--rtu", "--time-scale", "200"});
  ASSERT_FALSE(r.rtu.empty());
  ShellResult x = sh(mb_rtu() + "-r 1002 " + r.rtu);
  ASSERT_EQ(x.rc, 0) << x.out;
  EXPECT_EQ(value_at(x.out, 1002), 3);
  ASSERT_EQ(sh(mb_rtu() + "-r 1200 " + r.rtu + " 2 1 34464 1").rc, 0);  // axis 1 at 10 deg/s
  EXPECT_TRUE(wait_value(mb_rtu() + "-t 4:int -B -r 1212 " + r.rtu, 1212, 100000));
}

TEST(ModbusMbpoll, RtuThroughSocatPtyPair) {
  // The pty links in a directory of the test's own (socat removes its links on SIGTERM, not the directory).
  const imuforge::testing::TempDir dir("imuforge-modbus-");
  const std::string& d = dir.path;
  Child s;
  s.start({"socat", "pty,raw,echo=0,link=" + d + "/server", "pty,raw,echo=0,link=" + d + "/client"});
  struct stat st;
  for (int i = 0; i < 200 && (stat((d + "/server").c_str(), &st) != 0 || stat((d + "/client").c_str(), &st) != 0); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  Child b;
  start_bench(b, {"--no-tcp", "--rtu-device", d + "/server", "--unit-id", "7", "--time-scale", "200",
                  "--chamber-map", "watlow-f4.json"});
  const std::string mb = "mbpoll -m rtu -b 115200 -P none -a 7 -0 -1 -o 2 ";
  ShellResult x = sh(mb + "-r 1002 " + d + "/client");
  ASSERT_EQ(x.rc, 0) << x.out;
  EXPECT_EQ(value_at(x.out, 1002), 3);
  // The Watlow F4 map: set point 1 at 300 (one decimal), process value at 100.
  ASSERT_EQ(sh(mb + "-r 300 " + d + "/client 300").rc, 0);  // 30.0 degC
  x = sh(mb + "-r 300 " + d + "/client");
  EXPECT_EQ(value_at(x.out, 300), 300);
  x = sh(mb + "-r 100 " + d + "/client");
  EXPECT_GE(value_at(x.out, 100), 250);
  EXPECT_LE(value_at(x.out, 100), 300);
  b.stop(SIGTERM);
  s.stop(SIGTERM);
}

TEST(ModbusMbpoll, BenchSimProcessKilledAndRestarted) {
  Child b;
  const Ready r = start_bench(b, {"--tcp-port", "0", "--time-scale", "200"});
  ASSERT_GT(r.port, 0);
  imuforge::fixture::FixtureConfig cfg;
  cfg.name = "table-1";
  cfg.map_path = std::string(IMUFORGE_SOURCE_DIR) + "/host/fixture/maps/imuforge-table.json";
  cfg.link.port = r.port;
  cfg.link.timeout_s = 0.3;
  cfg.link.retries = 2;
  cfg.link.backoff_s = 0.02;
  auto t = imuforge::fixture::open_rate_table(cfg);
  t->set_notice_handler([](const std::string&) {});
  t->command_position(0, 20.0);
  ASSERT_TRUE(t->wait_settled(0, 30.0));
  b.stop(SIGKILL);  // the lab dies mid-campaign
  std::string msg;
  try {
    t->command_position(0, 30.0);
  } catch (const imuforge::fixture::FixtureError& e) {
    msg = e.what();
  }
  EXPECT_NE(msg.find("fixture 'table-1'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("command block"), std::string::npos) << msg;
  Child b2;
  const Ready r2 = start_bench(b2, {"--tcp-port", std::to_string(r.port), "--time-scale", "200"});
  ASSERT_EQ(r2.port, r.port);
  // A fresh lab: the driver reconnects and re-learns the sequence number before the next command.
  t->command_position(0, 30.0);
  ASSERT_TRUE(t->wait_settled(0, 30.0));
  EXPECT_NEAR(t->status(0).angle_deg, 30.0, 1e-4);
  EXPECT_GE(t->stats().reconnects, 1u);
}
}  // namespace modbus_test_mbpoll
