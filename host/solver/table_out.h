// From a calibration to the firmware coefficient table (docs/table-format.md), with the quantisation
// check: the firmware kernel itself (compiled for the host) compensates the calibration log with the
// table, and the difference to a double-precision compensation with the same estimate must stay below
// 0.1 σ of the sensor noise on every channel.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/solver/calfile.h"
#include "host/table/table_writer.h"

namespace imuforge::solver {

struct TableReport {
  bool ok = false;
  std::size_t bytes = 0;
  std::vector<double> breakpoints_C;
  std::array<double, 6> rms_diff{};   // RMS (kernel − double) per channel, SI
  std::array<double, 6> ratio{};      // rms_diff / noise σ
  double worst_ratio = 0.0;
  std::string worst_channel;
  long long samples = 0;
  nlohmann::json to_json() const;
};

// Writes the table to path and runs the check over the log (rewound). Throws SolverError when the
// estimate cannot be expressed in the table (e.g. an effect the kernel does not implement).
// True if the coefficient table v1 can hold the parameter (bias, scale, misalignment, their temperature
// polynomials, per-plateau values "@plateau<k>", gyro g-sensitivity; fixture nuisances are not sensor terms).
bool table_expressible(const std::string& name);

// The table's coefficients for an estimate at the given breakpoints, as the sensor model b(T), M(T)
// (polynomials in T − T_ref_C, or the plateau's values where bp_plateau[i] ≥ 0) and the gyro g-sensitivity.
// Parameters the table cannot hold are ignored here (callers decide: `solve --table` refuses them).
// Only the breakpoints and kind are filled; the caller sets serial, LSBs and raw widths.
table::TableSpec table_spec_from_estimate(const Estimate& e, double T_ref_C, const std::vector<double>& bps,
                                          const std::vector<int>& bp_plateau);

TableReport write_coefficient_table(const CalibrationResult& res, io::LogReader& log, const std::string& path,
                                    const std::string& serial);

}  // namespace imuforge::solver
