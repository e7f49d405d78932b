#include "host/navigate/impact.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <memory>
#include <stdexcept>
#include <thread>

#include "host/nav/strapdown.h"
#include "host/navigate/aided_run.h"
#include "host/table/host_kernel.h"

namespace imuforge::navigate {

Stats stats_of(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  auto q = [&](double p) {  // linear interpolation between order statistics (Hyndman-Fan type 7)
    const double h = p * static_cast<double>(v.size() - 1);
    const std::size_t lo = static_cast<std::size_t>(std::floor(h));
    const std::size_t hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (h - static_cast<double>(lo)) * (v[hi] - v[lo]);
  };
  s.median = q(0.5);
  s.p95 = q(0.95);
  s.max = v.back();
  return s;
}

namespace {

double wrap_pi(double a) {
  while (a > M_PI) a -= 2 * M_PI;
  while (a <= -M_PI) a += 2 * M_PI;
  return a;
}

struct RunOut {
  std::vector<float> hpos, hvel, head;
};

// One candidate on one realisation: kernel → increments → navigator, aided until i0, free to i1.
void navigate_run(const sim::VehicleTruth& truth, const std::vector<sim::RawSample>& raw, table::HostKernel& k,
                  std::size_t i0, std::size_t i1, std::size_t per_second, Aiding aiding, RunOut& out) {
  out.hpos.clear();
  out.hvel.clear();
  out.head.clear();
  aided_run(
      truth, i0, i1, aiding,
      [&](std::size_t i, Eigen::Vector3d& f, Eigen::Vector3d& w) {
        const table::CompensatedSample c = k.run(raw[i].data(), truth.temp_C[i]);
        f = Eigen::Vector3d(c.accel_mps2[0], c.accel_mps2[1], c.accel_mps2[2]);
        w = Eigen::Vector3d(c.gyro_rad_s[0], c.gyro_rad_s[1], c.gyro_rad_s[2]);
      },
      [&](std::size_t i, const nav::NavState& s) {
        if ((i - i0) % per_second != 0) return;
        const physics::VehicleState& t = truth.states[i];
        out.hpos.push_back(static_cast<float>(nav::horizontal_offset_m(s.pos, t.pos).norm()));
        out.hvel.push_back(static_cast<float>((s.v_ned - t.v_ned).head<2>().norm()));
        out.head.push_back(static_cast<float>(wrap_pi(nav::heading_rad(s.q_nb) - nav::heading_rad(t.q_nb))));
      });
}

}  // namespace

ImpactResult run_impact(const sim::VehicleTruth& truth, const model::SensorModel& sensor,
                        const std::vector<Candidate>& candidates, const ImpactOptions& opt) {
  const double fs = truth.rate_hz;
  const double dur = static_cast<double>(truth.states.size() - 1) / fs;
  if (!(opt.outage_start_s > 0)) throw std::invalid_argument("--outage: the start must be > 0 s (the navigator is aligned at t = 0)");
  if (!(opt.outage_s >= 1)) throw std::invalid_argument("--outage: the duration must be >= 1 s");
  if (opt.outage_start_s + opt.outage_s > dur + 1e-9)
    throw std::invalid_argument("--outage: " + std::to_string(opt.outage_start_s) + " + " + std::to_string(opt.outage_s) +
                                " s runs past the trajectory's end at " + std::to_string(dur) + " s");
  if (opt.runs < 1 || opt.runs > 100000) throw std::invalid_argument("--runs must be in 1..100000");
  if (std::abs(fs - std::round(fs)) > 1e-9) throw std::invalid_argument("sample rate must be a whole number of Hz");
  const std::size_t per_second = static_cast<std::size_t>(std::lround(fs));
  const std::size_t i0 = static_cast<std::size_t>(std::lround(opt.outage_start_s * fs));
  // Whole seconds of outage are scored; a duration within 1 ms of a whole number counts as that number
  // (segment durations built from radii and speeds are not exact in binary).
  const int D = static_cast<int>(std::floor(opt.outage_s + 1e-3));
  const std::size_t i1 = i0 + static_cast<std::size_t>(D) * per_second;

  ImpactResult res;
  res.outage_seconds = D;
  for (double c : opt.checkpoints_s)
    if (c >= 1 && c <= D && std::abs(c - std::round(c)) < 1e-9) res.checkpoints_s.push_back(c);
  if (res.checkpoints_s.empty() || res.checkpoints_s.back() != D) res.checkpoints_s.push_back(D);
  const std::size_t nc = candidates.size();
  res.candidates.resize(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    CandidateResult& r = res.candidates[c];
    r.name = candidates[c].name;
    r.kind = candidates[c].kind;
    r.source = candidates[c].source;
    r.dropped = candidates[c].dropped;
    r.hpos_m.resize(static_cast<std::size_t>(opt.runs));
    r.hvel_mps.resize(static_cast<std::size_t>(opt.runs));
    r.heading_rad.resize(static_cast<std::size_t>(opt.runs));
  }

  const auto wall0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  int nthreads = opt.threads > 0 ? opt.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  nthreads = std::min(nthreads, opt.runs);
  std::atomic<int> next{0};
  std::vector<std::string> errors(static_cast<std::size_t>(nthreads));
  auto worker = [&](int tid) {
    try {
      std::vector<std::unique_ptr<table::HostKernel>> kernels;
      for (const auto& cand : candidates)
        kernels.push_back(std::make_unique<table::HostKernel>(cand.table, table::KernelPath::kF32, 0.0));
      std::vector<sim::RawSample> raw;
      RunOut ro;
      for (int r = next++; r < opt.runs; r = next++) {
        sim::vehicle_raw(truth, sensor, opt.seed + static_cast<std::uint64_t>(r), i1 + 1, raw);
        if (opt.accel_shift > 0 || opt.gyro_shift > 0)
          for (auto& row : raw)
            for (int ch = 0; ch < 6; ++ch) {
              const int sh = ch < 3 ? opt.accel_shift : opt.gyro_shift;
              if (sh > 0)
                row[static_cast<std::size_t>(ch)] = static_cast<std::int32_t>(
                    (static_cast<std::int64_t>(row[static_cast<std::size_t>(ch)]) + (std::int64_t{1} << (sh - 1))) >> sh);
            }
        for (std::size_t c = 0; c < nc; ++c) {
          navigate_run(truth, raw, *kernels[c], i0, i1, per_second, opt.aiding, ro);
          CandidateResult& cr = res.candidates[c];
          cr.hpos_m[static_cast<std::size_t>(r)] = ro.hpos;
          cr.hvel_mps[static_cast<std::size_t>(r)] = ro.hvel;
          cr.heading_rad[static_cast<std::size_t>(r)] = ro.head;
        }
      }
    } catch (const std::exception& e) {
      errors[static_cast<std::size_t>(tid)] = e.what();
      next = opt.runs;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < nthreads; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (auto& th : pool) th.join();
  for (const auto& e : errors)
    if (!e.empty()) throw std::runtime_error(e);
  res.cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  res.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  res.nav_steps = static_cast<std::uint64_t>(opt.runs) * nc * i1;

  for (auto& cr : res.candidates) {
    auto column = [&](const std::vector<std::vector<float>>& m, int sec, bool deg) {
      std::vector<double> v;
      for (const auto& run : m) {
        const double x = run[static_cast<std::size_t>(sec - 1)];
        v.push_back(deg ? std::abs(x) * 180.0 / M_PI : x);
      }
      return v;
    };
    for (double c : res.checkpoints_s) {
      const int sec = static_cast<int>(std::lround(c));
      cr.hpos.push_back(stats_of(column(cr.hpos_m, sec, false)));
      cr.hvel.push_back(stats_of(column(cr.hvel_mps, sec, false)));
      cr.heading_deg.push_back(stats_of(column(cr.heading_rad, sec, true)));
    }
    for (int sec = 1; sec <= D; ++sec) {
      const Stats s = stats_of(column(cr.hpos_m, sec, false));
      cr.hpos_median_m.push_back(s.median);
      cr.hpos_p95_m.push_back(s.p95);
    }
  }
  return res;
}

}  // namespace imuforge::navigate
