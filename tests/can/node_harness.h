// A firmware CAN node on an in-memory bus with a host-side ISO-TP link, simulated flash and a
// deterministic sensor; shared by the node tests and the command fuzzer. No heap.
#pragma once
#include <cstring>

#include "firmware/can_node/node.h"
#include "firmware/common/endian.h"
#include "hal/sim/sim_flash.h"
#include "tests/can/loop_bus.h"

namespace cantest {

class RampSensor final : public imuforge::hal::Sensor {
 public:
  int read(std::uint64_t t_us, imuforge::hal::ImuRawSample& s) noexcept override {
    const auto v = static_cast<std::int16_t>(t_us / 1000u);
    for (int i = 0; i < 3; ++i) {
      s.accel_counts[i] = static_cast<std::int16_t>(v + i);
      s.gyro_counts[i] = static_cast<std::int16_t>(-v - i);
    }
    // Changes every sample (1 kHz and slower), so a test sees whose temperature a frame carries.
    s.temp_cdegC = static_cast<std::int16_t>(2500 + static_cast<int>(t_us / 1000u % 100u));
    return fail ? imuforge::hal::kSensorErrIo : imuforge::hal::kSensorOk;
  }
  bool fail = false;
};

constexpr std::uint32_t kFlashBytes = 16384;
constexpr std::uint64_t kSerial = 0x1122334455667788ull;

struct NodeRig {
  LoopBus bus;
  LoopPort node_port, host_port;
  std::uint8_t flash_mem[kFlashBytes];
  imuforge::hal::SimFlash flash{flash_mem, kFlashBytes, 2048};
  RampSensor sensor;
  imuforge::fw::CanNode node;
  imuforge::fw::NodeConfig cfg;
  imuforge::fw::IsotpLink host;
  std::uint8_t host_rx[imuforge::proto::kMaxMessageBytes + 16];
  std::uint8_t host_tx[imuforge::proto::kMaxMessageBytes + 16];
  std::uint64_t t_us = 1000;
  std::uint32_t stream_frames = 0;

  void init(bool erase = true, bool extended = false) {
    if (erase) flash.erase_all();
    bus = LoopBus{};
    node_port = LoopPort{};
    host_port = LoopPort{};
    bus.attach(node_port);
    bus.attach(host_port);
    cfg = imuforge::fw::NodeConfig{};
    cfg.node_id = 5;
    cfg.extended_ids = extended;
    cfg.serial = kSerial;
    for (unsigned i = 0; i < sizeof cfg.key; ++i) cfg.key[i] = static_cast<std::uint8_t>(0xA0u + i);
    cfg.key_provisioned = true;
    cfg.store.slot_addr[0] = 0;
    cfg.store.slot_addr[1] = 8192;
    cfg.store.slot_bytes = 4096;
    cfg.isotp_block_size = 4;
    imuforge::fw::node_init(node, cfg, node_port, flash, sensor);
    (void)imuforge::fw::node_boot(node, t_us);
    imuforge::fw::IsotpConfig hc;
    hc.tx_id = imuforge::proto::request_id(5, extended);
    hc.rx_id = imuforge::proto::response_id(5, extended);
    hc.extended = extended;
    imuforge::fw::isotp_init(host, hc, host_port, host_rx, sizeof host_rx, host_tx, sizeof host_tx);
  }

  // One scheduler round: node polls, host link consumes frames.
  void step(std::uint32_t dt_us = 100) {
    imuforge::fw::node_poll(node, t_us);
    imuforge::hal::CanFrame f;
    while (host_port.receive(f) == imuforge::hal::kCanOk) {
      if (f.id == imuforge::proto::response_id(5, cfg.extended_ids)) {
        (void)imuforge::fw::isotp_on_frame(host, f, t_us);
      } else {
        ++stream_frames;
      }
    }
    (void)imuforge::fw::isotp_poll(host, t_us);
    t_us += dt_us;
  }

  // Sends a request, returns the response length in host_rx (0 on timeout).
  std::size_t exchange(const std::uint8_t* req, std::size_t len, unsigned max_rounds = 20000) {
    if (imuforge::fw::isotp_send(host, req, len, t_us) != imuforge::fw::kIsotpOk) return 0;
    for (unsigned i = 0; i < max_rounds; ++i) {
      step();
      if (imuforge::fw::isotp_rx_ready(host)) {
        const std::size_t n = host.rx_len;
        imuforge::fw::isotp_rx_release(host);
        return n;
      }
    }
    return 0;
  }
};

// Serialises a valid neutral table for `serial` with `seq`; returns its length (0 on failure).
inline std::size_t make_table(std::uint8_t* buf, std::size_t cap, std::uint64_t serial, std::uint32_t seq,
                              float bias = 0.0f) {
  static imuforge::fw::Table t;
  imuforge::fw::table_init_identity(&t, 0.0024f, 0.0005f, 16, 16);
  t.device_serial = serial;
  t.table_sequence = seq;
  if (bias != 0.0f) {
    t.model_flags |= imuforge::fw::kModelAccelBias;
    t.coeffs[0].accel.b[0] = bias;
  }
  const int n = imuforge::fw::table_serialize(&t, buf, cap);
  return n > 0 ? static_cast<std::size_t>(n) : 0u;
}

// Builds a write-table request: cmd | seq | tag | table.
inline std::size_t make_write(std::uint8_t* req, const std::uint8_t key[32], std::uint64_t serial,
                              std::uint32_t seq, const std::uint8_t* table, std::size_t len) {
  req[0] = imuforge::proto::kCmdWriteTable;
  imuforge::fw::store_le32(req + 1, seq);
  imuforge::fw::node_table_tag(key, serial, seq, table, len, req + 5);
  std::memcpy(req + imuforge::proto::kWriteHeaderBytes, table, len);
  return imuforge::proto::kWriteHeaderBytes + len;
}

}  // namespace cantest
