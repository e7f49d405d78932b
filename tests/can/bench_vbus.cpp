// Virtual CAN bus figures (issue 14, not a test): what the embedded virtual bus (hal/linux, loopback UDP,
// one datagram per frame and accepting endpoint) carries when N units stream at the same sample rate,
// classic (3 frames of 8 bytes per sample) against CAN FD (1 frame of 64 bytes per 4 samples), and the CPU
// it costs. In-process: N virtual IMUs (the firmware node) and N host clients on one virtual bus.
//   can_bench_vbus [units=16] [rate_hz=1000] [seconds=3]
// Per mode, over the steady window (from 0.5 s after the streams started to `seconds`): stream frames per
// wall second received by the clients, samples per wall second delivered, and the process CPU (user +
// system: nodes, bus and clients) per 1000 delivered samples; over the whole run: samples lost (seq gaps)
// and frames the bus dropped (a reader fell behind). The machines are shared: the 1-minute load is
// printed with each row.
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "host/can/client.h"
#include "host/vimu/virtual_imu.h"
#include "tests/can/vcan_dir.h"

using namespace imuforge;

namespace {

double cpu_s() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  auto sec = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return sec(r.ru_utime) + sec(r.ru_stime);
}

}  // namespace

int main(int argc, char** argv) {
  const int units = argc > 1 ? std::atoi(argv[1]) : 16;
  const int rate = argc > 2 ? std::atoi(argv[2]) : 1000;
  const double seconds = argc > 3 ? std::atof(argv[3]) : 3.0;
  if (units < 1 || units > 63 || rate < 1 || rate > 2000 || !(seconds > 0)) {
    std::fprintf(stderr, "can_bench_vbus: units 1..63, rate_hz 1..2000, seconds > 0\n");
    return 2;
  }
  std::printf("| mode | units | rate Hz | window s | frames/s | samples/s | lost | bus dropped | CPU s per 1000 samples | load 1 min |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (bool fd : {false, true}) {
    const std::string bus = imuforge::testing::virtual_test_bus(std::string("bench-") + (fd ? "fd" : "classic"));
    std::vector<std::unique_ptr<vimu::VirtualImu>> imus;
    std::vector<std::unique_ptr<can::Client>> clients;
    for (int k = 0; k < units; ++k) {
      vimu::VirtualImuConfig c;
      c.bus = bus;
      c.node_id = static_cast<std::uint8_t>(k + 1);
      c.serial = static_cast<std::uint64_t>(k + 1);
      imus.push_back(std::make_unique<vimu::VirtualImu>(c));
      imus.back()->start();
    }
    for (int k = 0; k < units; ++k) clients.push_back(can::Client::connect(bus, static_cast<std::uint8_t>(k + 1)));
    for (auto& c : clients) c->start_stream(static_cast<std::uint16_t>(rate), proto::kChAll, nullptr, fd);
    auto totals = [&](std::uint64_t* frames, std::uint64_t* received) {
      *frames = *received = 0;
      for (auto& c : clients) {
        const auto k = c->stream_counters();
        *frames += k.frames;
        *received += k.received;
      }
    };
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    std::uint64_t f0 = 0, r0 = 0, f1 = 0, r1 = 0;
    totals(&f0, &r0);
    const double cpu0 = cpu_s();
    const auto t0 = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds - 0.5));
    totals(&f1, &r1);
    const double cpu = cpu_s() - cpu0;
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (auto& c : clients) c->stop_stream(100);
    const double frames = static_cast<double>(f1 - f0), received = static_cast<double>(r1 - r0);
    std::uint64_t lost = 0, dropped = 0;
    for (auto& c : clients) lost += c->stream_counters().lost;
    clients.clear();
    for (auto& i : imus) {
      i->stop();
      dropped += i->bus_tx_dropped();
    }
    double load[1] = {0};
    (void)getloadavg(load, 1);
    std::printf("| %s | %d | %d | %.2f | %.0f | %.0f | %llu | %llu | %.3f | %.1f |\n", fd ? "CAN FD" : "classic", units, rate,
                wall, frames / wall, received / wall, static_cast<unsigned long long>(lost),
                static_cast<unsigned long long>(dropped), received > 0 ? 1000.0 * cpu / received : 0.0, load[0]);
    std::fflush(stdout);
  }
  return 0;
}
