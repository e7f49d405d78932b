// Station figures (issue 14, not a test): units per hour of the live multi-unit runner on bench-sim with
// the end-of-line campaign (docs/examples/campaign-eol.json, time-scaled), for N units on one station.
// Per N: simulated campaign hours, wall time (collection at the time scale, then the finish on the
// host), units per simulated hour = passed units / (campaign + finish) (a failed unit is no output),
// finish CPU per unit (solve, table, flash, read back, verify, record: its thread's CPU), the whole run's
// CPU per unit (user + system of this process and of bench-sim over the row: the collection's streams
// and the virtual bus included), this process's peak RSS (the whole station run, cumulative
// over the N list), the largest child's peak RSS (bench-sim, virtual IMUs) and the 1-minute load average at
// the end of the row (the machines are shared: a figure without the load is not comparable).
//   eol_bench_station [N list, comma separated = 1,4,8,16] [time_scale=100] [rate_hz=10] [out_dir=/tmp/imuforge-station]
//                     [campaign=docs/examples/campaign-eol.json] [model=docs/examples/model-thermal.json]
//                     [classic|fd = classic: the units stream CAN FD frames, station can.fd]
// time_scale is the most a row uses: each N runs at eol::demo_time_scale() (what the virtual CAN bus
// carries and the node's rate allows, as `imuforge demo --slots N` does); the column "scale" says which.
// A time_scale with a trailing '!' (e.g. 200!) is used as given, to measure past those limits.
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>  // getloadavg
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "host/eol/demo.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  std::vector<int> ns;
  {
    std::stringstream ss(argc > 1 ? argv[1] : "1,4,8,16");
    for (std::string x; std::getline(ss, x, ',');) ns.push_back(std::atoi(x.c_str()));
  }
  const double scale = argc > 2 ? std::atof(argv[2]) : 100.0;
  const bool scale_fixed = argc > 2 && std::string(argv[2]).back() == '!';
  const double rate = argc > 3 ? std::atof(argv[3]) : 10.0;
  const fs::path root = argc > 4 ? argv[4] : "/tmp/imuforge-station";
  const std::string campaign = argc > 5 ? argv[5] : "", model = argc > 6 ? argv[6] : "";
  const bool fd = argc > 7 && std::string(argv[7]) == "fd";
  if (argc > 7 && !fd && std::string(argv[7]) != "classic") {
    std::fprintf(stderr, "eol_bench_station: 7th argument must be classic or fd, not '%s'\n", argv[7]);
    return 2;
  }
  std::printf("| N | scale | campaign (sim h) | collect wall s | finish wall s | units/h | finish CPU s/unit | run CPU s/unit | pass | early stop | peak RSS MB | child peak RSS MB | load 1 min |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  auto cpu_s = [] {
    rusage self{}, kids{};
    getrusage(RUSAGE_SELF, &self);
    getrusage(RUSAGE_CHILDREN, &kids);  // bench-sim, once it has been waited for
    auto sec = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
    return sec(self.ru_utime) + sec(self.ru_stime) + sec(kids.ru_utime) + sec(kids.ru_stime);
  };
  for (int n : ns) {
    const double cpu0 = cpu_s();
    imuforge::eol::DemoOptions o;
    o.out_dir = (root / ("n" + std::to_string(n))).string();
    std::error_code ec;
    fs::remove_all(o.out_dir, ec);
    o.self_exe = IMUFORGE_BIN;
    o.examples_dir = IMUFORGE_SOURCE_DIR "/docs/examples";
    o.time_scale = scale;
    o.time_scale_fixed = scale_fixed;
    o.stream_rate_hz = rate;
    o.can_fd = fd;
    o.quiet = true;
    o.slots = n;
    o.campaign = campaign;
    o.model = model;
    imuforge::eol::DemoOptions::Stats st;
    o.stats = &st;
    const int code = imuforge::eol::run_demo(o);  // 0: every unit passed
    (void)code;
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    rusage ruc{};
    getrusage(RUSAGE_CHILDREN, &ruc);
    double load[1] = {0};
    if (getloadavg(load, 1) != 1) load[0] = -1;
    double cpu = 0;
    for (double c : st.finish_cpu_s) cpu += c;
    const double hours = (st.campaign_time_s + st.finish_wall_s) / 3600.0;
    const double run_cpu = cpu_s() - cpu0;
    std::printf("| %d | %g | %.2f | %.0f | %.0f | %.1f | %.2f | %.1f | %d/%d | %s | %.0f | %.0f | %.1f |\n", n, st.time_scale, st.campaign_time_s / 3600.0,
                st.collect_wall_s, st.finish_wall_s, st.passed / hours, cpu / n, run_cpu / n, st.passed, st.units, st.early_stopped ? "yes" : "no",
                static_cast<double>(ru.ru_maxrss) / 1024.0,
                static_cast<double>(ruc.ru_maxrss) / 1024.0, load[0]);
    std::fflush(stdout);
  }
  return 0;
}
