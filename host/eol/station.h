// The station file: what one end-of-line station is (fixtures, CAN, records) and what it accepts
// (limits per parameter and per verification residual). Format: docs/eol.md "Station file";
// example: docs/examples/station.json.
#pragma once
#include <array>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/io/input_error.h"

namespace imuforge::eol {

// A station file that cannot be used (bad input: exit code 2).
class StationError : public io::InputError {
 public:
  using io::InputError::InputError;
};

// Limits on one parameter, or on every parameter matched by a pattern ("accel.bias.*").
struct ParamLimit {
  std::string pattern;   // exact catalog name, a prefix ("accel.bias" covers accel.bias.x), or "prefix*"
  double abs_max = 0.0;  // |value| must not exceed; 0 = no limit
  double sigma_max = 0.0;// σ must not exceed (also the early-stop spec); 0 = no limit
};

struct VerificationPose {
  std::string label;
  std::array<double, 3> position_deg{};  // table axis angles
  std::array<double, 3> rate_dps{};      // nonzero: a constant-rate check
  double dwell_s = 5.0;
};

// One nest of a multi-unit station (docs/eol.md "Station file", issue 14). Where the unit sits and how
// well: the nest's nominal mount rotation and lever arm on the platform, and the 1σ tolerance of the
// unit's rotation in it (overrides fixture_tolerance.mount_sigma_deg for this slot).
struct StationSlot {
  std::string name;                           // "slot01": unique
  int node_id = 1;                            // unique on its bus, 1..127
  std::string bus;                            // default: can.bus
  std::array<double, 3> mount_rotation_deg{}; // ZYX yaw, pitch, roll of the IMU w.r.t. the platform
  std::array<double, 3> lever_arm_m{};        // from the rotation centre, platform frame
  std::array<double, 3> mount_sigma_deg{-1.0, -1.0, -1.0};  // < 0: the station's fixture_tolerance
  bool has_geometry = false;                  // mount_rotation_deg or lever_arm_m given
};

struct StationConfig {
  std::string name = "station";
  std::string dir;                 // folder of the station file (relative paths resolve here)
  nlohmann::json fixtures;         // {"table": {...}, "chamber": {...}} for host/fixture
  std::string can_bus = "virtual:bench1";
  int can_node_id = 1;
  double stream_rate_hz = 100.0;   // sample rate wanted, in sensor (simulated) time
  double time_scale = 1.0;         // bench-sim only: simulated seconds per wall second (1 on a real lab)
  double accel_lsb_mps2 = 0.0;     // streamed count -> SI (0: from "sensor" model file)
  double gyro_lsb_rad_s = 0.0;
  std::string db = "records.sqlite";  // SQLite path (relative: to the run's --out folder) or postgresql:// URL
  std::string model_path;          // solver model file (model-thermal.json shape)
  std::string sensor_hint;         // optional sensor-model file for nominal noise (bench-sim's part)
  // Nominal per-sample noise at stream_rate_hz, used to weight rows and to predict information.
  double accel_noise_mps2 = 0.0;   // 0 = estimate from the data
  double gyro_noise_rad_s = 0.0;
  // Temperature settling, detected from the IMU's own temperature (docs/eol.md "Settling").
  double settle_window_s = 120.0;        // regression window over the IMU temperature
  double settle_slope_C_per_min = 0.05;  // |slope| below this over a full window = settled
  double settle_band_C = 3.0;            // and the IMU within this of the setpoint (plus self-heating)
  double settle_timeout_s = 7200.0;      // fixture seconds before the plateau fails
  double table_timeout_s = 120.0;        // fixture seconds for in-position + settled
  bool early_stop = true;
  // Early stop fires when every tracked σ is below this fraction of its spec. The tracker's σ uses the
  // station's nominal noise; the batch solve re-estimates the noise from the data, so its σ can come out
  // a few percent larger. The margin keeps the final, recorded σ within spec.
  double early_stop_sigma_fraction = 0.9;
  std::vector<ParamLimit> limits;
  double verify_accel_mps2 = 0.0;        // |compensated − reference| per accel axis; 0 = no check
  double verify_gyro_rad_s = 0.0;
  std::vector<VerificationPose> verification;
  std::string hmac_key_hex;              // device table key ("" = the test/demo key for the serial)
  // The fixture's tolerance (1σ: table axis tilts and zeros, the IMU's rotation in its nest), the format
  // of host/solver/consider.h; null when not stated. The batch solve carries it into every σ (honest σ),
  // and the σ limits and the report use that σ.
  nlohmann::json fixture_tolerance;
  // Multi-unit stations: the nests. Empty: one unit at can.node_id. The bus budget (host/can/bus_budget.h)
  // of every bus at stream_rate_hz is checked when the file is read; a plan above bus_load_limit is
  // refused with what would fit.
  std::vector<StationSlot> slots;
  bool can_fd = false;                   // can.fd: CAN FD stream frames
  double can_bitrate = 1e6;              // can.bitrate, bit/s
  double can_data_bitrate = 5e6;         // can.data_bitrate (CAN FD), bit/s
  double bus_load_limit = 0.70;          // can.load_limit
  // The slot of that name, or nullptr.
  const StationSlot* slot(const std::string& name) const;

  // The limit that applies to a parameter: exact name first, else the longest matching prefix.
  // Returns nullptr if none.
  const ParamLimit* limit_for(const std::string& param) const;
};

StationConfig station_from_json(const nlohmann::json& j, const std::string& dir);
StationConfig load_station(const std::string& path);

}  // namespace imuforge::eol
