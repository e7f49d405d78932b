// `imuforge simulate` and `imuforge import` end to end (exit codes, determinism of the whole file).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "host/io/log.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_cli_test {

namespace {
std::string tmp(const char* p) { return std::string(IMUFORGE_BINARY_DIR) + "/sim_cli_test_" + p; }
std::string ex(const char* f) { return std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/" + f; }
int sh(const std::string& args) {
  int rc = std::system((std::string(IMUFORGE_BIN) + " " + args + " 2>/dev/null").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}
}  // namespace

TEST(Cli, SimulateIsDeterministicAndWritesTruth) {
  if (!std::filesystem::exists(IMUFORGE_BIN)) GTEST_SKIP() << "imuforge not built";
  const std::string base = "simulate --campaign " + ex("campaign-small.json") + " --sensor " + ex("sensor-consumer.json");
  ASSERT_EQ(sh(base + " --seed 4 --out " + tmp("a.bin") + " --truth " + tmp("t.json")), 0);
  ASSERT_EQ(sh(base + " --seed 4 --out " + tmp("b.bin")), 0);
  ASSERT_EQ(sh(base + " --seed 5 --out " + tmp("c.bin")), 0);
  EXPECT_EQ(slurp(tmp("a.bin")), slurp(tmp("b.bin")));
  EXPECT_NE(slurp(tmp("a.bin")), slurp(tmp("c.bin")));
  auto truth = nlohmann::json::parse(slurp(tmp("t.json")));
  EXPECT_DOUBLE_EQ(truth["parameters"]["accel.bias.z"].get<double>(), 0.4);
  // CSV of the same run carries the same rows.
  ASSERT_EQ(sh(base + " --seed 4 --out " + tmp("a.csv") + " --rate 100"), 0);
  imuforge::io::LogReader rb(tmp("a.bin")), rc(tmp("a.csv"));
  imuforge::io::LogRow x, y;
  std::size_t n = 0;
  while (rb.next(x)) {
    ASSERT_TRUE(rc.next(y));
    ASSERT_EQ(x.t_s, y.t_s);
    for (int j = 0; j < 6; ++j) ASSERT_EQ(x.raw[j], y.raw[j]);
    for (int j = 0; j < 3; ++j) ASSERT_EQ(x.f_ref[j], y.f_ref[j]);
    ++n;
  }
  EXPECT_FALSE(rc.next(y));
  EXPECT_GT(n, 10000u);
}

TEST(Cli, ExitCodes) {
  if (!std::filesystem::exists(IMUFORGE_BIN)) GTEST_SKIP() << "imuforge not built";
  EXPECT_EQ(sh("simulate --campaign " + ex("campaign-small.json")), 2);  // missing options
  EXPECT_EQ(sh("simulate --campaign " + ex("campaign-small.json") + " --sensor /nonexistent.json --out " + tmp("x.csv")), 2);  // bad input: exit 2
  std::ofstream(tmp("bad-sensor.json")) << R"({"accel":{"lsb":1e-3},"gyro":{"lsb":1e-4},"effects":{"gyro.bias":{"q":1}}})";
  EXPECT_EQ(sh("simulate --campaign " + ex("campaign-small.json") + " --sensor " + tmp("bad-sensor.json") + " --out " + tmp("x.csv")), 2);
  EXPECT_EQ(sh("import --format xsens-imutk --in " + tmp("x.csv") + " --out " + tmp("y.csv")), 2);  // needs --in-gyro
  EXPECT_EQ(sh("import --format mpu6050-csv --in /nonexistent.csv --out " + tmp("y.csv")), 2);
}

// HDF5 is a first-class log: `simulate --format h5` writes it, `convert` carries it to binary byte for
// byte, and `solve` reads it to the same parameters as the binary log of the same run.
TEST(Cli, Hdf5LogThroughSimulateConvertAndSolve) {
  if (!std::filesystem::exists(IMUFORGE_BIN)) GTEST_SKIP() << "imuforge not built";
  const std::string base = "simulate --campaign " + ex("campaign-small.json") + " --sensor " +
                           ex("sensor-consumer.json") + " --seed 4 --rate 50";
  ASSERT_EQ(sh(base + " --format h5 --out " + tmp("h.log")), 0);  // forced encoding, odd extension
  ASSERT_EQ(sh(base + " --out " + tmp("h.bin")), 0);
  {
    imuforge::io::LogReader r(tmp("h.log"));
    EXPECT_EQ(r.encoding(), imuforge::io::LogEncoding::kHdf5);
  }
  ASSERT_EQ(sh("convert --in " + tmp("h.log") + " --out " + tmp("h2.bin")), 0);
  EXPECT_EQ(slurp(tmp("h.bin")), slurp(tmp("h2.bin")));
  EXPECT_FALSE(std::filesystem::exists(tmp("h2.bin.partial")));
  const std::string solve = "solve --model " + ex("model-basic.json");
  ASSERT_EQ(sh(solve + " --log " + tmp("h.log") + " --out " + tmp("cal-h5.json")), 0);
  ASSERT_EQ(sh(solve + " --log " + tmp("h.bin") + " --out " + tmp("cal-bin.json")), 0);
  const auto a = nlohmann::json::parse(slurp(tmp("cal-h5.json")));
  const auto b = nlohmann::json::parse(slurp(tmp("cal-bin.json")));
  EXPECT_EQ(a["parameters"], b["parameters"]);
  EXPECT_GT(a["parameters"].size(), 10u);
  // A broken input exits 2 (bad input, as every command) and leaves no output behind.
  std::ofstream(tmp("broken.h5"), std::ios::binary) << "\x89HDF\r\n\x1a\n garbage";
  EXPECT_EQ(sh("convert --in " + tmp("broken.h5") + " --out " + tmp("never.csv")), 2);
  EXPECT_FALSE(std::filesystem::exists(tmp("never.csv")));
  EXPECT_FALSE(std::filesystem::exists(tmp("never.csv.partial")));
}
}  // namespace sim_cli_test
