#include "host/eol/demo.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "host/eol/adapters.h"
#include "host/eol/journal.h"
#include "host/eol/runner.h"
#include "host/eol/station_runner.h"
#include "host/records/store.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace imuforge::eol {

std::string find_examples_dir(const std::string& hint, const std::string& self_exe) {
  std::vector<fs::path> c;
  if (!hint.empty()) c.push_back(hint);
#ifdef IMUFORGE_EOL_SOURCE_DIR
  c.push_back(fs::path(IMUFORGE_EOL_SOURCE_DIR) / "docs" / "examples");
#endif
  std::error_code ec;
  fs::path exe = fs::canonical(self_exe, ec);
  if (!ec) c.push_back(exe.parent_path() / ".." / ".." / ".." / "docs" / "examples");
  for (const auto& p : c)
    if (fs::exists(p / "campaign-eol.json")) return fs::canonical(p).string();
  throw std::runtime_error("demo: cannot find docs/examples/campaign-eol.json (run from a built source tree, or pass --examples DIR)");
}

namespace {

// bench-sim as a child process; stopped (SIGTERM, then SIGKILL) when this object goes.
class BenchSimChild {
 public:
  BenchSimChild(const std::vector<std::string>& argv, const std::string& log_path) {
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("demo: pipe failed");
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("demo: fork failed");
    if (pid_ == 0) {
      dup2(out[1], STDOUT_FILENO);
      FILE* lf = std::fopen(log_path.c_str(), "w");
      if (lf) dup2(fileno(lf), STDERR_FILENO);
      close(out[0]);
      close(out[1]);
      std::vector<char*> a;
      for (const auto& s : argv) a.push_back(const_cast<char*>(s.c_str()));
      a.push_back(nullptr);
      execv(a[0], a.data());
      std::fprintf(stderr, "exec %s failed: %s\n", a[0], std::strerror(errno));
      _exit(127);
    }
    close(out[1]);
    out_ = fdopen(out[0], "r");
  }
  ~BenchSimChild() {
    if (out_) std::fclose(out_);
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      for (int i = 0; i < 50; ++i) {
        if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
        usleep(100000);
      }
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  // The "ready tcp=HOST:PORT ..." line. Throws if bench-sim exits first.
  std::string ready_line() {
    char buf[1024];
    while (std::fgets(buf, sizeof buf, out_)) {
      std::string l(buf);
      if (l.rfind("ready ", 0) == 0) return l;
    }
    throw std::runtime_error("demo: bench-sim exited before it was ready");
  }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
};

std::string field(const std::string& line, const std::string& key) {
  auto p = line.find(key + "=");
  if (p == std::string::npos) return "";
  p += key.size() + 1;
  auto e = line.find_first_of(" \n", p);
  return line.substr(p, e == std::string::npos ? std::string::npos : e - p);
}

}  // namespace

// The multi-unit demo: StationRunner over the slots, the batch report at the end.
static int run_demo_station(const DemoOptions& opt, const std::string& station_path, const std::string& campaign,
                     const std::string& run_dir, std::chrono::steady_clock::time_point wall0) {
  StationConfig sc = load_station(station_path);
  auto bench = make_fixture_bench(sc);
  StationRunOptions so;
  so.out_dir = run_dir;
  so.campaign_path = campaign;
  so.station_path = station_path;
  so.resume = !opt.resume_run_dir.empty() && fs::exists(fs::path(run_dir) / "journal.log");
  so.early_stop = opt.early_stop;
  so.threads = opt.threads;
  so.progress = opt.quiet ? nullptr : stderr;
  so.crash_after_steps = opt.crash_after_steps;
  StationRunner runner(so, *bench, [](const StationConfig& s) { return make_can_device(s); }, [] { return make_table_ops(); });
  StationRunResult r = runner.run();
  if (opt.stats) {
    opt.stats->units = static_cast<int>(r.units.size());
    opt.stats->passed = r.passed;
    opt.stats->campaign_time_s = r.campaign_time_s;
    opt.stats->collect_wall_s = r.collect_wall_s;
    opt.stats->finish_wall_s = r.finish_wall_s;
    opt.stats->early_stopped = r.early_stopped;
    opt.stats->finish_cpu_s.clear();
    for (const auto& u : r.units) opt.stats->finish_cpu_s.push_back(u.finish_cpu_s);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  for (const auto& u : r.units) {
    std::printf("demo: %s %s serial %s record %s\n", u.slot.c_str(), u.pass ? "PASS" : "FAIL",
                u.serial.empty() ? "-" : u.serial.c_str(), u.record_id.c_str());
    for (const auto& x : u.reasons) std::printf("  reason: %s\n", x.c_str());
  }
  for (const auto& o : r.batch.units)
    if (!o.outliers.empty()) {
      std::string l;
      for (const auto& x : o.outliers) l += (l.empty() ? "" : ", ") + x;
      std::printf("demo: %s is an outlier on %s\n", o.slot.c_str(), l.c_str());
    }
  std::printf("demo: %d of %zu units PASS  campaign %.0f s simulated (%s)  collect wall %.1f s  finish wall %.1f s  wall %.1f s\n",
              r.passed, r.units.size(), r.campaign_time_s, r.early_stopped ? "stopped early" : "full schedule",
              r.collect_wall_s, r.finish_wall_s, wall);
  std::printf("demo: batch %s in %s\n", r.batch_id.c_str(), r.db.c_str());
  std::printf("demo: report %s\n", r.batch_report_path.c_str());
  return r.passed == static_cast<int>(r.units.size()) ? 0 : 1;
}

double demo_time_scale(double wanted, int slots, double rate_hz, bool fixed) {
  if (fixed || slots < 1 || !(rate_hz > 0)) return wanted;
  return std::min({wanted, kVirtualBusSamplesPerWallS / (static_cast<double>(slots) * rate_hz),
                   kCanDeviceMaxNodeRateHz / rate_hz});
}

int run_demo(const DemoOptions& opt_in) {
  const auto wall0 = std::chrono::steady_clock::now();
  DemoOptions opt = opt_in;
  opt.time_scale = demo_time_scale(opt.time_scale, opt.slots, opt.stream_rate_hz, opt.time_scale_fixed);
  if (opt.time_scale != opt_in.time_scale && !opt.quiet)
    std::fprintf(stderr, "demo: time scale %gx so %d units at %g Hz stay within the virtual CAN bus and the node's rate (docs/eol.md)\n",
                 opt.time_scale, opt.slots, opt.stream_rate_hz);
  if (opt.stats) opt.stats->time_scale = opt.time_scale;
  const std::string ex = find_examples_dir(opt.examples_dir, opt.self_exe);
  const fs::path out = fs::absolute(opt.out_dir);
  // A demo run never overwrites an earlier one: each goes to the first free run, run-2, run-3, ...
  // (the records database in the same folder keeps every run's record).
  fs::path run_dir = out / "run";
  for (int k = 2; fs::exists(run_dir); ++k) run_dir = out / ("run-" + std::to_string(k));
  if (!opt.resume_run_dir.empty()) run_dir = fs::absolute(opt.resume_run_dir);
  fs::create_directories(out);
  const std::string campaign = opt.campaign.empty() ? ex + "/campaign-eol.json" : opt.campaign;
  // The part: docs/examples/sensor-consumer.json (MPU-6050 class, 16-bit outputs as streamed over CAN)
  // in its ±500 dps gyro mode, so the campaign's 300 dps rate runs do not saturate.
  const std::string sensor = (out / "sensor.json").string();
  {
    std::ifstream f(ex + "/sensor-consumer.json");
    if (!f) throw std::runtime_error("demo: cannot read " + ex + "/sensor-consumer.json");
    json sj = json::parse(f);
    sj["gyro"]["lsb"] = 500.0 * M_PI / 180.0 / 32768.0;
    sj["gyro"]["bits"] = 16;
    sj["gyro"]["range"] = 500.0 * M_PI / 180.0;
    sj["name"] = sj.value("name", std::string("consumer")) + " (demo: +-500 dps gyro mode)";
    std::ofstream(sensor) << sj.dump(2) << "\n";
  }
  const std::string bus = "virtual:demo-" + std::to_string(getpid());

  char ts[32];
  std::snprintf(ts, sizeof ts, "%g", opt.time_scale);
  std::vector<std::string> sim_argv{opt.self_exe, "bench-sim", "--tcp-port", std::to_string(opt.tcp_port), "--time-scale", ts, "--campaign", campaign,
                                    "--sensor", sensor, "--bus", bus, "--seed", "1"};
  // The station figures run N = 1 through the multi-unit runner too (a one-slot station), to compare.
  const bool multi = opt.slots > 1 || opt.stats != nullptr;
  if (multi) {
    sim_argv.insert(sim_argv.end(), {"--slots", std::to_string(opt.slots)});
    for (int d : opt.dead_slots) sim_argv.insert(sim_argv.end(), {"--dead-slot", std::to_string(d)});
    if (!opt.outlier_slots.empty()) {
      // The odd part: the same sensor with accel.scale.x 0.015 further out (within the 0.03 limit, so it
      // passes and is marked, not failed).
      const std::string odd = (out / "sensor-outlier.json").string();
      std::ifstream f(sensor);
      json sj = json::parse(f);
      sj["effects"]["accel.scale"]["x"] = sj["effects"]["accel.scale"].value("x", 0.0) + 0.015;
      std::ofstream(odd) << sj.dump(2) << "\n";
      for (int d : opt.outlier_slots) sim_argv.insert(sim_argv.end(), {"--outlier-slot", std::to_string(d)});
      sim_argv.insert(sim_argv.end(), {"--outlier-sensor", odd});
    }
  }
  BenchSimChild sim(sim_argv, (out / "bench-sim.log").string());
  const std::string ready = sim.ready_line();
  const std::string tcp = field(ready, "tcp");
  auto colon = tcp.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("demo: bench-sim announced no TCP port: " + ready);
  const std::string host = tcp.substr(0, colon);
  const int port = std::stoi(tcp.substr(colon + 1));
  if (!opt.quiet) std::fprintf(stderr, "demo: bench-sim ready on %s (time scale %gx), IMU on %s\n", tcp.c_str(), opt.time_scale, bus.c_str());

  json st = {
      {"name", "demo-station"},
      {"time_scale", opt.time_scale},
      {"model", opt.model.empty() ? ex + "/model-thermal.json" : fs::absolute(opt.model).string()},
      {"sensor", sensor},
      {"fixtures",
       {{"table", {{"name", "table-1"}, {"transport", "tcp"}, {"host", host}, {"port", port}, {"map", "imuforge-table.json"},
                   {"timeout_s", 1.0}, {"retries", 3}}},
        {"chamber", {{"name", "chamber-1"}, {"transport", "tcp"}, {"host", host}, {"port", port},
                     {"map", "imuforge-chamber.json"}, {"timeout_s", 1.0}, {"retries", 3}}}}},
      {"can", {{"bus", bus}, {"node_id", 1}, {"stream_rate_hz", opt.stream_rate_hz}, {"fd", opt.can_fd}}},
      {"records", {{"db", (out / "records.sqlite").string()}}},
      {"settle", {{"temp_window_s", 180}, {"temp_slope_C_per_min", 0.1}, {"temp_band_C", 3}, {"table_timeout_s", 1200},
                  {"temp_timeout_s", 7200}}},
      {"early_stop", opt.early_stop},
  };
  // Limits for a consumer-grade part (docs/examples/spec-sigma.json is for a better class of sensor).
  json lim = {{"accel.bias", {{"sigma", 2e-3}}},       {"accel.scale", {{"sigma", 5e-4}}},
              {"accel.misalign", {{"sigma", 5e-4}}},   {"accel.bias_temp", {{"sigma", 2e-4}}},
              {"accel.scale_temp", {{"sigma", 5e-5}}}, {"gyro.bias", {{"sigma", 1e-4}}},
              {"gyro.scale", {{"sigma", 5e-4}}},       {"gyro.misalign", {{"sigma", 5e-4}}},
              {"gyro.bias_temp", {{"sigma", 1e-5}}},   {"gyro.scale_temp", {{"sigma", 5e-5}}}};
  lim["accel.bias"]["abs"] = 0.5;
  lim["accel.scale"]["abs"] = 0.03;
  lim["accel.misalign"]["abs"] = 0.02;
  lim["gyro.bias"]["abs"] = 0.05;
  lim["gyro.scale"]["abs"] = 0.03;
  lim["gyro.misalign"]["abs"] = 0.02;
  st["limits"] = {{"parameters", lim}, {"verification", {{"accel_mps2", 0.05}, {"gyro_rad_s", 0.01}}}};
  st["verification"] = json::array({
      {{"label", "ver-z-down"}, {"position_deg", {0, 0, 45}}, {"dwell_s", 10}},
      {{"label", "ver-x-down"}, {"position_deg", {0, 90, 45}}, {"dwell_s", 10}},
      {{"label", "ver-y-down"}, {"position_deg", {90, 90, 45}}, {"dwell_s", 10}},
      {{"label", "ver-rate-z"}, {"position_deg", {0, 0, 0}}, {"rate_dps", {0, 0, 200}}, {"dwell_s", 10}},
  });
  if (multi) {
    st["slots"] = json::array();
    for (int k = 1; k <= opt.slots; ++k) {
      char name[16];
      std::snprintf(name, sizeof name, "slot%02d", k);
      st["slots"].push_back({{"name", name}, {"node_id", k}});
    }
  }
  const std::string station_path = (out / "station.json").string();
  if (opt.resume_run_dir.empty() || !fs::exists(station_path)) std::ofstream(station_path) << st.dump(2) << "\n";
  if (multi) return run_demo_station(opt, station_path, campaign, run_dir.string(), wall0);

  StationConfig sc = load_station(station_path);
  auto bench = make_fixture_bench(sc);
  auto dev = make_can_device(sc);
  auto ops = make_table_ops();
  DeviceInfo info = dev->identify();
  RunOptions ro;
  ro.out_dir = run_dir.string();
  ro.serial = info.serial;
  ro.campaign_path = campaign;
  ro.station_path = station_path;
  ro.early_stop = opt.early_stop;
  ro.progress = opt.quiet ? nullptr : stderr;
  Runner runner(ro, *bench, *dev, *ops);
  RunResult r = runner.run();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  std::printf("demo: %s  serial %s  campaign %.0f s simulated (%s)  wall %.1f s\n", r.pass ? "PASS" : "FAIL",
              info.serial.c_str(), r.campaign_time_s, r.early_stopped ? "stopped early, every sigma met" : "full schedule",
              wall);
  for (const auto& x : r.reasons) std::printf("  reason: %s\n", x.c_str());
  std::printf("demo: record %s in %s\n", r.record_id.c_str(), r.db.c_str());
  std::printf("demo: report %s\n", r.report_path.c_str());
  return r.pass ? 0 : 1;
}

}  // namespace imuforge::eol
