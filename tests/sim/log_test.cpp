// Log v1: CSV, binary and HDF5 round trips, auto-detection, and clear errors on malformed files.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <hdf5.h>

#include "host/io/log.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_log_test {

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
  for (const char* name : {"a.csv", "a.bin", "a.h5"}) {
    const std::string path = tmp(name);
    {
      LogWriter w(path, meta());
      for (const auto& r : in) w.write(r);
      w.close();
    }
    LogReader rd(path);
    EXPECT_EQ(rd.encoding(), encoding_from_path(name));
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

// ---------------------------------------------------------------------------------------------- HDF5

namespace {

const char* const kRequiredColumnNames[16] = {"t_s", "segment", "temp_C", "chamber_C", "f_ref_x", "f_ref_y",
                                              "f_ref_z", "w_ref_x", "w_ref_y", "w_ref_z", "ax", "ay", "az",
                                              "gx", "gy", "gz"};

std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Copies a log into another encoding through the public API (what `imuforge convert` does).
void copy_log(const std::string& from, const std::string& to) {
  LogReader r(from);
  LogWriter w(to, r.meta());
  LogRow row;
  while (r.next(row)) w.write(row);
  w.close();
}

std::string run_capture(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    pclose(p);
  }
  return out;
}

}  // namespace

// CSV -> binary -> HDF5 -> CSV gives back the very same bytes (numbers and metadata bit for bit), with
// more rows than one HDF5 chunk (32768) so block reads and dataset extension are both crossed.
TEST(Log, CsvBinHdf5ChainIsByteExact) {
  LogMeta m = meta();
  m.set("source", "chain test: commas, = signs and unicode °C");
  m.set("z_last", "order is kept");
  const auto in = rows(70001);
  {
    LogWriter w(tmp("chain.csv"), m);
    for (const auto& r : in) w.write(r);
    w.close();
  }
  copy_log(tmp("chain.csv"), tmp("chain.bin"));
  copy_log(tmp("chain.bin"), tmp("chain.h5"));
  copy_log(tmp("chain.h5"), tmp("chain2.bin"));
  copy_log(tmp("chain.h5"), tmp("chain2.csv"));
  EXPECT_EQ(slurp(tmp("chain.csv")), slurp(tmp("chain2.csv")));
  EXPECT_EQ(slurp(tmp("chain.bin")), slurp(tmp("chain2.bin")));
  LogReader h(tmp("chain.h5"));
  EXPECT_EQ(h.encoding(), LogEncoding::kHdf5);
  EXPECT_EQ(h.declared_rows(), 70001u);
  ASSERT_EQ(h.meta().extra.size(), 3u);
  EXPECT_EQ(h.meta().extra[1].first, "source");
  EXPECT_EQ(h.meta().extra[1].second, "chain test: commas, = signs and unicode °C");
  // Random access pattern of multi-pass consumers: read part, rewind, read all.
  LogRow r;
  for (int i = 0; i < 40000; ++i) ASSERT_TRUE(h.next(r));
  h.rewind();
  int i = 0;
  while (h.next(r)) {
    if (i % 997 == 0 || i == 32767 || i == 32768) expect_equal(r, in[static_cast<std::size_t>(i)], i);
    ++i;
  }
  EXPECT_EQ(i, 70001);
  // Compressed: the HDF5 file is much smaller than the packed binary.
  EXPECT_LT(slurp(tmp("chain.h5")).size(), slurp(tmp("chain.bin")).size() * 3 / 4);
}

// The file opens with the HDF5 tools alone (hdf5-tools, installed by setup.sh): attributes, chunking,
// compression and data are what docs/formats.md says.
TEST(Log, Hdf5OpensWithH5dump) {
  ASSERT_EQ(std::system("command -v h5dump >/dev/null"), 0) << "h5dump missing: run ./setup.sh (hdf5-tools)";
  const auto in = rows(50);
  {
    LogWriter w(tmp("dump.h5"), meta());
    for (const auto& r : in) w.write(r);
    w.close();
  }
  const std::string attrs = run_capture("h5dump -A " + tmp("dump.h5"));
  EXPECT_NE(attrs.find("ATTRIBUTE \"serial\""), std::string::npos) << attrs;
  EXPECT_NE(attrs.find("\"SN-42\""), std::string::npos) << attrs;
  EXPECT_NE(attrs.find("ATTRIBUTE \"gravity_mps2\""), std::string::npos);
  EXPECT_NE(attrs.find("9.8087"), std::string::npos);
  EXPECT_NE(attrs.find("\"unit test\""), std::string::npos);
  for (const char* d : {"t_s", "segment", "temp_C", "f_ref_x", "w_ref_z", "ax", "gz", "tbl_angle_1", "tbl_rate_1"})
    EXPECT_NE(attrs.find(std::string("DATASET \"") + d + "\""), std::string::npos) << d;
  const std::string props = run_capture("h5dump -p -H -d /gx " + tmp("dump.h5"));
  EXPECT_NE(props.find("H5T_STD_I32LE"), std::string::npos) << props;
  EXPECT_NE(props.find("CHUNKED"), std::string::npos) << props;
  EXPECT_NE(props.find("DEFLATE"), std::string::npos) << props;
  EXPECT_NE(props.find("SHUFFLE"), std::string::npos) << props;
  // Values: the first three gx counts, as h5dump prints them.
  const std::string data = run_capture("h5dump -d /gx -s 0 -c 3 " + tmp("dump.h5"));
  const std::string want = "(0): " + std::to_string(in[0].raw[3]) + ", " + std::to_string(in[1].raw[3]) + ", " +
                           std::to_string(in[2].raw[3]);
  EXPECT_NE(data.find(want), std::string::npos) << data << "\nwanted " << want;
}

namespace {

// A log written by another program (as h5py or MATLAB would): fixed-length strings, format_version as
// a double, attributes in name order, no table datasets. `mutate` breaks it on purpose.
enum class Break { kNone, kMissingGz, kShortAx, kFloatAx, kNoVersion, kTwoDim };
void write_foreign(const std::string& path, Break b) {
  hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  auto attr_d = [&](const char* n, double v) {
    hid_t s = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(f, n, H5T_IEEE_F64LE, s, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, H5T_NATIVE_DOUBLE, &v);
    H5Aclose(a);
    H5Sclose(s);
  };
  auto attr_s = [&](const char* n, const std::string& v) {
    hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, v.size());
    hid_t s = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(f, n, t, s, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, t, v.data());
    H5Aclose(a);
    H5Sclose(s);
    H5Tclose(t);
  };
  attr_s("format", "imuforge-log");
  if (b != Break::kNoVersion) attr_d("format_version", 1.0);
  attr_s("serial", "FOREIGN-1");
  attr_d("sample_rate_hz", 100.0);
  attr_d("accel_lsb_mps2", 1.0 / 415);
  attr_d("gyro_lsb_rad_s", 1.0 / 4770);
  attr_s("source", "h5py");
  const hsize_t n = 5;
  for (int c = 0; c < 16; ++c) {
    const std::string name = kRequiredColumnNames[c];
    if (b == Break::kMissingGz && name == "gz") continue;
    const bool integer = c == 1 || c >= 10;
    hsize_t dims[2] = {b == Break::kShortAx && name == "ax" ? n - 1 : n, 1};
    hid_t s = H5Screate_simple(b == Break::kTwoDim && name == "ay" ? 2 : 1, dims, nullptr);
    const bool as_float = !integer || (b == Break::kFloatAx && name == "ax");
    hid_t d = H5Dcreate2(f, name.c_str(), as_float ? H5T_IEEE_F32LE : H5T_STD_I16LE, s, H5P_DEFAULT, H5P_DEFAULT,
                         H5P_DEFAULT);
    std::vector<double> v(n);
    for (hsize_t i = 0; i < n; ++i)
      v[i] = c == 0 ? 0.01 * static_cast<double>(i) : (c >= 2 && c < 10) ? std::nan("") : c == 1 ? -1 : c * 10.0 + i;
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Dclose(d);
    H5Sclose(s);
  }
  H5Fclose(f);
}

}  // namespace

TEST(Log, Hdf5FromAnotherWriterReads) {
  const std::string p = tmp("foreign.h5");
  write_foreign(p, Break::kNone);
  LogReader r(p);
  EXPECT_EQ(r.meta().serial, "FOREIGN-1");
  EXPECT_EQ(r.meta().accel_lsb_mps2, 1.0 / 415);
  ASSERT_NE(r.meta().find("source"), nullptr);
  LogRow row;
  int i = 0;
  while (r.next(row)) {
    EXPECT_FALSE(row.has_ref);
    EXPECT_TRUE(std::isnan(row.temp_C));
    EXPECT_EQ(row.segment, -1);
    EXPECT_EQ(row.raw[0], 100 + i);  // ax = 10·10 + i
    EXPECT_EQ(row.raw[5], 150 + i);
    EXPECT_TRUE(std::isnan(row.table_angle_rad[0]));
    ++i;
  }
  EXPECT_EQ(i, 5);
}

TEST(Log, Hdf5ErrorsNameTheDataset) {
  const std::string p = tmp("broken.h5");
  write_foreign(p, Break::kMissingGz);
  EXPECT_NE(error_of(p).find("lacks dataset '/gz'"), std::string::npos) << error_of(p);
  write_foreign(p, Break::kShortAx);
  EXPECT_NE(error_of(p).find("'/ax' has 4 rows"), std::string::npos) << error_of(p);
  write_foreign(p, Break::kFloatAx);
  EXPECT_NE(error_of(p).find("'/ax' has type class"), std::string::npos) << error_of(p);
  write_foreign(p, Break::kNoVersion);
  EXPECT_NE(error_of(p).find("format_version"), std::string::npos) << error_of(p);
  write_foreign(p, Break::kTwoDim);
  EXPECT_NE(error_of(p).find("'/ay' is not one-dimensional"), std::string::npos) << error_of(p);
  // Truncated file: refused with the file named, never read as a shorter log.
  {
    LogWriter w(p, meta());
    for (const auto& r : rows(3000)) w.write(r);
    w.close();
  }
  const std::string data = slurp(p);
  write_text(p, data.substr(0, data.size() / 2));
  const std::string e = error_of(p);
  EXPECT_NE(e.find(p), std::string::npos) << e;
  EXPECT_NE(e, "no error");
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
}  // namespace sim_log_test
