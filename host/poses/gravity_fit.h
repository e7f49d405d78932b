// The reference-free front end's accelerometer step (Tedaldi, Pretto, Menegatti, ICRA 2014): on the
// means ȳ_i of the detected static poses, minimise Σ_i (|(I+M)⁻¹(ȳ_i − b)| − g)². |f| is blind to a
// rotation of the frame, so M is lower triangular (the body frame is the accelerometer's: x sensing
// axis = body x, y sensing axis in the body xy plane): 9 unknowns, in the order of kGravityFitNames.
// Shared by the solver (which adds the gyro) and the diagnosis (which builds pseudo-references).
//
// Levenberg-Marquardt with a central-difference Jacobian (9 unknowns, tens of poses: negligible cost).
// σ² of the residual is its scatter RSS/(m − p): a hand's placement and micro-motion, not sensor noise,
// dominate the pose-to-pose error.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Dense>

#include "host/poses/detect.h"

namespace imuforge::poses {

extern const char* const kGravityFitNames[9];  // accel.bias.x … accel.misalign.zy

struct GravityFit {
  Eigen::Matrix<double, 9, 1> p = Eigen::Matrix<double, 9, 1>::Zero();  // inactive ones stay 0
  std::array<bool, 9> active{};
  Eigen::MatrixXd info;      // over the active unknowns, in order: JᵀJ / σ²
  Eigen::VectorXd residual;  // per pose: |f̂_i| − g, m/s²
  double rms_before = 0;     // RMS of |ȳ_i| − g (nominal LSB)
  double rms_after = 0;
  int dof = 0;
  Eigen::Vector3d bias() const { return p.head<3>(); }
  Eigen::Matrix3d im() const;  // I + M
  Eigen::Vector3d apply(const Eigen::Vector3d& y) const { return im().triangularView<Eigen::Lower>().solve(y - bias()); }
};

// Throws PoseError when there are not more poses than active unknowns.
GravityFit fit_gravity(const std::vector<Pose>& poses, double gravity_mps2, const std::array<bool, 9>& active);

// |a| − g over poses for any accelerometer correction: the independent metric (RMS) used to compare
// calibrations, e.g. one recording's calibration applied to another recording's poses.
template <class Apply>
double gravity_rms(const std::vector<Pose>& poses, double gravity_mps2, Apply&& apply) {
  double s = 0;
  for (const Pose& p : poses) {
    const double e = apply(p.acc).norm() - gravity_mps2;
    s += e * e;
  }
  return poses.empty() ? 0.0 : std::sqrt(s / static_cast<double>(poses.size()));
}

}  // namespace imuforge::poses
