// Host-side writer and reader of coefficient tables v1 (format: docs/table-format.md).
//
// The solver describes the calibration per temperature breakpoint in double precision, either as the
// SENSOR model of docs/error-model.md (what the sensor does):
//     y_a = b_a + (I + M_a) f                     y_g = b_g + (I + M_g) w + G_s f
// or directly as the CORRECTION the kernel applies (what the firmware undoes):
//     f = C_a (y_a − b_a)                          w = C_g (y_g − b_g) + G f
// build_table() turns a sensor model into the correction in double precision: C = (I+M)^-1 and
// G = −C_g·G_s, then rounds every coefficient once to float, derives model_flags from which terms are
// non-neutral and validates with the firmware's own rules (the same code that parses it on the MCU).
// y are SI values (raw · lsb); b in m/s² and rad/s; M, C dimensionless; G, G_s in (rad/s)/(m/s²).
// Breakpoints must be strictly increasing; 1 to 16 of them.
#pragma once

#include "host/io/input_error.h"
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "firmware/table/table.h"

namespace imuforge::table {

class TableError : public std::runtime_error {
 public:
  TableError(const std::string& what, int code) : std::runtime_error(what), code_(code) {}
  int code() const { return code_; }  // the firmware TableError code, or 0 for I/O errors

 private:
  int code_;
};
// A table file that cannot be used (read_table_file): bad input, exit code 2.
class TableFileError : public TableError, public io::BadInput {
 public:
  using TableError::TableError;
};


struct BreakpointSpec {
  double temp_degC = 25.0;
  // kSensorModel: M and G_s. kCorrection: C and G (the M/G_s fields are ignored, and vice versa).
  Eigen::Matrix3d accel_M = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d gyro_M = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d gyro_G_sensor = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d accel_C = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d gyro_C = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d gyro_G = Eigen::Matrix3d::Zero();
  Eigen::Vector3d accel_b = Eigen::Vector3d::Zero();  // m/s²
  Eigen::Vector3d gyro_b = Eigen::Vector3d::Zero();   // rad/s
};

enum class SpecKind { kSensorModel, kCorrection };

struct TableSpec {
  std::uint64_t device_serial = 0;
  std::uint32_t table_sequence = 0;
  std::int64_t created_unix_s = 0;       // 0: build_table() stamps the current time
  double accel_lsb_mps2 = 0.0;           // m/s² per count
  double gyro_lsb_rad_s = 0.0;           // rad/s per count
  int accel_raw_bits = 16;               // 8..24
  int gyro_raw_bits = 16;
  SpecKind kind = SpecKind::kSensorModel;
  std::vector<BreakpointSpec> breakpoints;
};

// Builds and validates the firmware table. Throws TableError (code = firmware TableError) naming the
// rule that failed, e.g. "breakpoints not strictly increasing", or a singular I+M.
fw::Table build_table(const TableSpec& spec);
// build_table + serialisation: the exact bytes that go to the device.
std::vector<std::uint8_t> serialize_table(const TableSpec& spec);
std::vector<std::uint8_t> serialize_table(fw::Table table);

// File I/O. read_table_file() runs the firmware parser; on failure the message names the file and the
// parser's failure ("T.bin: invalid coefficient table: CRC-32 mismatch (code -106)").
void write_table_file(const std::string& path, const std::vector<std::uint8_t>& bytes);
fw::Table read_table_file(const std::string& path);
fw::Table parse_table(const std::vector<std::uint8_t>& bytes, const std::string& what = "table");

}  // namespace imuforge::table
