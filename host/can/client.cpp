#include "host/can/client.h"

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <atomic>
#include <mutex>
#include <thread>

#include "firmware/can_node/node.h"
#include "firmware/common/endian.h"
#include "firmware/isotp/isotp.h"
#include "hal/linux/linux_can.h"

namespace imuforge::can {

using Clock = std::chrono::steady_clock;

const char* status_name(int s) {
  switch (s) {
    case proto::kStOk: return "ok";
    case proto::kStUnknownCommand: return "unknown command";
    case proto::kStBadLength: return "bad request length";
    case proto::kStBadArgument: return "bad argument";
    case proto::kStAuthFailed: return "authorisation failed (HMAC tag does not verify)";
    case proto::kStReplay: return "replayed or old table sequence number";
    case proto::kStTableInvalid: return "table rejected by the table parser";
    case proto::kStTableTooLarge: return "table too large";
    case proto::kStFlashError: return "flash error";
    case proto::kStNotStaged: return "nothing staged with that sequence number";
    case proto::kStNoTable: return "no table on the device";
    case proto::kStBusy: return "busy";
    case proto::kStNoKey: return "device has no provisioned key";
    case proto::kStWrongDevice: return "table is for another device (serial mismatch)";
    case proto::kStSeqMismatch: return "table_sequence differs from the write's sequence number";
    case proto::kStFdUnsupported: return "the node cannot send CAN FD (classic controller or bus)";
    default: return "unknown status";
  }
}

namespace {
// "0x03 (stream stop)": the byte a protocol trace shows and the word an operator reads.
std::string command_label(std::uint8_t cmd) {
  const char* name = "unknown";
  switch (cmd) {
    case proto::kCmdIdentify: name = "identify"; break;
    case proto::kCmdStreamStart: name = "stream start"; break;
    case proto::kCmdStreamStop: name = "stream stop"; break;
    case proto::kCmdReadTable: name = "read table"; break;
    case proto::kCmdWriteTable: name = "write table"; break;
    case proto::kCmdCommit: name = "commit"; break;
    case proto::kCmdReboot: name = "reboot"; break;
    case proto::kCmdStatus: name = "status"; break;
    default: break;
  }
  const char* hex = "0123456789abcdef";
  return std::string("0x") + hex[cmd >> 4] + hex[cmd & 15] + " (" + name + ")";
}
}  // namespace

// ---- transports ----------------------------------------------------------------------------------------
class Client::Transport {
 public:
  virtual ~Transport() = default;
  virtual void send(const std::vector<std::uint8_t>& msg) = 0;
  virtual bool recv(std::vector<std::uint8_t>* out, int timeout_ms, std::string* err) = 0;
  virtual void flush_rx() = 0;
  virtual void set_decoder(std::unique_ptr<StreamDecoder> d) = 0;  // nullptr: stop decoding
  virtual StreamCounters counters() const = 0;
  virtual void flush_decoder() = 0;
  // The host side can receive CAN FD frames (virtual bus; SocketCAN with MTU CANFD_MTU).
  virtual bool fd_capable() const = 0;
};

namespace {

class StreamSink {
 public:
  void set(std::unique_ptr<StreamDecoder> d) {
    std::lock_guard<std::mutex> lk(mu_);
    if (dec_) last_ = dec_->counters();
    dec_ = std::move(d);
  }
  bool feed(const hal::CanFrame& f) {
    std::lock_guard<std::mutex> lk(mu_);
    return dec_ ? dec_->on_frame(f) : false;
  }
  bool feed(const hal::CanFdFrame& f) {
    std::lock_guard<std::mutex> lk(mu_);
    return dec_ ? dec_->on_frame(f) : false;
  }
  // A batch under one lock (the SocketCAN receive thread reads frames in batches).
  void feed(const hal::CanFdFrame* f, int n) {
    std::lock_guard<std::mutex> lk(mu_);
    if (!dec_) return;
    for (int i = 0; i < n; ++i) (void)dec_->on_frame(f[i]);
  }
  StreamCounters counters() const {
    std::lock_guard<std::mutex> lk(mu_);
    return dec_ ? dec_->counters() : last_;
  }
  void flush() {
    std::lock_guard<std::mutex> lk(mu_);
    if (dec_) dec_->flush();
  }

 private:
  mutable std::mutex mu_;
  std::unique_ptr<StreamDecoder> dec_;
  StreamCounters last_;
};

// Virtual bus: the firmware ISO-TP on a receive thread that also decodes the stream.
class VirtualTransport final : public Client::Transport {
 public:
  VirtualTransport(std::unique_ptr<hal::LinuxCanPort> port, std::uint8_t node, bool ext)
      : port_(std::move(port)), rx_(proto::kMaxMessageBytes + 64), tx_(proto::kMaxMessageBytes + 64) {
    fw::IsotpConfig c;
    c.rx_id = proto::response_id(node, ext);
    c.tx_id = proto::request_id(node, ext);
    c.extended = ext;
    fw::isotp_init(link_, c, *port_, rx_.data(), rx_.size(), tx_.data(), tx_.size());
    thread_ = std::thread([this] { run(); });
  }
  ~VirtualTransport() override {
    stop_ = true;
    thread_.join();
  }

  void send(const std::vector<std::uint8_t>& msg) override {
    std::unique_lock<std::mutex> lk(mu_);
    const std::uint32_t errs = link_.counters.tx_errors;
    const int rc = fw::isotp_send(link_, msg.data(), msg.size(), now_us());
    if (rc != fw::kIsotpOk) throw Error(kErrTransport, "isotp send failed (" + std::to_string(rc) + ")");
    // Wait until the last frame left (N_Bs / N_As are enforced by the ISO-TP engine itself).
    cv_.wait(lk, [&] { return !fw::isotp_tx_busy(link_); });
    if (link_.counters.tx_errors != errs) {
      const int e = link_.last_error;
      throw Error(e == fw::kIsotpErrTimeoutBs ? kErrTimeout : kErrTransport,
                  std::string("isotp transmission aborted: ") +
                      (e == fw::kIsotpErrTimeoutBs ? "no flow control from the node (N_Bs timeout)"
                                                   : "error " + std::to_string(e)));
    }
  }

  bool recv(std::vector<std::uint8_t>* out, int timeout_ms, std::string* err) override {
    std::unique_lock<std::mutex> lk(mu_);
    if (!cv_.wait_for(lk, std::chrono::milliseconds(timeout_ms), [&] { return !responses_.empty() || io_error_; })) {
      *err = "timeout";
      return false;
    }
    if (io_error_) {
      *err = port_->last_error();
      return false;
    }
    *out = std::move(responses_.front());
    responses_.pop_front();
    return true;
  }

  void flush_rx() override {
    std::lock_guard<std::mutex> lk(mu_);
    responses_.clear();
  }
  void set_decoder(std::unique_ptr<StreamDecoder> d) override { sink_.set(std::move(d)); }
  StreamCounters counters() const override { return sink_.counters(); }
  void flush_decoder() override { sink_.flush(); }
  bool fd_capable() const override { return port_->fd_enabled(); }

 private:
  std::uint64_t now_us() const {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - t0_).count());
  }
  void run() {
    while (!stop_) {
      // Either kind of frame: the FD stream shares the socket with the classic ISO-TP responses.
      const int n = port_->receive_many_any_wait(batch_, kBatch, 1);
      std::lock_guard<std::mutex> lk(mu_);
      for (int i = 0; i < n; ++i) {
        const hal::CanFdFrame& a = batch_[i];
        if (sink_.feed(a) || a.fd) continue;
        fw::isotp_on_frame(link_, hal::can_frame_from_fd(a), now_us());
        take_response();  // before the next frame: a second response in the same batch must find room
      }
      if (n < 0) io_error_ = true;
      fw::isotp_poll(link_, now_us());
      take_response();
      cv_.notify_all();
    }
  }
  void take_response() {
    if (!fw::isotp_rx_ready(link_)) return;
    responses_.emplace_back(link_.rx_buf, link_.rx_buf + link_.rx_len);
    fw::isotp_rx_release(link_);
  }

  static constexpr int kBatch = 64;
  std::unique_ptr<hal::LinuxCanPort> port_;
  hal::CanFdFrame batch_[kBatch];
  std::vector<std::uint8_t> rx_, tx_;
  fw::IsotpLink link_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::vector<std::uint8_t>> responses_;
  bool io_error_ = false;
  StreamSink sink_;
  const Clock::time_point t0_ = Clock::now();
  std::atomic<bool> stop_{false};  // set by the destructor, read by the receive thread
  std::thread thread_;
};

// SocketCAN: kernel ISO-TP for commands, filtered CAN_RAW for the stream.
class SocketCanTransport final : public Client::Transport {
 public:
  SocketCanTransport(const std::string& spec, const std::string& ifname, std::uint8_t node, bool ext) {
    std::string err;
    if (!isotp_.open(ifname, proto::request_id(node, ext), proto::response_id(node, ext), ext, 0, 0, &err)) {
      throw Error(kErrTransport, "CAN bus " + spec + ": " + err);
    }
    // want_fd: FD frames are received if the interface carries them (MTU 72), else the port is classic.
    raw_ = hal::open_can_port(spec, &err, /*want_fd=*/true);
    if (!raw_) throw Error(kErrTransport, "CAN bus " + spec + ": " + err);
    std::vector<std::uint32_t> ids;
    for (std::uint8_t p = 0; p <= proto::kPartFd; ++p) ids.push_back(proto::stream_id(node, p, ext));
    if (!hal::set_can_filter(*raw_, ids, ext, &err)) throw Error(kErrTransport, "CAN bus " + spec + ": " + err);
    thread_ = std::thread([this] { run(); });
  }
  ~SocketCanTransport() override {
    stop_ = true;
    thread_.join();
  }
  void send(const std::vector<std::uint8_t>& msg) override {
    std::string err;
    if (!isotp_.send(msg.data(), msg.size(), &err)) throw Error(kErrTransport, err);
  }
  bool recv(std::vector<std::uint8_t>* out, int timeout_ms, std::string* err) override {
    return isotp_.recv(out, timeout_ms, err);
  }
  void flush_rx() override {
    std::vector<std::uint8_t> junk;
    std::string err;
    while (isotp_.recv(&junk, 0, &err)) {
    }
  }
  void set_decoder(std::unique_ptr<StreamDecoder> d) override { sink_.set(std::move(d)); }
  StreamCounters counters() const override { return sink_.counters(); }
  void flush_decoder() override { sink_.flush(); }
  bool fd_capable() const override { return raw_->fd_enabled(); }

 private:
  void run() {
    std::vector<hal::CanFdFrame> batch(64);
    while (!stop_.load(std::memory_order_relaxed)) {
      const int n = raw_->receive_many_any_wait(batch.data(), 64, 5);
      if (n > 0) sink_.feed(batch.data(), n);
    }
  }
  hal::KernelIsotp isotp_;
  std::unique_ptr<hal::LinuxCanPort> raw_;
  StreamSink sink_;
  // Written by the destructor's thread, read by the receive thread: an atomic (a volatile bool is a
  // data race, which ThreadSanitizer reports).
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class ClientImpl final : public Client {
 public:
  ClientImpl(std::unique_ptr<Transport> t, std::uint8_t node, const Options& o) {
    t_ = std::move(t);
    node_ = node;
    opt_ = o;
  }
};

std::uint32_t le32(const std::vector<std::uint8_t>& v, std::size_t at) {
  if (v.size() < at + 4) throw Error(kErrProtocol, "response too short");
  return fw::load_le32(v.data() + at);
}

}  // namespace

std::unique_ptr<Client> Client::connect(const std::string& bus_spec, std::uint8_t node_id) {
  return connect(bus_spec, node_id, Options{});
}

std::unique_ptr<Client> Client::connect(const std::string& bus_spec, std::uint8_t node_id, const Options& opt) {
  if (node_id > proto::kMaxNodeId) {
    throw Error(kErrProtocol, "node id " + std::to_string(node_id) + " out of range 0.." +
                                  std::to_string(proto::kMaxNodeId));
  }
  hal::BusSpec bs;
  std::string err;
  if (!hal::parse_bus_spec(bus_spec, &bs, &err)) throw Error(kErrTransport, err);
  std::unique_ptr<Transport> t;
  if (bs.kind == hal::BusSpec::Kind::kVirtual) {
    auto port = hal::open_can_port(bus_spec, &err);
    if (!port) throw Error(kErrTransport, "CAN bus " + bus_spec + ": " + err);
    // Only this node's responses and stream: with N units on one virtual bus, every client reading
    // every node's stream is what starved the command responses (docs/eol.md "Multi-unit stations").
    std::vector<std::uint32_t> ids{proto::response_id(node_id, opt.extended_ids)};
    for (std::uint8_t p = 0; p <= proto::kPartFd; ++p) ids.push_back(proto::stream_id(node_id, p, opt.extended_ids));
    if (!hal::set_can_filter(*port, ids, opt.extended_ids, &err)) throw Error(kErrTransport, "CAN bus " + bus_spec + ": " + err);
    t = std::make_unique<VirtualTransport>(std::move(port), node_id, opt.extended_ids);
  } else {
    t = std::make_unique<SocketCanTransport>(bus_spec, bs.name, node_id, opt.extended_ids);
  }
  return std::make_unique<ClientImpl>(std::move(t), node_id, opt);
}

Client::~Client() = default;

std::vector<std::uint8_t> Client::request(const std::vector<std::uint8_t>& req, bool retry_ok) {
  if (req.empty()) throw Error(kErrProtocol, "empty request");
  const std::uint8_t want = static_cast<std::uint8_t>(req[0] | proto::kResponseFlag);
  std::string last = "no attempt";
  const int attempts = retry_ok ? 1 + opt_.retries : 1;
  for (int a = 0; a < attempts; ++a) {
    if (a > 0) ++stats_.retries;
    t_->flush_rx();
    try {
      t_->send(req);
    } catch (const Error& e) {
      last = e.what();
      continue;
    }
    stats_.request_bytes += req.size();
    const auto deadline = Clock::now() + std::chrono::milliseconds(opt_.timeout_ms);
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      std::vector<std::uint8_t> resp;
      std::string err;
      if (left <= 0 || !t_->recv(&resp, static_cast<int>(left), &err)) {
        last = left <= 0 ? "timeout" : err;
        break;
      }
      if (resp.size() < 2 || resp[0] != want) continue;  // stale response of an earlier attempt
      stats_.response_bytes += resp.size();
      if (resp[1] != proto::kStOk) {
        throw Error(resp[1], std::string("node ") + std::to_string(node_) + " refused command " + command_label(req[0]) +
                                 ": " + status_name(resp[1]) + " (status " + std::to_string(resp[1]) + ")");
      }
      return std::vector<std::uint8_t>(resp.begin() + 2, resp.end());
    }
  }
  throw Error(kErrTimeout, "node " + std::to_string(node_) + " did not answer command " + command_label(req[0]) +
                               " after " + std::to_string(attempts) + " attempt(s): " + last);
}

Identity Client::identify() {
  const auto r = request({proto::kCmdIdentify});
  if (r.size() != proto::kIdentifyBytes) throw Error(kErrProtocol, "identify: bad response length");
  Identity id;
  id.serial = fw::load_le64(r.data());
  id.fw_version.assign(reinterpret_cast<const char*>(r.data() + 8), 16);
  id.fw_version.resize(std::strlen(id.fw_version.c_str()));
  id.table_present = r[24] != 0;
  id.table_seq = fw::load_le32(r.data() + 25);
  id.table_crc32 = fw::load_le32(r.data() + 29);
  id.table_len = fw::load_le32(r.data() + 33);
  id.node_id = r[37];
  id.extended_ids = (r[38] & proto::kIdExtendedIds) != 0;
  id.key_provisioned = (r[38] & proto::kIdKeyProvisioned) != 0;
  id.can_fd = (r[38] & proto::kIdCanFd) != 0;
  return id;
}

NodeStatus Client::status() {
  const auto r = request({proto::kCmdStatus});
  if (r.size() != proto::kStatusBytes) throw Error(kErrProtocol, "status: bad response length");
  NodeStatus s;
  std::uint32_t* f[] = {&s.uptime_ms, &s.samples_sent, &s.stream_frames_tx, &s.stream_frames_dropped,
                        &s.bus_off_events, &s.isotp_rx_errors, &s.isotp_tx_errors, &s.commands_ok,
                        &s.commands_rejected, &s.auth_failures, &s.boots};
  for (std::size_t i = 0; i < 11; ++i) *f[i] = fw::load_le32(r.data() + 4 * i);
  s.active_slot = static_cast<std::int8_t>(r[44]);
  s.staged_slot = static_cast<std::int8_t>(r[45]);
  s.streaming = r[46] != 0;
  s.stream_fd = r[46] == 2;
  s.channels = r[47];
  s.rate_hz = fw::load_le16(r.data() + 48);
  s.samples_fifo_overflow = fw::load_le32(r.data() + 50);
  return s;
}

void Client::start_stream(std::uint16_t rate_hz, std::uint8_t channels, StreamDecoder::Callback cb, bool fd) {
  if (fd && !t_->fd_capable()) {
    throw Error(kErrTransport, "CAN FD stream asked for, but this host's CAN port does not carry CAN FD "
                               "(SocketCAN: the interface MTU must be 72, `ip link set <if> mtu 72`)");
  }
  if (fd && rate_hz == 0) throw Error(kErrProtocol, "CAN FD stream: rate must be > 0");
  t_->set_decoder(std::make_unique<StreamDecoder>(node_, opt_.extended_ids, channels, std::move(cb), fd, rate_hz));
  std::vector<std::uint8_t> req{proto::kCmdStreamStart, 0, 0, channels};
  if (fd) req.push_back(proto::kStreamFlagFd);  // without it the request stays the 4-byte classic one
  fw::store_le16(req.data() + 1, rate_hz);
  try {
    request(req);
  } catch (...) {
    t_->set_decoder(nullptr);
    throw;
  }
}

std::uint32_t Client::stop_stream(int drain_ms) {
  std::vector<std::uint8_t> r;
  try {
    r = request({proto::kCmdStreamStop});
  } catch (...) {
    // The decoder's callback usually points into the caller's stack (eol::CanDevice::stream): it must
    // not outlive a failed stop, or frames still arriving would be delivered into freed memory.
    t_->set_decoder(nullptr);
    throw;
  }
  // Drain until the stream has been quiet for drain_ms (at most 20 × drain_ms): on a loaded host the
  // frames the node sent before it stopped can still be queued in the socket well after its answer.
  const auto t_end = Clock::now() + std::chrono::milliseconds(20 * drain_ms);
  auto quiet_since = Clock::now();
  std::uint64_t frames = t_->counters().frames;
  while (Clock::now() < t_end && Clock::now() - quiet_since < std::chrono::milliseconds(drain_ms)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const std::uint64_t f = t_->counters().frames;
    if (f != frames) {
      frames = f;
      quiet_since = Clock::now();
    }
  }
  t_->flush_decoder();
  t_->set_decoder(nullptr);
  return le32(r, 0);
}

StreamCounters Client::stream_counters() const { return t_->counters(); }

std::vector<std::uint8_t> Client::read_table(std::uint32_t* seq) {
  const auto r = request({proto::kCmdReadTable});
  const std::uint32_t s = le32(r, 0);
  if (seq != nullptr) *seq = s;
  return std::vector<std::uint8_t>(r.begin() + 4, r.end());
}

std::array<std::uint8_t, proto::kTagBytes> sign_table(const Key& key, std::uint64_t serial, std::uint32_t seq,
                                                       const std::vector<std::uint8_t>& table) {
  std::array<std::uint8_t, proto::kTagBytes> tag{};
  fw::node_table_tag(key.data(), serial, seq, table.data(), table.size(), tag.data());
  return tag;
}

Key key_from_hex(const std::string& hex) {
  if (hex.size() != 2 * proto::kKeyBytes) throw std::invalid_argument("key must be 64 hex digits");
  Key k{};
  for (std::size_t i = 0; i < k.size(); ++i) {
    auto nib = [&](char c) -> int {
      if (c >= '0' && c <= '9') return c - '0';
      if (c >= 'a' && c <= 'f') return c - 'a' + 10;
      if (c >= 'A' && c <= 'F') return c - 'A' + 10;
      throw std::invalid_argument(std::string("key: '") + c + "' is not a hex digit");
    };
    k[i] = static_cast<std::uint8_t>(nib(hex[2 * i]) << 4 | nib(hex[2 * i + 1]));
  }
  return k;
}

std::uint32_t Client::write_table(const std::vector<std::uint8_t>& table, std::uint32_t seq, const Key& key,
                                  std::uint64_t serial) {
  if (table.size() > proto::kMaxTableBytes) {
    throw Error(proto::kStTableTooLarge, "table of " + std::to_string(table.size()) + " bytes exceeds " +
                                             std::to_string(proto::kMaxTableBytes));
  }
  const auto tag = sign_table(key, serial, seq, table);
  std::vector<std::uint8_t> req(proto::kWriteHeaderBytes + table.size());
  req[0] = proto::kCmdWriteTable;
  fw::store_le32(req.data() + 1, seq);
  std::memcpy(req.data() + 5, tag.data(), tag.size());
  std::memcpy(req.data() + proto::kWriteHeaderBytes, table.data(), table.size());
  // Re-writing the inactive slot is harmless, so a lost response may be retried.
  return le32(request(req), 0);
}

void Client::commit_table(std::uint32_t seq) {
  std::vector<std::uint8_t> req{proto::kCmdCommit, 0, 0, 0, 0};
  fw::store_le32(req.data() + 1, seq);
  try {
    request(req, /*retry_ok=*/false);
    return;
  } catch (const Error& e) {
    if (e.is_peer_refusal()) throw;
  }
  // Transport failure: the commit may or may not have happened. Ask rather than guess.
  const Identity id = identify();
  if (id.table_present && id.table_seq == seq) return;
  ++stats_.retries;
  request(req, /*retry_ok=*/true);
}

void Client::flash_table(const std::vector<std::uint8_t>& table, std::uint32_t seq, const Key& key,
                         std::uint64_t serial) {
  for (int round = 0;; ++round) {
    const std::uint32_t crc = write_table(table, seq, key, serial);
    try {
      commit_table(seq);
    } catch (const Error& e) {
      // The node lost the staged table (it was reset between write and commit): do both again, once.
      if (e.code() == proto::kStNotStaged && round == 0) {
        ++stats_.retries;
        continue;
      }
      throw;
    }
    const Identity id = identify();
    if (!id.table_present || id.table_seq != seq || id.table_crc32 != crc) {
      throw Error(kErrVerify, "after commit the node reports table seq " + std::to_string(id.table_seq) +
                                  ", expected " + std::to_string(seq));
    }
    std::uint32_t rseq = 0;
    if (read_table(&rseq) != table || rseq != seq) throw Error(kErrVerify, "read-back differs from the written table");
    return;
  }
}

void Client::reboot() { request({proto::kCmdReboot}, /*retry_ok=*/false); }

}  // namespace imuforge::can
