// The runner's view of the outside world: a bench (rate table + chamber), a device (the IMU on CAN) and
// the table operations (build, compensate). Real adapters: adapters.h (host/fixture, host/can,
// host/table, firmware kernel). Tests may substitute their own: the runner's logic does not change.
// Every method may throw; a std::exception from a port is reported as a peer failure naming the port.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "host/solver/estimate.h"

namespace imuforge::eol {

struct TableReading {
  std::array<double, 3> angle_deg{};  // reported angles per table axis
  std::array<double, 3> rate_dps{};   // reported rates
  bool in_position = false;           // every axis at its command (position or rate)
  bool settled = false;               // and settled (the fixture's own flag)
  bool fault = false;
  std::string fault_text;
};

class Bench {
 public:
  virtual ~Bench() = default;
  virtual std::string describe() const = 0;  // e.g. "table-1 + chamber-1"
  virtual void set_chamber(double setpoint_C, double ramp_C_per_min) = 0;
  virtual double chamber_air_C() = 0;
  virtual void command_position(const std::array<double, 3>& angle_deg) = 0;
  virtual void command_rate(const std::array<double, 3>& rate_dps) = 0;
  virtual TableReading table() = 0;
  virtual double time_s() = 0;              // fixture clock (simulated under bench-sim), s
  virtual void wait(double fixture_s) = 0;  // let fixture time pass
};

struct ImuSample {
  double t_s = 0.0;       // sensor time, s
  double temp_C = 0.0;    // die temperature reported by the IMU
  std::int32_t raw[6] = {0, 0, 0, 0, 0, 0};  // ax ay az gx gy gz counts
};

struct DeviceInfo {
  std::string serial;
  std::string firmware_version;
  double accel_lsb_mps2 = 0.0;
  double gyro_lsb_rad_s = 0.0;
  bool table_present = false;
  std::uint32_t table_crc32 = 0;
  std::uint32_t table_seq = 0;
  int accel_raw_bits = 16, gyro_raw_bits = 16;  // width of the streamed counts
};

struct StreamStats {
  std::uint64_t received = 0, lost = 0, duplicated = 0, reordered = 0;
};

class Device {
 public:
  virtual ~Device() = default;
  virtual DeviceInfo identify() = 0;
  // The sample rate (sensor-time Hz) a stream request for rate_hz actually delivers.
  virtual double effective_rate_hz(double rate_hz) { return rate_hz; }
  // Streams at rate_hz and calls on_sample for each sample in order until it returns false. Returns the
  // loss counters of this stream.
  virtual StreamStats stream(double rate_hz, const std::function<bool(const ImuSample&)>& on_sample) = 0;
  // Writes, commits and activates a table (authenticated by the adapter); seq must exceed the active one.
  virtual void flash_table(const std::vector<std::uint8_t>& blob, std::uint32_t seq) = 0;
  virtual std::vector<std::uint8_t> read_table() = 0;
};

class TableOps {
 public:
  virtual ~TableOps() = default;
  // The coefficient table v1 for an estimate (catalog names) with breakpoints at the given die
  // temperatures, for this device. Throws if the estimate holds an effect the table cannot express.
  virtual std::vector<std::uint8_t> build(const solver::Estimate& e, double T_ref_C,
                                          const std::vector<double>& breakpoints_C, const DeviceInfo& dev,
                                          std::uint32_t seq) = 0;
  // Applies a table to one raw sample exactly as the firmware kernel does: out = ax ay az (m/s²),
  // gx gy gz (rad/s). Throws if the table does not parse.
  virtual void compensate(const std::vector<std::uint8_t>& table, const ImuSample& s, double out[6]) = 0;
};

}  // namespace imuforge::eol
