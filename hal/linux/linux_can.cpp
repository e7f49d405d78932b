// The Linux CAN backends in one file (past 600 lines because it holds three: the virtual bus, SocketCAN
// raw and kernel ISO-TP): they share the on-wire frame layouts (struct can_frame / canfd_frame), the
// receive paths and the bus-spec parsing, and each alone is small. Interface: hal/linux/linux_can.h.
#include "hal/linux/linux_can.h"

#include <dirent.h>
#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/isotp.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>
#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace imuforge::hal {
namespace {

std::string sys_error(const std::string& what) { return what + ": " + std::strerror(errno); }

// The on-wire layout of a classic frame, identical to struct can_frame.
void encode(const CanFrame& f, std::uint8_t out[16]) {
  std::uint32_t id = f.id | (f.extended ? CAN_EFF_FLAG : 0u);
  std::memset(out, 0, 16);
  std::memcpy(out, &id, 4);
  out[4] = f.len;
  std::memcpy(out + 8, f.data, 8);
}

// The on-wire layout of an FD frame, identical to struct canfd_frame (72 bytes).
void encode_fd(const CanFdFrame& f, std::uint8_t out[CANFD_MTU]) {
  std::uint32_t id = f.id | (f.extended ? CAN_EFF_FLAG : 0u);
  std::memset(out, 0, CANFD_MTU);
  std::memcpy(out, &id, 4);
  out[4] = f.len;
  out[5] = static_cast<std::uint8_t>(CANFD_FDF | (f.brs ? CANFD_BRS : 0));
  std::memcpy(out + 8, f.data, f.len);
}

// Either layout, by size (16: classic, 72: FD), into the FD type.
bool decode_any(const std::uint8_t* in, std::size_t n, CanFdFrame* f) {
  if (n != CAN_MTU && n != CANFD_MTU) return false;
  std::uint32_t id;
  std::memcpy(&id, in, 4);
  if ((id & (CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0u) return false;
  f->extended = (id & CAN_EFF_FLAG) != 0u;
  f->id = f->extended ? (id & CAN_EFF_MASK) : (id & CAN_SFF_MASK);
  f->fd = n == CANFD_MTU;
  f->brs = f->fd && (in[5] & CANFD_BRS) != 0;
  f->len = in[4];
  if (f->len > (f->fd ? kCanFdMaxLen : 8u)) return false;
  std::memcpy(f->data, in + 8, f->len);
  return can_fd_frame_valid(*f);
}

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// ---- virtual bus -------------------------------------------------------------------------------------
class VirtualPort final : public LinuxCanPort {
 public:
  ~VirtualPort() override {
    if (!announce_.empty()) ::unlink(announce_.c_str());
    // The last endpoint to leave takes the bus's directory with it (rmdir fails while another endpoint's file
    // is in it): a bus named per process (the demo's, the tests') would otherwise stay behind in /tmp.
    if (!dir_.empty()) ::rmdir(dir_.c_str());
    if (fd_ >= 0) ::close(fd_);
  }

  bool open(const std::string& name, std::string* err) {
    const char* root = std::getenv("IMUFORGE_VCAN_DIR");
    std::string base = root != nullptr && *root != '\0' ? root : "/tmp/imuforge-vcan";
    if (::mkdir(base.c_str(), 01777) != 0 && errno != EEXIST) {
      *err = sys_error("virtual bus: mkdir " + base);
      return false;
    }
    dir_ = base + "/" + name;
    if (::mkdir(dir_.c_str(), 01777) != 0 && errno != EEXIST) {
      *err = sys_error("virtual bus: mkdir " + dir_);
      return false;
    }
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) {
      *err = sys_error("virtual bus: socket");
      return false;
    }
    // Loopback datagrams stay charged to the SENDER's buffer until every receiver has read them, so
    // a reader lagging ~50 ms behind a 3 kHz frame stream would make the default 208 KiB send buffer
    // refuse frames. Ask for 4 MiB each way (FORCE needs CAP_NET_ADMIN; the plain call is capped by
    // net.core.[rw]mem_max).
    int buf = 4 * 1024 * 1024;
    if (::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &buf, sizeof buf) != 0 &&
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buf, sizeof buf) != 0) {
      *err = sys_error("virtual bus: SO_RCVBUF");
      return false;
    }
    if (::setsockopt(fd_, SOL_SOCKET, SO_SNDBUFFORCE, &buf, sizeof buf) != 0 &&
        ::setsockopt(fd_, SOL_SOCKET, SO_SNDBUF, &buf, sizeof buf) != 0) {
      *err = sys_error("virtual bus: SO_SNDBUF");
      return false;
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      *err = sys_error("virtual bus: bind 127.0.0.1");
      return false;
    }
    socklen_t al = sizeof a;
    if (::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &al) != 0) {
      *err = sys_error("virtual bus: getsockname");
      return false;
    }
    port_ = ntohs(a.sin_port);
    fd_enabled_ = true;
    announce_ = dir_ + "/" + std::to_string(port_);
    if (!write_announce(err)) {
      announce_.clear();
      return false;
    }
    refresh(true);
    return true;
  }

  // The endpoint's acceptance filter, announced in its file so that SENDERS skip it for other ids: a
  // CAN controller's hardware filter costs the node nothing, while a filter applied after the datagram
  // arrived would still cost every endpoint a system call per frame of every node (16 units: 31
  // datagrams per frame, which is what lost the command responses under stream load).
  bool set_filter(const std::vector<std::uint32_t>& ids, bool extended, std::string* err) {
    filter_.clear();
    for (std::uint32_t id : ids) filter_.push_back(filter_key(id, extended));
    std::sort(filter_.begin(), filter_.end());
    return write_announce(err);
  }

  int fd() const noexcept override { return fd_; }

  int send(const CanFrame& frame) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    if (!can_frame_valid(frame)) return kCanErrArg;
    std::uint8_t buf[CAN_MTU];
    encode(frame, buf);
    return broadcast(buf, sizeof buf, filter_key(frame.id, frame.extended));
  }

  int send_fd(const CanFdFrame& frame) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    const int chk = can_fd_frame_check(frame);
    if (chk != kCanOk) return chk;
    if (!frame.fd) return send(can_frame_from_fd(frame));
    std::uint8_t buf[CANFD_MTU];
    encode_fd(frame, buf);
    return broadcast(buf, sizeof buf, filter_key(frame.id, frame.extended));
  }

  int receive_any(CanFdFrame& frame) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    for (;;) {
      std::uint8_t buf[CANFD_MTU + 8];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) return kCanErrWouldBlock;
        if (errno == EINTR || errno == ECONNREFUSED) continue;
        error_ = sys_error("virtual bus: recv");
        return kCanErrIo;
      }
      if (decode_any(buf, static_cast<std::size_t>(n), &frame)) return kCanOk;
    }
  }

 private:
  // One datagram (a classic or an FD frame) to every peer whose filter takes `key`.
  int broadcast(const std::uint8_t* buf, std::size_t len, std::uint32_t key) noexcept {
    refresh(false);
    for (const Peer& peer : peers_) {
      if (!peer.accept.empty() && !std::binary_search(peer.accept.begin(), peer.accept.end(), key)) continue;
      const sockaddr_in& p = peer.addr;
      ssize_t n = -1;
      for (int attempt = 0; attempt < 3; ++attempt) {
        n = ::sendto(fd_, buf, len, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&p), sizeof p);
        if (n >= 0 || (errno != EAGAIN && errno != ENOBUFS)) break;
        pollfd w{fd_, POLLOUT, 0};  // send buffer full: give the readers up to 2 ms, as a TX mailbox would
        (void)::poll(&w, 1, 2);
      }
      if (n == static_cast<ssize_t>(len)) continue;
      if (n < 0 && (errno == EAGAIN || errno == ENOBUFS || errno == ECONNREFUSED)) {
        ++tx_dropped_;  // a receiver that does not keep up loses frames, as on a real bus
        continue;
      }
      error_ = sys_error("virtual bus: sendto");
      return kCanErrIo;
    }
    return kCanOk;
  }

 private:
  // Re-reads the peer directory when it changed (mtime) or every 500 ms; removes files of dead pids.
  void refresh(bool force) {
    struct stat st{};
    const std::int64_t t = now_ms();
    if (::stat(dir_.c_str(), &st) != 0) return;
    const bool changed = st.st_mtim.tv_sec != mtime_.tv_sec || st.st_mtim.tv_nsec != mtime_.tv_nsec;
    if (!force && !changed && t - last_refresh_ms_ < 500) return;
    mtime_ = st.st_mtim;
    last_refresh_ms_ = t;
    std::vector<Peer> peers;
    DIR* d = ::opendir(dir_.c_str());
    if (d == nullptr) return;
    while (dirent* e = ::readdir(d)) {
      char* end = nullptr;
      const unsigned long port = std::strtoul(e->d_name, &end, 10);
      if (end == e->d_name || *end != '\0' || port == 0 || port > 65535) continue;
      if (port == port_) continue;
      const std::string path = dir_ + "/" + e->d_name;
      std::ifstream f(path);
      long pid = 0;
      if (f >> pid && pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
        ::unlink(path.c_str());
        continue;
      }
      Peer peer;
      peer.addr.sin_family = AF_INET;
      peer.addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      peer.addr.sin_port = htons(static_cast<std::uint16_t>(port));
      // Optional second line: the ids the endpoint accepts (none: every frame). An unreadable list
      // also means every frame: a peer gets too much rather than too little.
      std::string word;
      if (f >> word && word == "accept") {
        for (unsigned long long k; f >> k;) peer.accept.push_back(static_cast<std::uint32_t>(k));
        if (!f.eof()) peer.accept.clear();
        std::sort(peer.accept.begin(), peer.accept.end());
      }
      peers.push_back(std::move(peer));
    }
    ::closedir(d);
    peers_.swap(peers);
  }

  struct Peer {
    sockaddr_in addr{};
    std::vector<std::uint32_t> accept;  // filter_key()s, sorted; empty: every frame
  };
  static std::uint32_t filter_key(std::uint32_t id, bool extended) { return id | (extended ? CAN_EFF_FLAG : 0u); }

  // "<pid>\n" and, with a filter, "accept <key> <key> ...\n"; written to a temporary name and renamed,
  // so a sender never reads half a list and the directory's mtime tells it to re-read.
  bool write_announce(std::string* err) {
    const std::string tmp = dir_ + "/.tmp-" + std::to_string(port_);
    {
      std::ofstream f(tmp, std::ios::trunc);
      if (!f.is_open() && errno == ENOENT) {
        // The last endpoint before this one removed the bus's directory as it left (~VirtualPort) between
        // open()'s mkdir and this write: make it again. Once the file is in it, no rmdir can take it.
        ::mkdir(dir_.c_str(), 01777);
        f.open(tmp, std::ios::trunc);
      }
      f << ::getpid() << "\n";
      if (!filter_.empty()) {
        f << "accept";
        for (std::uint32_t k : filter_) f << ' ' << k;
        f << "\n";
      }
      f.close();
      if (!f) {
        *err = "virtual bus: cannot write " + tmp;
        ::unlink(tmp.c_str());
        return false;
      }
    }
    if (::rename(tmp.c_str(), announce_.c_str()) != 0) {
      *err = sys_error("virtual bus: rename " + tmp + " to " + announce_);
      ::unlink(tmp.c_str());
      return false;
    }
    return true;
  }

  int fd_ = -1;
  std::uint16_t port_ = 0;
  std::string dir_;
  std::string announce_;
  std::vector<std::uint32_t> filter_;
  std::vector<Peer> peers_;
  timespec mtime_{};
  std::int64_t last_refresh_ms_ = 0;
};

// ---- SocketCAN raw -------------------------------------------------------------------------------------
class SocketCanPort final : public LinuxCanPort {
 public:
  ~SocketCanPort() override {
    if (fd_ >= 0) ::close(fd_);
  }

  bool open(const std::string& ifname, bool want_fd, std::string* err) {
    if (ifname.empty() || ifname.size() >= IFNAMSIZ) {
      *err = "socketcan: bad interface name '" + ifname + "'";
      return false;
    }
    fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd_ < 0) {
      *err = sys_error("socketcan: socket(PF_CAN, SOCK_RAW, CAN_RAW)");
      return false;
    }
    ifreq ifr{};
    std::strncpy(ifr.ifr_name, ifname.c_str(), IFNAMSIZ - 1);
    if (::ioctl(fd_, SIOCGIFINDEX, &ifr) != 0) {
      *err = sys_error("socketcan: SIOCGIFINDEX " + ifname);
      return false;
    }
    const int ifindex = ifr.ifr_ifindex;
    if (::ioctl(fd_, SIOCGIFMTU, &ifr) != 0) {
      *err = sys_error("socketcan: SIOCGIFMTU " + ifname);
      return false;
    }
    if (want_fd && ifr.ifr_mtu == static_cast<int>(CANFD_MTU)) {
      const int on = 1;
      if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0) {
        *err = sys_error("socketcan: CAN_RAW_FD_FRAMES");
        return false;
      }
      fd_enabled_ = true;
    }
    // Large buffers absorb bursts (catch-up after a stall, a slow reader). The FORCE variants need
    // CAP_NET_ADMIN (root in the VM); otherwise the plain ones, capped by net.core.[rw]mem_max, apply.
    int snd = 4 * 1024 * 1024;
    if (::setsockopt(fd_, SOL_SOCKET, SO_SNDBUFFORCE, &snd, sizeof snd) != 0 &&
        ::setsockopt(fd_, SOL_SOCKET, SO_SNDBUF, &snd, sizeof snd) != 0) {
      *err = sys_error("socketcan: SO_SNDBUF");
      return false;
    }
    int rcv = 16 * 1024 * 1024;
    if (::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &rcv, sizeof rcv) != 0 &&
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof rcv) != 0) {
      *err = sys_error("socketcan: SO_RCVBUF");
      return false;
    }
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifindex;
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      *err = sys_error("socketcan: bind " + ifname);
      return false;
    }
    const int fl = ::fcntl(fd_, F_GETFL);
    if (fl < 0 || ::fcntl(fd_, F_SETFL, fl | O_NONBLOCK) != 0) {
      *err = sys_error("socketcan: O_NONBLOCK");
      return false;
    }
    return true;
  }

  int fd() const noexcept override { return fd_; }

  int send(const CanFrame& frame) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    if (!can_frame_valid(frame)) return kCanErrArg;
    std::uint8_t buf[CAN_MTU];
    encode(frame, buf);
    return write_frame(buf, sizeof buf);
  }

  int send_fd(const CanFdFrame& frame) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    const int chk = can_fd_frame_check(frame);
    if (chk != kCanOk) return chk;
    if (!frame.fd) return send(can_frame_from_fd(frame));
    if (!fd_enabled_) return kCanErrNoFd;
    std::uint8_t buf[CANFD_MTU];
    encode_fd(frame, buf);
    return write_frame(buf, sizeof buf);
  }

  int receive_any(CanFdFrame& frame) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    for (;;) {
      std::uint8_t buf[CANFD_MTU];
      const ssize_t n = ::read(fd_, buf, sizeof buf);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) return kCanErrWouldBlock;
        if (errno == EINTR) continue;
        error_ = sys_error("socketcan: read");
        return kCanErrIo;
      }
      if (decode_any(buf, static_cast<std::size_t>(n), &frame)) return kCanOk;
    }
  }

  int receive_many_any(CanFdFrame* frames, int max) noexcept override {
    if (fd_ < 0) return kCanErrClosed;
    constexpr int kBatch = 64;
    canfd_frame cf[kBatch];
    iovec iov[kBatch];
    mmsghdr msgs[kBatch];
    int k = 0;
    while (k < max) {
      const int want = std::min(kBatch, max - k);
      for (int i = 0; i < want; ++i) {
        iov[i] = iovec{&cf[i], sizeof cf[i]};
        msgs[i] = mmsghdr{};
        msgs[i].msg_hdr.msg_iov = &iov[i];
        msgs[i].msg_hdr.msg_iovlen = 1;
      }
      const int n = ::recvmmsg(fd_, msgs, static_cast<unsigned>(want), MSG_DONTWAIT, nullptr);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) break;
        if (errno == EINTR) continue;
        error_ = sys_error("socketcan: recvmmsg");
        return k > 0 ? k : kCanErrIo;
      }
      for (int i = 0; i < n; ++i) {
        if (decode_any(reinterpret_cast<const std::uint8_t*>(&cf[i]), msgs[i].msg_len, &frames[k])) ++k;
      }
      if (n < want) break;  // the queue is empty
    }
    return k;
  }

 private:
  // One struct can_frame or canfd_frame. A full socket/qdisc queue is normal at high rates: wait up to
  // 2 ms for room once, as a CAN controller's TX mailbox would, then report it to the caller.
  int write_frame(const std::uint8_t* buf, std::size_t len) noexcept {
    for (int attempt = 0; attempt < 2; ++attempt) {
      const ssize_t n = ::write(fd_, buf, len);
      if (n == static_cast<ssize_t>(len)) return kCanOk;
      if (n >= 0) {
        error_ = "socketcan: short write";
        return kCanErrIo;
      }
      if (errno == ENETDOWN) return kCanErrBusOff;
      if (errno != EAGAIN && errno != ENOBUFS && errno != EINTR) {
        error_ = sys_error("socketcan: write");
        return kCanErrIo;
      }
      pollfd p{fd_, POLLOUT, 0};
      (void)::poll(&p, 1, 2);
    }
    ++tx_dropped_;
    return kCanErrWouldBlock;
  }

  int fd_ = -1;
};

}  // namespace

// The classic reads are the FD-aware ones with the FD frames skipped: one receive path per backend.
int LinuxCanPort::receive(CanFrame& frame) noexcept {
  for (;;) {
    CanFdFrame a;
    const int rc = receive_any(a);
    if (rc != kCanOk) return rc;
    if (a.fd) continue;
    frame = can_frame_from_fd(a);
    return kCanOk;
  }
}

int LinuxCanPort::receive_many(CanFrame* frames, int max) noexcept {
  CanFdFrame batch[64];
  int k = 0;
  while (k < max) {
    const int want = std::min(64, max - k);
    const int n = receive_many_any(batch, want);
    if (n < 0) return k > 0 ? k : n;
    for (int i = 0; i < n; ++i) {
      if (!batch[i].fd) frames[k++] = can_frame_from_fd(batch[i]);
    }
    if (n < want) break;  // the queue is empty
  }
  return k;
}

int LinuxCanPort::receive_many_any(CanFdFrame* frames, int max) noexcept {
  int k = 0;
  while (k < max) {
    const int rc = receive_any(frames[k]);
    if (rc == kCanErrWouldBlock) break;
    if (rc != kCanOk) return k > 0 ? k : rc;
    ++k;
  }
  return k;
}

int LinuxCanPort::wait_readable(int timeout_ms) noexcept {
  pollfd p{fd(), POLLIN, 0};
  const int pr = ::poll(&p, 1, timeout_ms);
  if (pr < 0 && errno != EINTR) {
    error_ = sys_error("poll");
    return kCanErrIo;
  }
  return pr > 0 ? 1 : 0;
}

int LinuxCanPort::receive_many_any_wait(CanFdFrame* frames, int max, int timeout_ms) noexcept {
  if (max <= 0) return 0;
  const int k = receive_many_any(frames, max);
  if (k != 0) return k;
  const int w = wait_readable(timeout_ms);
  return w <= 0 ? w : receive_many_any(frames, max);
}

int LinuxCanPort::receive_many_wait(CanFrame* frames, int max, int timeout_ms) noexcept {
  if (max <= 0) return 0;
  const int k = receive_many(frames, max);
  if (k != 0) return k;
  const int w = wait_readable(timeout_ms);
  return w <= 0 ? w : receive_many(frames, max);
}

int LinuxCanPort::receive_wait(CanFrame& frame, int timeout_ms) noexcept {
  const int rc = receive(frame);
  if (rc != kCanErrWouldBlock) return rc;
  const int w = wait_readable(timeout_ms);
  if (w < 0) return w;
  return w == 0 ? kCanErrWouldBlock : receive(frame);
}

bool parse_bus_spec(const std::string& spec, BusSpec* out, std::string* err) {
  const auto colon = spec.find(':');
  if (colon == std::string::npos || colon + 1 >= spec.size()) {
    *err = "bad bus spec '" + spec + "': expected virtual:<name> or socketcan:<ifname>";
    return false;
  }
  const std::string kind = spec.substr(0, colon);
  const std::string name = spec.substr(colon + 1);
  for (char c : name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) {
      *err = "bad bus spec '" + spec + "': name may hold only letters, digits, '_', '-', '.'";
      return false;
    }
  }
  if (kind == "virtual") {
    out->kind = BusSpec::Kind::kVirtual;
  } else if (kind == "socketcan") {
    out->kind = BusSpec::Kind::kSocketCan;
  } else {
    *err = "bad bus spec '" + spec + "': unknown kind '" + kind + "' (virtual, socketcan)";
    return false;
  }
  out->name = name;
  return true;
}

std::unique_ptr<LinuxCanPort> open_can_port(const std::string& spec, std::string* err, bool want_fd) {
  BusSpec bs;
  if (!parse_bus_spec(spec, &bs, err)) return nullptr;
  if (bs.kind == BusSpec::Kind::kVirtual) {
    auto p = std::make_unique<VirtualPort>();
    if (!p->open(bs.name, err)) return nullptr;
    return p;
  }
  auto p = std::make_unique<SocketCanPort>();
  if (!p->open(bs.name, want_fd, err)) return nullptr;
  return p;
}

bool set_can_filter(LinuxCanPort& port, const std::vector<std::uint32_t>& ids, bool extended, std::string* err) {
  if (auto* v = dynamic_cast<VirtualPort*>(&port)) return v->set_filter(ids, extended, err);
  if (dynamic_cast<SocketCanPort*>(&port) == nullptr) return true;
  std::vector<can_filter> f;
  for (std::uint32_t id : ids) {
    can_filter x{};
    x.can_id = id | (extended ? CAN_EFF_FLAG : 0u);
    x.can_mask = (extended ? CAN_EFF_MASK : CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG;
    f.push_back(x);
  }
  if (::setsockopt(port.fd(), SOL_CAN_RAW, CAN_RAW_FILTER, f.data(),
                   static_cast<socklen_t>(f.size() * sizeof(can_filter))) != 0) {
    *err = sys_error("socketcan: CAN_RAW_FILTER");
    return false;
  }
  return true;
}

// ---- kernel ISO-TP -----------------------------------------------------------------------------------
KernelIsotp::~KernelIsotp() { close(); }

void KernelIsotp::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool KernelIsotp::open(const std::string& ifname, std::uint32_t tx_id, std::uint32_t rx_id, bool extended,
                       std::uint8_t bs, std::uint8_t st_min_raw, std::string* err) {
  close();
  if (ifname.empty() || ifname.size() >= IFNAMSIZ) {
    *err = "isotp: bad interface name '" + ifname + "'";
    return false;
  }
  fd_ = ::socket(PF_CAN, SOCK_DGRAM | SOCK_CLOEXEC, CAN_ISOTP);
  if (fd_ < 0) {
    *err = sys_error("isotp: socket(PF_CAN, SOCK_DGRAM, CAN_ISOTP) (is can-isotp loaded?)");
    return false;
  }
  can_isotp_options opts{};
  opts.flags = CAN_ISOTP_TX_PADDING | CAN_ISOTP_WAIT_TX_DONE;
  opts.txpad_content = CAN_ISOTP_DEFAULT_PAD_CONTENT;
  opts.rxpad_content = CAN_ISOTP_DEFAULT_PAD_CONTENT;
  opts.frame_txtime = CAN_ISOTP_DEFAULT_FRAME_TXTIME;
  if (::setsockopt(fd_, SOL_CAN_ISOTP, CAN_ISOTP_OPTS, &opts, sizeof opts) != 0) {
    *err = sys_error("isotp: CAN_ISOTP_OPTS");
    close();
    return false;
  }
  can_isotp_fc_options fc{};
  fc.bs = bs;
  fc.stmin = st_min_raw;
  fc.wftmax = 0;
  if (::setsockopt(fd_, SOL_CAN_ISOTP, CAN_ISOTP_RECV_FC, &fc, sizeof fc) != 0) {
    *err = sys_error("isotp: CAN_ISOTP_RECV_FC");
    close();
    return false;
  }
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, ifname.c_str(), IFNAMSIZ - 1);
  if (::ioctl(fd_, SIOCGIFINDEX, &ifr) != 0) {
    *err = sys_error("isotp: SIOCGIFINDEX " + ifname);
    close();
    return false;
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  addr.can_addr.tp.tx_id = tx_id | (extended ? CAN_EFF_FLAG : 0u);
  addr.can_addr.tp.rx_id = rx_id | (extended ? CAN_EFF_FLAG : 0u);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    *err = sys_error("isotp: bind " + ifname);
    close();
    return false;
  }
  return true;
}

bool KernelIsotp::send(const std::uint8_t* data, std::size_t len, std::string* err) {
  if (fd_ < 0) {
    *err = "isotp: not open";
    return false;
  }
  for (;;) {
    const ssize_t n = ::write(fd_, data, len);
    if (n == static_cast<ssize_t>(len)) return true;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      // ECOMM: the kernel's N_Bs timer expired (no flow control from the node); EMSGSIZE: too long.
      *err = sys_error("isotp: write");
    } else {
      *err = "isotp: short write";
    }
    return false;
  }
}

bool KernelIsotp::recv(std::vector<std::uint8_t>* out, int timeout_ms, std::string* err) {
  if (fd_ < 0) {
    *err = "isotp: not open";
    return false;
  }
  const std::int64_t deadline = now_ms() + timeout_ms;
  for (;;) {
    const std::int64_t left = deadline - now_ms();
    if (left <= 0) {
      *err = "timeout";
      return false;
    }
    pollfd p{fd_, POLLIN, 0};
    const int pr = ::poll(&p, 1, static_cast<int>(left));
    if (pr < 0) {
      if (errno == EINTR) continue;
      *err = sys_error("isotp: poll");
      return false;
    }
    if (pr == 0) {
      *err = "timeout";
      return false;
    }
    out->resize(8200);
    const ssize_t n = ::read(fd_, out->data(), out->size());
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      // ECOMM / EILSEQ / EBADMSG: the kernel aborted a reception (N_Cr timeout, wrong SN); report it
      *err = sys_error("isotp: read");
      return false;
    }
    out->resize(static_cast<std::size_t>(n));
    return true;
  }
}

}  // namespace imuforge::hal
