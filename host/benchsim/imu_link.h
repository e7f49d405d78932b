// The virtual IMU inside bench-sim: the firmware CAN node (host/vimu) whose sensor reads the bench's
// world: true specific force, angular rate and die temperature at the sample's simulated time, through
// the sensor error model (host/model) to raw counts. One clock: the world is advanced to the sample
// time under the bench lock, so IMU samples and fixture registers describe the same instant.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hal/sensor.h"
#include "host/benchsim/bench.h"

namespace imuforge::benchsim {

class ImuLink {
 public:
  virtual ~ImuLink() = default;
  virtual void stop() = 0;
  // One line of the node's stream counters, for bench-sim's log at exit (samples against stream frames
  // shows whether it streamed classic, 3 frames per sample, or CAN FD, 1 per 4).
  virtual std::string summary() const = 0;
};

// Converts the world's truth at simulated time t_s into one raw sample (counts, 0.01 degC). Holds the
// compiled sensor model; an empty sensor path means an ideal sensor with default LSBs (docs/modbus.md).
class ImuSampler {
 public:
  // nest_error_rad: the unit's small rotation in its nest (IMU frame; the sensed vectors become
  // Exp([e×])·v, the convention of physics::TableGeometry's mount error for an identity nominal mount).
  ImuSampler(Bench& bench, const std::string& sensor_path, uint64_t seed,
             const Eigen::Vector3d& nest_error_rad = Eigen::Vector3d::Zero());
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
  Eigen::Vector3d nest_error_rad = Eigen::Vector3d::Zero();  // see ImuSampler
};

// A station's worth of virtual IMUs (issue 14): `slots` units, slot k (0-based) on buses[k % buses],
// node first_node + k, serial first_serial + k, noise/turn-on seed seed + k (its own sensor realisation),
// and a nest rotation drawn per axis from N(0, nest_sigma_rad) with its own seed. Slots listed in `dead`
// (1-based, as printed) are left out: a node that never answers. Throws std::invalid_argument on no bus,
// slots < 1, or node ids beyond 127.
struct SlotPlan {
  int slots = 1;
  std::vector<std::string> buses;
  std::string sensor_path;
  uint64_t seed = 1, first_serial = 1;
  int first_node = 1;
  double nest_sigma_rad = 0.0;
  std::vector<int> dead;
  // Slots (1-based) whose part is another sensor model (a unit far from the batch, for the outlier
  // marks of docs/eol.md "Batches"); outlier_sensor_path must then be set.
  std::vector<int> outlier;
  std::string outlier_sensor_path;
};
std::vector<ImuOptions> slot_imus(const SlotPlan& plan);

// Start the virtual IMU. Throws std::runtime_error (bad bus, bad sensor file, no vimu in this build).
std::unique_ptr<ImuLink> start_imu(Bench& bench, const ImuOptions& opt);

}  // namespace imuforge::benchsim
