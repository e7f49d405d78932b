// Per-block sufficient statistics: the reason the solver's memory and time do not grow with samples.
//
// A *block* is a run of consecutive samples whose non-thermal inputs are (nearly, see fixture.cpp) constant (one dwell of the
// table: constant f, ω, hysteresis state). Within it the model's prediction and Jacobian depend on the
// sample only through the temperature, and every catalog term is a polynomial of degree ≤ 3 in T.
// With s = (T − T0)/kBlockTempScale, the block keeps
//     n, Σ s^k (k = 0..6), and per channel Σ z s^k (k = 0..3), Σ z²
// and for ANY prediction p(s) and Jacobian J(s) that are cubics in s the normal equations are exact:
//     Σ r²   = Σz² − 2 pᵀ Zs + pᵀ S p          (p: coefficients of the prediction, r = z − p(s))
//     Σ J r  = B (Zs − S p)                     (B: coefficients of the Jacobian, n × 4)
//     Σ J Jᵀ = B S Bᵀ                           (S = [Σ s^{i+j}], 4 × 4)
// Coefficients come from values at 4 fixed nodes (so callers only evaluate the model at 4 temperatures
// per block); a 5th node checks that the model really is cubic in T.
#pragma once

#include <array>

#include <Eigen/Dense>

namespace imuforge::solver {

constexpr int kNumChannels = 6;           // ax ay az gx gy gz
constexpr double kBlockTempScale = 10.0;  // °C per unit of s (keeps s^6 well scaled)
constexpr int kNumNodes = 4;
// Node positions in s; node values are taken at T0 + node·kBlockTempScale.
constexpr std::array<double, kNumNodes> kNodes = {-1.0, 0.0, 1.0, 2.0};
constexpr double kCheckNode = 0.5;

struct BlockMoments {
  double T0_C = 0.0;  // expansion point (first sample's temperature)
  long long n = 0;
  std::array<double, 7> s_pow{};                             // Σ s^k
  std::array<std::array<double, 4>, kNumChannels> zs{};      // Σ z s^k per channel
  std::array<double, kNumChannels> zz{};                     // Σ z² per channel
  std::array<double, kNumChannels> z1{};                     // Σ z (== zs[c][0], kept for clarity)

  void reset(double T0) { *this = BlockMoments{}; T0_C = T0; }
  // O(1) per sample: 7 powers + 6·5 products.
  void add(double T_C, const double z[kNumChannels]);
  Eigen::Matrix4d S() const;
  double within_variance(int c) const;  // variance about a linear trend in T (dof n − 2); 0 if n < 3
  double mean_T() const { return n ? T0_C + kBlockTempScale * s_pow[1] / static_cast<double>(n) : T0_C; }
};

// Converts values at kNodes to monomial coefficients (row vector of node values -> coefficients).
// coeff = V⁻¹ values, where V(i,k) = node_i^k.
const Eigen::Matrix4d& node_to_coeff();
// Evaluates a cubic with coefficients c at s.
inline double cubic(const Eigen::Vector4d& c, double s) { return c[0] + s * (c[1] + s * (c[2] + s * c[3])); }

}  // namespace imuforge::solver
