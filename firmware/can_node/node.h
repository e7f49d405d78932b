// The imuforge CAN node: sample streaming, ISO-TP command server and authorised A/B table updates.
//
// Same sources on the MCU and in the virtual IMU (host/vimu/). The platform owns the hardware and calls:
//   node_init(node, cfg, port, flash, sensor);   // cannot fail
//   node_boot(node, now_us);                     // mounts the table store (newest valid slot)
//   loop: node_poll(node, now_us);               // >= 2x the stream rate; drains RX, serves commands,
//                                                // emits due samples, runs ISO-TP timers
//         if (node_reboot_requested(node)) reset the part (MCU) or call node_init+node_boot again (vimu)
// Time is the node's monotonic clock in microseconds (the stream timestamps use it).
// Protocol: firmware/can_node/protocol.h and docs/can-protocol.md.
// Memory: one CanNode holds two ISO-TP buffers of proto::kMaxMessageBytes; no heap, no recursion.
#pragma once
#include <cstddef>
#include <cstdint>

#include "firmware/can_node/protocol.h"
#include "firmware/isotp/isotp.h"
#include "firmware/store/table_store.h"
#include "firmware/table/table.h"
#include "hal/can.h"
#include "hal/flash.h"
#include "hal/sensor.h"

namespace imuforge::fw {

struct NodeConfig {
  std::uint8_t node_id = 1;         // 0..proto::kMaxNodeId (clamped)
  bool extended_ids = false;        // 29-bit identifiers
  std::uint64_t serial = 0;
  std::uint8_t key[proto::kKeyBytes] = {};  // per-device HMAC key (provisioned at manufacture)
  bool key_provisioned = false;
  TableStoreConfig store;
  std::uint8_t isotp_block_size = 0;    // BS announced to the host (0: one FC per message)
  std::uint8_t isotp_st_min_raw = 0;    // STmin announced to the host
  // The sensor's sample FIFO, as a MEMS IMU has one: samples fall due at the stream rate whether or
  // not the node is running. After a stall (a long flash erase on target, an OS scheduling gap in the
  // virtual IMU) every sample due since the last one sent is still sent, each with its own sensor
  // timestamp. Only when more than `fifo_depth_samples` are waiting does the FIFO overflow: the oldest
  // are dropped, counted in NodeCounters::samples_fifo_overflow, and their sequence numbers skipped,
  // so the host counts exactly those as lost.
  std::uint16_t fifo_depth_samples = 128;
  // Samples sent from the FIFO per node_poll: a long backlog drains over several polls, so commands
  // (stream stop, status) are served in between instead of waiting for the whole backlog.
  std::uint16_t max_samples_per_poll = 16;
  // The port sends CAN FD (CanPort::send_fd). Announced in identify (proto::kIdCanFd); without it a
  // stream start asking for FD is refused with proto::kStFdUnsupported rather than streaming nothing.
  bool can_fd = false;
};

struct NodeCounters {
  std::uint32_t samples_sent = 0;
  std::uint32_t stream_frames_tx = 0;
  std::uint32_t stream_frames_dropped = 0;  // port refused (queue full, bus-off)
  std::uint32_t bus_off_events = 0;
  std::uint32_t commands_ok = 0;
  std::uint32_t commands_rejected = 0;
  std::uint32_t auth_failures = 0;
  std::uint32_t sensor_errors = 0;
  std::uint32_t boots = 0;
  std::uint32_t samples_fifo_overflow = 0;  // dropped by the FIFO (NodeConfig::fifo_depth_samples)
};

struct CanNode {
  NodeConfig cfg;
  hal::CanPort* port = nullptr;
  hal::Flash* flash = nullptr;
  hal::Sensor* sensor = nullptr;
  TableStore store;
  IsotpLink link;
  std::uint8_t rx_buf[proto::kMaxMessageBytes];
  std::uint8_t tx_buf[proto::kMaxMessageBytes];
  std::uint8_t resp[proto::kMaxMessageBytes];
  Table parsed;  // scratch for validating a written table (2.3 KB; not on the stack)

  bool streaming = false;
  std::uint16_t rate_hz = 0;
  std::uint8_t channels = 0;
  std::uint32_t period_us = 0;
  std::uint64_t next_sample_us = 0;  // due time of the oldest sample in the FIFO (not yet sent)
  std::uint16_t seq = 0;
  bool bus_off = false;
  // CAN FD stream (proto::kStreamFlagFd): samples are packed into fd_frame and sent 4 at a time; the
  // frame under construction holds fd_count samples. One 64-byte buffer, only used when streaming FD.
  bool stream_fd = false;
  std::uint8_t fd_count = 0;
  hal::CanFdFrame fd_frame;

  std::uint64_t boot_us = 0;
  bool reboot_pending = false;   // reboot accepted, waiting for the response to leave
  bool reboot_now = false;
  int mount_result = 0;
  NodeCounters counters;
};

// Cannot fail. Counters survive (boots is incremented by node_boot), everything else is reset.
void node_init(CanNode& n, const NodeConfig& cfg, hal::CanPort& port, hal::Flash& flash,
               hal::Sensor& sensor) noexcept;
// Mounts the store. Returns the store result (kStoreOk or kStoreErrNoTable are normal).
int node_boot(CanNode& n, std::uint64_t now_us) noexcept;
void node_poll(CanNode& n, std::uint64_t now_us) noexcept;
inline bool node_reboot_requested(const CanNode& n) noexcept { return n.reboot_now; }

// Serves one command request, writes the response into `resp` (capacity >= proto::kMaxMessageBytes).
// Returns the response length (>= 2). Exposed for the command-parser fuzzer and unit tests.
std::size_t node_handle_command(CanNode& n, const std::uint8_t* req, std::size_t len, std::uint8_t* resp,
                                std::size_t resp_cap, std::uint64_t now_us) noexcept;

// Computes the authorisation tag of a table (the same function the host uses to sign).
void node_table_tag(const std::uint8_t key[proto::kKeyBytes], std::uint64_t serial, std::uint32_t seq,
                    const std::uint8_t* table, std::size_t len, std::uint8_t tag[proto::kTagBytes]) noexcept;

// Validates a table blob for this device: coefficient table v1 parser (firmware/table), then its
// device_serial and table_sequence against `serial` and `seq`. Returns a proto::Status (kStOk = valid).
std::uint8_t node_table_check(const std::uint8_t* table, std::size_t len, std::uint64_t serial,
                              std::uint32_t seq, Table& scratch) noexcept;

}  // namespace imuforge::fw
