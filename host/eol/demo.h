// `imuforge demo`: the whole end-of-line run on the embedded defaults. It starts `imuforge bench-sim`
// (Modbus TCP on loopback, the virtual IMU on a private virtual CAN bus, accelerated time), writes a demo
// station file, runs docs/examples/campaign-eol.json with docs/examples/model-thermal.json into SQLite,
// stops the bench and prints where the report is. docs/eol.md "Demo".
#pragma once
#include <string>

namespace imuforge::eol {

struct DemoOptions {
  std::string out_dir = "demo-out";
  std::string self_exe = "/proc/self/exe";  // the imuforge program (for bench-sim)
  std::string examples_dir;                 // "" = find docs/examples from the source tree / the binary
  std::string campaign;                     // "" = examples/campaign-eol.json
  std::string model;                        // "" = examples/model-thermal.json
  double time_scale = 100.0;                // simulated seconds per wall second
  double stream_rate_hz = 10.0;             // samples per SIMULATED second
  bool early_stop = true;
  bool quiet = false;
};

// Returns an exit code of host/app/command.h (0 PASS, 1 FAIL/bad input, 3 peer failure).
int run_demo(const DemoOptions& opt);

// The docs/examples folder: examples_dir if set, else the source tree this binary was built from, else
// relative to the executable (build/<preset>/bin/ -> ../../../docs/examples). Throws if none exists.
std::string find_examples_dir(const std::string& hint, const std::string& self_exe);

}  // namespace imuforge::eol
