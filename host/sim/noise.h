// Deterministic random numbers and the stochastic sensor processes (docs/error-model.md § noise).
// Own generator and normal transform so a seed gives the same stream on every platform and library.
#pragma once

#include <cmath>
#include <cstdint>

namespace imuforge::sim {

// xoshiro256** seeded through splitmix64.
class Rng {
 public:
  explicit Rng(std::uint64_t seed = 1) { this->seed(seed); }
  void seed(std::uint64_t s) {
    for (auto& x : s_) {
      s += 0x9e3779b97f4a7c15ULL;
      std::uint64_t z = s;
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
      x = z ^ (z >> 31);
    }
    have_spare_ = false;
  }
  std::uint64_t next_u64() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform in (0, 1).
  double uniform() { return (static_cast<double>(next_u64() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  // Standard normal, Marsaglia polar method (pairs cached).
  double normal() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double m = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * m;
    have_spare_ = true;
    return u * m;
  }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
  double spare_ = 0.0;
  bool have_spare_ = false;
};

// Number of first-order Gauss-Markov processes approximating flicker (bias instability).
constexpr int kFlickerTerms = 3;

// Stochastic part of one sensor axis at a fixed sample interval dt.
// bias instability B: kFlickerTerms Gauss-Markov processes with correlation times tau_s·{0.1, 1, 10},
// each of standard deviation σ_gm = B·kFlickerSigmaPerB, chosen so the Allan deviation of the sum stays
// within 10 % of 0.664·B between 0.2·tau_s and 10·tau_s (see docs/error-model.md).
constexpr double kFlickerSigmaPerB = 0.664 / 0.62 / 1.2247;  // per-term σ / B (three overlapping humps)

struct AxisNoise {
  double white_sigma = 0;         // N·√fs
  double rrw_step = 0;            // K·√dt
  double gm_phi[kFlickerTerms] = {};
  double gm_drive[kFlickerTerms] = {};  // σ_gm·√(1−φ²)
  double gm_state[kFlickerTerms] = {};
  double rrw_state = 0;

  void configure(double N, double B, double tau_s, double K, double dt_s, Rng& rng) {
    white_sigma = N / std::sqrt(dt_s);
    rrw_step = K * std::sqrt(dt_s);
    for (int i = 0; i < kFlickerTerms; ++i) {
      const double tc = tau_s * std::pow(10.0, i - 1);
      const double sigma = B * kFlickerSigmaPerB;
      gm_phi[i] = tau_s > 0 ? std::exp(-dt_s / tc) : 0.0;
      gm_drive[i] = sigma * std::sqrt(1.0 - gm_phi[i] * gm_phi[i]);
      gm_state[i] = sigma > 0 ? sigma * rng.normal() : 0.0;  // start in steady state
    }
    rrw_state = 0;
  }
  // One sample of the sum of all processes. Draws a fixed number of normals per enabled process.
  double step(Rng& rng) {
    double v = 0;
    if (white_sigma > 0) v += white_sigma * rng.normal();
    for (int i = 0; i < kFlickerTerms; ++i) {
      if (gm_drive[i] > 0) gm_state[i] = gm_phi[i] * gm_state[i] + gm_drive[i] * rng.normal();
      v += gm_state[i];
    }
    if (rrw_step > 0) rrw_state += rrw_step * rng.normal();
    return v + rrw_state;
  }
};

}  // namespace imuforge::sim
