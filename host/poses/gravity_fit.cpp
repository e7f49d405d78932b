#include "host/poses/gravity_fit.h"

#include <cmath>
#include <limits>

namespace imuforge::poses {

const char* const kGravityFitNames[9] = {"accel.bias.x",      "accel.bias.y",      "accel.bias.z",
                                         "accel.scale.x",     "accel.scale.y",     "accel.scale.z",
                                         "accel.misalign.yx", "accel.misalign.zx", "accel.misalign.zy"};

Eigen::Matrix3d GravityFit::im() const {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  for (int j = 0; j < 3; ++j) m(j, j) += p[3 + j];
  m(1, 0) = p[6];
  m(2, 0) = p[7];
  m(2, 1) = p[8];
  return m;
}

GravityFit fit_gravity(const std::vector<Pose>& poses, double g, const std::array<bool, 9>& active) {
  GravityFit f;
  f.active = active;
  std::vector<int> idx;
  for (int k = 0; k < 9; ++k)
    if (active[static_cast<std::size_t>(k)]) idx.push_back(k);
  const int na = static_cast<int>(idx.size());
  const long m = static_cast<long>(poses.size());
  if (m <= na)
    throw PoseError("gravity-magnitude fit: " + std::to_string(m) + " static poses for " + std::to_string(na) +
                    " accelerometer unknowns (need more poses than unknowns)");
  auto resid = [&](const Eigen::Matrix<double, 9, 1>& p) {
    GravityFit t;
    t.p = p;
    const Eigen::Matrix3d im = t.im();
    Eigen::VectorXd e(m);
    for (long i = 0; i < m; ++i)
      e[i] = im.triangularView<Eigen::Lower>().solve(poses[static_cast<std::size_t>(i)].acc - t.bias()).norm() - g;
    return e;
  };
  auto jac = [&](const Eigen::Matrix<double, 9, 1>& p) {
    Eigen::MatrixXd j(m, na);
    for (int a = 0; a < na; ++a) {
      const double h = idx[static_cast<std::size_t>(a)] < 3 ? 1e-6 : 1e-7;
      Eigen::Matrix<double, 9, 1> u = p, v = p;
      u[idx[static_cast<std::size_t>(a)]] += h;
      v[idx[static_cast<std::size_t>(a)]] -= h;
      j.col(a) = (resid(u) - resid(v)) / (2 * h);
    }
    return j;
  };
  Eigen::Matrix<double, 9, 1> p = Eigen::Matrix<double, 9, 1>::Zero();
  Eigen::VectorXd e = resid(p);
  f.rms_before = std::sqrt(e.squaredNorm() / static_cast<double>(m));
  double lambda = 1e-3;
  for (int it = 0; it < 100 && na > 0; ++it) {
    const Eigen::MatrixXd j = jac(p);
    const Eigen::MatrixXd a = j.transpose() * j;
    const Eigen::VectorXd rhs = -j.transpose() * e;
    bool improved = false;
    Eigen::VectorXd dx;
    for (int tries = 0; tries < 20 && !improved; ++tries) {
      Eigen::MatrixXd ad = a;
      ad.diagonal() += lambda * a.diagonal().cwiseMax(1e-12);
      dx = ad.ldlt().solve(rhs);
      Eigen::Matrix<double, 9, 1> q = p;
      for (int k = 0; k < na; ++k) q[idx[static_cast<std::size_t>(k)]] += dx[k];
      const Eigen::VectorXd eq = resid(q);
      if (eq.allFinite() && eq.squaredNorm() <= e.squaredNorm()) {
        p = q;
        e = eq;
        lambda = std::max(1e-12, lambda / 10);
        improved = true;
      } else {
        lambda *= 10;
      }
    }
    if (!improved || dx.norm() < 1e-12) break;
  }
  f.p = p;
  f.residual = e;
  f.rms_after = std::sqrt(e.squaredNorm() / static_cast<double>(m));
  f.dof = static_cast<int>(m) - na;
  const double s2 = e.squaredNorm() / f.dof;
  const Eigen::MatrixXd j = jac(p);
  f.info = j.transpose() * j / (s2 > 0 ? s2 : std::numeric_limits<double>::min());
  return f;
}

}  // namespace imuforge::poses
