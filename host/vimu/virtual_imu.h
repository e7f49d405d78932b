// The virtual IMU: the firmware CAN node (firmware/can_node/, the same sources as the MCU build) running
// on Linux with a simulated sensor, a simulated flash, and a CAN port from hal/linux (virtual bus or
// SocketCAN). The program imuforge-vimu wraps it; the bench simulator embeds it in-process and feeds
// the sensor from its simulated world through `truth`.
//
//   imuforge::vimu::VirtualImuConfig cfg;
//   cfg.bus = "virtual:bench1"; cfg.node_id = 1; cfg.serial = 1001;
//   cfg.truth = [&](double t_s) { hal::ImuRawSample s; ...; return s; };  // raw counts + 0.01 degC
//   imuforge::vimu::VirtualImu imu(cfg);
//   imu.start();   // throws std::runtime_error naming the bus if it cannot be opened
//   ...
//   imu.stop();
// `truth` is called on the node thread at every sample instant, t_s = node time since start().
#pragma once
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "firmware/can_node/node.h"
#include "hal/sensor.h"

namespace imuforge::vimu {

using Key = std::array<std::uint8_t, proto::kKeyBytes>;
using TruthFn = std::function<hal::ImuRawSample(double t_s)>;

// Development/test key: SHA-256("imuforge-dev-key" | serial u64 le). NOT for production devices, whose
// key is random and provisioned at manufacture (docs/can-protocol.md).
Key dev_key_for_serial(std::uint64_t serial);
// The stand-in signal used when no truth is given: 1 g on z with small sines on every channel and a
// slow temperature ramp, so every stream field changes.
hal::ImuRawSample standin_signal(double t_s);

struct VirtualImuConfig {
  std::string bus = "virtual:imuforge";
  std::uint8_t node_id = 1;
  bool extended_ids = false;
  std::uint64_t serial = 1;
  bool has_key = false;     // false: dev_key_for_serial(serial)
  Key key{};
  std::string flash_file;   // optional: flash image persisted across process restarts
  TruthFn truth;            // empty: standin_signal
  std::uint8_t isotp_block_size = 8;
  std::uint8_t isotp_st_min_raw = 0;
  // Depth of the node's sample FIFO (fw::NodeConfig::fifo_depth_samples): 5 s at 1 kHz. A Linux
  // process (worse: one inside an emulated VM on a loaded host) can be descheduled for seconds, which a
  // real node with its own CPU is not; beyond this the FIFO overflows and the loss is counted.
  std::uint16_t fifo_depth_samples = 5000;
  // An FD-capable controller: the node streams CAN FD when the host asks and the bus carries it
  // (virtual bus always, SocketCAN with MTU 72). false: a classic-only part (refuses FD streams).
  bool can_fd = true;
};

class VirtualImu {
 public:
  static constexpr std::uint32_t kFlashBytes = 16384;
  static constexpr std::uint32_t kSectorBytes = 2048;
  static constexpr std::uint32_t kSlotBytes = 4096;

  explicit VirtualImu(VirtualImuConfig cfg);
  ~VirtualImu();
  VirtualImu(const VirtualImu&) = delete;
  VirtualImu& operator=(const VirtualImu&) = delete;

  void start();
  void stop();
  bool running() const { return running_.load(); }
  // Resets the node as a watchdog would: RAM state (transfers, stream, staged table) is lost, flash kept.
  void reset();
  // Fault injection on the node's CAN port.
  void set_bus_off(bool on) { bus_off_.store(on); }
  void set_tx_drop_every(std::uint32_t n) { drop_every_.store(n); }
  fw::NodeCounters counters() const;
  std::uint32_t active_table_seq() const;
  // Frames the bus backend could not deliver to some receiver (virtual bus: a reader fell behind).
  std::uint64_t bus_tx_dropped() const;
  std::vector<std::uint8_t> flash_image() const;

 private:
  class Port;
  class SimSensor;
  struct Impl;
  void run();
  void save_flash_locked();

  VirtualImuConfig cfg_;
  std::unique_ptr<Impl> impl_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::atomic<bool> reset_{false};
  std::atomic<bool> bus_off_{false};
  std::atomic<std::uint32_t> drop_every_{0};
  mutable std::mutex mu_;
  std::uint64_t dropped_at_stop_ = 0;
};

}  // namespace imuforge::vimu
