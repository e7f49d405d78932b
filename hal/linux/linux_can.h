// Linux CAN backends (host builds only): SocketCAN raw, SocketCAN kernel ISO-TP, and the embedded
// virtual CAN bus for machines without CAN hardware.
//
// Bus specs (strings used on every command line and API):
//   socketcan:<ifname>   e.g. socketcan:vcan0, socketcan:can0
//   virtual:<name>       UDP datagrams on 127.0.0.1 between any number of processes; each endpoint
//                        binds an ephemeral port and announces it as a file <port> (content: pid) in
//                        $IMUFORGE_VCAN_DIR/<name>/ (default /tmp/imuforge-vcan/<name>/; the last endpoint to
//                        close removes <name>/); a frame is sent
//                        to every announced endpoint but itself whose acceptance filter (set_can_filter,
//                        announced in the same file) takes its id. Same 16-byte frame layout as SocketCAN's
//                        struct can_frame (can_id with the EFF flag bit 31, dlc, 3 pad, 8 data); CAN FD
//                        frames as the 72-byte struct canfd_frame (flags CANFD_FDF|CANFD_BRS, 64 data).
//                        The virtual bus always carries FD; a classic receive() skips FD datagrams.
//                        Unix datagram sockets were rejected: their queue is 10 datagrams by default.
// Every system call's result is checked; failures are reported as CanError codes plus a message.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hal/can.h"

namespace imuforge::hal {

class LinuxCanPort : public CanPort {
 public:
  virtual ~LinuxCanPort() = default;
  // A pollable file descriptor that becomes readable when receive() has a frame.
  virtual int fd() const noexcept = 0;
  // A classic frame (FD frames on the bus are skipped): receive_any without the FD ones.
  int receive(CanFrame& frame) noexcept final;
  // Blocks up to timeout_ms for one frame. kCanOk, kCanErrWouldBlock (timeout) or an error.
  int receive_wait(CanFrame& frame, int timeout_ms) noexcept;
  // Up to `max` frames already queued, without blocking; returns how many (0: none), or a negative
  // kCanErr* on an error. SocketCAN reads them with one recvmmsg call: a stream at 1 kHz is 3000
  // frames/s, and one system call per frame is what a starved emulated host could not keep up with.
  int receive_many(CanFrame* frames, int max) noexcept;
  // Blocks up to timeout_ms for the first frame, then takes what else is queued (receive_many).
  int receive_many_wait(CanFrame* frames, int max, int timeout_ms) noexcept;
  // True if send_fd() can put CAN FD frames on this bus (virtual bus: always; SocketCAN: opened with
  // want_fd on an interface whose MTU is CANFD_MTU).
  bool fd_enabled() const noexcept { return fd_enabled_; }
  // One frame of either kind (CanFdFrame::fd tells which). The FD-aware counterpart of receive(),
  // for the host's stream reader; kCanOk, kCanErrWouldBlock or an error.
  virtual int receive_any(CanFdFrame& frame) noexcept = 0;
  // Up to `max` frames of either kind already queued (as receive_many); how many, or a negative error.
  virtual int receive_many_any(CanFdFrame* frames, int max) noexcept;
  // Blocks up to timeout_ms for the first frame of either kind, then takes what else is queued.
  int receive_many_any_wait(CanFdFrame* frames, int max, int timeout_ms) noexcept;
  // Text of the last error (system call and errno text).
  const std::string& last_error() const noexcept { return error_; }
  std::uint64_t tx_dropped() const noexcept { return tx_dropped_; }

 protected:
  // Waits up to timeout_ms for fd() to become readable: 1 readable, 0 timeout (or a signal), kCanErrIo.
  int wait_readable(int timeout_ms) noexcept;
  std::string error_;
  std::uint64_t tx_dropped_ = 0;
  bool fd_enabled_ = false;
};

struct BusSpec {
  enum class Kind { kVirtual, kSocketCan } kind = Kind::kVirtual;
  std::string name;  // virtual bus name or interface name
};
// Parses "virtual:<name>" or "socketcan:<ifname>". Returns false and sets *err on a malformed spec.
bool parse_bus_spec(const std::string& spec, BusSpec* out, std::string* err);

// Opens a raw port on the bus. Returns nullptr and sets *err (naming the spec and the failing call).
// For SocketCAN, `want_fd` requests CAN FD frames; it is only honoured if the interface MTU is
// CANFD_MTU (checked with SIOCGIFMTU), otherwise the port stays classic.
std::unique_ptr<LinuxCanPort> open_can_port(const std::string& spec, std::string* err, bool want_fd = false);

// Restricts a port to the given identifiers: CAN_RAW_FILTER on SocketCAN; on the virtual bus the list is
// announced and the senders skip this endpoint for other ids (a hardware acceptance filter: the bus
// still carries every frame, the endpoint no longer pays for them; an empty list: every frame again).
bool set_can_filter(LinuxCanPort& port, const std::vector<std::uint32_t>& ids, bool extended, std::string* err);

// The Linux kernel's ISO 15765-2 implementation (CAN_ISOTP socket), one (tx_id, rx_id) pair.
class KernelIsotp {
 public:
  KernelIsotp() = default;
  ~KernelIsotp();
  KernelIsotp(const KernelIsotp&) = delete;
  KernelIsotp& operator=(const KernelIsotp&) = delete;
  // Opens and binds; pads frames with 0xCC, waits for TX completion, announces BS/STmin as receiver.
  bool open(const std::string& ifname, std::uint32_t tx_id, std::uint32_t rx_id, bool extended,
            std::uint8_t bs, std::uint8_t st_min_raw, std::string* err);
  // Sends one message (blocks until sent or the kernel reports an error such as a FC timeout).
  bool send(const std::uint8_t* data, std::size_t len, std::string* err);
  // Receives one message within timeout_ms. Returns false on timeout (err "timeout") or error.
  bool recv(std::vector<std::uint8_t>* out, int timeout_ms, std::string* err);
  void close();
  bool is_open() const noexcept { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

}  // namespace imuforge::hal
