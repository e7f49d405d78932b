// Recursive tracking of the calibration during collection (docs/eol.md "Tracking and early stop").
//
// Each finished segment is reduced to normal equations with the catalog's regressors
// (host/model/measure.h: y = u + J θ, exactly linear) and folded into the solver's square-root
// information filter (host/solver/srif.h), so σ is known after every segment and equals the batch
// fixture-mode solution at the end. Samples are averaged in blocks of ~0.1 s (σ²/B each): exact for
// static segments, and the regressors vary slowly enough in rate segments. Cost per segment:
// O(blocks · n²) with n parameters; memory O(n²) plus O(n) per segment for the residual report.
//
// The same regressors predict the information a segment WOULD bring (it does not depend on the data for
// a linear model), which the runner uses to choose and to stop steps early.
#pragma once
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "host/io/log.h"
#include "host/model/measure.h"
#include "host/model/sensor_model.h"
#include "host/solver/estimate.h"
#include "host/solver/srif.h"
#include "host/physics/campaign.h"
#include "host/solver/consider.h"

namespace imuforge::eol {

// Per-segment summary kept for the report: mean error before and after compensation, per axis.
struct SegmentResidual {
  int segment = -1;
  std::string label;
  double temp_C = 0.0;
  double t_s = 0.0;                       // segment start, log time
  std::array<double, 6> before{};         // mean(y − u): ax ay az (m/s²) gx gy gz (rad/s)
  std::array<double, 6> after{};          // mean(y − u − J θ̂), filled by finalize_residuals()
  std::string still_note;                 // static step: what the pose detector dropped ("" = nothing)
  Eigen::MatrixXd mean_j;                 // 6 × n mean regressor (internal)
};

class Tracker {
 public:
  explicit Tracker(const model::ModelSpec& spec);

  const std::vector<std::string>& names() const { return names_; }
  int size() const { return static_cast<int>(ids_.size()); }

  // Per-sample noise (1σ) at the stream rate. If not set (0), it is estimated from the data: pooled
  // within-block scatter, floored at lsb/√12.
  void set_noise(double accel_mps2, double gyro_rad_s);
  double accel_noise() const;
  double gyro_noise() const;

  // Folds one segment in. Rows without reference (has_ref false) are skipped. Accelerometer rows are
  // used only when the reference specific force is constant over the segment (static dwells, rate runs
  // about the vertical): in a rate run about a tilted axis the reference would depend on the exact table
  // phase, which the runner knows only to the stream latency. A static step (table not turning, constant
  // reference, temperature within 0.5 °C) keeps only the samples the one pose detector (host/poses,
  // still_part) calls still: settle margins, ringing and bumps are dropped. Returns false if no usable
  // rows; a static step with no still part is listed in rejections() with the detector's reason.
  bool add_segment(const io::LogMeta& meta, const std::vector<io::LogRow>& rows, int segment,
                   const std::string& label);

  solver::Estimate estimate() const { return srif_.estimate(); }
  Eigen::MatrixXd information() const { return srif_.information(); }
  long long segments() const { return srif_.segments(); }

  // Fisher information of a hypothetical segment: constant f, w, temperature, duration, at rate_hz.
  // accel_ok = false: only gyro rows (see add_segment: accel rows need a constant reference).
  Eigen::MatrixXd predicted_information(const Eigen::Vector3d& f, const Eigen::Vector3d& w, double T_C,
                                        double duration_s, double rate_hz, bool accel_ok = true) const;

  // σ per parameter from an information matrix (inf where not observable). O(n³).
  Eigen::VectorXd sigma_of(const Eigen::MatrixXd& info) const;

  // Honest σ (docs/calibration.md "Honest σ"): with the station's fixture tolerance set, every segment's
  // model × fixture block of the joint information (solver::fixture_joint_information, one pass over the
  // segment file, the same linearisation as the batch solve's consider analysis) is summed, and
  // honest_sigma() = sqrt(diag(P + S Σ Sᵀ)), S = P H_θη, P the noise-only covariance. The runner steers
  // and stops on it, so a spec below the fixture's floor is never "met" by noise alone. A segment the
  // joint linearisation refuses (e.g. a per-plateau model) turns the fixture part off: fixture_error().
  void set_fixture_tolerance(const solver::FixtureTolerance& tol, const model::ModelSpec& spec,
                             const physics::Campaign& campaign);
  void add_fixture_segment(const std::string& segment_file);
  // diag(S Σ Sᵀ) for the current data (zeros without a tolerance). O(n³).
  Eigen::VectorXd fixture_variance() const;
  Eigen::VectorXd honest_sigma() const;
  const std::string& fixture_error() const { return fixture_error_; }

  // Computes SegmentResidual::after with the given parameter values (in names() order).
  void finalize_residuals(const Eigen::VectorXd& theta);
  const std::vector<SegmentResidual>& residuals() const { return residuals_; }
  struct Rejection {
    int segment = -1;
    std::string label, reason;
  };
  const std::vector<Rejection>& rejections() const { return rejections_; }
  double T_ref_C() const { return T_ref_C_; }

 private:
  std::vector<model::ParamId> ids_;
  std::vector<std::string> names_;
  double T_ref_C_ = 25.0;
  solver::SquareRootInformationFilter srif_;
  model::HysteresisTracker hyst_;
  double fixed_noise_[2] = {0, 0};
  double pooled_ss_[2] = {0, 0};  // Σ squared deviations within blocks
  double pooled_dof_[2] = {0, 0};
  double lsb_[2] = {0, 0};
  std::vector<SegmentResidual> residuals_;
  std::vector<Rejection> rejections_;
  // Honest σ: the considered fixture parameters, their 1σ, and Σ H_θη over the segments.
  model::ModelSpec spec_;
  physics::Campaign campaign_;
  std::vector<std::string> considered_;
  Eigen::VectorXd considered_sigma_;
  Eigen::MatrixXd h_theta_eta_;
  std::string fixture_error_;
};

}  // namespace imuforge::eol
