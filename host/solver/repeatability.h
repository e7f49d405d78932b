// Repeatability of a reference-free calibration over several recordings of one unit (imuforge solve
// --log A --log B …): each recording is calibrated on its own and all together; every parameter's
// spread between recordings is set against its σ, and each recording's accelerometer calibration is
// applied to every other recording's poses (cross-application) against its self-fit.
//
// Why: σ from one recording covers only that recording's noise and pose scatter. Placement, re-mounting,
// turn-on bias and day-to-day drift show up only between recordings. When the spread exceeds σ (ratio
// above kSpreadWarnRatio) the σ do not cover them; the figure that does is the between-recording spread
// (sample standard deviation), reported per parameter as sigma_covering = √(σ² + spread²), and, for the
// whole accelerometer calibration, the cross-application |a| − g RMS.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "host/solver/reference_free.h"

namespace imuforge::solver {

constexpr double kSpreadWarnRatio = 3.0;

struct ParameterSpread {
  std::string name;
  std::vector<double> values, sigmas;  // per recording
  double joint = 0, joint_sigma = 0;   // all recordings together
  double spread = 0;                   // sample standard deviation of values between recordings
  double sigma = 0;                    // median per-recording σ
  double ratio = 0;                    // spread / sigma
  double sigma_covering = 0;           // √(σ² + spread²)
};

struct Repeatability {
  std::vector<ReferenceFreeResult> each;
  ReferenceFreeResult joint;
  std::vector<ParameterSpread> params;
  // cross_rms(i, j): RMS of |a| − g over recording j's poses with recording i's accelerometer calibration;
  // the diagonal is each self-fit. joint_rms[j]: with the joint calibration.
  Eigen::MatrixXd cross_rms;
  std::vector<double> joint_rms;
  double self_min = 0, self_max = 0, cross_min = 0, cross_max = 0;
  std::vector<std::string> warnings;
  nlohmann::json to_json(const std::vector<std::string>& logs) const;
  std::string report(const std::vector<std::string>& logs) const;  // text for the terminal
};

// Throws SolverError (fewer than 2 recordings, or any single solve failing, naming the recording).
Repeatability repeatability(const std::vector<const RawRecording*>& recs, const std::vector<std::string>& names,
                            const model::ModelSpec& spec, const ReferenceFreeOptions& opt = {});

}  // namespace imuforge::solver
