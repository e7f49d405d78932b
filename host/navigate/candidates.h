// The coefficient tables navigate compares: uncompensated (nominal scale only), every calibration file
// given, and the oracle (the sensor file's true values of every term the table holds).
// Each is built as `imuforge solve --table` builds a table (host/solver/table_out.h): 16 breakpoints over
// the temperature span seen along the trajectory (one if it spans < 0.5 °C), the plateau temperatures for
// per-plateau estimates.
#pragma once

#include <string>
#include <vector>

#include "host/model/sensor_model.h"
#include "host/navigate/impact.h"
#include "host/solver/estimate.h"

namespace imuforge::navigate {

// Raw word width the table v1 takes is 8..24 bits. A sensor with wider registers (32-bit outputs) is
// read through its top 24 bits: counts shifted right (rounded) and the LSB scaled by 2^shift.
struct RawFormat {
  double accel_lsb_mps2 = 0, gyro_lsb_rad_s = 0;
  int accel_bits = 16, gyro_bits = 16;
  int accel_shift = 0, gyro_shift = 0;
};
RawFormat raw_format(const model::SensorModel& m);

// A calibration from a cal.json (docs/calibration.md). temps_C: the die temperatures along the trajectory.
// Throws std::invalid_argument naming the file for a malformed file or a table the firmware rejects.
Candidate calibration_candidate(const std::string& path, const RawFormat& fmt, const std::vector<double>& temps_C);
Candidate oracle_candidate(const model::SensorModel& m, const RawFormat& fmt, const std::vector<double>& temps_C);
Candidate uncompensated_candidate(const RawFormat& fmt);

// The same from an estimate already in memory (tests, sensitivity). plateau_T_C: per-plateau estimates only.
Candidate estimate_candidate(const std::string& name, const std::string& kind, const solver::Estimate& e, double T_ref_C,
                             const std::vector<double>& plateau_T_C, const RawFormat& fmt,
                             const std::vector<double>& temps_C);

}  // namespace imuforge::navigate
