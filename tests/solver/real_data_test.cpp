// Reference-free calibration on the REAL recordings of ../shared/data/real (README there): Xsens MTi
// (IMU-TK test data) and MPU-6050 (tomisuarez2/ImuCalibration). Skipped when the directory is absent.
//
// What may be asserted on data nobody here produced, with no reference:
//   - the solve succeeds with full rank and finite σ for every parameter;
//   - the gravity-magnitude residual over the static poses falls far below the nominal-LSB one (limits
//     about 2× the figures measured on 22 Nov 2026, so noise-level changes pass and a broken fit fails);
//   - Xsens: the gravity-direction residual across rotations falls (gyro fit works);
//   - MPU-6050 90° check (imu_90_x_rot.csv, one hand rotation about x): the calibration recording
//     clips the ±250 °/s gyro on 3 of its 9 transitions; those are left out, and the 6 left determine
//     the gyro scale only to ≈ 5 %. The honest claim is therefore that 90° lies within 3σ of the
//     calibrated angle, σ propagated from the gyro scale/misalignment covariance, and that σ is small
//     enough (< 10°) for this to mean something. Measured: 103.0 ± 5.6° (2.3σ). Fitting the clipped
//     transitions gave 94.97 ± 1.30°, 3.8σ from 90°: this test fails on that bias.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include <Eigen/Geometry>

#include "host/io/import.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/solver/reference_free.h"
#include "host/model/measure.h"
#include "tests/solver/turn.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_real_data_test {

using namespace imuforge;
using namespace imuforge::solver;

namespace {

std::string real(const std::string& p) { return std::string(IMUFORGE_REAL_DATA_DIR) + "/" + p; }

// Imports into the build tree (never into the source tree) and reads back in SI.
RawRecording load(const io::ImportOptions& o, const std::string& name) {
  const std::string out = std::string(IMUFORGE_BINARY_DIR) + "/solver_real_data_" + name + ".bin";
  io::import_recording(o, out);
  io::LogReader r(out);
  return read_recording(r);
}

model::ModelSpec basic() { return model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json"); }

void expect_calibrated(const ReferenceFreeResult& r) {
  EXPECT_EQ(r.observability.rank, r.observability.n_params);
  // 24 basic − 3 gauge-fixed accel misalignments, plus the extra terms chosen by cross-validation (issue 17)
  EXPECT_EQ(r.estimate.names.size(), 21u + r.terms_added.size());
  for (const auto& t : r.terms_added) EXPECT_GE(r.estimate.index_of(t), 0) << t;
  const Eigen::VectorXd s = r.estimate.sigma();
  for (long i = 0; i < s.size(); ++i)
    EXPECT_TRUE(std::isfinite(s[i]) && s[i] > 0) << r.estimate.names[size_t(i)] << " sigma " << s[i];
  EXPECT_TRUE(r.estimate.value.allFinite());
}

void print(const char* what, const RawRecording& rec, const ReferenceFreeResult& r) {
  std::printf("%s: %zu samples, %zu static poses; gravity-magnitude RMS %.4g -> %.4g m/s^2; "
              "gravity-direction RMS %.4g -> %.4g (%d transitions, %d left out: gyro clipped)\n",
              what, rec.y.size(), r.intervals.size(), r.gravity_rms_before, r.gravity_rms_after,
              r.rotation_rms_before, r.rotation_rms_after, r.transitions_used, r.transitions_clipped);
  const Eigen::VectorXd s = r.estimate.sigma();
  for (size_t i = 0; i < r.estimate.names.size(); ++i)
    std::printf("  %-20s % .5e +- %.2e\n", r.estimate.names[i].c_str(), r.estimate.value[long(i)], s[long(i)]);
}

}  // namespace

TEST(RealData, XsensMtiCalibratesReferenceFree) {
  if (!std::filesystem::exists(real("xsens-mti-imutk/xsens_acc.txt")))
    GTEST_SKIP() << "real data not found at " << IMUFORGE_REAL_DATA_DIR << " (set -DIMUFORGE_REAL_DATA_DIR)";
  const RawRecording rec =
      load({"xsens-imutk", real("xsens-mti-imutk/xsens_acc.txt"), real("xsens-mti-imutk/xsens_gyro.txt"), "", 0}, "xsens");
  const ReferenceFreeResult r = solve_reference_free(rec, basic());
  print("Xsens MTi", rec, r);
  expect_calibrated(r);
  EXPECT_GE(r.intervals.size(), 30u);  // ≈ 37 hand poses + the initial still period
  EXPECT_EQ(r.transitions_clipped, 0);
  // Measured 0.988 -> 9.8e-4 m/s²; the floor is the accelerometer's bias instability (≈ 1e-3 m/s²).
  EXPECT_GT(r.gravity_rms_before, 0.1);
  EXPECT_LT(r.gravity_rms_after, 2e-3);
  EXPECT_LT(r.gravity_rms_after, 0.01 * r.gravity_rms_before);
  // Measured 3.3e-2 -> 4.8e-3: the gyro fit explains most of the pose-to-pose direction error.
  EXPECT_LT(r.rotation_rms_after, 0.3 * r.rotation_rms_before);
}

TEST(RealData, Mpu6050CalibratesAndPassesTheNinetyDegreeCheck) {
  if (!std::filesystem::exists(real("mpu6050-tomisuarez2/example_data_calibration.csv")))
    GTEST_SKIP() << "real data not found at " << IMUFORGE_REAL_DATA_DIR << " (set -DIMUFORGE_REAL_DATA_DIR)";
  const RawRecording rec =
      load({"mpu6050-csv", real("mpu6050-tomisuarez2/example_data_calibration.csv"), "", "", 0}, "mpu_cal");
  const ReferenceFreeResult r = solve_reference_free(rec, basic());
  print("MPU-6050", rec, r);
  expect_calibrated(r);
  EXPECT_GE(r.intervals.size(), 10u);
  // 10 poses for 9 accelerometer unknowns: nearly exact, so the limit is loose (measured 0.70 -> 1.4e-4).
  EXPECT_LT(r.gravity_rms_after, 5e-3);
  EXPECT_LT(r.gravity_rms_after, 0.01 * r.gravity_rms_before);
  // The raw file has 18 samples with a gyro count at ±32767/−32768 (hand flips above 250 °/s).
  EXPECT_GT(rec.clipped_samples, 0u);
  EXPECT_GE(r.transitions_clipped, 1);
  EXPECT_GE(r.transitions_used, 5);  // 2 per transition > 9 gyro unknowns

  const RawRecording rot = load({"mpu6050-csv", real("mpu6050-tomisuarez2/imu_90_x_rot.csv"), "", "", 0}, "mpu_rot");
  ASSERT_EQ(rot.clipped_samples, 0u);
  const RotationCheck rc = rotation_check(rot, r.estimate);
  // Independent view of the same hand rotation: the tilt of gravity between the first and last still
  // periods (the rotation axis is nearly horizontal), nominal and calibrated accelerometer.
  const auto still = poses::detect_poses(rot).poses;
  ASSERT_GE(still.size(), 2u);
  const TriadCal acc = triad_from_estimate(r.estimate, "accel");
  auto tilt = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
  };
  std::printf("MPU-6050 90-degree check (imu_90_x_rot.csv): gyro nominal %.3f deg, calibrated %.3f +- %.3f deg "
              "(%.2f sigma from 90) about [%.3f %.3f %.3f]; accelerometer tilt nominal %.2f deg, calibrated %.2f deg\n",
              rc.angle_nominal_deg, rc.angle_deg, rc.angle_sigma_deg, (rc.angle_deg - 90.0) / rc.angle_sigma_deg,
              rc.axis.x(), rc.axis.y(), rc.axis.z(), tilt(still.front().acc, still.back().acc),
              tilt(acc.apply(still.front().acc), acc.apply(still.back().acc)));
  EXPECT_GT(std::abs(rc.axis.x()), 0.95);  // a rotation about x
  // Bias removal and integration, independent of the calibration: a hand "90°" with a gyro within the
  // MPU-6050's ±3 % sensitivity tolerance (measured 93.08°).
  EXPECT_NEAR(rc.angle_nominal_deg, 90.0, 6.0);
  ASSERT_TRUE(std::isfinite(rc.angle_sigma_deg));
  EXPECT_GT(rc.angle_sigma_deg, 0.0);
  EXPECT_LT(rc.angle_sigma_deg, 10.0);  // else the next line could not fail
  EXPECT_LT(std::abs(rc.angle_deg - 90.0), 3.0 * rc.angle_sigma_deg)
      << "calibrated angle " << rc.angle_deg << " +- " << rc.angle_sigma_deg;
}

TEST(RealData, RotationCheckRefusesAClippedRecording) {
  if (!std::filesystem::exists(real("mpu6050-tomisuarez2/example_data_calibration.csv")))
    GTEST_SKIP() << "real data not found at " << IMUFORGE_REAL_DATA_DIR << " (set -DIMUFORGE_REAL_DATA_DIR)";
  const RawRecording rec =
      load({"mpu6050-csv", real("mpu6050-tomisuarez2/example_data_calibration.csv"), "", "", 0}, "mpu_cal2");
  try {
    rotation_check(rec, TriadCal{});
    FAIL() << "a recording with clipped gyro samples gave an angle";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("full-scale"), std::string::npos) << e.what();
  }
}

// The two mechanisms the real data needed, checked without it.
TEST(ReferenceFreeChecks, ClippedGyroCountsAreFlaggedOnRead) {
  const std::string p = std::string(IMUFORGE_BINARY_DIR) + "/solver_real_data_clip.csv";
  io::LogMeta m;
  m.sample_rate_hz = 100;
  m.accel_lsb_mps2 = 1e-3;
  m.gyro_lsb_rad_s = 1e-4;
  {
    io::LogWriter w(p, m);
    for (int i = 0; i < 20; ++i) {
      io::LogRow r;
      r.t_s = 0.01 * i;
      r.raw[2] = 9807;
      r.raw[3] = i == 5 ? 32767 : 32766;  // 32766 is not a limit
      r.raw[5] = i == 11 ? -32768 : -32767;
      w.write(r);
    }
    w.close();
  }
  io::LogReader r(p);
  const RawRecording rec = read_recording(r);
  EXPECT_EQ(rec.clipped_samples, 2u);
  ASSERT_EQ(rec.gyro_clipped.size(), 20u);
  for (size_t i = 0; i < 20; ++i) EXPECT_EQ(rec.gyro_clipped[i], i == 5 || i == 11) << i;
}

TEST(ReferenceFreeChecks, RotationCheckSigmaIsPropagatedFromTheGyroScale) {
  // One 90° turn about x at constant rate, gyro scale +2 %; the calibration states scale.x = 0.02 with
  // σ = 0.01. The angle is θ·(1 + s_true)/(1 + s), so σ_angle = 90°/(1.02) · 0.01 = 0.882°; the
  // misalignments enter at second order only.
  model::ParamSet truth;
  truth.set("gyro.scale.x", 0.02);
  const RawRecording rec = turn::quarter_turn_about_x(truth, 1e-4, 1e-5, 3);
  Estimate cal;
  cal.names = {"gyro.scale.x", "gyro.misalign.yx", "gyro.misalign.zx"};
  cal.value = Eigen::Vector3d(0.02, 0.0, 0.0);
  cal.covariance = Eigen::Vector3d(1e-4, 4e-6, 4e-6).asDiagonal();
  const RotationCheck rc = rotation_check(rec, cal);
  EXPECT_NEAR(rc.angle_deg, 90.0, 0.02);
  EXPECT_NEAR(rc.angle_nominal_deg, 91.8, 0.02);
  EXPECT_NEAR(rc.angle_sigma_deg, 90.0 / 1.02 * 0.01, 0.01);
  cal.covariance.setZero();
  EXPECT_NEAR(rotation_check(rec, cal).angle_sigma_deg, 0.0, 1e-9);
  cal.covariance.resize(0, 0);  // no covariance: σ unknown, not zero
  EXPECT_TRUE(std::isnan(rotation_check(rec, cal).angle_sigma_deg));
}
}  // namespace solver_real_data_test
