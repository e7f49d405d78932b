// CAN seam: the classic CAN 2.0 frame, the CAN FD frame, and a non-blocking port interface.
//
// The firmware node (firmware/can_node/) and the firmware ISO-TP (firmware/isotp/) only see CanPort.
// Backends: hal/linux/ (SocketCAN raw, the virtual bus over UDP datagrams), an MCU driver on target.
// Classic frames (CanFrame, 0..8 data bytes) stay the only type of the command path, so a classic-only
// controller and every classic caller pay nothing for FD: CanFdFrame is a separate type, sent through
// CanPort::send_fd, which a backend without FD leaves at its default (kCanErrNoFd). The node uses it only
// for the optional FD sample stream (docs/can-protocol.md "CAN FD stream frame").
// No heap; every call is O(1) in the frame size.
#pragma once
#include <cstdint>

namespace imuforge::hal {

// Error codes shared by every CAN backend (stable; negative; 0 = success).
enum CanError : int {
  kCanOk = 0,
  kCanErrWouldBlock = -1,  // TX queue full (send) or nothing pending (receive): try again later
  kCanErrBusOff = -2,      // controller is bus-off; frames are not sent until recovery
  kCanErrIo = -3,          // backend I/O failure (socket error, driver fault)
  kCanErrArg = -4,         // bad frame (dlc > 8, id out of range for its format)
  kCanErrClosed = -5,      // port not open
  kCanErrFdLength = -6,    // CAN FD frame length not one of 0..8, 12, 16, 20, 24, 32, 48, 64
  kCanErrNoFd = -7,        // the port (controller, interface MTU, bus) does not carry CAN FD frames
};

constexpr std::uint32_t kCanStdIdMask = 0x7FFu;       // 11-bit identifier
constexpr std::uint32_t kCanExtIdMask = 0x1FFFFFFFu;  // 29-bit identifier

struct CanFrame {
  std::uint32_t id = 0;     // 11 or 29 bits, without flag bits
  bool extended = false;    // true: 29-bit identifier
  std::uint8_t len = 0;     // 0..8
  std::uint8_t data[8] = {0, 0, 0, 0, 0, 0, 0, 0};
};

// True if the frame is well formed (len <= 8, id fits its format).
constexpr bool can_frame_valid(const CanFrame& f) noexcept {
  return f.len <= 8u && (f.extended ? (f.id & ~kCanExtIdMask) == 0u : (f.id & ~kCanStdIdMask) == 0u);
}

// CAN FD (ISO 11898-1:2015) data frame. `fd == false` carries a classic frame in the same type (len
// 0..8): a host receiving both kinds from one socket gets them in one array (hal/linux).
constexpr unsigned kCanFdMaxLen = 64;
struct CanFdFrame {
  std::uint32_t id = 0;     // 11 or 29 bits, without flag bits
  bool extended = false;    // true: 29-bit identifier
  bool fd = true;           // FDF: an FD frame (false: classic, len <= 8)
  bool brs = true;          // bit-rate switch in the data phase (FD only)
  std::uint8_t len = 0;     // FD: one of can_fd_len_valid(); classic: 0..8
  std::uint8_t data[kCanFdMaxLen] = {};
};

// True for the data lengths a CAN FD DLC can encode: 0..8, 12, 16, 20, 24, 32, 48, 64.
constexpr bool can_fd_len_valid(unsigned n) noexcept {
  return n <= 8u || n == 12u || n == 16u || n == 20u || n == 24u || n == 32u || n == 48u || n == 64u;
}

// kCanOk, kCanErrFdLength (FD length not encodable, or a classic one above 8) or kCanErrArg (id does
// not fit its format). The length is checked first, so a bad length always gives the same code.
constexpr int can_fd_frame_check(const CanFdFrame& f) noexcept {
  if (f.fd ? !can_fd_len_valid(f.len) : f.len > 8u) return kCanErrFdLength;
  if (f.extended ? (f.id & ~kCanExtIdMask) != 0u : (f.id & ~kCanStdIdMask) != 0u) return kCanErrArg;
  return kCanOk;
}
constexpr bool can_fd_frame_valid(const CanFdFrame& f) noexcept { return can_fd_frame_check(f) == kCanOk; }

// The classic frame that a CanFdFrame with fd == false carries (bytes beyond 8 are not part of it).
inline CanFrame can_frame_from_fd(const CanFdFrame& a) noexcept {
  CanFrame f;
  f.id = a.id;
  f.extended = a.extended;
  f.len = a.len > 8u ? static_cast<std::uint8_t>(8u) : a.len;
  for (unsigned i = 0; i < f.len; ++i) f.data[i] = a.data[i];
  return f;
}

// A CAN port. Implementations never block: send() queues or fails with kCanErrWouldBlock, receive()
// returns kCanErrWouldBlock when no frame is pending.
class CanPort {
 public:
  // Queues one frame for transmission. Returns kCanOk or a negative CanError.
  virtual int send(const CanFrame& frame) noexcept = 0;
  // Takes one received frame. Returns kCanOk (frame filled) or a negative CanError.
  virtual int receive(CanFrame& frame) noexcept = 0;
  // Queues one CAN FD frame. Returns kCanOk, kCanErrNoFd (this port cannot send FD: the default),
  // kCanErrFdLength / kCanErrArg (can_fd_frame_check) or another negative CanError.
  virtual int send_fd(const CanFdFrame& frame) noexcept {
    (void)frame;
    return kCanErrNoFd;
  }

 protected:
  ~CanPort() = default;  // not deleted through the interface (no heap in firmware)
};

}  // namespace imuforge::hal
