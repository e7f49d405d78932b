// Conversion of real recordings (../shared/data/real, see its README) to log v1 with empty references.
//
//   xsens-imutk  IMU-TK test data: two space-separated files `t x y z` (accel, gyro) with identical
//                timestamps, raw unsigned 16-bit counts about 32768. Converted to signed counts
//                (raw − 32768); metadata raw_offset=32768 records the shift. Nominal LSBs from the README:
//                accel 1/415 m/s² per count, gyro 1/4770 rad/s per count (starting values, not a calibration).
//   mpu6050-csv  tomisuarez2/ImuCalibration: metadata rows (`Fs,100`, …), header `ax,ay,az,gx,gy,gz`,
//                int16 counts; no time column, so t_s = i / Fs. Nominal LSBs from the configured ranges:
//                accel ±2 g = 9.80665/16384 m/s², gyro ±250 °/s = (π/180)/131 rad/s.
//   si-csv       floats in SI: header `t_s,ax,ay,az,gx,gy,gz` (m/s², rad/s; `#` lines skipped), mapped to
//                counts of accel_lsb_mps2 / gyro_lsb_rad_s in a `bits`-wide word (default 1e-5 m/s², 1e-6 rad/s,
//                32 bits: ±21 km/s² and ±2147 rad/s, resolution far below any MEMS noise). A value beyond the
//                word is an error naming the line.
//   csv          any delimited text export, described by a column map (JSON, docs/formats.md): delimiter,
//                header names or 1-based indices, time column and unit (or a sample rate), accel/gyro in
//                counts with their LSB or in physical units with the sensor's resolution, optional
//                temperature, free metadata. Errors name the file, line and column.
// xsens-imutk and mpu6050-csv declare 16-bit words (accel_bits = gyro_bits = 16), si-csv its `bits`.
// All: temperature unknown unless mapped (temp_C, chamber_C empty = NaN), has_ref = false, segment = −1 (no
// fixture schedule: reference-free consumers detect static intervals themselves), table_axes = 0.
#pragma once

#include <cstdint>
#include <string>

#include "host/io/log.h"

namespace imuforge::io {

struct ImportOptions {
  std::string format;      // "xsens-imutk", "mpu6050-csv" or "csv"
  std::string in;          // accel file (xsens) or the CSV (mpu6050)
  std::string in_gyro;     // xsens only
  std::string serial;      // written to metadata ("" -> derived from the file name)
  double sample_rate_hz = 0;  // 0 = from the file (xsens, si-csv: median Δt; mpu6050: its Fs row)
  double accel_lsb_mps2 = 1e-5, gyro_lsb_rad_s = 1e-6;  // si-csv only
  int bits = 32;                                         // si-csv only
  std::string map;            // csv only: the column map (JSON); last, so positional initialisers still fit
};

struct ImportSummary {
  std::uint64_t rows = 0;
  double duration_s = 0;
  double sample_rate_hz = 0;
};

// Writes the converted log to `out_path` (encoding by extension, or `enc`) through a staging file (host/io/staged_file.h),
// renamed at the end: a failure leaves no output. Throws LogError naming the input file, line and column
// on malformed input (and the map file and key for a bad column map).
ImportSummary import_recording(const ImportOptions& opt, const std::string& out_path,
                               LogEncoding enc = LogEncoding::kAuto);

// The "csv" format alone (host/io/import_csv.cpp); writes out_path directly.
ImportSummary import_mapped_csv(const ImportOptions& opt, const std::string& out_path, LogEncoding enc);

}  // namespace imuforge::io
