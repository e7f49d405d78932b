#include "host/benchsim/modbus_server.h"

#include <modbus/modbus.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <pty.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace imuforge::benchsim {

namespace {
modbus_t* M(void* p) { return static_cast<modbus_t*>(p); }

std::string err_text() { return std::strerror(errno); }

void sleep_ms(int ms) {
  if (ms > 0) usleep(static_cast<useconds_t>(ms) * 1000u);
}
}  // namespace

Bench::Bench(std::unique_ptr<World> world, RegisterBank bank, double time_scale)
    : world_(std::move(world)), bank_(std::move(bank)), time_scale_(time_scale), t0_(std::chrono::steady_clock::now()) {
  if (!(time_scale_ > 0)) throw std::runtime_error("bench-sim: time scale must be > 0");
  bank_.init_from(*world_);
}

double Bench::now_s() const {
  if (clock_) return clock_();
  return time_scale_ * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

void Bench::sync() {
  world_->advance_to(now_s());
  bank_.publish(*world_);
}

ModbusServer::ModbusServer(Bench& bench, ServerOptions opt) : bench_(bench), opt_(std::move(opt)) {}

ModbusServer::~ModbusServer() { stop(); }

void ModbusServer::start() {
  stop_ = false;
  if (opt_.tcp_port >= 0) {
    tcp_ctx_ = modbus_new_tcp(opt_.bind.c_str(), opt_.tcp_port);
    if (!tcp_ctx_) throw std::runtime_error("bench-sim: cannot create the TCP context: " + err_text());
    modbus_set_debug(M(tcp_ctx_), opt_.debug ? TRUE : FALSE);
    listen_fd_ = modbus_tcp_listen(M(tcp_ctx_), 16);
    if (listen_fd_ < 0) {
      const std::string e = err_text();
      modbus_free(M(tcp_ctx_));
      tcp_ctx_ = nullptr;
      throw std::runtime_error("bench-sim: cannot listen on " + opt_.bind + ":" + std::to_string(opt_.tcp_port) + ": " + e);
    }
    sockaddr_in sa{};
    socklen_t sl = sizeof sa;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&sa), &sl);
    tcp_port_ = ntohs(sa.sin_port);
  }
  if (opt_.rtu_pty || !opt_.rtu_device.empty()) {
    if (opt_.rtu_pty) {
      char name[128] = {0};
      if (openpty(&pty_master_, &pty_slave_, name, nullptr, nullptr) != 0)
        throw std::runtime_error("bench-sim: openpty failed: " + err_text());
      // Raw line: no echo or line editing may touch the binary RTU frames before a client configures it.
      termios t{};
      tcgetattr(pty_slave_, &t);
      cfmakeraw(&t);
      tcsetattr(pty_slave_, TCSANOW, &t);
      rtu_path_ = name;
      rtu_ctx_ = modbus_new_rtu(name, opt_.baud, 'N', 8, 1);
      if (!rtu_ctx_) throw std::runtime_error("bench-sim: cannot create the RTU context: " + err_text());
      // The server talks on the master side; we keep our own slave fd open so the master never sees a
      // hang-up (EIO) between clients.
      modbus_set_socket(M(rtu_ctx_), pty_master_);
      rtu_fd_ = pty_master_;
    } else {
      rtu_ctx_ = modbus_new_rtu(opt_.rtu_device.c_str(), opt_.baud, 'N', 8, 1);
      if (!rtu_ctx_) throw std::runtime_error("bench-sim: cannot create the RTU context: " + err_text());
      if (modbus_connect(M(rtu_ctx_)) == -1) {
        const std::string e = modbus_strerror(errno);
        modbus_free(M(rtu_ctx_));
        rtu_ctx_ = nullptr;
        throw std::runtime_error("bench-sim: cannot open RTU device " + opt_.rtu_device + ": " + e);
      }
      rtu_path_ = opt_.rtu_device;
      rtu_fd_ = modbus_get_socket(M(rtu_ctx_));
    }
    modbus_set_slave(M(rtu_ctx_), opt_.unit_id);
    modbus_set_debug(M(rtu_ctx_), opt_.debug ? TRUE : FALSE);
  }
  if (tcp_ctx_) tcp_thread_ = std::thread([this] { tcp_loop(); });
  if (rtu_ctx_) rtu_thread_ = std::thread([this] { rtu_loop(); });
}

void ModbusServer::stop() {
  stop_ = true;
  if (tcp_thread_.joinable()) tcp_thread_.join();
  if (rtu_thread_.joinable()) rtu_thread_.join();
  if (listen_fd_ >= 0) close(listen_fd_);
  listen_fd_ = -1;
  if (tcp_ctx_) {
    modbus_set_socket(M(tcp_ctx_), -1);
    modbus_free(M(tcp_ctx_));
    tcp_ctx_ = nullptr;
  }
  if (rtu_ctx_) {
    if (!opt_.rtu_pty) modbus_close(M(rtu_ctx_));
    modbus_free(M(rtu_ctx_));
    rtu_ctx_ = nullptr;
  }
  if (pty_master_ >= 0) close(pty_master_);
  if (pty_slave_ >= 0) close(pty_slave_);
  pty_master_ = pty_slave_ = rtu_fd_ = -1;
}

void ModbusServer::tcp_loop() {
  std::vector<int> clients;
  std::vector<uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH);
  while (!stop_) {
    fd_set rd;
    FD_ZERO(&rd);
    FD_SET(listen_fd_, &rd);
    int maxfd = listen_fd_;
    for (int c : clients) {
      FD_SET(c, &rd);
      maxfd = std::max(maxfd, c);
    }
    timeval tv{0, 50000};  // wake up regularly to notice stop()
    const int n = select(maxfd + 1, &rd, nullptr, nullptr, &tv);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (n == 0) continue;
    if (FD_ISSET(listen_fd_, &rd)) {
      const int s = accept(listen_fd_, nullptr, nullptr);
      if (s >= 0) clients.push_back(s);
    }
    for (size_t i = 0; i < clients.size();) {
      const int c = clients[i];
      if (!FD_ISSET(c, &rd)) {
        ++i;
        continue;
      }
      modbus_set_socket(M(tcp_ctx_), c);
      const int rc = modbus_receive(M(tcp_ctx_), query.data());
      if (rc > 0) serve(tcp_ctx_, query.data(), rc);
      if (rc < 0) {
        close(c);  // client gone or sent garbage: drop it, as a real controller would
        clients.erase(clients.begin() + static_cast<long>(i));
        continue;
      }
      ++i;
    }
  }
  for (int c : clients) close(c);
}

void ModbusServer::rtu_loop() {
  std::vector<uint8_t> query(MODBUS_RTU_MAX_ADU_LENGTH);
  while (!stop_) {
    fd_set rd;
    FD_ZERO(&rd);
    FD_SET(rtu_fd_, &rd);
    timeval tv{0, 50000};
    const int n = select(rtu_fd_ + 1, &rd, nullptr, nullptr, &tv);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (n == 0) continue;
    const int rc = modbus_receive(M(rtu_ctx_), query.data());
    if (rc > 0) {
      serve(rtu_ctx_, query.data(), rc);
    } else if (rc < 0) {
      // Bad CRC, truncated frame or a line error: discard what is buffered and listen again.
      if (errno == EIO) sleep_ms(10);
      modbus_flush(M(rtu_ctx_));
    }
  }
}

void ModbusServer::serve(void* vctx, const uint8_t* req, int len) {
  modbus_t* ctx = M(vctx);
  ++requests_;
  const int off = modbus_get_header_length(ctx);
  Faults& f = bench_.faults();
  if (f.exception_count.load() > 0) {
    --f.exception_count;
    modbus_reply_exception(ctx, req, static_cast<unsigned>(f.exception_code.load()));
    return;
  }
  if (f.ignore_count.load() > 0) {
    --f.ignore_count;
    return;
  }
  bool drop = false;
  if (f.drop_count.load() > 0) {
    --f.drop_count;
    drop = true;
  }
  int delay = 0;
  if (f.delay_ms.load() > 0 && f.delay_count.load() != 0) {
    if (f.delay_count.load() > 0) --f.delay_count;
    delay = f.delay_ms.load();
  }

  std::lock_guard<std::mutex> lock(bench_.mutex());
  RegisterBank& bank = bench_.bank();
  bench_.sync();
  modbus_mapping_t map{};
  map.nb_registers = bank.size();
  map.tab_registers = bank.registers();
  map.nb_input_registers = bank.size();  // FC4 reads the same registers
  map.tab_input_registers = bank.registers();

  const uint8_t fc = req[off];
  if (fc != MODBUS_FC_READ_HOLDING_REGISTERS && fc != MODBUS_FC_READ_INPUT_REGISTERS &&
      fc != MODBUS_FC_WRITE_SINGLE_REGISTER && fc != MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
    modbus_reply_exception(ctx, req, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
    return;
  }
  if (len < off + 5) return;  // libmodbus checked the frame; a short one cannot reach here, but never read past it
  const uint16_t addr = static_cast<uint16_t>((req[off + 1] << 8) | req[off + 2]);
  std::vector<uint16_t> words;
  switch (fc) {
    case MODBUS_FC_READ_HOLDING_REGISTERS:
    case MODBUS_FC_READ_INPUT_REGISTERS:
      break;
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
      words.push_back(static_cast<uint16_t>((req[off + 3] << 8) | req[off + 4]));
      break;
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS: {
      const int nb = (req[off + 3] << 8) | req[off + 4];
      if (nb < 1 || nb > MODBUS_MAX_WRITE_REGISTERS || len < off + 6 + 2 * nb) {
        modbus_reply_exception(ctx, req, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        return;
      }
      for (int i = 0; i < nb; ++i)
        words.push_back(static_cast<uint16_t>((req[off + 6 + 2 * i] << 8) | req[off + 7 + 2 * i]));
      break;
    }
    default:
      modbus_reply_exception(ctx, req, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
      return;
  }
  if (!words.empty()) {
    std::string why;
    const int code = bank.check_write(addr, words.data(), static_cast<int>(words.size()), &why);
    if (code != 0) {
      if (opt_.debug) std::fprintf(stderr, "bench-sim: refused write: %s\n", why.c_str());
      modbus_reply_exception(ctx, req, static_cast<unsigned>(code));
      return;
    }
    bank.apply_write(addr, words.data(), static_cast<int>(words.size()), bench_.world());
  }
  if (drop) return;
  sleep_ms(delay);  // a slow controller: the request is processed, the answer comes late
  modbus_reply(ctx, req, len, &map);
}

}  // namespace imuforge::benchsim
