// imuforge-vimu: the virtual IMU program. The firmware CAN node with a simulated sensor (stand-in
// signal) and simulated flash, on a virtual CAN bus or SocketCAN. See docs/can-protocol.md.
#include <csignal>
#include <cstdio>
#include <iostream>
#include <thread>

#include <CLI/CLI.hpp>

#include "host/can/client.h"
#include "host/vimu/virtual_imu.h"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"imuforge-vimu: virtual IMU (firmware CAN node + simulated sensor)"};
  imuforge::vimu::VirtualImuConfig cfg;
  std::string key_hex;
  double duration_s = 0;
  unsigned node = cfg.node_id;
  app.add_option("--bus", cfg.bus, "virtual:<name> or socketcan:<ifname>")->capture_default_str();
  app.add_option("--node", node, "node id 0..63")->check(CLI::Range(0, 63))->capture_default_str();
  app.add_option("--serial", cfg.serial, "device serial number")->capture_default_str();
  app.add_flag("--ext", cfg.extended_ids, "use 29-bit identifiers");
  app.add_option("--key-hex", key_hex, "device HMAC key, 64 hex digits (default: the dev key of the serial)");
  app.add_option("--flash-file", cfg.flash_file, "persist the simulated flash in this file");
  app.add_option("--duration-s", duration_s, "exit after this many seconds (0: until SIGINT/SIGTERM)");
  app.add_option("--fifo-depth", cfg.fifo_depth_samples,
                 "depth of the node's sample FIFO: samples kept while the node runs late (default 5000)");
  bool classic_only = false;
  app.add_flag("--classic-only", classic_only, "a classic CAN controller: refuse CAN FD streams");
  unsigned bs = cfg.isotp_block_size;
  app.add_option("--isotp-bs", bs, "ISO-TP block size announced to the host")->check(CLI::Range(0, 255));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  cfg.node_id = static_cast<std::uint8_t>(node);
  cfg.can_fd = !classic_only;
  cfg.isotp_block_size = static_cast<std::uint8_t>(bs);
  if (!key_hex.empty()) {
    try {
      cfg.key = imuforge::can::key_from_hex(key_hex);
      cfg.has_key = true;
    } catch (const std::exception& e) {
      std::cerr << "imuforge-vimu: --key-hex: " << e.what() << "\n";
      return 2;
    }
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    imuforge::vimu::VirtualImu imu(cfg);
    imu.start();
    std::printf("ready bus=%s node=%u serial=%llu\n", cfg.bus.c_str(), node, static_cast<unsigned long long>(cfg.serial));
    std::fflush(stdout);
    const auto t0 = std::chrono::steady_clock::now();
    while (!g_stop) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (duration_s > 0 &&
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >= duration_s) {
        break;
      }
    }
    imu.stop();
    const auto k = imu.counters();
    std::fprintf(stderr,
                 "imuforge-vimu: samples_sent=%u frames_tx=%u frames_dropped=%u fifo_overflow=%u bus_tx_dropped=%llu "
                 "commands_ok=%u rejected=%u\n",
                 k.samples_sent, k.stream_frames_tx, k.stream_frames_dropped, k.samples_fifo_overflow,
                 static_cast<unsigned long long>(imu.bus_tx_dropped()), k.commands_ok, k.commands_rejected);
  } catch (const std::exception& e) {
    std::cerr << "imuforge-vimu: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
