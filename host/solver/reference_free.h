// Reference-free mode (Tedaldi, Pretto, Menegatti, "A robust and easy to implement method for IMU
// calibration without external equipments", ICRA 2014): static poses of unknown orientation.
//
// 1. Static poses: the one detector of host/poses/detect.h (noise-adaptive per axis, minimum dwell,
//    settle margins, split on attitude change, merge of bumped poses); --explain-poses prints its table.
// 2. Accelerometer (host/poses/gravity_fit.h, shared with the diagnosis): minimise Σ_i (|f̂_i| − g)², f̂_i = (I+M_a)⁻¹ (ȳ_i − b_a), over the pose means ȳ_i.
//    |f| is blind to a rotation of the frame, so 3 of the 6 misalignments are fixed by a gauge: the body
//    frame is the accelerometer's (x sensing axis = body x, y sensing axis in the body xy plane), i.e.
//    accel.misalign.xy = xz = yz = 0 (a lower-triangular I+M_a, Tedaldi's convention).
// 3. Gyro bias: the sample-weighted mean gyro output over the static intervals.
// 4. Gyro scale and misalignment (transitions with a clipped gyro sample are skipped): integrate ω̂ = (I+M_g)⁻¹ (y_g − b_g) (quaternion, RK4) from the end of
//    pose i to the start of pose i+1; the predicted gravity direction Rᵀ ĝ_i must match ĝ_{i+1}.
// Weights: the residual scatter (σ² = RSS / (m − p)); a transition's residual is the difference of two
// unit vectors, which has 2 degrees of freedom, not 3, so m = 2 × transitions. Scatter rather than
// noise, since a hand's micro-motion, not sensor noise, dominates the pose-to-pose error. Covariance:
// per block (accel; gyro bias; gyro scale/misalign), plus the accelerometer and gyro-bias uncertainty
// propagated into the gyro block through its sensitivity to them (sequential estimate, with the
// cross-covariances).
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/poses/detect.h"
#include "host/poses/gravity_fit.h"
#include "host/poses/recording.h"
#include "host/solver/estimate.h"

namespace imuforge::solver {

// All samples of a recording in SI, with the clip flags judged against the log's declared raw widths.
using RawRecording = poses::Recording;
using poses::read_recording;
using StaticInterval = poses::Pose;

struct ReferenceFreeOptions {
  poses::DetectOptions detect;
  int min_intervals = 9;  // the accelerometer has 9 unknowns
  // Extra accelerometer terms of the catalog chosen by leave-poses-out cross-validation
  // (poses::select_gravity_terms) when the model asks for all 9 basic terms and there are enough poses.
  bool select_terms = true;
  poses::TermSelectOptions term_select;
  // A coefficient table (v1: bias, scale, misalignment and their temperature terms) will be written:
  // it cannot express the extra terms, so none is tried (terms_note says so).
  bool for_table = false;
};

struct ReferenceFreeResult {
  Estimate estimate;                // the model's parameters (those not fixed by the gauge)
  std::vector<std::string> gauge_fixed;
  Observability observability;      // of the stacked blocks
  std::vector<StaticInterval> intervals;  // = detection.poses
  poses::Detection detection;
  double gravity_mps2 = 0.0;
  double gravity_rms_before = 0.0;  // RMS over poses of |ȳ_i| − g with the nominal LSB
  double gravity_rms_after = 0.0;   // same with the calibration
  double rotation_rms_before = 0.0; // RMS |ĝ_pred − ĝ| over pose transitions, nominal gyro (+ static bias)
  double rotation_rms_after = 0.0;
  std::array<double, 6> residual_rms{};  // per channel: static-interval scatter after calibration
  // Term selection: the extra catalog terms added (also in estimate), the held-out |f̂|−g RMS of the 9-term
  // fit and of the selected one, and why selection stopped or was not tried.
  std::vector<std::string> terms_added;
  double heldout_rms_basic = 0.0, heldout_rms_selected = 0.0;
  bool terms_tried = false;
  std::string terms_note;
  poses::GravityFit accel_fit;      // the accelerometer calibration as fitted (apply() includes the extras)
  int transitions_used = 0;         // pose-to-pose transitions in the gyro fit
  int transitions_clipped = 0;      // left out: a gyro sample at full scale
};

ReferenceFreeResult solve_reference_free(const RawRecording& rec, const model::ModelSpec& spec,
                                         const ReferenceFreeOptions& opt = {});
// Several recordings of one unit calibrated together: the poses of all feed one gravity fit; each
// recording's transitions are integrated about its own turn-on gyro bias (the estimate states the pooled
// bias, its σ from the scatter of every pose); no transition spans two recordings. detection = the
// first recording's.
ReferenceFreeResult solve_reference_free(const std::vector<const RawRecording*>& recs, const model::ModelSpec& spec,
                                         const ReferenceFreeOptions& opt = {});
// The "reference_free" section of cal.json (poses, threshold, gravity and its source, residuals before
// and after, transitions, gauge), shared by `imuforge solve` and the Python module.
nlohmann::json reference_free_summary(const ReferenceFreeResult& r, const RawRecording& rec);

// Applies a (reference-free) calibration to a triad sample: (I+M)⁻¹ (y − b).
struct TriadCal {
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d IM = Eigen::Matrix3d::Identity();
  Eigen::Vector3d apply(const Eigen::Vector3d& y) const { return IM.lu().solve(y - b); }
};
TriadCal triad_from_estimate(const Estimate& e, const std::string& sensor);
// The accelerometer calibration of an estimate with its extra catalog terms (scale_nonlinearity,
// scale_asymmetry, cross_coupling) as a gravity fit, whose apply() inverts the whole model.
// The upper misalignments (gauge-fixed at 0 in reference-free mode) are not representable: throws
// SolverError when one is non-zero.
poses::GravityFit accel_fit_from_estimate(const Estimate& e);

// Known-angle check: integrates the calibrated gyro over the whole recording, with the gyro bias
// re-estimated from the recording's first static interval (turn-on bias changes at every power-up).
// Throws SolverError when the recording has a clipped gyro sample (the angle would be short).
struct RotationCheck {
  double angle_deg = 0.0;
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  double angle_nominal_deg = 0.0;    // same with nominal scale (bias still removed)
  // 1σ of angle_deg propagated from the covariance of the gyro scale/misalignment (first order, central
  // differences); NaN when no covariance was given. The bias is re-estimated, so its σ does not enter.
  double angle_sigma_deg = std::numeric_limits<double>::quiet_NaN();
};
RotationCheck rotation_check(const RawRecording& rec, const TriadCal& gyro, const poses::DetectOptions& det = {});
RotationCheck rotation_check(const RawRecording& rec, const Estimate& cal, const poses::DetectOptions& det = {});

// Integrates ω over samples [i0, i1) with RK4 on the unit quaternion; returns R such that v_start = R v_end.
Eigen::Matrix3d integrate_rotation(const RawRecording& rec, const TriadCal& gyro, std::size_t i0, std::size_t i1);

}  // namespace imuforge::solver
