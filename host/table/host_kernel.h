// Runs the firmware compensation kernel (firmware/kernel/, the same source as on the MCU) on the host,
// sample by sample or over a whole log v1. Used by `imuforge compensate` and by the end-of-line checks.
#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"
#include "host/io/log.h"

namespace imuforge::table {

enum class KernelPath { kF32, kFixed };

struct CompensatedSample {
  double accel_mps2[3];
  double gyro_rad_s[3];
  std::uint32_t status;  // fw::KernelStatus bits
};

// Owns a copy of the table and one kernel instance. Not thread-safe (the kernel caches).
class HostKernel {
 public:
  // step_degC: re-interpolation step (0 = on every temperature change). Throws TableError if the kernel
  // refuses the table (e.g. the fixed path's kKernelFixedRange), naming the reason.
  HostKernel(const fw::Table& table, KernelPath path, double step_degC = 0.0);
  // raw: ax ay az gx gy gz counts (int32, clamped to the table's raw width). temp_degC may be NaN
  // (the kernel then clamps to the lowest breakpoint and flags kStatusTempClamped).
  CompensatedSample run(const std::int32_t raw[6], double temp_degC);
  const fw::Table& table() const { return *table_; }
  KernelPath path() const { return path_; }

 private:
  std::unique_ptr<fw::Table> table_;  // heap-held so the f32 kernel's borrowed pointer stays valid
  KernelPath path_;
  std::unique_ptr<fw::KernelF32> kf_;
  std::unique_ptr<fw::KernelQ> kq_;
};

struct CompensateSummary {
  std::uint64_t rows = 0;
  std::uint64_t temp_clamped = 0;
  std::uint64_t accel_saturated = 0;
  std::uint64_t gyro_saturated = 0;
};

// Reads log v1 `in_path` (CSV or binary), writes the compensated CSV `out_path` (columns: docs/kernel.md).
// temp_override_degC (if finite) replaces the log's temp_C. Throws io::LogError / TableError /
// std::runtime_error with a message naming the file.
CompensateSummary compensate_log(const fw::Table& table, KernelPath path, double step_degC, const std::string& in_path,
                                 const std::string& out_path, double temp_override_degC);

}  // namespace imuforge::table
