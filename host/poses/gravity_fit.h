// The reference-free front end's accelerometer step (Tedaldi, Pretto, Menegatti, ICRA 2014): on the
// means ȳ_i of the detected static poses, minimise Σ_i (|(I+M)⁻¹(ȳ_i − b)| − g)². |f| is blind to a
// rotation of the frame, so M is lower triangular (the body frame is the accelerometer's: x sensing
// axis = body x, y sensing axis in the body xy plane): 9 unknowns, in the order of kGravityFitNames.
// Shared by the solver (which adds the gyro) and the diagnosis (which builds pseudo-references).
//
// Extra catalog terms (host/model, the one catalog: accel.scale_nonlinearity, scale_asymmetry,
// cross_coupling) enter as y = (I+M) f + b + J_x(f) q with the catalog's own regressors J_x; f̂ is then
// the fixed point of f = (I+M)⁻¹ (y − b − J_x(f) q) (the terms are small, 4 iterations reach 1e-12).
// select_gravity_terms adds such terms only where leave-poses-out cross-validation says they predict
// withheld poses better: a term is never chosen on its in-sample gain.
//
// Levenberg-Marquardt with a central-difference Jacobian (9 unknowns, tens of poses: negligible cost).
// σ² of the residual is its scatter RSS/(m − p): a hand's placement and micro-motion, not sensor noise,
// dominate the pose-to-pose error.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "host/model/catalog.h"
#include "host/poses/detect.h"

namespace imuforge::poses {

extern const char* const kGravityFitNames[9];  // accel.bias.x … accel.misalign.zy

struct GravityFit {
  Eigen::Matrix<double, 9, 1> p = Eigen::Matrix<double, 9, 1>::Zero();  // inactive ones stay 0
  std::array<bool, 9> active{};
  std::vector<model::ParamId> extra;  // extra catalog terms (accelerometer), after the 9
  Eigen::VectorXd q;                  // their values, in extra's order
  Eigen::MatrixXd info;      // over the active unknowns, then the extras, in order: JᵀJ / σ²
  Eigen::VectorXd residual;  // per pose: |f̂_i| − g, m/s²
  double rms_before = 0;     // RMS of |ȳ_i| − g (nominal LSB)
  double rms_after = 0;
  int dof = 0;
  Eigen::Vector3d bias() const { return p.head<3>(); }
  Eigen::Matrix3d im() const;  // I + M
  Eigen::Vector3d apply(const Eigen::Vector3d& y) const;  // f̂ = (I+M)⁻¹ (y − b − J_x(f̂) q)
};

// Throws PoseError when there are not more poses than active unknowns.
GravityFit fit_gravity(const std::vector<Pose>& poses, double gravity_mps2, const std::array<bool, 9>& active,
                       const std::vector<model::ParamId>& extra = {});

// The accelerometer terms of the catalog the gravity-magnitude fit may add (scale_nonlinearity k2, k3,
// scale_asymmetry, cross_coupling). Not the cross-axis nonlinearity, which a static pose excites too: beside
// these its 9 terms cost the selection its false-add rate on noise (gravity_fit.cpp).
std::vector<model::ParamId> gravity_candidate_terms();

// Forward selection by leave-poses-out cross-validation: starting from the 9-term fit, each round tries
// every remaining candidate, refits with each pose (or fold of poses) withheld in turn and scores |f̂|−g
// on the withheld poses; the candidate with the lowest held-out RMS is added when that RMS is below
// (1 − min_gain) × the current one and the fit keeps ≥ min_dof degrees of freedom. Nothing is tried with
// fewer than min_poses poses. Folds: kHeldoutFolds interleaved in time (estimator::interleaved_fold, not
// i mod K, which puts every repeat of one orientation in one fold when a tumble of 6 or 12 poses is repeated:
// that fold then tests an orientation no training pose has); 12 rather than leave-one-out keeps the ~15
// candidates × a few rounds well under a second.
constexpr std::size_t kHeldoutFolds = 12;
struct TermSelectOptions {
  int min_poses = 20;
  int min_dof = 10;
  double min_gain = 0.10;  // a term must cut the held-out RMS by ≥ 10 % (selection among many is optimistic)
  int max_terms = 6;
};
struct TermSelection {
  GravityFit fit;                      // the final fit on every pose, with the selected extras
  std::vector<model::ParamId> added;   // in the order chosen
  std::vector<double> heldout_rms;     // held-out RMS after each round: [0] = 9 terms, [k] = k extras
  bool tried = false;                  // false: fewer than min_poses poses, the 9-term fit is kept
  std::string note;                    // why selection stopped or was not tried
};
TermSelection select_gravity_terms(const std::vector<Pose>& poses, double gravity_mps2, const std::array<bool, 9>& active,
                                   const TermSelectOptions& opt = {});
// Held-out RMS of |f̂|−g: each fold's poses scored with the fit to the other poses.
double heldout_gravity_rms(const std::vector<Pose>& poses, double gravity_mps2, const std::array<bool, 9>& active,
                           const std::vector<model::ParamId>& extra);

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
