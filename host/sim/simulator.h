// The campaign simulator: campaign + sensor model + seed -> log v1 (+ truth).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/physics/table.h"

namespace imuforge::sim {

struct SimOptions {
  std::uint64_t seed = 1;
  double sample_rate_hz = 0.0;      // 0 = campaign's rate
  std::string serial = "SIM-0001";
  // Fixture errors and encoder noise; defaults come from the campaign's "simulation" block.
  bool use_campaign_fixture_errors = true;
  double max_duration_s = 0.0;      // > 0: stop after this much simulated time (benchmarks, previews)
};

struct SimSummary {
  std::uint64_t rows = 0;
  double duration_s = 0.0;
  int segments = 0;
  nlohmann::json truth;   // {"parameters": {name: value}, "realised": {...}, "fixture": {...}, ...}
};

// Runs the whole campaign, writing every sample to `out` (already opened by the caller with
// make_log_meta()). Deterministic: same inputs and seed -> bit-identical rows.
SimSummary simulate(const physics::Campaign& c, const model::SensorModel& m, const SimOptions& opt, io::LogWriter& out);

// The metadata the simulator writes (sample rate, LSBs, site, gravity, serial, campaign/sensor names).
io::LogMeta make_log_meta(const physics::Campaign& c, const model::SensorModel& m, const SimOptions& opt);

// Callback flavour (no file): each row is handed to sink (used by the bench simulator / tests).
SimSummary simulate(const physics::Campaign& c, const model::SensorModel& m, const SimOptions& opt,
                    const std::function<void(const io::LogRow&)>& sink);

}  // namespace imuforge::sim
