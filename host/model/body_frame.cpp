#include "host/model/body_frame.h"

#include <Eigen/Dense>

namespace imuforge::model {

namespace {

const char* kAxes = "xyz";

std::string comp(int j, int k) { return std::string(1, kAxes[j]) + kAxes[k]; }

// The 3×3 input-side matrix of one sensor's scale (diagonal) and misalignment (off-diagonal) effect
// pair, optionally a temperature power p (1..3; 0 = the constant part).
Eigen::Matrix3d get_matrix(const ParamSet& p, const char* sensor, int power) {
  Eigen::Matrix3d m;
  const std::string s(sensor);
  const std::string suffix = power ? ".t" + std::to_string(power) : "";
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k)
      m(j, k) = j == k ? p.get(s + (power ? ".scale_temp." : ".scale.") + kAxes[j] + suffix)
                       : p.get(s + (power ? ".misalign_temp." : ".misalign.") + comp(j, k) + suffix);
  return m;
}

void set_matrix(ParamSet& p, const char* sensor, int power, const Eigen::Matrix3d& m) {
  const std::string s(sensor);
  const std::string suffix = power ? ".t" + std::to_string(power) : "";
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k)
      p.set(j == k ? s + (power ? ".scale_temp." : ".scale.") + kAxes[j] + suffix
                   : s + (power ? ".misalign_temp." : ".misalign.") + comp(j, k) + suffix,
            m(j, k));
}

}  // namespace

BodyFrameParams to_accel_body_frame(const ParamSet& in) {
  BodyFrameParams out{in, Eigen::Matrix3d::Identity()};
  const Eigen::Matrix3d A = Eigen::Matrix3d::Identity() + get_matrix(in, "accel", 0);
  // LQ of A from the QR of Aᵀ: Aᵀ = Q₁R₁  ⇒  A = R₁ᵀQ₁ᵀ. Signs flipped so L has a positive diagonal.
  Eigen::HouseholderQR<Eigen::Matrix3d> qr(A.transpose());
  const Eigen::Matrix3d R1 = qr.matrixQR().triangularView<Eigen::Upper>();
  const Eigen::Matrix3d Q1 = qr.householderQ();
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 3; ++i)
    if (R1(i, i) < 0) D(i, i) = -1.0;
  Eigen::Matrix3d L = R1.transpose() * D;
  const Eigen::Matrix3d Q = D * Q1.transpose();  // A = L·Q, Q orthonormal with det +1 for small errors
  L.triangularView<Eigen::StrictlyUpper>().setZero();  // exact zeros, not rounding residue
  out.C_body_case = Q;
  set_matrix(out.params, "accel", 0, L - Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d Qt = Q.transpose();
  set_matrix(out.params, "gyro", 0, (Eigen::Matrix3d::Identity() + get_matrix(in, "gyro", 0)) * Qt - Eigen::Matrix3d::Identity());
  for (const char* s : {"accel", "gyro"})
    for (int pw = 1; pw <= 3; ++pw) set_matrix(out.params, s, pw, get_matrix(in, s, pw) * Qt);
  Eigen::Matrix3d G;
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k) G(j, k) = in.get(std::string("gyro.g_sensitivity.") + comp(j, k));
  const Eigen::Matrix3d Gb = G * Qt;
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k) out.params.set(std::string("gyro.g_sensitivity.") + comp(j, k), Gb(j, k));
  return out;
}

const std::vector<ParamId>& intrinsic_misalignment_ids() {
  static const std::vector<ParamId> ids = [] {
    std::vector<ParamId> v;
    for (const char* c : {"yx", "zx", "zy"}) v.push_back(find_param(std::string("accel.misalign.") + c));
    for (const char* c : {"xy", "xz", "yx", "yz", "zx", "zy"}) v.push_back(find_param(std::string("gyro.misalign.") + c));
    return v;
  }();
  return ids;
}

}  // namespace imuforge::model
