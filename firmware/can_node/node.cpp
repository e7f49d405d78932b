#include "firmware/can_node/node.h"

#include <cstring>

#include "firmware/common/endian.h"
#include "firmware/crypto/sha256.h"

#ifndef IMUFORGE_FW_VERSION
#define IMUFORGE_FW_VERSION "0.0.0"
#endif

namespace imuforge::fw {
namespace {

using namespace imuforge::proto;

std::size_t reply(std::uint8_t* resp, std::uint8_t cmd, std::uint8_t status) noexcept {
  resp[0] = static_cast<std::uint8_t>(cmd | kResponseFlag);
  resp[1] = status;
  return 2;
}

std::uint8_t store_status(int e) noexcept {
  switch (e) {
    case kStoreOk: return kStOk;
    case kStoreErrTooLarge: return kStTableTooLarge;
    case kStoreErrNotStaged: return kStNotStaged;
    case kStoreErrNoTable: return kStNoTable;
    default: return kStFlashError;
  }
}

void count_stream_tx(CanNode& n, int rc) noexcept {
  if (rc == hal::kCanOk) {
    ++n.counters.stream_frames_tx;
    n.bus_off = false;
    return;
  }
  ++n.counters.stream_frames_dropped;
  if (rc == hal::kCanErrBusOff && !n.bus_off) {
    n.bus_off = true;
    ++n.counters.bus_off_events;
  }
}

void send_stream_frame(CanNode& n, std::uint8_t part, const std::uint8_t payload[8]) noexcept {
  hal::CanFrame f;
  f.id = stream_id(n.cfg.node_id, part, n.cfg.extended_ids);
  f.extended = n.cfg.extended_ids;
  f.len = 8;
  std::memcpy(f.data, payload, 8);
  count_stream_tx(n, n.port->send(f));
}

// Sends the FD frame under construction, if it holds any sample. Called when it is full and before
// anything that breaks the run of consecutive samples (stop, reboot, a skipped seq), because the frame
// only carries the first sample's seq and t_us.
void flush_fd_frame(CanNode& n) noexcept {
  if (n.fd_count == 0u) return;
  n.fd_frame.data[2] = n.fd_count;
  count_stream_tx(n, n.port->send_fd(n.fd_frame));
  n.fd_count = 0;
}

void pack_fd_sample(CanNode& n, const hal::ImuRawSample& s, std::uint64_t t_us) noexcept {
  hal::CanFdFrame& f = n.fd_frame;
  if (n.fd_count == 0u) {
    f.id = stream_id(n.cfg.node_id, kPartFd, n.cfg.extended_ids);
    f.extended = n.cfg.extended_ids;
    f.fd = true;
    f.brs = true;
    f.len = static_cast<std::uint8_t>(kFdFrameBytes);
    std::memset(f.data, kFdPadByte, kFdFrameBytes);
    store_le16(f.data, n.seq);
    f.data[3] = n.channels;
    store_le32(f.data + 4, static_cast<std::uint32_t>(t_us));
    store_le16s(f.data + 8, s.temp_cdegC);
  }
  if (n.fd_count > 0u) store_le16s(f.data + kFdTempTailOffset + 2u * (n.fd_count - 1u), s.temp_cdegC);
  std::uint8_t* p = f.data + kFdHeaderBytes + kFdSampleBytes * n.fd_count;
  // Channels not streamed read as 0, so a frame never leaks what the host did not ask for.
  const bool acc = (n.channels & kChAccel) != 0u, gyr = (n.channels & kChGyro) != 0u;
  for (unsigned i = 0; i < 3; ++i) {
    store_le16s(p + 2 * i, acc ? s.accel_counts[i] : static_cast<std::int16_t>(0));
    store_le16s(p + 6 + 2 * i, gyr ? s.gyro_counts[i] : static_cast<std::int16_t>(0));
  }
  if (++n.fd_count == kFdSamplesPerFrame) flush_fd_frame(n);
}

void emit_sample(CanNode& n, std::uint64_t t_us) noexcept {
  hal::ImuRawSample s;
  if (n.sensor->read(t_us, s) != hal::kSensorOk) {
    // The sequence number still advances: the host then sees the sample as lost, which it is.
    ++n.counters.sensor_errors;
    if (n.stream_fd) flush_fd_frame(n);
    ++n.seq;
    return;
  }
  if (n.stream_fd) {
    pack_fd_sample(n, s, t_us);
    ++n.counters.samples_sent;
    ++n.seq;
    return;
  }
  std::uint8_t p[8];
  store_le16(p, n.seq);
  if ((n.channels & kChAccel) != 0u) {
    for (unsigned i = 0; i < 3; ++i) store_le16s(p + 2 + 2 * i, s.accel_counts[i]);
    send_stream_frame(n, kPartAccel, p);
  }
  if ((n.channels & kChGyro) != 0u) {
    for (unsigned i = 0; i < 3; ++i) store_le16s(p + 2 + 2 * i, s.gyro_counts[i]);
    send_stream_frame(n, kPartGyro, p);
  }
  if ((n.channels & kChTemp) != 0u) {
    store_le16s(p + 2, s.temp_cdegC);
    store_le32(p + 4, static_cast<std::uint32_t>(t_us));
    send_stream_frame(n, kPartTemp, p);
  }
  ++n.counters.samples_sent;
  ++n.seq;
}

std::size_t cmd_identify(CanNode& n, std::uint8_t* r) noexcept {
  std::size_t k = reply(r, kCmdIdentify, kStOk);
  store_le64(r + k, n.cfg.serial);
  k += 8;
  std::memset(r + k, 0, 16);
  const char* v = IMUFORGE_FW_VERSION;
  for (std::size_t i = 0; i < 15u && v[i] != '\0'; ++i) r[k + i] = static_cast<std::uint8_t>(v[i]);
  k += 16;
  const StoreSlotInfo* a = store_active(n.store);
  r[k++] = a != nullptr ? 1u : 0u;
  store_le32(r + k, a != nullptr ? a->seq : 0u);
  k += 4;
  store_le32(r + k, a != nullptr ? a->crc : 0u);
  k += 4;
  store_le32(r + k, a != nullptr ? a->len : 0u);
  k += 4;
  r[k++] = n.cfg.node_id;
  r[k++] = static_cast<std::uint8_t>((n.cfg.extended_ids ? kIdExtendedIds : 0u) |
                                     (n.cfg.key_provisioned ? kIdKeyProvisioned : 0u) |
                                     (n.cfg.can_fd ? kIdCanFd : 0u));
  return k;
}

std::size_t cmd_status(CanNode& n, std::uint8_t* r, std::uint64_t now_us) noexcept {
  std::size_t k = reply(r, kCmdStatus, kStOk);
  const std::uint32_t v[11] = {static_cast<std::uint32_t>((now_us - n.boot_us) / 1000u),
                               n.counters.samples_sent,
                               n.counters.stream_frames_tx,
                               n.counters.stream_frames_dropped,
                               n.counters.bus_off_events,
                               n.link.counters.rx_errors,
                               n.link.counters.tx_errors,
                               n.counters.commands_ok,
                               n.counters.commands_rejected,
                               n.counters.auth_failures,
                               n.counters.boots};
  for (std::uint32_t x : v) {
    store_le32(r + k, x);
    k += 4;
  }
  r[k++] = static_cast<std::uint8_t>(static_cast<std::int8_t>(n.store.active));
  r[k++] = static_cast<std::uint8_t>(static_cast<std::int8_t>(n.store.staged));
  r[k++] = n.streaming ? (n.stream_fd ? 2u : 1u) : 0u;
  r[k++] = n.channels;
  store_le16(r + k, n.rate_hz);
  k += 2;
  store_le32(r + k, n.counters.samples_fifo_overflow);
  k += 4;
  return k;
}

std::size_t cmd_write(CanNode& n, const std::uint8_t* q, std::size_t len, std::uint8_t* r) noexcept {
  if (len < kWriteHeaderBytes + 1u) return reply(r, kCmdWriteTable, kStBadLength);
  const std::size_t table_len = len - kWriteHeaderBytes;
  if (table_len > kMaxTableBytes) return reply(r, kCmdWriteTable, kStTableTooLarge);
  if (!n.cfg.key_provisioned) return reply(r, kCmdWriteTable, kStNoKey);
  const std::uint32_t seq = load_le32(q + 1);
  const std::uint8_t* tag = q + 5;
  const std::uint8_t* table = q + kWriteHeaderBytes;
  std::uint8_t want[kTagBytes];
  node_table_tag(n.cfg.key, n.cfg.serial, seq, table, table_len, want);
  if (!ct_equal(want, tag, kTagBytes)) {
    ++n.counters.auth_failures;
    return reply(r, kCmdWriteTable, kStAuthFailed);
  }
  const StoreSlotInfo* a = store_active(n.store);
  if (a != nullptr && seq <= a->seq) return reply(r, kCmdWriteTable, kStReplay);
  const std::uint8_t chk = node_table_check(table, table_len, n.cfg.serial, seq, n.parsed);
  if (chk != kStOk) return reply(r, kCmdWriteTable, chk);
  const int e = store_write(n.store, table, static_cast<std::uint32_t>(table_len), seq);
  if (e != kStoreOk) return reply(r, kCmdWriteTable, store_status(e));
  std::size_t k = reply(r, kCmdWriteTable, kStOk);
  store_le32(r + k, n.store.slot[n.store.staged].crc);
  return k + 4;
}

std::size_t cmd_commit(CanNode& n, const std::uint8_t* q, std::size_t len, std::uint8_t* r) noexcept {
  if (len != 5u) return reply(r, kCmdCommit, kStBadLength);
  const std::uint32_t seq = load_le32(q + 1);
  const StoreSlotInfo* a = store_active(n.store);
  if (a != nullptr && seq <= a->seq) return reply(r, kCmdCommit, kStReplay);
  const int e = store_commit(n.store, seq);
  if (e != kStoreOk) return reply(r, kCmdCommit, store_status(e));
  a = store_active(n.store);
  std::size_t k = reply(r, kCmdCommit, kStOk);
  store_le32(r + k, a->seq);
  store_le32(r + k + 4, a->crc);
  return k + 8;
}

std::size_t cmd_read(CanNode& n, std::uint8_t* r, std::size_t cap) noexcept {
  const StoreSlotInfo* a = store_active(n.store);
  if (a == nullptr) return reply(r, kCmdReadTable, kStNoTable);
  if (a->len + 6u > cap) return reply(r, kCmdReadTable, kStTableTooLarge);
  std::size_t k = reply(r, kCmdReadTable, kStOk);
  store_le32(r + k, a->seq);
  k += 4;
  const int e = store_read(n.store, 0, r + k, a->len);
  if (e != kStoreOk) return reply(r, kCmdReadTable, store_status(e));
  return k + a->len;
}

}  // namespace

void node_table_tag(const std::uint8_t key[kKeyBytes], std::uint64_t serial, std::uint32_t seq,
                    const std::uint8_t* table, std::size_t len, std::uint8_t tag[kTagBytes]) noexcept {
  HmacSha256 m;
  hmac_sha256_init(m, key, kKeyBytes);
  std::uint8_t hdr[16];
  std::memcpy(hdr, kTagDomain, 4);
  store_le64(hdr + 4, serial);
  store_le32(hdr + 12, seq);
  hmac_sha256_update(m, hdr, sizeof hdr);
  hmac_sha256_update(m, table, len);
  hmac_sha256_final(m, tag);
}

void node_init(CanNode& n, const NodeConfig& cfg, hal::CanPort& port, hal::Flash& flash,
               hal::Sensor& sensor) noexcept {
  const NodeCounters keep = n.counters;
  n.cfg = cfg;
  if (n.cfg.node_id > kMaxNodeId) n.cfg.node_id = kMaxNodeId;
  n.port = &port;
  n.flash = &flash;
  n.sensor = &sensor;
  store_init(n.store, flash, cfg.store);
  IsotpConfig ic;
  ic.rx_id = request_id(n.cfg.node_id, n.cfg.extended_ids);
  ic.tx_id = response_id(n.cfg.node_id, n.cfg.extended_ids);
  ic.extended = n.cfg.extended_ids;
  ic.block_size = cfg.isotp_block_size;
  ic.st_min_raw = cfg.isotp_st_min_raw;
  isotp_init(n.link, ic, port, n.rx_buf, sizeof n.rx_buf, n.tx_buf, sizeof n.tx_buf);
  n.streaming = false;
  n.rate_hz = 0;
  n.channels = 0;
  n.period_us = 0;
  n.next_sample_us = 0;
  n.seq = 0;
  n.bus_off = false;
  n.stream_fd = false;
  n.fd_count = 0;  // a reset loses the frame under construction, as it loses the sensor's FIFO
  n.boot_us = 0;
  n.reboot_pending = false;
  n.reboot_now = false;
  n.mount_result = 0;
  n.counters = keep;
}

int node_boot(CanNode& n, std::uint64_t now_us) noexcept {
  n.boot_us = now_us;
  ++n.counters.boots;
  n.mount_result = store_mount(n.store);
  return n.mount_result;
}

std::size_t node_handle_command(CanNode& n, const std::uint8_t* q, std::size_t len, std::uint8_t* r,
                                std::size_t cap, std::uint64_t now_us) noexcept {
  if (len == 0u) return reply(r, 0, kStBadLength);
  const std::uint8_t cmd = q[0];
  std::size_t k;
  switch (cmd) {
    case kCmdIdentify:
      k = len == 1u ? cmd_identify(n, r) : reply(r, cmd, kStBadLength);
      break;
    case kCmdStreamStart: {
      if (len != 4u && len != 5u) {
        k = reply(r, cmd, kStBadLength);
        break;
      }
      const std::uint16_t rate = load_le16(q + 1);
      const std::uint8_t ch = q[3];
      const std::uint8_t flags = len == 5u ? q[4] : 0u;
      if (rate < kMinRateHz || rate > kMaxRateHz || ch == 0u || (ch & ~kChAll) != 0u ||
          (flags & ~kStreamFlagFd) != 0u) {
        k = reply(r, cmd, kStBadArgument);
        break;
      }
      const bool fd = (flags & kStreamFlagFd) != 0u;
      if (fd && !n.cfg.can_fd) {
        k = reply(r, cmd, kStFdUnsupported);
        break;
      }
      // A restart while streaming: the old run's partial frame goes out first (it has the old seq).
      if (n.stream_fd) flush_fd_frame(n);
      n.stream_fd = fd;
      n.rate_hz = rate;
      n.channels = ch;
      n.period_us = 1000000u / rate;
      n.next_sample_us = now_us;
      n.streaming = true;
      k = reply(r, cmd, kStOk);
      break;
    }
    case kCmdStreamStop:
      if (len != 1u) {
        k = reply(r, cmd, kStBadLength);
        break;
      }
      // The partial FD frame leaves before the response, so the host has every sample when it reads
      // samples_sent.
      if (n.stream_fd) flush_fd_frame(n);
      n.streaming = false;
      k = reply(r, cmd, kStOk);
      store_le32(r + k, n.counters.samples_sent);
      k += 4;
      break;
    case kCmdReadTable:
      k = len == 1u ? cmd_read(n, r, cap) : reply(r, cmd, kStBadLength);
      break;
    case kCmdWriteTable:
      k = cmd_write(n, q, len, r);
      break;
    case kCmdCommit:
      k = cmd_commit(n, q, len, r);
      break;
    case kCmdReboot:
      if (len != 1u) {
        k = reply(r, cmd, kStBadLength);
        break;
      }
      n.reboot_pending = true;
      if (n.stream_fd) flush_fd_frame(n);
      n.streaming = false;
      k = reply(r, cmd, kStOk);
      break;
    case kCmdStatus:
      k = len == 1u ? cmd_status(n, r, now_us) : reply(r, cmd, kStBadLength);
      break;
    default:
      k = reply(r, cmd, kStUnknownCommand);
      break;
  }
  if (r[1] == kStOk) {
    ++n.counters.commands_ok;
  } else {
    ++n.counters.commands_rejected;
  }
  return k;
}

void node_poll(CanNode& n, std::uint64_t now_us) noexcept {
  // Drain the receive queue (bounded: a flooded bus cannot starve the stream).
  for (unsigned i = 0; i < 64u; ++i) {
    hal::CanFrame f;
    if (n.port->receive(f) != hal::kCanOk) break;
    (void)isotp_on_frame(n.link, f, now_us);
    if (isotp_rx_ready(n.link) && !isotp_tx_busy(n.link)) {
      const std::size_t k = node_handle_command(n, n.link.rx_buf, n.link.rx_len, n.resp, sizeof n.resp, now_us);
      isotp_rx_release(n.link);
      (void)isotp_send(n.link, n.resp, k, now_us);
    }
  }
  if (isotp_rx_ready(n.link) && !isotp_tx_busy(n.link)) {
    const std::size_t k = node_handle_command(n, n.link.rx_buf, n.link.rx_len, n.resp, sizeof n.resp, now_us);
    isotp_rx_release(n.link);
    (void)isotp_send(n.link, n.resp, k, now_us);
  }
  (void)isotp_poll(n.link, now_us);
  if (n.reboot_pending && !isotp_tx_busy(n.link)) n.reboot_now = true;

  if (n.streaming && n.period_us > 0u) {
    // The FIFO holds every sample due at or before now_us and not yet sent (see
    // NodeConfig::fifo_depth_samples). Overflow drops the oldest, as a stream-mode MEMS FIFO does.
    if (now_us >= n.next_sample_us) {
      const std::uint64_t waiting = (now_us - n.next_sample_us) / n.period_us + 1u;
      const std::uint64_t depth = n.cfg.fifo_depth_samples > 0u ? n.cfg.fifo_depth_samples : 1u;
      if (waiting > depth) {
        const std::uint64_t over = waiting - depth;
        if (n.stream_fd) flush_fd_frame(n);  // the frame's samples precede the gap
        n.counters.samples_fifo_overflow += static_cast<std::uint32_t>(over);
        n.seq = static_cast<std::uint16_t>(n.seq + static_cast<std::uint16_t>(over & 0xFFFFu));
        n.next_sample_us += over * n.period_us;
      }
    }
    const unsigned per_poll = n.cfg.max_samples_per_poll > 0u ? n.cfg.max_samples_per_poll : 1u;
    for (unsigned k = 0; k < per_poll && now_us >= n.next_sample_us; ++k) {
      emit_sample(n, n.next_sample_us);
      n.next_sample_us += n.period_us;
    }
  }
}

}  // namespace imuforge::fw
