// A small synthetic fixture campaign for the solver tests, generated in-process through the catalog's
// own measurement function (model::measure), so the tests do not depend on files or on the simulator's
// timeline. Fixture reference is exact; noise is white Gaussian with known σ; counts are rounded with an
// LSB far below σ so quantisation is negligible.
#pragma once

#include <array>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "host/io/log.h"
#include "host/model/catalog.h"
#include "host/model/measure.h"
#include "host/model/sensor_model.h"

namespace synth {

using imuforge::io::LogMeta;
using imuforge::io::LogRow;
namespace model = imuforge::model;

// The synthetic dwells change the reference instantly and carry no timing error, and at 0.5–1 s they
// are no longer than the fixture solver's dwell guard on both sides (solver::DwellGuard, 0.5 s by
// default). Specs for them turn the guard off, so every dwell row is used, as the tests' reference sums
// and the Cramér-Rao bound assume.
inline model::ModelSpec unguarded(model::ModelSpec spec) {
  if (!spec.extra.is_object()) spec.extra = nlohmann::json::object();
  spec.extra["dwell_guard_s"] = 0.0;
  return spec;
}

// docs/examples/model-thermal.json without the dwell guard (see unguarded).
inline model::ModelSpec thermal_spec() {
  return unguarded(model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json"));
}

struct Dwell {
  Eigen::Vector3d f, w;
};

// 6 face-up/down positions + 8 corner (45°/35°) positions + CW/CCW rate runs about each axis.
inline std::vector<Dwell> tumble_and_rates(double g = 9.80665, double rate = 1.0) {
  std::vector<Dwell> d;
  const Eigen::Vector3d we(2e-5, 5e-5, -4e-5);  // an Earth-rate-like constant
  for (int k = 0; k < 3; ++k)
    for (int sgn : {1, -1}) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero();
      f[k] = sgn * g;
      d.push_back({f, we});
    }
  for (int sx : {1, -1})
    for (int sy : {1, -1})
      for (int sz : {1, -1}) d.push_back({Eigen::Vector3d(sx, sy, sz).normalized() * g, we});
  for (int k = 0; k < 3; ++k)
    for (int sgn : {1, -1}) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero(), w = we;
      f[k] = g;
      w[k] += sgn * rate;
      d.push_back({f, w});
    }
  return d;
}

struct Config {
  std::vector<double> plateaus_C{25.0};
  double drift_C = 0.4;          // linear die drift across one dwell (exercises the moment compression)
  int samples_per_dwell = 100;
  double rate_hz = 100.0;
  double sigma[6] = {0.01, 0.01, 0.01, 0.001, 0.001, 0.001};
  double T_ref_C = 25.0;
  std::vector<Dwell> dwells = tumble_and_rates();
};

// The per-sample noise σ per channel of a config (solver::Sigma6's layout).
inline std::array<double, 6> sigma_of(const Config& c) {
  std::array<double, 6> s{};
  for (int k = 0; k < 6; ++k) s[static_cast<size_t>(k)] = c.sigma[k];
  return s;
}

inline LogMeta meta(const Config& c) {
  LogMeta m;
  m.serial = "SYNTH";
  m.sample_rate_hz = c.rate_hz;
  m.accel_lsb_mps2 = c.sigma[0] / 20;
  m.gyro_lsb_rad_s = c.sigma[3] / 20;
  m.accel_bits = m.gyro_bits = 32;  // counts are never clamped here: the widest word
  m.gravity_mps2 = 9.80665;
  return m;
}

// Calls sink for every row in time order (a −1 row between dwells, as a moving table would give).
inline void generate(const Config& c, const model::ParamSet& truth, std::uint64_t seed,
                     const std::function<void(const LogRow&)>& sink) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  const LogMeta m = meta(c);
  const auto ca = model::compile(truth, model::Sensor::kAccel, c.T_ref_C);
  const auto cg = model::compile(truth, model::Sensor::kGyro, c.T_ref_C);
  double t = 0;
  int seg = 0;
  const double dt = 1.0 / c.rate_hz;
  for (double Tp : c.plateaus_C)
    for (const auto& d : c.dwells) {
      LogRow mv;
      mv.t_s = t;
      mv.segment = -1;
      mv.temp_C = Tp;
      sink(mv);
      t += dt;
      for (int i = 0; i < c.samples_per_dwell; ++i) {
        LogRow r;
        r.t_s = t;
        r.segment = seg;
        r.temp_C = Tp - 0.5 * c.drift_C + c.drift_C * i / std::max(1, c.samples_per_dwell - 1);
        r.chamber_C = Tp;
        r.has_ref = true;
        model::MeasureInput in;
        in.f = d.f;
        in.w = d.w;
        in.T_C = r.temp_C;
        for (int k = 0; k < 3; ++k) {
          r.f_ref[k] = d.f[k];
          r.w_ref[k] = d.w[k];
        }
        const Eigen::Vector3d ya = model::measure(ca, in);
        const Eigen::Vector3d yg = model::measure(cg, in);
        for (int k = 0; k < 3; ++k) {
          r.raw[k] = static_cast<std::int32_t>(std::lround((ya[k] + c.sigma[k] * n01(rng)) / m.accel_lsb_mps2));
          r.raw[3 + k] = static_cast<std::int32_t>(std::lround((yg[k] + c.sigma[3 + k] * n01(rng)) / m.gyro_lsb_rad_s));
        }
        sink(r);
        t += dt;
      }
      ++seg;
    }
}

// A plausible consumer-grade truth for the basic + thermal model.
inline model::ParamSet truth_params(std::uint64_t seed = 42) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  model::ParamSet p;
  const char* ax = "xyz";
  const char* mis[6] = {"xy", "xz", "yx", "yz", "zx", "zy"};
  for (const char* s : {"accel", "gyro"}) {
    const bool acc = std::string(s) == "accel";
    for (int j = 0; j < 3; ++j) {
      p.set(std::string(s) + ".bias." + ax[j], (acc ? 0.05 : 0.005) * u(rng));
      p.set(std::string(s) + ".scale." + ax[j], 0.01 * u(rng));
      p.set(std::string(s) + ".bias_temp." + ax[j] + ".t1", (acc ? 1e-3 : 1e-4) * u(rng));
      p.set(std::string(s) + ".bias_temp." + ax[j] + ".t2", (acc ? 1e-5 : 1e-6) * u(rng));
      p.set(std::string(s) + ".scale_temp." + ax[j] + ".t1", 1e-4 * u(rng));
    }
    for (auto mname : mis) p.set(std::string(s) + ".misalign." + mname, 0.003 * u(rng));
  }
  return p;
}

}  // namespace synth
