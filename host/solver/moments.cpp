#include "host/solver/moments.h"

namespace imuforge::solver {

void BlockMoments::add(double T_C, const double z[kNumChannels]) {
  const double s = (T_C - T0_C) / kBlockTempScale;
  double p[7];
  p[0] = 1.0;
  for (int k = 1; k < 7; ++k) p[k] = p[k - 1] * s;
  for (int k = 0; k < 7; ++k) s_pow[static_cast<size_t>(k)] += p[k];
  for (int c = 0; c < kNumChannels; ++c) {
    auto& a = zs[static_cast<size_t>(c)];
    const double zc = z[c];
    a[0] += zc;
    a[1] += zc * p[1];
    a[2] += zc * p[2];
    a[3] += zc * p[3];
    zz[static_cast<size_t>(c)] += zc * zc;
    z1[static_cast<size_t>(c)] += zc;
  }
  ++n;
}

Eigen::Matrix4d BlockMoments::S() const {
  Eigen::Matrix4d m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m(i, j) = s_pow[static_cast<size_t>(i + j)];
  return m;
}

double BlockMoments::within_variance(int c) const {
  // Residual variance about a straight line in temperature: a dwell's die drift times the bias tempco
  // must not count as noise.
  if (n < 3) return 0.0;
  const auto& a = zs[static_cast<size_t>(c)];
  Eigen::Matrix2d m;
  m << s_pow[0], s_pow[1], s_pow[1], s_pow[2];
  const Eigen::Vector2d v(a[0], a[1]);
  double fit;
  if (std::abs(m.determinant()) > 1e-12 * s_pow[0] * std::max(s_pow[2], 1e-300)) {
    fit = v.dot(m.ldlt().solve(v));
  } else {
    fit = a[0] * a[0] / s_pow[0];  // constant temperature: plain variance
  }
  const double dof = static_cast<double>(n) - (fit == a[0] * a[0] / s_pow[0] ? 1.0 : 2.0);
  return std::max(0.0, (zz[static_cast<size_t>(c)] - fit) / dof);
}

const Eigen::Matrix4d& node_to_coeff() {
  static const Eigen::Matrix4d inv = [] {
    Eigen::Matrix4d v;
    for (int i = 0; i < 4; ++i) {
      double p = 1.0;
      for (int k = 0; k < 4; ++k) {
        v(i, k) = p;
        p *= kNodes[static_cast<size_t>(i)];
      }
    }
    return Eigen::Matrix4d(v.inverse());
  }();
  return inv;
}

}  // namespace imuforge::solver
