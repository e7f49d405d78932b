// The virtual IMU inside bench-sim: the firmware CAN node (host/vimu) whose sensor reads the bench's
// world: true specific force, angular rate and die temperature at the sample's simulated time, through
// the sensor error model (host/model) to raw counts. One clock: the world is advanced to the sample
// time under the bench lock, so IMU samples and fixture registers describe the same instant.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "hal/sensor.h"
#include "host/benchsim/bench.h"

namespace imuforge::benchsim {

class ImuLink {
 public:
  virtual ~ImuLink() = default;
  virtual void stop() = 0;
};

// Converts the world's truth at simulated time t_s into one raw sample (counts, 0.01 degC). Holds the
// compiled sensor model; an empty sensor path means an ideal sensor with default LSBs (docs/modbus.md).
class ImuSampler {
 public:
  ImuSampler(Bench& bench, const std::string& sensor_path, uint64_t seed);
  ~ImuSampler();
  hal::ImuRawSample sample(double t_s);
  double accel_lsb() const;
  double gyro_lsb() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct ImuOptions {
  std::string bus;          // "virtual:NAME" or "socketcan:IF"
  std::string sensor_path;  // sensor model JSON; empty: ideal sensor
  uint64_t seed = 1;
  uint64_t serial = 1;
  int node_id = 1;
};

// Start the virtual IMU. Throws std::runtime_error (bad bus, bad sensor file, no vimu in this build).
std::unique_ptr<ImuLink> start_imu(Bench& bench, const ImuOptions& opt);

}  // namespace imuforge::benchsim
