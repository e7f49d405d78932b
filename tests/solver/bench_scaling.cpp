// Fixture-solver cost versus the number of samples and the number of parameters (not a test: prints
// figures, asserts nothing about time, never runs in CI).
//
//   solver_bench_scaling [DIR] [MAX_ROWS] [--keep]
//     DIR       where the binary logs go (default /tmp; MAX_ROWS=3.6 M needs ≈ 0.7 GB there)
//     MAX_ROWS  the longest log (default 3 600 000 = 1 h at 1 kHz)
//
// Campaign (tests/solver/synth.h, catalog measurement function, white noise): 1 kHz, 5 plateaus
// (−20, 0, 25, 50, 70 °C) × 26 dwells (24-position-equivalent tumble: 6 faces + 8 corners, CW/CCW about
// each axis at 0.3, 1 and 2 rad/s), equal dwell lengths. Each log is written once (binary, as
// `imuforge simulate` writes it) and solved as `imuforge solve` does: LogReader → FixtureAccumulator →
// static noise σ → solve_fixture. Every solve runs in a fresh child process so its peak RSS
// (wait4 ru_maxrss) is its own; CPU = user + system of the child, split into the streaming pass
// (read + accumulate) and the solve (normal equations, Cholesky, covariance, observability).
//
//   samples:    model-thermal (42 parameters) on MAX_ROWS/16 … MAX_ROWS
//   parameters: MAX_ROWS/4 rows with 24 (basic), 42 (thermal), 60 (bias/scale temperature order 3),
//               84 (+ misalignment temperature order 2), 111 (+ accel scale nonlinearity k2/k3, accel
//               cross-coupling, gyro scale nonlinearity, gyro g-sensitivity)
// Fitted exponents: least-squares slope of log CPU against log rows / log parameters.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"
#include "tests/solver/synth.h"

using namespace imuforge;
using namespace imuforge::solver;

namespace {

struct ModelCase {
  std::string label;
  nlohmann::json effects;
};

nlohmann::json basic_effects() {
  nlohmann::json e;
  for (const char* s : {"accel", "gyro"})
    for (const char* k : {"bias", "scale", "misalign"}) e[std::string(s) + "." + k] = nlohmann::json::object();
  return e;
}

std::vector<ModelCase> model_cases() {
  std::vector<ModelCase> m;
  nlohmann::json e = basic_effects();
  m.push_back({"basic", e});
  for (const char* s : {"accel", "gyro"}) {
    e[std::string(s) + ".bias_temp"] = {{"order", 2}};
    e[std::string(s) + ".scale_temp"] = {{"order", 1}};
  }
  m.push_back({"thermal", e});
  for (const char* s : {"accel", "gyro"}) {
    e[std::string(s) + ".bias_temp"] = {{"order", 3}};
    e[std::string(s) + ".scale_temp"] = {{"order", 3}};
  }
  m.push_back({"thermal-o3", e});
  for (const char* s : {"accel", "gyro"}) e[std::string(s) + ".misalign_temp"] = {{"order", 2}};
  m.push_back({"+misalign_temp", e});
  e["accel.scale_nonlinearity"] = nlohmann::json::object();
  e["accel.cross_coupling"] = nlohmann::json::object();
  e["gyro.scale_nonlinearity"] = nlohmann::json::object();
  e["gyro.g_sensitivity"] = nlohmann::json::object();
  m.push_back({"+input/g terms", e});
  return m;
}

model::ModelSpec spec_of(const ModelCase& c) {
  return model::model_spec_from_json(
      {{"format", "imuforge-model"}, {"version", 1}, {"name", c.label}, {"T_ref_C", 25.0}, {"effects", c.effects}});
}

synth::Config campaign(long long rows) {
  synth::Config cfg;
  cfg.rate_hz = 1000.0;
  cfg.plateaus_C = {-20, 0, 25, 50, 70};
  auto d = synth::tumble_and_rates(9.80665, 1.0);
  for (double rate : {0.3, 2.0}) {
    const auto extra = synth::tumble_and_rates(9.80665, rate);
    d.insert(d.end(), extra.end() - 6, extra.end());
  }
  cfg.dwells = d;
  const long long dwells = static_cast<long long>(cfg.plateaus_C.size() * cfg.dwells.size());
  cfg.samples_per_dwell = static_cast<int>(std::max<long long>(10, rows / dwells - 1));
  return cfg;
}

long long write_log(const std::string& path, const synth::Config& cfg) {
  io::LogWriter w(path, synth::meta(cfg), io::LogEncoding::kBinary);
  synth::generate(cfg, synth::truth_params(), 7, [&](const io::LogRow& r) { w.write(r); });
  w.close();
  return static_cast<long long>(w.rows_written());
}

struct Point {
  long long rows = 0;
  int params = 0;
  double cpu_stream_s = 0, cpu_solve_s = 0, cpu_total_s = 0, peak_mb = 0;
  bool ok = false;
};

double cpu_of(const rusage& u) {
  return double(u.ru_utime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec) + double(u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_stime.tv_usec);
}

// Solves in a child process; the child reports its phase split through a pipe, the parent takes the
// child's total CPU and peak RSS from wait4.
Point solve_in_child(const std::string& log_path, const ModelCase& mc) {
  Point p;
  int fd[2];
  if (pipe(fd) != 0) return p;
  const pid_t pid = fork();
  if (pid < 0) return p;
  if (pid == 0) {
    close(fd[0]);
    double out[3] = {0, 0, -1};
    try {
      const model::ModelSpec spec = spec_of(mc);
      rusage u0, u1, u2;
      getrusage(RUSAGE_SELF, &u0);
      io::LogReader log(log_path);
      FixtureAccumulator acc(spec, log.meta());
      io::LogRow row;
      while (log.next(row)) acc.add(row);
      acc.finish();
      getrusage(RUSAGE_SELF, &u1);
      const FixtureSolution sol = solve_fixture(acc, acc.static_noise_sigma());
      getrusage(RUSAGE_SELF, &u2);
      out[0] = cpu_of(u1) - cpu_of(u0);
      out[1] = cpu_of(u2) - cpu_of(u1);
      out[2] = double(sol.estimate.names.size());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "  %s: %s\n", mc.label.c_str(), e.what());
    }
    if (write(fd[1], out, sizeof out) != sizeof out) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  double in[3] = {0, 0, -1};
  const bool got = read(fd[0], in, sizeof in) == sizeof in;
  close(fd[0]);
  int status = 0;
  rusage ru{};
  wait4(pid, &status, 0, &ru);
  p.ok = got && WIFEXITED(status) && WEXITSTATUS(status) == 0 && in[2] > 0;
  p.cpu_stream_s = in[0];
  p.cpu_solve_s = in[1];
  p.params = static_cast<int>(in[2]);
  p.cpu_total_s = cpu_of(ru);
  p.peak_mb = double(ru.ru_maxrss) / 1024.0;  // Linux: kB
  return p;
}

double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = double(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    sx += std::log(x[i]);
    sy += std::log(y[i]);
    sxx += std::log(x[i]) * std::log(x[i]);
    sxy += std::log(x[i]) * std::log(y[i]);
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

void print_point(const char* label, const Point& p) {
  if (!p.ok) {
    std::printf("  %-16s %9lld rows  FAILED\n", label, p.rows);
    return;
  }
  std::printf("  %-16s %9lld rows %4d params  CPU %6.3f s (stream %6.3f, solve %6.4f)  peak RSS %6.1f MB\n", label,
              p.rows, p.params, p.cpu_total_s, p.cpu_stream_s, p.cpu_solve_s, p.peak_mb);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir = "/tmp";
  long long max_rows = 3600000;
  bool keep = false;
  int pos = 0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--keep") == 0) keep = true;
    else if (pos == 0) dir = argv[i], ++pos;
    else if (pos == 1) max_rows = std::atoll(argv[i]), ++pos;
    else {
      std::fprintf(stderr, "usage: %s [DIR] [MAX_ROWS] [--keep]\n", argv[0]);
      return 2;
    }
  }
  if (max_rows < 16 * 1000) {
    std::fprintf(stderr, "MAX_ROWS must be >= 16000\n");
    return 2;
  }
  const auto models = model_cases();
  std::vector<std::string> logs;

  std::printf("Solver cost versus samples (model thermal, 1 kHz, 5 plateaus x 26 dwells):\n");
  std::vector<double> xs, ys;
  Point at_quarter;
  for (long long div : {16, 8, 4, 2, 1}) {
    const synth::Config cfg = campaign(max_rows / div);
    const std::string path = dir + "/solver_bench_" + std::to_string(max_rows / div) + ".bin";
    const long long rows = write_log(path, cfg);
    logs.push_back(path);
    Point p = solve_in_child(path, models[1]);
    p.rows = rows;
    print_point("thermal", p);
    if (p.ok) xs.push_back(double(rows)), ys.push_back(p.cpu_total_s);
    if (div == 4) at_quarter = p;
  }
  if (xs.size() >= 2) std::printf("  fitted exponent: CPU ~ rows^%.2f\n", slope(xs, ys));

  const std::string qpath = logs[2];
  std::printf("Solver cost versus parameters (%lld rows):\n", at_quarter.rows);
  std::vector<double> xp, yp, ys_solve;
  for (const auto& mc : models) {
    Point p = solve_in_child(qpath, mc);
    p.rows = at_quarter.rows;
    print_point(mc.label.c_str(), p);
    if (p.ok) xp.push_back(p.params), yp.push_back(p.cpu_total_s), ys_solve.push_back(std::max(p.cpu_solve_s, 1e-4));
  }
  if (xp.size() >= 2)
    std::printf("  fitted exponents: total CPU ~ params^%.2f; solve phase alone ~ params^%.2f\n", slope(xp, yp),
                slope(xp, ys_solve));
  if (!keep)
    for (const auto& l : logs) std::remove(l.c_str());
  return 0;
}
