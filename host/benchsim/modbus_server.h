// bench-sim's Modbus servers (libmodbus): TCP on a loopback port (port 0 picks a free one) and RTU on a
// pseudo-terminal it creates (openpty; clients open the slave path it reports) or on an existing serial
// device (e.g. one end of a `socat` pty pair). Both serve the same Bench, one thread each.
//
// Function codes: 3 (read holding registers), 4 (same registers, as input registers), 6 and 16
// (write). Anything else is answered with exception 1 (illegal function).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "host/benchsim/bench.h"

namespace imuforge::benchsim {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  int tcp_port = 0;           // 0: any free port; < 0: no TCP server
  bool rtu_pty = false;       // create a pty and serve RTU on it
  std::string rtu_device;     // or serve RTU on this existing device
  int baud = 115200;
  int unit_id = 1;            // RTU slave address (TCP answers any unit id)
  bool debug = false;         // libmodbus frame dump on stderr
};

class ModbusServer {
 public:
  ModbusServer(Bench& bench, ServerOptions opt);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // Bind/open and start serving. Throws std::runtime_error with the cause (port in use, no pty...).
  void start();
  // Stop serving and close every socket and the pty (clients see the server die).
  void stop();

  int tcp_port() const { return tcp_port_; }
  const std::string& rtu_path() const { return rtu_path_; }
  uint64_t requests() const { return requests_.load(); }

 private:
  void tcp_loop();
  void rtu_loop();
  void serve(void* ctx, const uint8_t* req, int len);

  Bench& bench_;
  ServerOptions opt_;
  void* tcp_ctx_ = nullptr;
  void* rtu_ctx_ = nullptr;
  int listen_fd_ = -1;
  int pty_master_ = -1, pty_slave_ = -1;
  int rtu_fd_ = -1;
  int tcp_port_ = -1;
  std::string rtu_path_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> requests_{0};
  std::thread tcp_thread_, rtu_thread_;
};

}  // namespace imuforge::benchsim
