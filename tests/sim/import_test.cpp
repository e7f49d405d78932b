// Import of the real recordings (skipped when the data directory is absent).
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "host/io/import.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_import_test {

using namespace imuforge::io;

namespace {
std::string real(const char* p) { return std::string(IMUFORGE_REAL_DATA_DIR) + "/" + p; }
std::string tmp(const char* p) { return std::string(IMUFORGE_BINARY_DIR) + "/sim_import_test_" + p; }
}  // namespace

TEST(Import, XsensImutk) {
  if (!std::filesystem::exists(real("xsens-mti-imutk/xsens_acc.txt"))) GTEST_SKIP() << "no real data";
  ImportOptions o{"xsens-imutk", real("xsens-mti-imutk/xsens_acc.txt"), real("xsens-mti-imutk/xsens_gyro.txt"), "", 0};
  auto s = import_recording(o, tmp("xsens.bin"));
  EXPECT_EQ(s.rows, 51175u);
  EXPECT_NEAR(s.sample_rate_hz, 100.0, 0.5);
  EXPECT_NEAR(s.duration_s, 511.7, 1.0);
  LogReader r(tmp("xsens.bin"));
  EXPECT_EQ(*r.meta().find("raw_offset"), "32768");
  LogRow row;
  ASSERT_TRUE(r.next(row));
  EXPECT_FALSE(row.has_ref);
  EXPECT_TRUE(std::isnan(row.temp_C));
  EXPECT_EQ(row.t_s, 0.0);
  EXPECT_EQ(row.raw[0], 33108 - 32768);  // first accel line: 2.984e-02 3.3108e+04 …
  EXPECT_EQ(row.raw[3], 32786 - 32768);
  // Initial still period: |f| ≈ g with the nominal LSB (within the ±10 % an uncalibrated LSB allows).
  double f = std::sqrt(std::pow(row.raw[0], 2) + std::pow(row.raw[1], 2) + std::pow(row.raw[2], 2)) * r.meta().accel_lsb_mps2;
  EXPECT_NEAR(f, 9.81, 1.0);
}

TEST(Import, Mpu6050Csv) {
  if (!std::filesystem::exists(real("mpu6050-tomisuarez2/imu_static_test.csv"))) GTEST_SKIP() << "no real data";
  ImportOptions o{"mpu6050-csv", real("mpu6050-tomisuarez2/imu_static_test.csv"), "", "", 0};
  auto s = import_recording(o, tmp("mpu.csv"));
  EXPECT_EQ(s.rows, 9991u - 5u);
  EXPECT_EQ(s.sample_rate_hz, 100.0);
  LogReader r(tmp("mpu.csv"));
  LogRow row;
  std::uint64_t n = 0;
  double t_last = 0, fz = 0;
  while (r.next(row)) {
    t_last = row.t_s;
    fz += row.raw[2];
    ++n;
  }
  EXPECT_EQ(n, s.rows);
  EXPECT_NEAR(t_last, (n - 1) / 100.0, 1e-9);
  EXPECT_NEAR(fz / n * r.meta().accel_lsb_mps2, 9.81, 1.0);  // static, z roughly up
}

TEST(Import, MalformedInputNamesLineAndColumn) {
  const std::string p = tmp("bad-mpu.csv");
  std::ofstream(p) << "Fs,100\nax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n1,2,70000,4,5,6\n";
  try {
    import_recording(ImportOptions{"mpu6050-csv", p, "", "", 0}, tmp("bad-out.csv"));
    FAIL();
  } catch (const LogError& e) {
    EXPECT_NE(std::string(e.what()).find(p + ":4: column 3"), std::string::npos) << e.what();
  }
  std::ofstream(tmp("a.txt")) << "0.01 1 2 3\n0.02 1 2 3\n";
  std::ofstream(tmp("g.txt")) << "0.01 1 2 3\n0.03 1 2 3\n";
  try {
    import_recording(ImportOptions{"xsens-imutk", tmp("a.txt"), tmp("g.txt"), "", 0}, tmp("bad-out.csv"));
    FAIL();
  } catch (const LogError& e) {
    EXPECT_NE(std::string(e.what()).find("differs"), std::string::npos) << e.what();
  }
  EXPECT_THROW(import_recording(ImportOptions{"nope", p, "", "", 0}, tmp("x.csv")), LogError);
}
}  // namespace sim_import_test
