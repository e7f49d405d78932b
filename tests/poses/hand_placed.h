// A synthetic hand-placed recording for the static-pose detector, written independently of the
// simulator and the model catalog (plain matrices): poses of random attitude, smooth hand rotations
// between them (raised-cosine angle profile, so the peak rate is angle·π/(2·T)), a hand's translation
// acceleration during the moves, optional slow settling (a decaying tilt wobble after placement), bumps
// (a short tap that returns to the same attitude), slow tilts below the still-rate limit, hand tremor.
// The sensor: y = (I+M)·x + b + white noise (different per axis), quantised to counts of a given word.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "host/io/log.h"
#include "host/poses/recording.h"

namespace handtest {

struct Step {
  enum Kind { kPose, kMove, kBump, kSlowTilt } kind = kPose;
  double duration_s = 5;
  double angle_deg = 90;   // kMove / kSlowTilt
  bool settle = false;     // kPose: a decaying wobble at the start
  double blips_mps2 = 0;   // kPose: 0.1 s vibration bursts every 2 s (a bench someone knocks), 1σ
};

struct Sensor {
  Eigen::Matrix3d Ma = Eigen::Matrix3d::Zero(), Mg = Eigen::Matrix3d::Zero();
  Eigen::Vector3d ba = Eigen::Vector3d::Zero(), bg = Eigen::Vector3d::Zero();
  Eigen::Vector3d noise_a{0.004, 0.008, 0.02}, noise_g{0.002, 0.003, 0.004};  // per axis, 1σ per sample
  double lsb_a = 1e-4, lsb_g = 1e-5;
  int bits = 20;
  double tremor_rad_s = 0;  // hand tremor during poses (white, per axis)
};

struct Truth {
  int poses = 0;  // distinct still placements a person would count
};

inline Truth generate(const std::vector<Step>& steps, const Sensor& s, unsigned seed, imuforge::poses::Recording& rec) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::uniform_real_distribution<double> u01(0, 1);
  const double fs = 100, g = 9.80665, dt = 1 / fs;
  rec = {};
  rec.rate_hz = fs;
  rec.gravity_mps2 = g;
  rec.accel_lsb = s.lsb_a;
  rec.gyro_lsb = s.lsb_g;
  rec.accel_bits = rec.gyro_bits = s.bits;
  Eigen::Quaterniond q(Eigen::AngleAxisd(2 * M_PI * u01(rng), Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(M_PI * u01(rng), Eigen::Vector3d::UnitX()));  // body -> world
  double t = 0;
  const double word = std::ldexp(1.0, s.bits - 1);
  auto emit = [&](const Eigen::Vector3d& w_body, const Eigen::Vector3d& a_world_dyn) {
    const Eigen::Vector3d f = q.toRotationMatrix().transpose() * (Eigen::Vector3d(0, 0, g) + a_world_dyn);
    const Eigen::Vector3d ya = (Eigen::Matrix3d::Identity() + s.Ma) * f + s.ba;
    const Eigen::Vector3d yg = (Eigen::Matrix3d::Identity() + s.Mg) * w_body + s.bg;
    std::array<double, 6> y;
    bool ca = false, cg = false;
    for (int k = 0; k < 3; ++k) {
      double c = std::nearbyint((ya[k] + s.noise_a[k] * n01(rng)) / s.lsb_a);
      ca = ca || c <= -word || c >= word - 1;
      y[static_cast<std::size_t>(k)] = std::clamp(c, -word, word - 1) * s.lsb_a;
      c = std::nearbyint((yg[k] + s.noise_g[k] * n01(rng)) / s.lsb_g);
      cg = cg || c <= -word || c >= word - 1;
      y[static_cast<std::size_t>(3 + k)] = std::clamp(c, -word, word - 1) * s.lsb_g;
    }
    rec.t_s.push_back(t);
    rec.y.push_back(y);
    rec.accel_clipped.push_back(ca);
    rec.gyro_clipped.push_back(cg);
    rec.clipped_samples += cg;
    rec.accel_clipped_samples += ca;
    t += dt;
  };
  Truth tr;
  for (const Step& st : steps) {
    const int n = static_cast<int>(std::lround(st.duration_s * fs));
    if (st.kind == Step::kPose) {
      ++tr.poses;
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d w = Eigen::Vector3d::Zero();
        const double ti = i * dt;
        if (st.settle && ti < 3.0) {
          // Decaying wobble: 1.5° at 1.3 Hz, τ = 0.6 s, about a body axis; the IMU ends where it started.
          const double om = 2 * M_PI * 1.3, amp = 1.5 * M_PI / 180 * std::exp(-ti / 0.6);
          w = Eigen::Vector3d(1, 0.5, 0).normalized() * amp * (om * std::cos(om * ti) - std::sin(om * ti) / 0.6);
        }
        for (int k = 0; k < 3; ++k) w[k] += s.tremor_rad_s * n01(rng);
        Eigen::Vector3d a_dyn = Eigen::Vector3d::Zero();
        if (st.blips_mps2 > 0 && std::fmod(ti, 2.0) > 1.0 && std::fmod(ti, 2.0) < 1.1) {
          for (int k = 0; k < 3; ++k) a_dyn[k] = st.blips_mps2 * n01(rng);
          for (int k = 0; k < 3; ++k) w[k] += 0.2 * n01(rng);  // the gyro sees the knock, not a turn
        }
        if (w.norm() > 0 && (st.settle || s.tremor_rad_s > 0) && st.blips_mps2 == 0) {
          q = q * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm() * dt, w.normalized()));
          q.normalize();
        }
        emit(w, a_dyn);
      }
      continue;
    }
    // A rotation about a random body axis with a raised-cosine profile; bumps rotate out and back.
    Eigen::Vector3d axis(n01(rng), n01(rng), n01(rng));
    axis.normalize();
    const double ang = st.angle_deg * M_PI / 180, T = st.duration_s;
    const Eigen::Vector3d push(n01(rng), n01(rng), 0.3 * n01(rng));
    for (int i = 0; i < n; ++i) {
      const double x = (i + 0.5) * dt / T;
      double rate = ang * M_PI / (2 * T) * std::sin(M_PI * x);
      Eigen::Vector3d a_dyn = Eigen::Vector3d::Zero();
      if (st.kind == Step::kBump) {
        rate = ang * M_PI / T * std::sin(2 * M_PI * x);  // out and back: net rotation 0
        a_dyn = 3.0 * push * std::sin(2 * M_PI * x);
      } else if (st.kind == Step::kMove) {
        a_dyn = 1.5 * push * std::sin(2 * M_PI * x);  // the hand's translation (starts and ends at rest)
      }
      const Eigen::Vector3d w = axis * rate;
      q = q * Eigen::Quaterniond(Eigen::AngleAxisd(std::abs(rate) * dt, rate >= 0 ? axis : Eigen::Vector3d(-axis)));
      q.normalize();
      emit(w, a_dyn);
    }
  }
  return tr;
}

// A session: initial still period, then `poses` placements of dwell_s each with moves between.
inline std::vector<Step> session(int poses, double dwell_min_s, double dwell_max_s, unsigned seed, bool settle = false,
                                 double peak_angle_deg = 150, double move_s = 1.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<Step> v;
  v.push_back({Step::kPose, 20, 0, false});
  for (int p = 1; p < poses; ++p) {
    v.push_back({Step::kMove, move_s * (0.8 + 0.4 * u01(rng)), 40 + (peak_angle_deg - 40) * u01(rng), false});
    v.push_back({Step::kPose, dwell_min_s + (dwell_max_s - dwell_min_s) * u01(rng), 0, settle});
  }
  return v;
}

}  // namespace handtest
