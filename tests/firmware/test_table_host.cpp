// Host writer of coefficient table v1: round trip through the firmware parser, model inversion in double,
// error reporting, and the firmware kernel run over a log (imuforge compensate's engine).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>

#include "firmware/table/table.h"
#include "host/io/log.h"
#include "host/table/host_kernel.h"
#include "host/table/table_writer.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace firmware_test_table_host {

using namespace imuforge;

namespace {

std::string tmp_path(const std::string& name) {
  return std::string(IMUFORGE_BINARY_DIR) + "/tests/firmware/" + name;
}

table::TableSpec make_spec(int n_bp, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  table::TableSpec s;
  s.device_serial = 1001;
  s.table_sequence = 3;
  s.created_unix_s = 1790000000;
  s.accel_lsb_mps2 = 16 * 9.80665 / 32768;
  s.gyro_lsb_rad_s = 2000 * M_PI / 180 / 32768;
  for (int i = 0; i < n_bp; ++i) {
    table::BreakpointSpec b;
    b.temp_degC = -40.0 + 12.0 * i;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        b.accel_M(r, c) = 0.01 * u(rng);
        b.gyro_M(r, c) = 0.01 * u(rng);
        b.gyro_G_sensor(r, c) = 1e-3 * u(rng);
      }
      b.accel_b(r) = 0.3 * u(rng);
      b.gyro_b(r) = 0.02 * u(rng);
    }
    s.breakpoints.push_back(b);
  }
  return s;
}

}  // namespace

TEST(TableWriter, RoundTripThroughFirmwareParser) {
  for (int n : {1, 2, 7, 16}) {
    const auto spec = make_spec(n, 10u + static_cast<unsigned>(n));
    const fw::Table built = table::build_table(spec);
    const auto bytes = table::serialize_table(built);
    ASSERT_EQ(bytes.size(), fw::table_serialized_size(static_cast<std::size_t>(n)));
    const fw::Table parsed = table::parse_table(bytes);
    EXPECT_EQ(parsed.device_serial, 1001u);
    EXPECT_EQ(parsed.table_sequence, 3u);
    EXPECT_EQ(parsed.created_unix_s, 1790000000);
    EXPECT_EQ(parsed.n_breakpoints, n);
    EXPECT_EQ(parsed.model_flags, n > 1 ? 0x3Fu : 0x1Fu);
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(parsed.breakpoints_degC[i], built.breakpoints_degC[i]);
      EXPECT_EQ(0, std::memcmp(&parsed.coeffs[i], &built.coeffs[i], sizeof(fw::BreakpointCoeffs)));
      // C = (I+M)^-1 in double, then rounded once: C·(I+M) = I to float precision.
      Eigen::Matrix3d Ca, Cg, G;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          Ca(r, c) = parsed.coeffs[i].accel.C[3 * r + c];
          Cg(r, c) = parsed.coeffs[i].gyro.C[3 * r + c];
          G(r, c) = parsed.coeffs[i].G[3 * r + c];
        }
      const auto& b = spec.breakpoints[static_cast<std::size_t>(i)];
      EXPECT_LT((Ca * (Eigen::Matrix3d::Identity() + b.accel_M) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 3e-7);
      EXPECT_LT((Cg * (Eigen::Matrix3d::Identity() + b.gyro_M) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 3e-7);
      EXPECT_LT((G + Cg * b.gyro_G_sensor).cwiseAbs().maxCoeff(), 1e-9);
    }
  }
}

TEST(TableWriter, FileRoundTripAndCorruptionNamesTheFailure) {
  const std::string path = tmp_path("writer_test_table.bin");
  const auto bytes = table::serialize_table(make_spec(3, 1));
  table::write_table_file(path, bytes);
  const fw::Table t = table::read_table_file(path);
  EXPECT_TRUE(fw::table_is_valid(&t));
  auto corrupt = bytes;
  corrupt[200] ^= 0x01;
  table::write_table_file(path, corrupt);
  try {
    (void)table::read_table_file(path);
    FAIL() << "corrupt table accepted";
  } catch (const table::TableError& e) {
    EXPECT_EQ(e.code(), fw::kTableCrcMismatch);
    EXPECT_NE(std::string(e.what()).find("CRC-32 mismatch"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(table::read_table_file(tmp_path("does-not-exist.bin")), table::TableError);
  std::remove(path.c_str());
}

TEST(TableWriter, RejectsBadSpecs) {
  auto s = make_spec(3, 2);
  s.breakpoints[2].temp_degC = s.breakpoints[1].temp_degC;
  try {
    (void)table::build_table(s);
    FAIL();
  } catch (const table::TableError& e) {
    EXPECT_EQ(e.code(), fw::kTableBreakpointsNotIncreasing);
  }
  s = make_spec(17, 3);
  EXPECT_THROW((void)table::build_table(s), table::TableError);
  s = make_spec(1, 4);
  s.breakpoints[0].accel_M = -Eigen::Matrix3d::Identity();  // I+M singular
  EXPECT_THROW((void)table::build_table(s), table::TableError);
  s = make_spec(1, 5);
  s.gyro_lsb_rad_s = 0;
  try {
    (void)table::build_table(s);
    FAIL();
  } catch (const table::TableError& e) {
    EXPECT_EQ(e.code(), fw::kTableBadLsb);
  }
  table::TableSpec empty;
  EXPECT_THROW((void)table::build_table(empty), table::TableError);
}

// The kernel undoes the sensor model: simulate counts from known f, w with the model, compensate, compare.
TEST(HostKernel, UndoesTheSensorModel) {
  auto spec = make_spec(2, 6);
  const fw::Table t = table::build_table(spec);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uf(-60, 60), uw(-20, 20);
  for (auto path : {table::KernelPath::kF32, table::KernelPath::kFixed}) {
    table::HostKernel k(t, path);
    for (int s = 0; s < 200; ++s) {
      const auto& b = spec.breakpoints[static_cast<std::size_t>(s % 2)];  // at a breakpoint: no interpolation
      const Eigen::Vector3d f(uf(rng), uf(rng), uf(rng)), w(uw(rng), uw(rng), uw(rng));
      const Eigen::Vector3d ya = b.accel_b + (Eigen::Matrix3d::Identity() + b.accel_M) * f;
      const Eigen::Vector3d yg = b.gyro_b + (Eigen::Matrix3d::Identity() + b.gyro_M) * w + b.gyro_G_sensor * f;
      std::int32_t raw[6];
      for (int i = 0; i < 3; ++i) {
        raw[i] = static_cast<std::int32_t>(std::lround(ya(i) / spec.accel_lsb_mps2));
        raw[3 + i] = static_cast<std::int32_t>(std::lround(yg(i) / spec.gyro_lsb_rad_s));
      }
      const auto out = k.run(raw, b.temp_degC);
      EXPECT_EQ(out.status, 0u);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(out.accel_mps2[i], f(i), 1.1 * spec.accel_lsb_mps2);  // count quantisation ±½ LSB per axis
        EXPECT_NEAR(out.gyro_rad_s[i], w(i), 1.1 * spec.gyro_lsb_rad_s);
      }
    }
  }
}

TEST(HostKernel, CompensatesALogAndFlags) {
  auto spec = make_spec(2, 8);
  const fw::Table t = table::build_table(spec);
  io::LogMeta meta;
  meta.serial = "1001";
  meta.sample_rate_hz = 100;
  meta.accel_lsb_mps2 = spec.accel_lsb_mps2;
  meta.gyro_lsb_rad_s = spec.gyro_lsb_rad_s;
  const std::string in = tmp_path("compensate_in.csv"), out = tmp_path("compensate_out.csv");
  {
    io::LogWriter w(in, meta);
    for (int i = 0; i < 10; ++i) {
      io::LogRow r;
      r.t_s = 0.01 * i;
      r.segment = 0;
      r.temp_C = i < 9 ? -40.0 + i : 200.0;  // last row beyond the table: clamped
      r.raw[2] = 2048;
      r.raw[3] = i == 5 ? 32767 : 10;  // saturated gyro on row 5
      w.write(r);
    }
    w.close();
  }
  const auto sum = table::compensate_log(t, table::KernelPath::kFixed, 0.0, in, out, NAN);
  EXPECT_EQ(sum.rows, 10u);
  EXPECT_EQ(sum.temp_clamped, 1u);
  EXPECT_EQ(sum.gyro_saturated, 1u);
  std::ifstream f(out);
  std::string line;
  std::getline(f, line);
  EXPECT_EQ(line.rfind("# imuforge compensate", 0), 0u);
  std::getline(f, line);
  EXPECT_EQ(line, "t_s,segment,temp_C,ax_mps2,ay_mps2,az_mps2,gx_rad_s,gy_rad_s,gz_rad_s,status");
  int rows = 0;
  while (std::getline(f, line)) ++rows;
  EXPECT_EQ(rows, 10);
  // A log recorded with another LSB is refused with a message naming it.
  meta.accel_lsb_mps2 *= 2;
  { io::LogWriter w(in, meta); w.close(); }
  try {
    (void)table::compensate_log(t, table::KernelPath::kF32, 0.0, in, out, NAN);
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("LSB"), std::string::npos) << e.what();
  }
  std::remove(in.c_str());
  std::remove(out.c_str());
}
}  // namespace firmware_test_table_host
