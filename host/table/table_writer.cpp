#include "host/table/table_writer.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>

namespace imuforge::table {

namespace {

std::string fw_error(int code) {
  return std::string(fw::table_strerror(code)) + " (code " + std::to_string(code) + ")";
}

void put_matrix(const Eigen::Matrix3d& m, float out[9]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[3 * r + c] = static_cast<float>(m(r, c));
}
void put_vector(const Eigen::Vector3d& v, float out[3]) {
  for (int i = 0; i < 3; ++i) out[i] = static_cast<float>(v(i));
}
bool is_identity(const float m[9]) {
  for (int i = 0; i < 9; ++i)
    if (m[i] != (i % 4 == 0 ? 1.0f : 0.0f)) return false;
  return true;
}
bool is_zero(const float* v, int n) {
  for (int i = 0; i < n; ++i)
    if (v[i] != 0.0f) return false;
  return true;
}

Eigen::Matrix3d invert_checked(const Eigen::Matrix3d& IM, const char* what, double temp) {
  Eigen::FullPivLU<Eigen::Matrix3d> lu(IM);
  if (!lu.isInvertible() || !(std::abs(IM.determinant()) > 1e-9))
    throw TableError(std::string(what) + " I+M is singular at " + std::to_string(temp) + " degC", 0);
  return lu.inverse();
}

}  // namespace

fw::Table build_table(const TableSpec& spec) {
  const std::size_t n = spec.breakpoints.size();
  if (n == 0) throw TableError("table: " + fw_error(fw::kTableZeroBreakpoints), fw::kTableZeroBreakpoints);
  if (n > fw::kTableMaxBreakpoints)
    throw TableError("table: " + fw_error(fw::kTableTooManyBreakpoints) + ", got " + std::to_string(n),
                     fw::kTableTooManyBreakpoints);
  if (spec.accel_raw_bits < 0 || spec.accel_raw_bits > 255 || spec.gyro_raw_bits < 0 || spec.gyro_raw_bits > 255)
    throw TableError("table: " + fw_error(fw::kTableBadRawBits), fw::kTableBadRawBits);
  fw::Table t;
  fw::table_init_identity(&t, static_cast<float>(spec.accel_lsb_mps2), static_cast<float>(spec.gyro_lsb_rad_s),
                          static_cast<std::uint8_t>(spec.accel_raw_bits), static_cast<std::uint8_t>(spec.gyro_raw_bits));
  t.device_serial = spec.device_serial;
  t.table_sequence = spec.table_sequence;
  t.created_unix_s = spec.created_unix_s != 0 ? spec.created_unix_s : static_cast<std::int64_t>(std::time(nullptr));
  t.n_breakpoints = static_cast<std::uint8_t>(n);
  for (std::size_t i = 0; i < n; ++i) {
    const BreakpointSpec& b = spec.breakpoints[i];
    Eigen::Matrix3d Ca, Cg, G;
    if (spec.kind == SpecKind::kSensorModel) {
      Ca = invert_checked(Eigen::Matrix3d::Identity() + b.accel_M, "accel", b.temp_degC);
      Cg = invert_checked(Eigen::Matrix3d::Identity() + b.gyro_M, "gyro", b.temp_degC);
      G = -Cg * b.gyro_G_sensor;
    } else {
      Ca = b.accel_C;
      Cg = b.gyro_C;
      G = b.gyro_G;
    }
    t.breakpoints_degC[i] = static_cast<float>(b.temp_degC);
    fw::BreakpointCoeffs& c = t.coeffs[i];
    put_matrix(Ca, c.accel.C);
    put_matrix(Cg, c.gyro.C);
    put_matrix(G, c.G);
    put_vector(b.accel_b, c.accel.b);
    put_vector(b.gyro_b, c.gyro.b);
  }
  // Flags describe what the float table actually carries (a term that rounds to neutral is absent).
  std::uint32_t flags = n > 1 ? static_cast<std::uint32_t>(fw::kModelTemperature) : 0u;
  for (std::size_t i = 0; i < n; ++i) {
    const fw::BreakpointCoeffs& c = t.coeffs[i];
    if (!is_identity(c.accel.C)) flags |= fw::kModelAccelMatrix;
    if (!is_zero(c.accel.b, 3)) flags |= fw::kModelAccelBias;
    if (!is_identity(c.gyro.C)) flags |= fw::kModelGyroMatrix;
    if (!is_zero(c.gyro.b, 3)) flags |= fw::kModelGyroBias;
    if (!is_zero(c.G, 9)) flags |= fw::kModelGyroGSens;
  }
  t.model_flags = flags;
  const int rc = fw::table_validate(&t);
  if (rc != fw::kTableOk) throw TableError("table: " + fw_error(rc), rc);
  return t;
}

std::vector<std::uint8_t> serialize_table(fw::Table table) {
  std::vector<std::uint8_t> out(fw::kTableMaxSize);
  const int len = fw::table_serialize(&table, out.data(), out.size());
  if (len < 0) throw TableError("table: " + fw_error(len), len);
  out.resize(static_cast<std::size_t>(len));
  return out;
}

std::vector<std::uint8_t> serialize_table(const TableSpec& spec) { return serialize_table(build_table(spec)); }

void write_table_file(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw TableError(path + ": cannot open for writing: " + std::strerror(errno), 0);
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) throw TableError(path + ": write failed", 0);
}

fw::Table parse_table(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  fw::Table t;
  const int rc = fw::table_parse(bytes.data(), bytes.size(), &t);
  if (rc != fw::kTableOk) throw TableError(what + ": invalid coefficient table: " + fw_error(rc), rc);
  return t;
}

static fw::Table read_table_file_unchecked(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw TableError(path + ": cannot open: " + std::strerror(errno), 0);
  std::vector<std::uint8_t> bytes;
  std::uint8_t buf[4096];
  std::size_t got;
  // Read at most one byte more than the largest valid table: anything longer is rejected by length.
  while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) {
    bytes.insert(bytes.end(), buf, buf + got);
    if (bytes.size() > fw::kTableMaxSize) break;
  }
  const bool err = std::ferror(f) != 0;
  std::fclose(f);
  if (err) throw TableError(path + ": read error", 0);
  if (bytes.size() > fw::kTableMaxSize)
    throw TableError(path + ": invalid coefficient table: larger than the maximum " +
                         std::to_string(fw::kTableMaxSize) + " bytes",
                     fw::kTableLengthMismatch);
  return parse_table(bytes, path);
}

fw::Table read_table_file(const std::string& path) {
  try {
    return read_table_file_unchecked(path);
  } catch (const TableError& e) {
    throw TableFileError(e.what(), e.code());  // the user handed this file: bad input
  }
}

}  // namespace imuforge::table
