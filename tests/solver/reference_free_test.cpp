// Reference-free mode (Tedaldi et al. 2014) on a synthetic hand-held recording generated through the
// catalog's measurement function, and on the real recordings when they have been imported.
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Geometry>

#include "host/model/measure.h"
#include "host/model/sensor_model.h"
#include "host/solver/reference_free.h"
#include "tests/solver/turn.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_reference_free_test {

using namespace imuforge;
using namespace imuforge::solver;

namespace {

model::ParamSet handheld_truth() {
  model::ParamSet p;
  p.set("accel.bias.x", 0.08);
  p.set("accel.bias.y", -0.05);
  p.set("accel.bias.z", 0.12);
  p.set("accel.scale.x", 0.012);
  p.set("accel.scale.y", -0.008);
  p.set("accel.scale.z", 0.02);
  // Gauge: the accelerometer frame is the body frame (upper misalignments zero).
  p.set("accel.misalign.yx", 0.004);
  p.set("accel.misalign.zx", -0.003);
  p.set("accel.misalign.zy", 0.002);
  p.set("gyro.bias.x", 0.01);
  p.set("gyro.bias.y", -0.02);
  p.set("gyro.bias.z", 0.005);
  p.set("gyro.scale.x", 0.02);
  p.set("gyro.scale.y", -0.015);
  p.set("gyro.scale.z", 0.01);
  const char* mis[6] = {"xy", "xz", "yx", "yz", "zx", "zy"};
  const double mv[6] = {0.004, -0.006, 0.003, 0.005, -0.002, 0.007};
  for (int i = 0; i < 6; ++i) p.set(std::string("gyro.misalign.") + mis[i], mv[i]);
  return p;
}

RawRecording handheld(const model::ParamSet& truth, std::uint64_t seed, int poses = 30) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  const double g = 9.80665, fs = 100.0, sa = 0.01, sg = 0.002;
  const auto ca = model::compile(truth, model::Sensor::kAccel, 25.0);
  const auto cg = model::compile(truth, model::Sensor::kGyro, 25.0);
  RawRecording rec;
  rec.gravity_mps2 = g;
  rec.rate_hz = fs;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // body -> world
  double t = 0;
  auto emit = [&](const Eigen::Vector3d& w) {
    model::MeasureInput in;
    in.f = q.toRotationMatrix().transpose() * Eigen::Vector3d(0, 0, g);
    in.w = w;
    const Eigen::Vector3d ya = model::measure(ca, in), yg = model::measure(cg, in);
    rec.t_s.push_back(t);
    rec.y.push_back({ya[0] + sa * n01(rng), ya[1] + sa * n01(rng), ya[2] + sa * n01(rng), yg[0] + sg * n01(rng),
                     yg[1] + sg * n01(rng), yg[2] + sg * n01(rng)});
    t += 1 / fs;
  };
  for (int p = 0; p < poses; ++p) {
    const int still = p == 0 ? 1000 : 300;
    for (int i = 0; i < still; ++i) emit(Eigen::Vector3d::Zero());
    // A rotation of 60-120° about a random body axis over 1.5 s, at constant body rate.
    Eigen::Vector3d axis(n01(rng), n01(rng), n01(rng));
    axis.normalize();
    const double ang = (60 + 60 * std::uniform_real_distribution<double>(0, 1)(rng)) * M_PI / 180;
    const Eigen::Vector3d w = axis * ang / 1.5;
    for (int i = 0; i < 150; ++i) {
      q = q * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm() / fs, w.normalized()));
      q.normalize();
      emit(w);
    }
  }
  for (int i = 0; i < 300; ++i) emit(Eigen::Vector3d::Zero());
  return rec;
}

}  // namespace

TEST(ReferenceFree, RecoversAccelAndGyroFromStaticPoses) {
  const auto truth = handheld_truth();
  const RawRecording rec = handheld(truth, 11);
  const auto spec = model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json");
  const ReferenceFreeResult r = solve_reference_free(rec, spec);
  EXPECT_GE(r.intervals.size(), 30u);
  EXPECT_EQ(r.gauge_fixed.size(), 3u);
  ASSERT_EQ(r.estimate.names.size(), 21u);  // 24 basic − 3 gauge
  EXPECT_LT(r.gravity_rms_after, 0.01 * r.gravity_rms_before);
  EXPECT_LT(r.rotation_rms_after, 0.1 * r.rotation_rms_before);
  for (size_t i = 0; i < r.estimate.names.size(); ++i) {
    const double err = r.estimate.value[long(i)] - truth.get(r.estimate.names[i]);
    EXPECT_LT(std::abs(err), 5 * r.estimate.sigma()[long(i)] + 1e-5) << r.estimate.names[i] << " err " << err
                                                                      << " sigma " << r.estimate.sigma()[long(i)];
  }
}

TEST(ReferenceFree, RotationCheckRecoversTheAngle) {
  auto truth = handheld_truth();
  // A recording with exactly one 90° rotation about x (noise: static detection needs a floor to find).
  const RawRecording rec = turn::quarter_turn_about_x(truth, 1e-4, 1e-4, 1);
  Estimate cal;
  cal.names = {"gyro.scale.x", "gyro.misalign.yx", "gyro.misalign.zx"};
  cal.value = Eigen::Vector3d(truth.get("gyro.scale.x"), truth.get("gyro.misalign.yx"), truth.get("gyro.misalign.zx"));
  const RotationCheck rc = rotation_check(rec, triad_from_estimate(cal, "gyro"));
  EXPECT_NEAR(rc.angle_deg, 90.0, 0.05);
  EXPECT_GT(std::abs(rc.angle_nominal_deg - 90.0), 1.0);  // 2 % scale error uncorrected
  EXPECT_GT(rc.axis.x(), 0.999);
}
}  // namespace solver_reference_free_test
