// Building bench-sim's WorldConfig from the files a station already has: the campaign (table axes and
// limits, mount, lever arm, site, chamber limits), the sensor model (die lag, self-heating) and an
// optional world JSON of overrides (docs/modbus.md, "bench-sim world file").
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "host/benchsim/world.h"

namespace imuforge::benchsim {

// Any path may be empty. Throws std::runtime_error naming the file and the field.
WorldConfig world_config(const std::string& campaign_path, const std::string& world_json_path,
                         const std::string& sensor_path, uint64_t seed);
// Apply a world JSON object (keys: axes, axis_names, max_rate_dps, max_accel_dps2, in_position_deg,
// settle_s, initial_C, ramp_C_per_min, max_ramp_C_per_min, chamber_tau_s, at_setpoint_band_C,
// die_tau_s, self_heating_C, self_heating_tau_s, latitude_deg, height_m, dt_s, mount_ypr_deg,
// lever_arm_m). Unknown keys are an error.
void apply_world_json(WorldConfig& wc, const nlohmann::json& j, const std::string& origin);

}  // namespace imuforge::benchsim
