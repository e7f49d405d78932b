// `imuforge demo`: the whole end-of-line run on the embedded defaults. It starts `imuforge bench-sim`
// (Modbus TCP on loopback, the virtual IMU on a private virtual CAN bus, accelerated time), writes a demo
// station file, runs docs/examples/campaign-eol.json with docs/examples/model-thermal.json into SQLite,
// stops the bench and prints where the report is. docs/eol.md "Demo".
#pragma once
#include <string>
#include <vector>

namespace imuforge::eol {

struct DemoOptions {
  std::string out_dir = "demo-out";
  std::string self_exe = "/proc/self/exe";  // the imuforge program (for bench-sim)
  std::string examples_dir;                 // "" = find docs/examples from the source tree / the binary
  std::string campaign;                     // "" = examples/campaign-eol.json
  std::string model;                        // "" = examples/model-thermal.json
  double time_scale = 100.0;                // simulated seconds per wall second
  // false: a multi-unit run lowers time_scale to what the virtual CAN bus carries
  // (demo_time_scale()); true: time_scale as given (the user chose it).
  bool time_scale_fixed = false;
  double stream_rate_hz = 10.0;             // samples per SIMULATED second
  bool can_fd = false;                      // the station streams CAN FD frames (station can.fd)
  bool early_stop = true;
  bool quiet = false;
  // Multi-unit station (slots > 1): bench-sim serves `slots` virtual IMUs (nodes 1..slots, serials
  // 1..slots), the dead ones never answer, the outlier ones are another part (accel.scale.x + 0.015).
  int slots = 1;
  std::vector<int> dead_slots, outlier_slots;
  int threads = 0;
  // Test hooks (multi-unit only): resume this earlier demo run folder instead of a new one (the same
  // bench-sim world starts again: a lab power cycle), and crash after this many steps.
  std::string resume_run_dir;
  int crash_after_steps = 0;
  int tcp_port = 0;  // bench-sim's Modbus TCP port (0: any free one); a resumed demo needs the same station file

  // Filled by a multi-unit demo when set (the station figures, tests/eol/bench_station.cpp).
  struct Stats {
    int units = 0, passed = 0;
    double campaign_time_s = 0.0;  // simulated fixture seconds of the collection
    double time_scale = 0.0;       // the one the run used (demo_time_scale())
    double collect_wall_s = 0.0, finish_wall_s = 0.0;
    bool early_stopped = false;
    std::vector<double> finish_cpu_s;  // per unit
  }* stats = nullptr;
};

// Returns an exit code of host/app/command.h (0 PASS, 1 FAIL/bad input, 3 peer failure).
int run_demo(const DemoOptions& opt);

// What the virtual CAN bus (hal/linux/linux_can.h: loopback UDP, one datagram per frame and accepting
// endpoint, all endpoints in the processes of one shared machine) carries, in samples per WALL second
// summed over the units. Measured, not derived: docs/eol.md "Multi-unit stations", figures.
constexpr double kVirtualBusSamplesPerWallS = 16000.0;

// The time scale a run of `slots` units at `rate_hz` simulated samples per second uses: `wanted`, or
// lower if it would stream more than kVirtualBusSamplesPerWallS, or ask a node for more than
// kCanDeviceMaxNodeRateHz (host/eol/adapters.h: the run would silently sample fewer times per simulated
// second), unless `fixed` (the user's choice).
double demo_time_scale(double wanted, int slots, double rate_hz, bool fixed);

// The docs/examples folder: examples_dir if set, else the source tree this binary was built from, else
// relative to the executable (build/<preset>/bin/ -> ../../../docs/examples). Throws if none exists.
std::string find_examples_dir(const std::string& hint, const std::string& self_exe);

}  // namespace imuforge::eol
