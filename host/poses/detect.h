// The static-pose detector: which stretches of a recording are still poses of constant attitude, and
// why every other stretch was rejected. One detector for every reference-free consumer (solve, diagnose,
// import previews), so one recording gives one set of poses.
//
// Method (all thresholds relative to the recording's own noise, per axis):
//  1. Centred sliding window (window_s): per channel mean and standard deviation. The noise floor of a
//     channel is the 10th percentile of its windowed deviation (still windows are the quietest), floored
//     at one count/√12 (a quantised sensor quieter than one count).
//  2. Still accelerometer: RMS over the three axes of (window deviation / floor) below k_accel, or the
//     deviation itself below hand_accel_mps2 (≈ 2 mg: a very quiet sensor on a table that someone bumps
//     or walks past still averages to gravity; motion between poses is far above it and turns the gyro).
//     Still gyro: the window's RMS rate about the gyro bias (mean offset AND scatter: a slow turn at
//     constant rate has no scatter) below max(k_gyro × floor, hand_rate_rad_s). The bias is the median
//     window mean over the accelerometer-still samples. The rate floor keeps hand-held poses (tremor of
//     a few hundredths of rad/s, far above a MEMS gyro's noise, but too little to tilt the pose) in.
//  3. Runs of still samples keep settle_s away from the motion before them (the hand lets go, the mount
//     rings) and lead_s from the motion after them (counted from the motion: the window's half-width
//     is part of the margin).
//  4. Attitude: the run is cut into blocks (block_s); where the blocks' gravity directions spread over
//     more than split_deg the run is split at its largest block-to-block step, recursively (a pose
//     nudged without enough motion to break stillness, or a slow drift). Leading and trailing blocks
//     farther than settle_deg from the piece's median direction are trimmed (slow settling).
//  5. Pieces with a clipped accelerometer sample are rejected.
//  6. Adjacent pieces from different runs, at most merge_gap_s apart and within split_deg, are one pose
//     that was bumped: they are merged (the gap's samples excluded). Then a pose shorter than
//     min_dwell_s in total is rejected (so vibration blips that cut a dwell into short pieces do not
//     lose it).
// Cost: O(n) for the windows plus O(n log n) for the percentiles; memory O(n).
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "host/poses/recording.h"

namespace imuforge::poses {

struct DetectOptions {
  double window_s = 0.5;
  double min_dwell_s = 1.5;
  double settle_s = 0.3;
  double lead_s = 0.1;
  double k_accel = 4.0;           // × the per-axis noise floor (standard deviation ratio)
  double k_gyro = 6.0;
  double hand_rate_rad_s = 0.05;  // ≈ 3 °/s: below it a hand-held IMU counts as still
  double hand_accel_mps2 = 0.02;  // window deviation (norm over axes) that is still whatever the noise floor
  double block_s = 0.25;
  double split_deg = 3.0;
  double settle_deg = 0.5;
  double merge_gap_s = 2.0;
};

struct Pose {
  std::size_t begin = 0, end = 0;  // sample span [begin, end) (a merged pose spans its bump)
  std::vector<std::pair<std::size_t, std::size_t>> parts;  // the still sample ranges averaged
  std::size_t samples = 0;
  Eigen::Vector3d acc = Eigen::Vector3d::Zero(), gyro = Eigen::Vector3d::Zero();  // means, SI
};

// One line of the explanation: a stretch of the recording and what became of it.
struct Stretch {
  double t_begin_s = 0, t_end_s = 0;
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();  // mean, m/s²
  int pose = -1;                                   // index into Detection::poses, −1 = rejected/moving
  std::string reason;                              // "pose", "moving (peak 3.1 rad/s)", "shorter than …"
};

struct Detection {
  std::vector<Pose> poses;
  std::vector<Stretch> stretches;  // in time order, covering the recording
  Eigen::Vector3d accel_floor = Eigen::Vector3d::Zero(), gyro_floor = Eigen::Vector3d::Zero();  // 1σ per axis
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  double gyro_limit_rad_s = 0;
  double still_s = 0;  // total duration of the poses' samples
};

// Throws PoseError on options out of range or a recording without a rate.
Detection detect_poses(const Recording& rec, const DetectOptions& opt = {});

// Pose means over an arbitrary sample range (the consumers' helper for sub-ranges).
Pose pose_over(const Recording& rec, std::size_t begin, std::size_t end);

// One stretch that should be a single static pose (an end-of-line fixture's position dwell): which of its
// samples the detector keeps (noise-adaptive still test, settle margins, attitude settling, bumps), or why
// none. The minimum dwell is capped at half the stretch (a fixture dwell is short but known to be one pose).
// Several poses in one dwell (the mount slipped): the longest is kept and the reason says so.
struct StillPart {
  std::vector<std::pair<std::size_t, std::size_t>> parts;  // sample ranges kept; empty = rejected
  std::size_t samples = 0, total = 0;
  std::string reason;  // why samples were dropped, or why the stretch was rejected; "" = kept whole
  bool rejected() const { return parts.empty(); }
};
StillPart still_part(const Recording& stretch, DetectOptions opt = {});

// The --explain-poses table, one stretch per line (start, end, duration, mean, verdict/reason).
std::string explain_table(const Detection& d);

}  // namespace imuforge::poses
