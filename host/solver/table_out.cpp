#include "host/solver/table_out.h"

namespace imuforge::solver {

nlohmann::json TableReport::to_json() const {
  nlohmann::json j;
  j["ok"] = ok;
  j["bytes"] = bytes;
  j["samples_checked"] = samples;
  j["quantisation_rms"] = rms_diff;
  j["quantisation_over_noise"] = ratio;
  j["worst_ratio"] = worst_ratio;
  j["worst_channel"] = worst_channel;
  j["limit"] = 0.1;
  return j;
}

TableReport write_coefficient_table(const CalibrationResult&, io::LogReader&, const std::string&, const std::string&) {
  throw SolverError("coefficient table: the host table writer (host/table/) is not available in this build yet");
}

}  // namespace imuforge::solver
