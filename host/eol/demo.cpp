#include "host/eol/demo.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

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

int run_demo(const DemoOptions& opt) {
  const auto wall0 = std::chrono::steady_clock::now();
  const std::string ex = find_examples_dir(opt.examples_dir, opt.self_exe);
  const fs::path out = fs::absolute(opt.out_dir);
  // A demo run never overwrites an earlier one: each goes to the first free run, run-2, run-3, ...
  // (the records database in the same folder keeps every run's record).
  fs::path run_dir = out / "run";
  for (int k = 2; fs::exists(run_dir); ++k) run_dir = out / ("run-" + std::to_string(k));
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
  BenchSimChild sim({opt.self_exe, "bench-sim", "--tcp-port", "0", "--time-scale", ts, "--campaign", campaign, "--sensor",
                     sensor, "--bus", bus, "--seed", "1"},
                    (out / "bench-sim.log").string());
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
      {"can", {{"bus", bus}, {"node_id", 1}, {"stream_rate_hz", opt.stream_rate_hz}}},
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
  const std::string station_path = (out / "station.json").string();
  std::ofstream(station_path) << st.dump(2) << "\n";

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
