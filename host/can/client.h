// Host CAN client for the imuforge node: identify, stream, read/write/commit tables, reboot, status.
//
//   auto c = imuforge::can::Client::connect("virtual:bench1", 1);   // or "socketcan:vcan0"
//   Identity id = c->identify();
//   c->start_stream(1000, proto::kChAll, [](const StreamSample& s) { ... });  // client thread
//   (start_stream(..., /*fd=*/true): the CAN FD stream frame, 4 samples per 64-byte frame)
//   ... c->stream_counters() ... c->stop_stream();
//   c->flash_table(blob, seq, key);    // write + commit + verify (identify + read-back)
//
// Transport: on SocketCAN the commands go through the Linux kernel's CAN_ISOTP socket and the stream
// through a filtered CAN_RAW socket; on the virtual bus the client runs the firmware's ISO-TP
// (firmware/isotp/) on a receive thread. Every failure throws can::Error with a code:
//   code > 0 : the node answered with that proto::Status (the request was refused)
//   code < 0 : transport failure (kErrTimeout, kErrTransport, kErrProtocol, kErrVerify)
// Commands that are safe to repeat are retried (`retries`, default 2) after a transport failure;
// commit is made idempotent by checking the node's active seq (identify) before retrying.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "firmware/can_node/protocol.h"
#include "host/can/stream_decoder.h"

namespace imuforge::can {

enum ClientError : int {
  kErrTimeout = -1,    // no (complete) response in time
  kErrTransport = -2,  // socket / bus failure
  kErrProtocol = -3,   // malformed or mismatched response
  kErrVerify = -4,     // read-back after a write does not match
};

class Error : public std::runtime_error {
 public:
  Error(int code, const std::string& what) : std::runtime_error(what), code_(code) {}
  int code() const noexcept { return code_; }
  bool is_peer_refusal() const noexcept { return code_ > 0; }

 private:
  int code_;
};

// Name of a proto::Status ("auth failed", ...), for messages.
const char* status_name(int status);

struct Identity {
  std::uint64_t serial = 0;
  std::string fw_version;
  bool table_present = false;
  std::uint32_t table_seq = 0;
  std::uint32_t table_crc32 = 0;
  std::uint32_t table_len = 0;
  std::uint8_t node_id = 0;
  bool extended_ids = false;
  bool key_provisioned = false;
  bool can_fd = false;  // the node can stream CAN FD frames (proto::kIdCanFd)
};

struct NodeStatus {
  std::uint32_t uptime_ms = 0, samples_sent = 0, stream_frames_tx = 0, stream_frames_dropped = 0,
                bus_off_events = 0, isotp_rx_errors = 0, isotp_tx_errors = 0, commands_ok = 0,
                commands_rejected = 0, auth_failures = 0, boots = 0;
  int active_slot = -1, staged_slot = -1;
  bool streaming = false;
  bool stream_fd = false;  // streaming CAN FD frames
  std::uint8_t channels = 0;
  std::uint16_t rate_hz = 0;
  std::uint32_t samples_fifo_overflow = 0;  // samples the node's FIFO dropped (the host sees them lost)
};

struct TransferStats {
  std::uint64_t request_bytes = 0;
  std::uint64_t response_bytes = 0;
  std::uint64_t retries = 0;
};

using Key = std::array<std::uint8_t, proto::kKeyBytes>;

class Client {
 public:
  struct Options {
    bool extended_ids = false;
    int timeout_ms = 1000;  // per request attempt
    int retries = 2;        // extra attempts after a transport failure
  };
  static std::unique_ptr<Client> connect(const std::string& bus_spec, std::uint8_t node_id);
  static std::unique_ptr<Client> connect(const std::string& bus_spec, std::uint8_t node_id, const Options& opt);
  virtual ~Client();

  Identity identify();
  NodeStatus status();
  // fd: CAN FD stream frames, 4 samples each (docs/can-protocol.md); throws kErrTransport if this
  // host's port cannot receive FD, and the node refuses with proto::kStFdUnsupported if it cannot send.
  void start_stream(std::uint16_t rate_hz, std::uint8_t channels, StreamDecoder::Callback cb, bool fd = false);
  // Stops the stream, waits `drain_ms` for frames in flight, settles the counters. Returns node's
  // samples_sent.
  std::uint32_t stop_stream(int drain_ms = 50);
  StreamCounters stream_counters() const;
  // Returns the table bytes; *seq (optional) gets the active seq.
  std::vector<std::uint8_t> read_table(std::uint32_t* seq = nullptr);
  // Signs and sends; returns the CRC-32 the node computed of the staged table.
  std::uint32_t write_table(const std::vector<std::uint8_t>& table, std::uint32_t seq, const Key& key,
                            std::uint64_t serial);
  void commit_table(std::uint32_t seq);
  // write + commit + identify + read-back compare; redoes write+commit once if the node lost the staged
  // table (reset mid-transfer). Throws on any refusal or mismatch.
  void flash_table(const std::vector<std::uint8_t>& table, std::uint32_t seq, const Key& key, std::uint64_t serial);
  void reboot();
  // Raw request/response (cmd byte + args) -> response payload after cmd|0x80,status. Throws on status != 0.
  std::vector<std::uint8_t> request(const std::vector<std::uint8_t>& req, bool retry_ok = true);
  const TransferStats& transfer_stats() const { return stats_; }

  class Transport;

 protected:
  Client() = default;
  std::unique_ptr<Transport> t_;
  Options opt_;
  std::uint8_t node_ = 0;
  TransferStats stats_;
};

// Signs a table the way the node checks it: HMAC-SHA256(key, "IFTB" | serial | seq | table).
std::array<std::uint8_t, proto::kTagBytes> sign_table(const Key& key, std::uint64_t serial, std::uint32_t seq,
                                                       const std::vector<std::uint8_t>& table);
// Parses 64 hex digits into a key. Throws std::invalid_argument.
Key key_from_hex(const std::string& hex);

}  // namespace imuforge::can
