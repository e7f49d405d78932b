#include "host/diagnosis/table_errors.h"

#include <string>

#include "host/physics/earth.h"
#include "host/physics/timeline.h"

namespace imuforge::diagnosis {

Options::Table table_of_campaign(const physics::Campaign& c, int log_table_axes, const std::string& campaign_name) {
  Options::Table t;
  t.nominal = physics::geometry_from_campaign(c).nominal();
  if (log_table_axes != t.nominal.n_axes)
    throw DiagnosisError(campaign_name + ": its table has " + std::to_string(t.nominal.n_axes) + " axes but the log has " +
                         std::to_string(log_table_axes) +
                         " table angle columns (the table's axis errors need the reported angles of every axis)");
  const physics::Site site{c.latitude_deg, c.height_m};
  t.g_ned = physics::gravity_ned(site);
  t.wie_ned = physics::earth_rate_ned(site);
  t.known = true;
  return t;
}

}  // namespace imuforge::diagnosis
