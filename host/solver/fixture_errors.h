// Fixture+errors mode: the rate table's axis tilts and encoder zero offsets (and, on request, the IMU
// mount rotation) are estimated as nuisance parameters together with the model, so an imprecise fixture
// still calibrates. The reference is recomputed from the LOGGED (reported) table angles and rates with
// physics::table_kinematics() — the simulator's own kinematics — for the current nuisance values.
//
// The problem is nonlinear in the nuisance parameters: Levenberg-Marquardt, each iteration one streaming
// pass over the log (LogReader::rewind), memory independent of the log length. Per sample: one
// kinematics + measurement per nuisance parameter and direction (central differences), one rank-one
// update of the (n_model + n_nuisance)² information. Static dwells reuse the kinematics (angles constant).
//
// Gauge: a constant rotation of the IMU case on the platform (mount rotation; equally the zero offset of
// the innermost axis, and one of its two tilts together with the next axis's zero) is indistinguishable
// from a common rotation of both triads' misalignments: no campaign separates them. Two ways to live
// with that:
//   * body-frame model (recommended; docs/calibration.md): the accelerometer misalignment estimates only
//     {yx, zx, zy} (host/model/body_frame.h). The mount rotation then takes the gauge freedom, is
//     estimated, and the misalignments are the intrinsic ones, immune to fixture errors.
//   * full 6+6 misalignments: the mount rotation is fixed at zero, and the misalignments are relative to
//     the platform, carrying whatever mount and inner-axis errors the fixture has.
// Nuisance parameters found in an unobservable direction of the information at the start are fixed at
// zero (reported in `fixed`), the innermost axis's first; a direction with no nuisance parameter in it is
// an error as in every other mode.
#pragma once

#include <string>
#include <vector>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/solver/fixture.h"

namespace imuforge::solver {

struct FixtureErrorsOptions {
  bool mount = true;  // also estimate fixture.mount.rx|ry|rz (the gauge fixes it under full misalignments)
  int max_iterations = 50;
  // Scaled-information eigenvalue (relative to the largest) below which a direction counts as
  // unobservable when choosing which nuisance parameters to fix. Looser than the rank test of the final
  // solve: tilts of the inner axis are equivalent, to first order, to a mount rotation plus a zero offset
  // of the next axis, and are separable only through second-order terms (variance inflation > 100²).
  double gauge_tolerance = 1e-4;
  // Nuisance parameters stated to be zero (a measured, trusted fixture property), e.g.
  // "fixture.axis0.tilt_a". They are left out of the estimation; listed in FixtureErrorsResult.
  std::vector<std::string> assume_zero;
};

struct FixtureErrorsResult {
  Estimate estimate;                        // model parameters (spec order), then free nuisance parameters
  Observability observability;
  Sigma6 residual_rms{}, noise_sigma{};
  long long samples = 0;
  std::vector<std::string> nuisance_names;  // free: fixture.axis<i>.tilt_a|tilt_b|zero, fixture.mount.r*
  std::vector<std::string> fixed;           // nuisance fixed at 0 by the gauge (see above)
  std::vector<std::string> assumed_zero;    // FixtureErrorsOptions::assume_zero
  // The mount rotation is estimated (body frame: intrinsic misalignments); false in the platform
  // convention, where the misalignments include the mount rotation (docs/calibration.md).
  bool mount_estimated = false;
  int iterations = 0;
  // The drift between dwells fitted to the residuals at the solution (docs/calibration.md, "Dwell drift"); the
  // covariance above carries the adopted ones. All not adopted with the model's "dwell_scatter": false.
  ChannelDrifts drifts{};
};

FixtureErrorsResult solve_fixture_errors(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& campaign,
                                         const FixtureErrorsOptions& opt = {});

// Every nuisance parameter of a table with n_axes axes, in the solver's order:
// fixture.axis<i>.tilt_a|tilt_b|zero (innermost first), then fixture.mount.rx|ry|rz.
std::vector<std::string> fixture_nuisance_names(int n_axes);
// The information (model parameters in spec order, then `nuisance`, named as above) at x, weighted by
// 1/sigma², from one streaming pass over the log: the same linearisation as the fixture+errors solve.
// The consider analysis (consider.h) takes the model × nuisance block from it. Throws SolverError on an
// unknown name, a per-plateau model or a log whose table columns do not match the campaign.
Eigen::MatrixXd fixture_joint_information(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& campaign,
                                          const std::vector<std::string>& nuisance, const Eigen::VectorXd& x,
                                          const Sigma6& sigma);
// Convenience for the command: loads the campaign; "fixture_nuisance": {"mount": false} in the model's
// extra section keeps the mount rotation out of the nuisance set (it is in by default).
FixtureErrorsResult solve_fixture_errors(io::LogReader& log, const model::ModelSpec& spec, const std::string& campaign_path);

}  // namespace imuforge::solver
