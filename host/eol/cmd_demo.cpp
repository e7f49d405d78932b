// `imuforge demo --out DIR`: the end-to-end end-of-line run on the embedded defaults (host/eol/demo.h).
#include <CLI/CLI.hpp>
#include <cstdio>

#include "host/app/command.h"
#include "host/can/client.h"
#include "host/fixture/fixture.h"
#include "host/eol/demo.h"
#include "host/eol/journal.h"
#include "host/eol/runner.h"
#include "host/eol/station.h"
#include "host/records/store.h"

namespace {

int run_demo_cmd(int argc, char** argv) {
  using namespace imuforge;
  CLI::App app{"End-to-end demo: bench simulator (Modbus TCP on loopback), the virtual IMU on a virtual CAN bus, "
               "the realistic campaign docs/examples/campaign-eol.json in accelerated time, SQLite records, report.html"};
  eol::DemoOptions o;
  bool full = false;
  app.add_option("--out", o.out_dir, "output folder (default demo-out)");
  CLI::Option* ts_opt =
      app.add_option("--time-scale", o.time_scale,
                     "simulated seconds per wall second (default 100; lowered to what the virtual CAN bus and a 1000 Hz node rate allow)")
          ->check(CLI::PositiveNumber);
  app.add_option("--rate", o.stream_rate_hz, "IMU samples per simulated second (default 10)")->check(CLI::PositiveNumber);
  app.add_option("--campaign", o.campaign, "campaign file (default docs/examples/campaign-eol.json)");
  app.add_option("--model", o.model, "solver model file (default docs/examples/model-thermal.json)");
  app.add_option("--examples", o.examples_dir, "docs/examples folder (default: found from the build tree)");
  app.add_flag("--full-schedule", full, "do not stop early when every sigma meets its spec");
  app.add_flag("--quiet", o.quiet, "no progress display");
  app.add_option("--slots", o.slots, "units on the station (default 1; > 1: the multi-unit runner, docs/eol.md)")
      ->check(CLI::Range(1, 127));
  app.add_option("--dead-slot", o.dead_slots, "slot (1-based) whose node never answers; repeatable");
  app.add_option("--outlier-slot", o.outlier_slots, "slot (1-based) whose part has accel.scale.x 0.015 off the others");
  app.add_option("--threads", o.threads, "finish threads of a multi-unit run (default: the CPUs)");
  app.add_flag("--can-fd", o.can_fd, "stream CAN FD frames, 4 samples per 64-byte frame (station can.fd, docs/can-protocol.md)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  o.early_stop = !full;
  // A multi-unit run lowers an unchosen scale to what the virtual bus carries (eol::demo_time_scale).
  o.time_scale_fixed = ts_opt->count() > 0;
  try {
    return eol::run_demo(o);
  } catch (const eol::PeerError& e) {
    std::fprintf(stderr, "imuforge demo: peer failure: %s\n", e.what());
    return app::kExitPeer;
  } catch (const records::RecordError& e) {
    std::fprintf(stderr, "imuforge demo: records: %s\n", e.what());
    return app::kExitPeer;
  } catch (const fixture::FixtureError& e) {
    std::fprintf(stderr, "imuforge demo: fixture: %s\n", e.what());
    return app::kExitPeer;
  } catch (const can::Error& e) {
    std::fprintf(stderr, "imuforge demo: CAN: %s\n", e.what());
    return app::kExitPeer;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge demo: %s\n", e.what());
    return app::exit_code_for(e);
  }
}

}  // namespace

IMUFORGE_COMMAND(demo, "end-to-end demo: bench simulator + virtual IMU + SQLite, prints where the report is", run_demo_cmd);
