// The runner's ports on real components:
//   FixtureBench  rate table + chamber over Modbus (host/fixture), per the station's "fixtures"
//   CanDevice     the IMU over CAN (host/can): identify, stream, flash (HMAC-signed), read back
//   KernelTableOps table v1 writer (host/table) and the firmware kernel on the host for verification
// time_scale (station "time_scale", default 1) is for bench-sim: simulated seconds per wall second.
// The fixture clock register is simulated time already; the IMU node's timestamps are wall time, so
// CanDevice multiplies them by time_scale, and FixtureBench::wait() sleeps fixture_s / time_scale.
#pragma once
#include <memory>

#include "host/eol/ports.h"
#include "host/eol/station.h"

namespace imuforge::eol {

// The highest node stream rate (wall Hz) CanDevice asks for: the station's rate × time_scale is clamped
// to it, so a faster time scale samples fewer times per SIMULATED second (Device::effective_rate_hz).
constexpr double kCanDeviceMaxNodeRateHz = 1000.0;

std::unique_ptr<Bench> make_fixture_bench(const StationConfig& st);
std::unique_ptr<Device> make_can_device(const StationConfig& st);
std::unique_ptr<TableOps> make_table_ops();

}  // namespace imuforge::eol
