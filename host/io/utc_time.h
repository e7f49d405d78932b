// Wall-clock timestamps for provenance (cal.json, records, journals): one format everywhere.
#pragma once

#include <string>

namespace imuforge::io {

// Current UTC time as ISO 8601, "YYYY-MM-DDThh:mm:ssZ".
std::string utc_now_iso8601();

}  // namespace imuforge::io
