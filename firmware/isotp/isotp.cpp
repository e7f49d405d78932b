#include "firmware/isotp/isotp.h"

#include <cstring>

namespace imuforge::fw {
namespace {

constexpr std::uint8_t kPciSf = 0x0u;
constexpr std::uint8_t kPciFf = 0x1u;
constexpr std::uint8_t kPciCf = 0x2u;
constexpr std::uint8_t kPciFc = 0x3u;
constexpr std::uint8_t kFcCts = 0x0u;
constexpr std::uint8_t kFcWait = 0x1u;
constexpr std::uint8_t kFcOvflw = 0x2u;
// The 12-bit FF_DL covers up to 4095 bytes; above that the 2016 escape (FF_DL = 0 + 32 bits) is used.
constexpr std::size_t kFfDl12Max = 4095u;
// Bound on frames emitted per poll so one long transfer cannot starve the caller's loop.
constexpr unsigned kMaxFramesPerPoll = 32u;

hal::CanFrame make_frame(const IsotpLink& l, std::uint8_t used) noexcept {
  hal::CanFrame f;
  f.id = l.cfg.tx_id;
  f.extended = l.cfg.extended;
  f.len = l.cfg.pad ? 8u : used;
  for (unsigned i = used; i < 8u; ++i) f.data[i] = l.cfg.pad_byte;
  return f;
}

void fail_rx(IsotpLink& l, int err) noexcept {
  l.rx_state = IsotpRxState::kIdle;
  l.rx_fc_pending = false;
  l.last_error = err;
  ++l.counters.rx_errors;
}

void fail_tx(IsotpLink& l, int err) noexcept {
  l.tx_state = IsotpTxState::kIdle;
  l.tx_frame_pending = false;
  l.last_error = err;
  ++l.counters.tx_errors;
}

// Tries to put the receiver's FC on the bus; keeps it pending on a full TX queue.
void flush_fc(IsotpLink& l) noexcept {
  if (!l.rx_fc_pending) return;
  hal::CanFrame f = make_frame(l, 3);
  f.data[0] = static_cast<std::uint8_t>((kPciFc << 4) | l.rx_fc_flag);
  f.data[1] = l.cfg.block_size;
  f.data[2] = l.cfg.st_min_raw;
  if (l.port->send(f) == hal::kCanOk) l.rx_fc_pending = false;
}

void queue_fc(IsotpLink& l, std::uint8_t flag) noexcept {
  l.rx_fc_pending = true;
  l.rx_fc_flag = flag;
  flush_fc(l);
}

void build_cf(IsotpLink& l, std::uint64_t now_us) noexcept {
  std::size_t n = l.tx_len - l.tx_pos;
  if (n > 7u) n = 7u;
  l.tx_frame = make_frame(l, static_cast<std::uint8_t>(1u + n));
  l.tx_frame.data[0] = static_cast<std::uint8_t>((kPciCf << 4) | l.tx_sn);
  std::memcpy(&l.tx_frame.data[1], l.tx_buf + l.tx_pos, n);
  l.tx_pos += n;
  l.tx_sn = static_cast<std::uint8_t>((l.tx_sn + 1u) & 0x0Fu);
  l.tx_frame_pending = true;
  l.tx_pending_pci = kPciCf;
  l.tx_deadline_us = now_us + l.cfg.n_as_us;
}

// Called when the port accepted the pending frame.
void on_frame_sent(IsotpLink& l, std::uint64_t now_us) noexcept {
  l.tx_frame_pending = false;
  if (l.tx_pending_pci == kPciSf) {
    l.tx_state = IsotpTxState::kIdle;
    ++l.counters.tx_messages;
    return;
  }
  if (l.tx_pending_pci == kPciFf) {
    l.tx_state = IsotpTxState::kWaitFc;
    l.tx_wft = 0;
    l.tx_deadline_us = now_us + l.cfg.n_bs_us;
    return;
  }
  if (l.tx_pos >= l.tx_len) {
    l.tx_state = IsotpTxState::kIdle;
    ++l.counters.tx_messages;
    return;
  }
  ++l.tx_bs_count;
  if (l.tx_bs != 0u && l.tx_bs_count >= l.tx_bs) {
    l.tx_state = IsotpTxState::kWaitFc;
    l.tx_wft = 0;
    l.tx_deadline_us = now_us + l.cfg.n_bs_us;
  } else {
    l.tx_next_us = now_us + l.tx_st_min_us;
  }
}

// Returns true if the pending frame went out.
bool flush_tx(IsotpLink& l, std::uint64_t now_us) noexcept {
  if (!l.tx_frame_pending) return true;
  if (l.port->send(l.tx_frame) == hal::kCanOk) {
    on_frame_sent(l, now_us);
    return true;
  }
  if (now_us >= l.tx_deadline_us) fail_tx(l, kIsotpErrTimeoutAs);
  return false;
}

int on_flow_control(IsotpLink& l, const hal::CanFrame& f, std::uint64_t now_us) noexcept {
  if (l.tx_state != IsotpTxState::kWaitFc) return kIsotpOk;  // stray FC: ignored, as the standard says
  if (f.len < 3u) {
    fail_tx(l, kIsotpErrBadFrame);
    return kIsotpErrBadFrame;
  }
  const std::uint8_t fs = static_cast<std::uint8_t>(f.data[0] & 0x0Fu);
  if (fs == kFcCts) {
    l.tx_bs = f.data[1];
    l.tx_bs_count = 0;
    l.tx_st_min_us = isotp_st_min_to_us(f.data[2]);
    l.tx_state = IsotpTxState::kSendCf;
    l.tx_next_us = now_us;
    return kIsotpOk;
  }
  if (fs == kFcWait) {
    if (++l.tx_wft > l.cfg.wft_max) {
      fail_tx(l, kIsotpErrWftMax);
      return kIsotpErrWftMax;
    }
    l.tx_deadline_us = now_us + l.cfg.n_bs_us;
    return kIsotpOk;
  }
  const int err = fs == kFcOvflw ? kIsotpErrOverflow : kIsotpErrBadFrame;
  fail_tx(l, err);
  return err;
}

}  // namespace

std::uint32_t isotp_st_min_to_us(std::uint8_t raw) noexcept {
  if (raw <= 0x7Fu) return static_cast<std::uint32_t>(raw) * 1000u;
  if (raw >= 0xF1u && raw <= 0xF9u) return static_cast<std::uint32_t>(raw - 0xF0u) * 100u;
  return 127000u;
}

void isotp_init(IsotpLink& link, const IsotpConfig& cfg, hal::CanPort& port, std::uint8_t* rx_buf,
                std::size_t rx_cap, std::uint8_t* tx_buf, std::size_t tx_cap) noexcept {
  link = IsotpLink{};
  link.cfg = cfg;
  link.port = &port;
  link.rx_buf = rx_buf;
  link.rx_cap = rx_buf != nullptr ? rx_cap : 0u;
  link.tx_buf = tx_buf;
  link.tx_cap = tx_buf != nullptr ? tx_cap : 0u;
}

void isotp_reset(IsotpLink& link) noexcept {
  link.rx_state = IsotpRxState::kIdle;
  link.rx_fc_pending = false;
  link.tx_state = IsotpTxState::kIdle;
  link.tx_frame_pending = false;
}

void isotp_rx_release(IsotpLink& link) noexcept {
  if (link.rx_state == IsotpRxState::kReady) link.rx_state = IsotpRxState::kIdle;
}

int isotp_on_frame(IsotpLink& l, const hal::CanFrame& f, std::uint64_t now_us) noexcept {
  if (f.id != l.cfg.rx_id || f.extended != l.cfg.extended) return kIsotpOk;
  if (f.len == 0u || f.len > 8u) return kIsotpOk;  // not an ISO-TP frame
  const std::uint8_t pci = static_cast<std::uint8_t>(f.data[0] >> 4);

  if (pci == kPciFc) return on_flow_control(l, f, now_us);

  if (pci == kPciSf || pci == kPciFf) {
    int result = kIsotpOk;
    if (l.rx_state == IsotpRxState::kReady) {
      // The previous message is still being processed: refuse this one (its sender will time out or
      // see OVFLW) rather than overwrite a buffer the application is reading.
      if (pci == kPciFf) queue_fc(l, kFcOvflw);
      ++l.counters.rx_errors;
      return kIsotpErrBusy;
    }
    if (l.rx_state == IsotpRxState::kReceiving) {
      fail_rx(l, kIsotpErrUnexpected);
      result = kIsotpErrUnexpected;
    }
    if (pci == kPciSf) {
      const std::uint8_t n = static_cast<std::uint8_t>(f.data[0] & 0x0Fu);
      if (n == 0u || n > 7u || f.len < 1u + n) {
        fail_rx(l, kIsotpErrBadFrame);
        return kIsotpErrBadFrame;
      }
      if (n > l.rx_cap) {
        fail_rx(l, kIsotpErrTooLong);
        return kIsotpErrTooLong;
      }
      std::memcpy(l.rx_buf, &f.data[1], n);
      l.rx_len = n;
      l.rx_pos = n;
      l.rx_state = IsotpRxState::kReady;
      ++l.counters.rx_messages;
      return result;
    }
    // First frame: classic CAN first frames are always 8 bytes long.
    if (f.len != 8u) {
      fail_rx(l, kIsotpErrBadFrame);
      return kIsotpErrBadFrame;
    }
    std::size_t dl = (static_cast<std::size_t>(f.data[0] & 0x0Fu) << 8) | f.data[1];
    std::size_t off = 2;
    if (dl == 0u) {
      dl = (static_cast<std::size_t>(f.data[2]) << 24) | (static_cast<std::size_t>(f.data[3]) << 16) |
           (static_cast<std::size_t>(f.data[4]) << 8) | static_cast<std::size_t>(f.data[5]);
      off = 6;
      if (dl <= kFfDl12Max) {  // escape only allowed for lengths the 12-bit field cannot hold
        fail_rx(l, kIsotpErrBadFrame);
        return kIsotpErrBadFrame;
      }
    } else if (dl < 8u) {  // would have fit a single frame
      fail_rx(l, kIsotpErrBadFrame);
      return kIsotpErrBadFrame;
    }
    if (dl > l.rx_cap) {
      queue_fc(l, kFcOvflw);
      fail_rx(l, kIsotpErrTooLong);
      return kIsotpErrTooLong;
    }
    const std::size_t n = 8u - off;
    std::memcpy(l.rx_buf, &f.data[off], n);
    l.rx_len = dl;
    l.rx_pos = n;
    l.rx_sn = 1;
    l.rx_bs_count = l.cfg.block_size;
    l.rx_state = IsotpRxState::kReceiving;
    l.rx_deadline_us = now_us + l.cfg.n_cr_us;
    queue_fc(l, kFcCts);
    return result;
  }

  if (pci == kPciCf) {
    if (l.rx_state != IsotpRxState::kReceiving) return kIsotpOk;  // stray CF: ignored
    const std::uint8_t sn = static_cast<std::uint8_t>(f.data[0] & 0x0Fu);
    if (sn != l.rx_sn) {
      fail_rx(l, kIsotpErrWrongSn);
      return kIsotpErrWrongSn;
    }
    std::size_t n = l.rx_len - l.rx_pos;
    if (n > 7u) n = 7u;
    if (f.len < 1u + n) {
      fail_rx(l, kIsotpErrBadFrame);
      return kIsotpErrBadFrame;
    }
    std::memcpy(l.rx_buf + l.rx_pos, &f.data[1], n);
    l.rx_pos += n;
    l.rx_sn = static_cast<std::uint8_t>((l.rx_sn + 1u) & 0x0Fu);
    if (l.rx_pos >= l.rx_len) {
      l.rx_state = IsotpRxState::kReady;
      ++l.counters.rx_messages;
      return kIsotpOk;
    }
    l.rx_deadline_us = now_us + l.cfg.n_cr_us;
    if (l.cfg.block_size != 0u && --l.rx_bs_count == 0u) {
      l.rx_bs_count = l.cfg.block_size;
      queue_fc(l, kFcCts);
    }
    return kIsotpOk;
  }
  return kIsotpOk;  // PCI 4..15: not ISO-TP on classic CAN, ignored
}

int isotp_poll(IsotpLink& l, std::uint64_t now_us) noexcept {
  int result = kIsotpOk;
  const std::uint32_t tx_errors_before = l.counters.tx_errors;
  flush_fc(l);
  if (l.rx_state == IsotpRxState::kReceiving && now_us >= l.rx_deadline_us) {
    fail_rx(l, kIsotpErrTimeoutCr);
    result = kIsotpErrTimeoutCr;
  }
  for (unsigned i = 0; i < kMaxFramesPerPoll; ++i) {
    if (l.tx_frame_pending) {
      if (!flush_tx(l, now_us)) break;
      continue;
    }
    if (l.tx_state == IsotpTxState::kSendCf && now_us >= l.tx_next_us) {
      build_cf(l, now_us);
      continue;
    }
    break;
  }
  if (l.tx_state == IsotpTxState::kWaitFc && now_us >= l.tx_deadline_us) {
    fail_tx(l, kIsotpErrTimeoutBs);
    result = kIsotpErrTimeoutBs;
  }
  if (l.counters.tx_errors != tx_errors_before && result == kIsotpOk) result = l.last_error;
  return result;
}

int isotp_send(IsotpLink& l, const std::uint8_t* data, std::size_t len, std::uint64_t now_us) noexcept {
  if (l.tx_state != IsotpTxState::kIdle) return kIsotpErrBusy;
  if (len == 0u) return kIsotpErrEmpty;
  if (len > l.tx_cap) return kIsotpErrTooLong;
  std::memcpy(l.tx_buf, data, len);
  l.tx_len = len;
  l.tx_deadline_us = now_us + l.cfg.n_as_us;
  if (len <= 7u) {
    l.tx_frame = make_frame(l, static_cast<std::uint8_t>(1u + len));
    l.tx_frame.data[0] = static_cast<std::uint8_t>(len);
    std::memcpy(&l.tx_frame.data[1], data, len);
    l.tx_pos = len;
    l.tx_pending_pci = kPciSf;
  } else {
    l.tx_frame = make_frame(l, 8);
    std::size_t off;
    if (len <= kFfDl12Max) {
      l.tx_frame.data[0] = static_cast<std::uint8_t>((kPciFf << 4) | ((len >> 8) & 0x0Fu));
      l.tx_frame.data[1] = static_cast<std::uint8_t>(len);
      off = 2;
    } else {
      l.tx_frame.data[0] = static_cast<std::uint8_t>(kPciFf << 4);
      l.tx_frame.data[1] = 0;
      l.tx_frame.data[2] = static_cast<std::uint8_t>(len >> 24);
      l.tx_frame.data[3] = static_cast<std::uint8_t>(len >> 16);
      l.tx_frame.data[4] = static_cast<std::uint8_t>(len >> 8);
      l.tx_frame.data[5] = static_cast<std::uint8_t>(len);
      off = 6;
    }
    std::memcpy(&l.tx_frame.data[off], data, 8u - off);
    l.tx_pos = 8u - off;
    l.tx_sn = 1;
    l.tx_pending_pci = kPciFf;
  }
  l.tx_frame_pending = true;
  l.tx_state = IsotpTxState::kSendCf;  // not idle; real state set when the frame goes out
  flush_tx(l, now_us);
  return kIsotpOk;
}

}  // namespace imuforge::fw
