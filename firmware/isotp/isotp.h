// ISO-TP (ISO 15765-2) transport for classic CAN, normal addressing, one link = one (rx id, tx id) pair.
//
// Why our own: the MCU has no kernel. The firmware node runs this on target and in the virtual IMU; the
// host runs the Linux kernel's CAN_ISOTP sockets on SocketCAN, so the two implementations meet in the VM
// test (tests/vm/). On the embedded virtual bus the host reuses this implementation.
//
// Supported: single frame (SF), first frame (FF) incl. the 32-bit FF_DL escape for messages > 4095 bytes,
// consecutive frames (CF) with sequence check, flow control (FC: CTS / WAIT / OVFLW) with block size BS
// and separation time STmin (0..127 ms, 100..900 us), and the timeouts
//   N_As / N_Ar : a frame we queued was not accepted by the CAN port in time -> abort,
//   N_Bs        : sender waiting for FC after FF or after a block -> abort,
//   N_Cr        : receiver waiting for the next CF -> abort.
// Buffers belong to the caller (no heap): the link only keeps pointers. Half duplex per direction:
// one message in reception and one in transmission at a time.
//
// Usage:
//   isotp_init(link, cfg, port, rx_buf, sizeof rx_buf, tx_buf, sizeof tx_buf);
//   loop: for each received frame -> isotp_on_frame(link, f, now_us);  isotp_poll(link, now_us);
//         if (isotp_rx_ready(link)) { use link.rx_buf[0..link.rx_len); isotp_rx_release(link); }
//         isotp_send(link, msg, n, now_us)  when !isotp_tx_busy(link)
// Complexity: on_frame O(frame), poll O(frames sent in that call), send O(n) copy.
#pragma once
#include <cstddef>
#include <cstdint>

#include "hal/can.h"

namespace imuforge::fw {

// Stable error codes (also stored in IsotpLink::last_error and counted).
enum IsotpError : int {
  kIsotpOk = 0,
  kIsotpErrBusy = -1,          // isotp_send while a transmission is in progress
  kIsotpErrTooLong = -2,       // message larger than the tx buffer / peer announced more than rx buffer
  kIsotpErrTimeoutAs = -3,     // N_As/N_Ar: CAN port did not accept a frame in time
  kIsotpErrTimeoutBs = -4,     // N_Bs: no flow control from the receiver
  kIsotpErrTimeoutCr = -5,     // N_Cr: no consecutive frame from the sender
  kIsotpErrWrongSn = -6,       // consecutive frame with an unexpected sequence number
  kIsotpErrOverflow = -7,      // receiver answered FC OVFLW
  kIsotpErrWftMax = -8,        // too many FC WAIT frames in a row
  kIsotpErrUnexpected = -9,    // new SF/FF interrupted a reception in progress (the new one is taken)
  kIsotpErrBadFrame = -10,     // malformed PCI (length 0, FF_DL too small, invalid FC flag)
  kIsotpErrEmpty = -11,        // isotp_send with zero length
};

struct IsotpConfig {
  std::uint32_t rx_id = 0;         // frames we accept (peer -> us)
  std::uint32_t tx_id = 0;         // frames we send (us -> peer)
  bool extended = false;           // 29-bit identifiers
  std::uint8_t block_size = 0;     // BS we announce as receiver (0 = no further FC)
  std::uint8_t st_min_raw = 0;     // STmin we announce as receiver (ISO encoding)
  bool pad = true;                 // pad frames to 8 bytes
  std::uint8_t pad_byte = 0xCC;
  std::uint32_t n_as_us = 1000000; // N_As and N_Ar
  std::uint32_t n_bs_us = 1000000; // N_Bs
  std::uint32_t n_cr_us = 1000000; // N_Cr
  std::uint8_t wft_max = 10;       // consecutive FC WAIT accepted before giving up
};

enum class IsotpRxState : std::uint8_t { kIdle, kReceiving, kReady };
enum class IsotpTxState : std::uint8_t { kIdle, kWaitFc, kSendCf };

struct IsotpCounters {
  std::uint32_t rx_messages = 0;
  std::uint32_t tx_messages = 0;
  std::uint32_t rx_errors = 0;
  std::uint32_t tx_errors = 0;
};

struct IsotpLink {
  IsotpConfig cfg;
  hal::CanPort* port = nullptr;
  std::uint8_t* rx_buf = nullptr;
  std::size_t rx_cap = 0;
  std::uint8_t* tx_buf = nullptr;
  std::size_t tx_cap = 0;

  // reception
  IsotpRxState rx_state = IsotpRxState::kIdle;
  std::size_t rx_len = 0;        // announced length
  std::size_t rx_pos = 0;        // bytes received
  std::uint8_t rx_sn = 0;        // next expected SN
  std::uint8_t rx_bs_count = 0;  // CFs left in current block (0 = unlimited when BS = 0)
  std::uint64_t rx_deadline_us = 0;
  bool rx_fc_pending = false;    // an FC we must (re)try to send
  std::uint8_t rx_fc_flag = 0;

  // transmission
  IsotpTxState tx_state = IsotpTxState::kIdle;
  std::size_t tx_len = 0;
  std::size_t tx_pos = 0;
  std::uint8_t tx_sn = 0;
  std::uint8_t tx_bs = 0;        // peer BS
  std::uint8_t tx_bs_count = 0;  // CFs sent in current block
  std::uint32_t tx_st_min_us = 0;
  std::uint64_t tx_next_us = 0;  // earliest time for the next CF
  std::uint64_t tx_deadline_us = 0;
  std::uint8_t tx_wft = 0;
  bool tx_frame_pending = false; // SF/FF/CF built but not yet accepted by the port
  std::uint8_t tx_pending_pci = 0; // PCI type (0 SF, 1 FF, 2 CF) of the pending frame
  hal::CanFrame tx_frame;

  int last_error = kIsotpOk;
  IsotpCounters counters;
};

// Cannot fail: buffers and port are taken as given (rx_cap/tx_cap may be 0 to disable a direction).
void isotp_init(IsotpLink& link, const IsotpConfig& cfg, hal::CanPort& port, std::uint8_t* rx_buf,
                std::size_t rx_cap, std::uint8_t* tx_buf, std::size_t tx_cap) noexcept;
// Drops any transfer in progress (both directions) without sending anything.
void isotp_reset(IsotpLink& link) noexcept;

// Feeds one received frame. Frames whose id/format is not cfg.rx_id are ignored (returns kIsotpOk).
// Returns kIsotpOk or the error that aborted a transfer.
int isotp_on_frame(IsotpLink& link, const hal::CanFrame& frame, std::uint64_t now_us) noexcept;
// Sends due frames and checks timeouts. Returns kIsotpOk or the error that aborted a transfer.
int isotp_poll(IsotpLink& link, std::uint64_t now_us) noexcept;

// Starts sending `len` bytes (copied). Returns kIsotpOk, kIsotpErrBusy, kIsotpErrTooLong, kIsotpErrEmpty.
int isotp_send(IsotpLink& link, const std::uint8_t* data, std::size_t len, std::uint64_t now_us) noexcept;

inline bool isotp_tx_busy(const IsotpLink& link) noexcept { return link.tx_state != IsotpTxState::kIdle; }
inline bool isotp_rx_ready(const IsotpLink& link) noexcept { return link.rx_state == IsotpRxState::kReady; }
// Frees the received message; the next SF/FF can be taken.
void isotp_rx_release(IsotpLink& link) noexcept;

// STmin encoding <-> microseconds (reserved values map to 127 ms, per ISO 15765-2).
std::uint32_t isotp_st_min_to_us(std::uint8_t raw) noexcept;

}  // namespace imuforge::fw
