#include "host/vimu/virtual_imu.h"

#include <poll.h>
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "firmware/crypto/sha256.h"
#include "hal/linux/linux_can.h"
#include "hal/sim/sim_flash.h"

namespace imuforge::vimu {

Key dev_key_for_serial(std::uint64_t serial) {
  std::uint8_t msg[16 + 8];
  std::memcpy(msg, "imuforge-dev-key", 16);
  for (int i = 0; i < 8; ++i) msg[16 + i] = static_cast<std::uint8_t>(serial >> (8 * i));
  Key k{};
  fw::sha256(msg, sizeof msg, k.data());
  return k;
}

hal::ImuRawSample standin_signal(double t_s) {
  constexpr double kPi = 3.14159265358979323846;
  hal::ImuRawSample s;
  auto c16 = [](double v) { return static_cast<std::int16_t>(std::lround(std::fmax(-32768.0, std::fmin(32767.0, v)))); };
  // 16-bit, +-8 g accel (4096 counts/g) and +-1000 deg/s gyro (32.8 counts per deg/s)
  s.accel_counts[0] = c16(200.0 * std::sin(2 * kPi * 1.0 * t_s));
  s.accel_counts[1] = c16(150.0 * std::cos(2 * kPi * 0.5 * t_s));
  s.accel_counts[2] = c16(4096.0 + 50.0 * std::sin(2 * kPi * 2.0 * t_s));
  s.gyro_counts[0] = c16(328.0 * std::sin(2 * kPi * 0.2 * t_s));
  s.gyro_counts[1] = c16(-164.0 * std::sin(2 * kPi * 0.3 * t_s));
  s.gyro_counts[2] = c16(50.0 * std::cos(2 * kPi * 0.1 * t_s));
  s.temp_cdegC = c16(2500.0 + 10.0 * t_s / 60.0);
  return s;
}

// The node's CAN port: the Linux port plus injected faults.
class VirtualImu::Port final : public hal::CanPort {
 public:
  Port(hal::LinuxCanPort& inner, VirtualImu& owner) : inner_(inner), owner_(owner) {}
  int send(const hal::CanFrame& f) noexcept override {
    if (owner_.bus_off_.load()) return hal::kCanErrBusOff;
    const std::uint32_t n = owner_.drop_every_.load();
    if (n != 0u && ++count_ % n == 0u) return hal::kCanOk;  // lost on the wire: the sender cannot tell
    return inner_.send(f);
  }
  int send_fd(const hal::CanFdFrame& f) noexcept override {
    if (owner_.bus_off_.load()) return hal::kCanErrBusOff;
    const std::uint32_t n = owner_.drop_every_.load();
    if (n != 0u && ++count_ % n == 0u) return hal::kCanOk;
    return inner_.send_fd(f);
  }
  int receive(hal::CanFrame& f) noexcept override { return inner_.receive(f); }

 private:
  hal::LinuxCanPort& inner_;
  VirtualImu& owner_;
  std::uint64_t count_ = 0;
};

class VirtualImu::SimSensor final : public hal::Sensor {
 public:
  explicit SimSensor(TruthFn fn) : fn_(std::move(fn)) {}
  int read(std::uint64_t t_us, hal::ImuRawSample& out) noexcept override {
    const double t_s = static_cast<double>(t_us) * 1e-6;
    out = fn_ ? fn_(t_s) : standin_signal(t_s);
    return hal::kSensorOk;
  }

 private:
  TruthFn fn_;
};

struct VirtualImu::Impl {
  std::vector<std::uint8_t> flash_mem = std::vector<std::uint8_t>(kFlashBytes, 0xFF);
  hal::SimFlash flash{flash_mem.data(), kFlashBytes, kSectorBytes};
  std::unique_ptr<hal::LinuxCanPort> linux_port;
  std::unique_ptr<Port> port;
  std::unique_ptr<SimSensor> sensor;
  std::unique_ptr<fw::CanNode> node = std::make_unique<fw::CanNode>();  // ~9 KB: not on the stack
  fw::NodeConfig node_cfg;
  std::uint32_t saved_ops = 0;
};

VirtualImu::VirtualImu(VirtualImuConfig cfg) : cfg_(std::move(cfg)), impl_(std::make_unique<Impl>()) {
  if (!cfg_.flash_file.empty()) {
    std::ifstream f(cfg_.flash_file, std::ios::binary);
    if (f) {
      std::vector<std::uint8_t> img((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      if (img.size() != kFlashBytes) {
        throw std::runtime_error("vimu: flash file " + cfg_.flash_file + " has " + std::to_string(img.size()) +
                                 " bytes, expected " + std::to_string(kFlashBytes));
      }
      impl_->flash_mem = img;
    }
  }
  fw::NodeConfig& nc = impl_->node_cfg;
  nc.node_id = cfg_.node_id;
  nc.extended_ids = cfg_.extended_ids;
  nc.serial = cfg_.serial;
  const Key key = cfg_.has_key ? cfg_.key : dev_key_for_serial(cfg_.serial);
  std::memcpy(nc.key, key.data(), key.size());
  nc.key_provisioned = true;
  nc.store.slot_addr[0] = 0;
  nc.store.slot_addr[1] = kFlashBytes / 2;
  nc.store.slot_bytes = kSlotBytes;
  nc.isotp_block_size = cfg_.isotp_block_size;
  nc.isotp_st_min_raw = cfg_.isotp_st_min_raw;
  nc.fifo_depth_samples = cfg_.fifo_depth_samples;
}

VirtualImu::~VirtualImu() { stop(); }

void VirtualImu::start() {
  if (running_.load()) return;
  std::string err;
  impl_->linux_port = hal::open_can_port(cfg_.bus, &err, /*want_fd=*/cfg_.can_fd);
  if (!impl_->linux_port) throw std::runtime_error("vimu: cannot open CAN bus '" + cfg_.bus + "': " + err);
  // The node's hardware acceptance filter: its request id only (the other nodes' streams never reach it).
  if (!hal::set_can_filter(*impl_->linux_port, {proto::request_id(cfg_.node_id, cfg_.extended_ids)}, cfg_.extended_ids, &err))
    throw std::runtime_error("vimu: CAN bus '" + cfg_.bus + "': " + err);
  impl_->port = std::make_unique<Port>(*impl_->linux_port, *this);
  // The node offers FD streaming iff its port carries FD (virtual bus; SocketCAN with MTU 72).
  impl_->node_cfg.can_fd = cfg_.can_fd && impl_->linux_port->fd_enabled();
  impl_->sensor = std::make_unique<SimSensor>(cfg_.truth);
  stop_.store(false);
  running_.store(true);
  thread_ = std::thread([this] { run(); });
}

void VirtualImu::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true);
  thread_.join();
  running_.store(false);
  std::lock_guard<std::mutex> lk(mu_);
  save_flash_locked();
  dropped_at_stop_ = impl_->linux_port ? impl_->linux_port->tx_dropped() : 0;
  impl_->linux_port.reset();
}

void VirtualImu::reset() { reset_.store(true); }

fw::NodeCounters VirtualImu::counters() const {
  std::lock_guard<std::mutex> lk(mu_);
  return impl_->node->counters;
}

std::uint32_t VirtualImu::active_table_seq() const {
  std::lock_guard<std::mutex> lk(mu_);
  const fw::StoreSlotInfo* a = fw::store_active(impl_->node->store);
  return a != nullptr ? a->seq : 0u;
}

std::uint64_t VirtualImu::bus_tx_dropped() const {
  std::lock_guard<std::mutex> lk(mu_);
  return impl_->linux_port ? impl_->linux_port->tx_dropped() : dropped_at_stop_;
}

std::vector<std::uint8_t> VirtualImu::flash_image() const {
  std::lock_guard<std::mutex> lk(mu_);
  return impl_->flash_mem;
}

void VirtualImu::save_flash_locked() {
  if (cfg_.flash_file.empty() || impl_->flash.op_count() == impl_->saved_ops) return;
  const std::string tmp = cfg_.flash_file + ".tmp";
  std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(impl_->flash_mem.data()), static_cast<std::streamsize>(impl_->flash_mem.size()));
  f.close();
  if (f && std::rename(tmp.c_str(), cfg_.flash_file.c_str()) == 0) impl_->saved_ops = impl_->flash.op_count();
}

void VirtualImu::run() {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  auto now_us = [&] {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(clock::now() - t0).count());
  };
  fw::CanNode& node = *impl_->node;
  {
    std::lock_guard<std::mutex> lk(mu_);
    fw::node_init(node, impl_->node_cfg, *impl_->port, impl_->flash, *impl_->sensor);
    fw::node_boot(node, now_us());
  }
  const int fd = impl_->linux_port->fd();
  while (!stop_.load()) {
    {
      std::lock_guard<std::mutex> lk(mu_);
      if (reset_.exchange(false) || fw::node_reboot_requested(node)) {
        fw::node_init(node, impl_->node_cfg, *impl_->port, impl_->flash, *impl_->sensor);
        fw::node_boot(node, now_us());
      }
      fw::node_poll(node, now_us());
      save_flash_locked();
    }
    // Sleep until the next sample is due, a frame arrives, or 1 ms passes (ISO-TP timers, STmin).
    std::uint64_t wait_us = 1000;
    const std::uint64_t t = now_us();
    if (node.streaming && node.next_sample_us > t && node.next_sample_us - t < wait_us) {
      wait_us = node.next_sample_us - t;
    } else if (node.streaming && node.next_sample_us <= t) {
      wait_us = 0;
    }
    if (node.link.tx_state != fw::IsotpTxState::kIdle && node.link.tx_st_min_us < wait_us) {
      wait_us = node.link.tx_st_min_us;
    }
    pollfd p{fd, POLLIN, 0};
    timespec ts{static_cast<time_t>(wait_us / 1000000u), static_cast<long>((wait_us % 1000000u) * 1000u)};
    (void)::ppoll(&p, 1, &ts, nullptr);
  }
}

}  // namespace imuforge::vimu
