// The campaign file (docs/formats.md § campaign): JSON <-> physics::Campaign.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "host/physics/campaign.h"

namespace imuforge::io {

// Throws std::invalid_argument naming the JSON path of the problem (e.g. "phases[2].steps[5].dwell_s").
physics::Campaign campaign_from_json(const nlohmann::json& j);
// As campaign_from_json, the message prefixed with the file's path.
physics::Campaign load_campaign(const std::string& path);
nlohmann::json campaign_to_json(const physics::Campaign& c);

}  // namespace imuforge::io
