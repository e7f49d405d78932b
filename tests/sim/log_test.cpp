// Log v1: CSV and binary round trips, auto-detection, and clear errors on malformed files.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "host/io/log.h"

using namespace imuforge::io;

namespace {

std::string tmp(const std::string& name) { return std::string(IMUFORGE_BINARY_DIR) + "/sim_log_test_" + name; }

LogMeta meta() {
  LogMeta m;
  m.serial = "SN-42";
  m.sample_rate_hz = 200;
  m.accel_lsb_mps2 = 9.80665 / 16384;
  m.gyro_lsb_rad_s = 1.3323e-4;
  m.latitude_deg = 48.14;
  m.height_m = 520;
  m.gravity_mps2 = 9.8087;
  m.table_axes = 2;
  m.accel_bits = m.gyro_bits = 32;  // the rows span the whole int32 range (INT32_MIN included)
  m.set("campaign", "unit test");
  return m;
}

std::vector<LogRow> rows(int n) {
  std::mt19937_64 g(3);
  std::normal_distribution<double> nd;
  std::vector<LogRow> v;
  for (int i = 0; i < n; ++i) {
    LogRow r;
    r.t_s = i / 200.0;
    r.segment = (i / 10) % 3 == 0 ? -1 : i / 10;
    r.temp_C = i % 7 == 0 ? std::nan("") : 25 + nd(g);
    r.chamber_C = 24.5 + 0.1 * nd(g);
    r.has_ref = i % 5 != 0;
    for (int j = 0; j < 3; ++j) {
      r.f_ref[j] = r.has_ref ? nd(g) * 9.8 : 0.0;
      r.w_ref[j] = r.has_ref ? nd(g) : 0.0;
    }
    for (int j = 0; j < 6; ++j) r.raw[j] = static_cast<std::int32_t>(nd(g) * 30000);
    r.raw[5] = i == 3 ? INT32_MIN : r.raw[5];
    r.table_angle_rad[0] = nd(g);
    r.table_rate_rad_s[0] = nd(g);
    r.table_angle_rad[1] = nd(g);
    r.table_rate_rad_s[1] = i % 4 == 0 ? std::nan("") : nd(g);
    v.push_back(r);
  }
  return v;
}

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void expect_equal(const LogRow& a, const LogRow& b, int i) {
  EXPECT_EQ(a.t_s, b.t_s) << i;
  EXPECT_EQ(a.segment, b.segment) << i;
  EXPECT_TRUE(same(a.temp_C, b.temp_C)) << i;
  EXPECT_TRUE(same(a.chamber_C, b.chamber_C)) << i;
  EXPECT_EQ(a.has_ref, b.has_ref) << i;
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(a.f_ref[j], b.f_ref[j]) << i;
    EXPECT_EQ(a.w_ref[j], b.w_ref[j]) << i;
  }
  for (int j = 0; j < 6; ++j) EXPECT_EQ(a.raw[j], b.raw[j]) << i;
  for (int j = 0; j < 2; ++j) {
    EXPECT_TRUE(same(a.table_angle_rad[j], b.table_angle_rad[j])) << i;
    EXPECT_TRUE(same(a.table_rate_rad_s[j], b.table_rate_rad_s[j])) << i;
  }
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string error_of(const std::string& path) {
  try {
    LogReader r(path);
    LogRow row;
    while (r.next(row)) {
    }
  } catch (const LogError& e) {
    return e.what();
  }
  return "no error";
}

const char* kHeader =
    "# format=imuforge-log\n# format_version=1\n# sample_rate_hz=100\n"
    "t_s,segment,temp_C,chamber_C,f_ref_x,f_ref_y,f_ref_z,w_ref_x,w_ref_y,w_ref_z,ax,ay,az,gx,gy,gz\n";

}  // namespace

TEST(Log, CsvAndBinaryRoundTripBitExact) {
  const auto in = rows(500);
  for (const char* name : {"a.csv", "a.bin"}) {
    const std::string path = tmp(name);
    {
      LogWriter w(path, meta());
      for (const auto& r : in) w.write(r);
      w.close();
    }
    LogReader rd(path);
    EXPECT_EQ(rd.encoding(), std::string(name).find(".bin") != std::string::npos ? LogEncoding::kBinary : LogEncoding::kCsv);
    EXPECT_EQ(rd.meta().serial, "SN-42");
    EXPECT_EQ(rd.meta().accel_lsb_mps2, 9.80665 / 16384);
    EXPECT_EQ(rd.meta().table_axes, 2);
    ASSERT_NE(rd.meta().find("campaign"), nullptr);
    EXPECT_EQ(*rd.meta().find("campaign"), "unit test");
    for (int pass = 0; pass < 2; ++pass) {
      LogRow r;
      int i = 0;
      while (rd.next(r)) {
        ASSERT_LT(i, 500);
        expect_equal(r, in[static_cast<std::size_t>(i)], i);
        ++i;
      }
      EXPECT_EQ(i, 500);
      rd.rewind();
    }
  }
}

TEST(Log, ForcedEncodingOverridesExtension) {
  const std::string path = tmp("forced.csv");
  {
    LogWriter w(path, meta(), LogEncoding::kBinary);
    w.write(rows(1)[0]);
  }
  LogReader r(path);
  EXPECT_EQ(r.encoding(), LogEncoding::kBinary);
  EXPECT_EQ(r.declared_rows(), 1u);
}

TEST(Log, CsvErrorsNameFileLineAndColumn) {
  const std::string p = tmp("bad.csv");
  write_text(p, std::string(kHeader) + "0,0,25,25,0,0,-9.8,0,0,0,1,2,3,4,5,6\n0.01,0,25,25,0,0,-9.8,0,0,0,1,2,x3,4,5,6\n");
  std::string e = error_of(p);
  EXPECT_NE(e.find(p + ":6"), std::string::npos) << e;
  EXPECT_NE(e.find("column 13 (az)"), std::string::npos) << e;

  write_text(p, std::string(kHeader) + "0,0,25,25,0,,-9.8,0,0,0,1,2,3,4,5,6\n");
  EXPECT_NE(error_of(p).find("all present or all empty"), std::string::npos);
  write_text(p, std::string(kHeader) + "0,0,25,25,0,0,-9.8,0,0,0,1,2,3,4,5\n");
  EXPECT_NE(error_of(p).find("15 cells"), std::string::npos) << error_of(p);
  write_text(p, std::string(kHeader) + "0,1.5,25,25,0,0,-9.8,0,0,0,1,2,3,4,5,6\n");
  EXPECT_NE(error_of(p).find("segment"), std::string::npos);
  write_text(p, std::string(kHeader) + "0,0,25,25,0,0,-9.8,0,0,0,1,2,3,4,5,99999999999\n");
  EXPECT_NE(error_of(p).find("gz"), std::string::npos);
  write_text(p, "# format_version=1\nt_s,segment,temp_C\n");
  EXPECT_NE(error_of(p).find("lacks required column 'chamber_C'"), std::string::npos) << error_of(p);
  write_text(p, "t_s,segment\n");
  EXPECT_NE(error_of(p).find("not an imuforge log"), std::string::npos);
  write_text(p, "# format_version=2\n");
  EXPECT_NE(error_of(p).find("version 2"), std::string::npos);
  write_text(p, "");
  EXPECT_NE(error_of(p).find("no header"), std::string::npos);
  EXPECT_NE(error_of(tmp("does-not-exist.csv")).find("cannot open"), std::string::npos);
  // Empty temperature and reference cells are valid (imported recordings).
  write_text(p, std::string(kHeader) + "0,0,,,,,,,,,1,2,3,4,5,6\n");
  EXPECT_EQ(error_of(p), "no error");
}

TEST(Log, TruncatedOrCorruptBinaryIsAnError) {
  const std::string p = tmp("t.bin");
  {
    LogWriter w(p, meta());
    for (const auto& r : rows(10)) w.write(r);
  }
  std::ifstream in(p, std::ios::binary);
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  write_text(p, data.substr(0, data.size() - 7));
  EXPECT_NE(error_of(p).find("truncated record 9"), std::string::npos) << error_of(p);
  write_text(p, data.substr(0, data.size() - kLogBinaryRecordBytes));
  EXPECT_NE(error_of(p).find("announces 10"), std::string::npos) << error_of(p);
  write_text(p, data.substr(0, 20));
  EXPECT_NE(error_of(p).find("header truncated"), std::string::npos) << error_of(p);
  std::string bad = data;
  bad[12] = 99;  // record size field
  write_text(p, bad);
  EXPECT_NE(error_of(p).find("record size"), std::string::npos);
}

TEST(Log, MetaRejectsBadKeys) {
  LogMeta m;
  EXPECT_THROW(m.set("bad key", "x"), LogError);
  EXPECT_THROW(m.set("serial", "x"), LogError);
  EXPECT_THROW(m.set("ok", "two\nlines"), LogError);
  m.set("ok", "1");
  m.set("ok", "2");
  EXPECT_EQ(*m.find("ok"), "2");
  EXPECT_EQ(m.extra.size(), 1u);
}

// Found by fuzz_log_csv (issue 16): a refused header left its FILE* open (the constructor threw, so the
// destructor never ran). Open descriptors are counted before and after 200 refusals.
TEST(Log, RefusedFilesDoNotLeakDescriptors) {
  auto open_fds = [] {
    std::size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) n += e.exists() ? 1 : 0;
    return n;
  };
  const std::string p = ::testing::TempDir() + "/imuforge-not-a-log.csv";
  const std::size_t before = open_fds();
  std::ofstream(p) << "this is not a log\n";
  for (int i = 0; i < 100; ++i) EXPECT_THROW(imuforge::io::LogReader r(p), imuforge::io::LogError);
  std::ofstream(p) << "# format_version=1\nt_s,segment\n";  // header lacks columns
  for (int i = 0; i < 100; ++i) EXPECT_THROW(imuforge::io::LogReader r(p), imuforge::io::LogError);
  EXPECT_EQ(open_fds(), before);
}
