// Column-mapping CSV import (`imuforge import --format csv --map`): the two real recordings mapped by
// hand (as a lab would describe its own export) must give the same log as their dedicated importers;
// broken files and maps fail with the file, line and column (or the map key) named.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "host/io/import.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_import_map_test {

using namespace imuforge::io;

namespace {
std::string real(const char* p) { return std::string(IMUFORGE_REAL_DATA_DIR) + "/" + p; }
std::string tmp(const std::string& p) { return std::string(IMUFORGE_BINARY_DIR) + "/sim_import_map_test_" + p; }
void write_text(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

ImportSummary import_csv(const std::string& in, const std::string& map_json, const std::string& out) {
  write_text(tmp("map.json"), map_json);
  ImportOptions o;
  o.format = "csv";
  o.in = in;
  o.map = tmp("map.json");
  return import_recording(o, out);
}

std::string error_of(const std::string& in, const std::string& map_json) {
  std::filesystem::remove(tmp("err.csv"));
  try {
    import_csv(in, map_json, tmp("err.csv"));
  } catch (const LogError& e) {
    EXPECT_FALSE(std::filesystem::exists(tmp("err.csv"))) << "partial output left behind";
    EXPECT_FALSE(std::filesystem::exists(tmp("err.csv.partial")));
    return e.what();
  }
  return "no error";
}

// Every row equal (time to 1e-9 s: the mapped import rebases t by subtraction as the dedicated one does).
void expect_same_rows(const std::string& a, const std::string& b, std::uint64_t n_expected) {
  LogReader ra(a), rb(b);
  EXPECT_DOUBLE_EQ(ra.meta().accel_lsb_mps2, rb.meta().accel_lsb_mps2);
  EXPECT_DOUBLE_EQ(ra.meta().gyro_lsb_rad_s, rb.meta().gyro_lsb_rad_s);
  EXPECT_NEAR(ra.meta().sample_rate_hz, rb.meta().sample_rate_hz, 1e-3);
  LogRow x, y;
  std::uint64_t n = 0;
  while (ra.next(x)) {
    ASSERT_TRUE(rb.next(y)) << n;
    ASSERT_NEAR(x.t_s, y.t_s, 1e-9) << n;
    for (int k = 0; k < 6; ++k) ASSERT_EQ(x.raw[k], y.raw[k]) << n << " " << k;
    ASSERT_EQ(x.has_ref, y.has_ref);
    ++n;
  }
  EXPECT_FALSE(rb.next(y));
  EXPECT_EQ(n, n_expected);
}
}  // namespace

// Xsens: the lab's export is the two files pasted side by side (t ax ay az t gx gy gz), space-separated,
// unsigned 16-bit counts about 32768, no header.
TEST(ImportMap, XsensPastedByHandEqualsTheDedicatedImporter) {
  if (!std::filesystem::exists(real("xsens-mti-imutk/xsens_acc.txt"))) GTEST_SKIP() << "no real data";
  std::ifstream fa(real("xsens-mti-imutk/xsens_acc.txt")), fg(real("xsens-mti-imutk/xsens_gyro.txt"));
  std::ofstream out(tmp("xsens_joined.txt"));
  std::string la, lg;
  while (std::getline(fa, la) && std::getline(fg, lg)) out << la << " " << lg << "\n";
  out.close();
  const auto s = import_csv(tmp("xsens_joined.txt"), R"({
    "delimiter": "whitespace", "header": false,
    "time": {"column": 1, "unit": "s"},
    "accel": {"columns": [2, 3, 4], "unit": "counts", "offset": 32768, "lsb": 0.0024096385542168677},
    "gyro":  {"columns": [6, 7, 8], "unit": "counts", "offset": 32768, "lsb": 0.00020964360587002095},
    "serial": "MTi-lab", "metadata": {"site": "IMU-TK test data", "gravity_mps2": 9.80665}
  })", tmp("xsens_mapped.h5"));
  EXPECT_EQ(s.rows, 51175u);
  ImportOptions o{"xsens-imutk", real("xsens-mti-imutk/xsens_acc.txt"), real("xsens-mti-imutk/xsens_gyro.txt"), "", 0};
  import_recording(o, tmp("xsens_dedicated.bin"));
  expect_same_rows(tmp("xsens_mapped.h5"), tmp("xsens_dedicated.bin"), 51175);
  LogReader r(tmp("xsens_mapped.h5"));
  EXPECT_EQ(r.meta().serial, "MTi-lab");
  EXPECT_EQ(r.meta().gravity_mps2, 9.80665);     // a reserved key from the map lands typed
  ASSERT_NE(r.meta().find("site"), nullptr);     // a free key is carried
  EXPECT_EQ(*r.meta().find("raw_offset_accel"), "32768");
}

// MPU-6050: 4 metadata rows, a header, int16 counts, no time column (100 Hz). Mapped by column names,
// and once more in physical units (g and deg/s with the register resolution), which must give the same counts.
TEST(ImportMap, Mpu6050ByNameAndInPhysicalUnitsEqualsTheDedicatedImporter) {
  const std::string in = real("mpu6050-tomisuarez2/example_data_calibration.csv");
  if (!std::filesystem::exists(in)) GTEST_SKIP() << "no real data";
  const auto s = import_csv(in, R"({
    "skip_lines": 4, "sample_rate_hz": 100,
    "accel": {"columns": ["ax", "ay", "az"], "lsb": 0.0005985504150390625},
    "gyro":  {"columns": ["gx", "gy", "gz"], "lsb": 0.00013323124061025417}
  })", tmp("mpu_mapped.csv"));
  ImportOptions o{"mpu6050-csv", in, "", "", 0};
  const auto d = import_recording(o, tmp("mpu_dedicated.csv"));
  EXPECT_EQ(s.rows, d.rows);
  EXPECT_GT(s.rows, 1000u);
  expect_same_rows(tmp("mpu_mapped.csv"), tmp("mpu_dedicated.csv"), d.rows);

  // The same numbers exported in g and °/s (what a driver would print), with the sensor's resolution.
  std::ifstream f(in);
  std::ofstream g(tmp("mpu_physical.csv"));
  std::string line;
  int ln = 0;
  g << "time_ms;ax_g;ay_g;az_g;gx_dps;gy_dps;gz_dps;temp_F\n";
  while (std::getline(f, line)) {
    if (++ln <= 5) continue;
    long v[6];
    if (std::sscanf(line.c_str(), "%ld,%ld,%ld,%ld,%ld,%ld", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) != 6) continue;
    char buf[256];
    std::snprintf(buf, sizeof buf, "%d;%.9g;%.9g;%.9g;%.9g;%.9g;%.9g;%s\n", (ln - 6) * 10, v[0] / 16384.0,
                  v[1] / 16384.0, v[2] / 16384.0, v[3] / 131.0, v[4] / 131.0, v[5] / 131.0, ln % 2 ? "77" : "");
    g << buf;
  }
  g.close();
  import_csv(tmp("mpu_physical.csv"), R"({
    "delimiter": ";",
    "time": {"column": "time_ms", "unit": "ms"},
    "accel": {"columns": ["ax_g", "ay_g", "az_g"], "unit": "g", "lsb": 6.103515625e-05},
    "gyro":  {"columns": ["gx_dps", "gy_dps", "gz_dps"], "unit": "deg/s", "lsb": 0.007633587786259542},
    "temperature": {"column": "temp_F", "unit": "degF"}
  })", tmp("mpu_physical.bin"));
  LogReader a(tmp("mpu_physical.bin")), b(tmp("mpu_dedicated.csv"));
  EXPECT_NEAR(a.meta().accel_lsb_mps2, b.meta().accel_lsb_mps2, 1e-15);
  EXPECT_NEAR(a.meta().gyro_lsb_rad_s, b.meta().gyro_lsb_rad_s, 1e-15);
  LogRow x, y;
  int n = 0, with_temp = 0;
  while (a.next(x) && b.next(y)) {
    for (int k = 0; k < 6; ++k) ASSERT_EQ(x.raw[k], y.raw[k]) << n;
    ASSERT_NEAR(x.t_s, y.t_s, 1e-9);
    if (!std::isnan(x.temp_C)) {
      ASSERT_NEAR(x.temp_C, 25.0, 1e-12);  // 77 °F
      ++with_temp;
    }
    ++n;
  }
  EXPECT_EQ(static_cast<std::uint64_t>(n), d.rows);
  EXPECT_GT(with_temp, n / 3);
}

TEST(ImportMap, BrokenFilesNameLineAndColumn) {
  const std::string map = R"({"time": {"column": "t"}, "accel": {"columns": ["ax", "ay", "az"], "lsb": 0.001},
                             "gyro": {"columns": ["gx", "gy", "gz"], "lsb": 0.0001}, "temperature": {"column": 8}})";
  const std::string p = tmp("broken.csv");
  const std::string head = "t,ax,ay,az,gx,gy,gz,T\n";
  write_text(p, head + "0.00,1,2,3,4,5,6,25\n0.01,1,2,x3,4,5,6,25\n");
  std::string e = error_of(p, map);
  EXPECT_NE(e.find(p + ":3: column 4 (az)"), std::string::npos) << e;
  EXPECT_NE(e.find("'x3'"), std::string::npos) << e;
  write_text(p, head + "0.00,1,2,3,4,5,6,25\n0.01,1,2,3,4.5,5,6,25\n");
  e = error_of(p, map);
  EXPECT_NE(e.find(p + ":3: column 5 (gx): expected an integer count"), std::string::npos) << e;
  write_text(p, head + "0.00,1,2,3,4,5,6,25\n0.01,1,2,3,4,5\n");
  e = error_of(p, map);
  EXPECT_NE(e.find(p + ":3: 6 cells, the map reads column 8 (temperature)"), std::string::npos) << e;
  write_text(p, head + "0.00,1,2,3,4,5,6,25\n0.00,1,2,3,4,5,6,25\n");
  e = error_of(p, map);
  EXPECT_NE(e.find(p + ":3: column 1 (t): time 0.00 does not increase"), std::string::npos) << e;
  write_text(p, "t,ax,ay,az,gx,gy,T\n0,1,2,3,4,5,6\n");
  e = error_of(p, map);
  EXPECT_NE(e.find("gyro z column 'gz' is not in the header at " + p + ":1"), std::string::npos) << e;
  write_text(p, head + "0.00,1,2,3,4,5,6,25\n0.01,1,2,3,4,5,6,hot\n");
  e = error_of(p, map);
  EXPECT_NE(e.find(p + ":3: column 8 (T)"), std::string::npos) << e;
  write_text(p, head);
  EXPECT_NE(error_of(p, map).find("no data rows"), std::string::npos);
  EXPECT_NE(error_of(tmp("missing.csv"), map).find("cannot open"), std::string::npos);
}

TEST(ImportMap, BrokenMapsNameTheKey) {
  const std::string p = tmp("ok.csv");
  write_text(p, "t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6\n");
  const std::string acc = R"("accel": {"columns": ["ax","ay","az"], "lsb": 0.001})";
  const std::string gyr = R"("gyro": {"columns": ["gx","gy","gz"], "lsb": 0.0001})";
  auto err = [&](const std::string& body) { return error_of(p, "{" + body + "}"); };
  EXPECT_NE(err(R"("time": {"column": "t"}, )" + acc + "," + gyr + R"(, "delimeter": ";")").find("unknown key 'map.delimeter'"),
            std::string::npos);
  EXPECT_NE(err(R"("time": {"column": "t"}, )" + acc + "," + gyr.substr(0, gyr.size() - 1) + R"(, "unit": "furlong/s"})")
                .find("gyro.unit: unknown unit 'furlong/s'"), std::string::npos);
  EXPECT_NE(err(R"("time": {"column": "t"}, )" + acc + R"(, "gyro": {"columns": ["gx","gy","gz"], "unit": "g", "lsb": 1})")
                .find("not a unit of angular rate"), std::string::npos);
  EXPECT_NE(err(R"("time": {"column": "t"}, )" + acc + R"(, "gyro": {"columns": ["gx","gy"], "lsb": 1})")
                .find("gyro.columns must list 3 columns"), std::string::npos);
  EXPECT_NE(err(acc + "," + gyr).find("give \"sample_rate_hz\""), std::string::npos);
  EXPECT_NE(err(R"("time": {"column": 0}, )" + acc + "," + gyr).find("1-based index"), std::string::npos);
  EXPECT_NE(err(R"("time": {"column": "t"}, "accel": {"columns": ["ax","ay","az"]}, )" + gyr).find("accel.lsb must be"),
            std::string::npos);
  EXPECT_NE(err(R"("time": {"column": "t"}, )" + acc + "," + gyr + R"(, "metadata": {"latitude_deg": "north"})")
                .find("metadata 'latitude_deg'"), std::string::npos);
  EXPECT_EQ(err(R"("time": {"column": "t"}, )" + acc + "," + gyr), "no error");
}
}  // namespace sim_import_map_test
