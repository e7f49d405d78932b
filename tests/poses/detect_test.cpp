// The static-pose detector on synthetic hand-placed recordings (tests/poses/hand_placed.h, written
// without the simulator or the model catalog) with known pose counts: the cases real hand-placed data
// throws at it beyond the two real recordings: 36 poses with 8+ rad/s peaks in a 20-bit word, short
// dwells, slow settling, the same attitude twice in a row separated by a bump, a slow tilt without
// motion, a 10× noisier axis. Plus the declared raw word width in the log.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <cstdlib>
#include <sys/wait.h>
#include <filesystem>

#include "host/diagnosis/sources.h"
#include "host/io/import.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/poses/detect.h"
#include "host/poses/gravity_fit.h"
#include "host/solver/reference_free.h"
#include "host/solver/repeatability.h"
#include "tests/poses/hand_placed.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace poses_detect_test {

using namespace imuforge;
using handtest::Step;

namespace {

handtest::Sensor unit() {
  handtest::Sensor s;
  s.Ma << 0.004, 0, 0, 0.002, -0.003, 0, -0.001, 0.003, 0.006;  // lower triangular: the fit's gauge
  s.ba = Eigen::Vector3d(0.08, -0.05, 0.12);
  s.Mg << 0.01, 0.004, -0.003, 0.002, -0.008, 0.005, -0.004, 0.001, 0.005;
  s.bg = Eigen::Vector3d(0.01, -0.02, 0.005);
  s.lsb_g = 3e-5;  // 20-bit word: ±15.7 rad/s per axis
  return s;
}

int count(const std::vector<Step>& steps, const handtest::Sensor& s, unsigned seed, poses::Detection* out = nullptr,
          const poses::DetectOptions& o = {}) {
  poses::Recording rec;
  const handtest::Truth tr = handtest::generate(steps, s, seed, rec);
  const poses::Detection d = poses::detect_poses(rec, o);
  if (out) *out = d;
  if (static_cast<int>(d.poses.size()) != tr.poses) std::printf("%s", poses::explain_table(d).c_str());
  EXPECT_EQ(static_cast<int>(d.poses.size()), tr.poses) << "seed " << seed;
  return static_cast<int>(d.poses.size());
}

bool explains(const poses::Detection& d, const std::string& what) {
  for (const auto& s : d.stretches)
    if (s.reason.find(what) != std::string::npos) return true;
  return false;
}

model::ModelSpec basic() { return model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json"); }

}  // namespace

TEST(PoseDetector, ThirtySixPosesWithFastHandMovesInATwentyBitWord) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    poses::Recording rec;
    const auto steps = handtest::session(36, 4, 12, seed, false, 170, 0.45);
    handtest::generate(steps, unit(), seed, rec);
    double peak = 0;
    for (const auto& y : rec.y) peak = std::max(peak, Eigen::Vector3d(y[3], y[4], y[5]).norm());
    EXPECT_GT(peak, 8.0);  // the hand moves the issue describes
    EXPECT_EQ(rec.clipped_samples, 0u);  // the same rates in an int16 word at this LSB would clip at ±0.98 rad/s
    count(steps, unit(), seed);
    EXPECT_EQ(poses::detect_poses(rec).poses.size(), 36u);
  }
}

TEST(PoseDetector, ShortDwellsAndSlowSettling) {
  count(handtest::session(20, 2.2, 3.0, 7), unit(), 7);  // 2.2-3 s dwells: 1.5 s minimum after the margins
  poses::Detection d;
  count(handtest::session(15, 5, 8, 8, /*settle=*/true), unit(), 8, &d);  // 1.5° wobble decaying over ~2 s
  EXPECT_TRUE(explains(d, "settling")) << poses::explain_table(d);
}

TEST(PoseDetector, SameAttitudeTwiceAcrossABumpIsOnePoseAndASlowTiltSplits) {
  // pose, bump (0.4 s tap, back to the same attitude), pose, move, pose: a person counts 2 placements.
  std::vector<Step> bumped = {{Step::kPose, 20}, {Step::kMove, 1.0, 90}, {Step::kPose, 5}, {Step::kBump, 0.4, 8},
                              {Step::kPose, 5},  {Step::kMove, 1.0, 90}, {Step::kPose, 6}};
  poses::Recording rec;
  handtest::generate(bumped, unit(), 3, rec);
  poses::Detection d = poses::detect_poses(rec);
  EXPECT_EQ(d.poses.size(), 3u) << poses::explain_table(d);  // the two halves around the bump are merged
  EXPECT_TRUE(explains(d, "merged into pose 1")) << poses::explain_table(d);
  ASSERT_EQ(d.poses.size(), 3u);
  EXPECT_EQ(d.poses[1].parts.size(), 2u);
  // 12° tilted over 8 s at 0.026 rad/s: below the still-rate limit, so no motion is seen; the attitude
  // change splits the stretch (the tilting part itself is rejected or trimmed, not averaged in).
  std::vector<Step> tilted = {{Step::kPose, 20}, {Step::kMove, 1.0, 90}, {Step::kPose, 6}, {Step::kSlowTilt, 8, 12},
                              {Step::kPose, 6}};
  handtest::generate(tilted, unit(), 4, rec);
  d = poses::detect_poses(rec);
  EXPECT_TRUE(explains(d, "split") || d.poses.size() >= 3u) << poses::explain_table(d);
  ASSERT_GE(d.poses.size(), 3u) << poses::explain_table(d);
  for (const auto& p : d.poses) {
    // No pose straddles the tilt: each pose's own blocks agree within the split angle.
    const auto first = poses::pose_over(rec, p.parts.front().first, p.parts.front().first + 25).acc;
    const auto last = poses::pose_over(rec, p.parts.back().second - 25, p.parts.back().second).acc;
    EXPECT_LT(std::atan2(first.cross(last).norm(), first.dot(last)) * 180 / M_PI, 3.5);
  }
}

TEST(PoseDetector, NoiseIsJudgedPerAxisAndTremorOfAHandIsStill) {
  handtest::Sensor s = unit();
  s.noise_a = Eigen::Vector3d(0.002, 0.002, 0.04);  // one axis 20× noisier
  count(handtest::session(12, 4, 8, 11), s, 11);
  s = unit();
  s.tremor_rad_s = 0.01;  // hand-held poses: rate noise 5× the gyro's own
  count(handtest::session(12, 4, 8, 12), s, 12);
}

TEST(PoseDetector, AQuietSensorOnAKnockedBenchKeepsItsPoses) {
  // ADXL355-like noise (0.5 mm/s² per sample) with 0.3 m/s² knocks every 2 s during every pose: the
  // knocks cut each dwell into pieces shorter than the minimum; merged, the dwell is one pose again.
  handtest::Sensor s = unit();
  s.noise_a = Eigen::Vector3d(5e-4, 5e-4, 7e-4);
  s.lsb_a = 2e-5;
  std::vector<Step> steps = handtest::session(12, 6, 9, 81);
  for (std::size_t k = 1; k < steps.size(); ++k)
    if (steps[k].kind == Step::kPose) steps[k].blips_mps2 = 0.3;
  poses::Detection d;
  count(steps, s, 81, &d);
  EXPECT_TRUE(explains(d, "merged into pose")) << poses::explain_table(d);
}

TEST(PoseDetector, ExplainTableCoversTheRecordingAndNamesEveryVerdict) {
  poses::Detection d;
  poses::Recording rec;  // some dwells shorter than the minimum
  const auto steps = handtest::session(10, 1.0, 6, 21);
  handtest::generate(steps, unit(), 21, rec);
  d = poses::detect_poses(rec);
  const std::string tab = poses::explain_table(d);
  EXPECT_NE(tab.find("start_s"), std::string::npos);
  EXPECT_TRUE(explains(d, "moving"));
  EXPECT_TRUE(explains(d, "rejected: shorter than min dwell")) << tab;
  ASSERT_FALSE(d.stretches.empty());
  EXPECT_NEAR(d.stretches.front().t_begin_s, 0.0, 1e-9);
  EXPECT_NEAR(d.stretches.back().t_end_s, rec.t_s.back() + 0.01, 1e-6);
  for (std::size_t k = 1; k < d.stretches.size(); ++k)
    EXPECT_NEAR(d.stretches[k].t_begin_s, d.stretches[k - 1].t_end_s, 1e-9) << tab;  // contiguous, no gaps
  EXPECT_THROW(poses::detect_poses(rec, [] { poses::DetectOptions o; o.min_dwell_s = 0; return o; }()), poses::PoseError);
}

TEST(ReferenceFreeOnHandPlaced, CalibrationRecoversTheAccelerometerWithin4Sigma) {
  poses::Recording rec;
  const handtest::Sensor s = unit();
  handtest::generate(handtest::session(30, 4, 10, 31, true, 150, 0.8), s, 31, rec);
  const auto r = solver::solve_reference_free(rec, basic());
  EXPECT_EQ(r.intervals.size(), 30u);
  // (I+M)⁻¹ form of the truth, lower triangular as generated: compare bias and the matrix entries.
  const Eigen::VectorXd sig = r.estimate.sigma();
  auto check = [&](const std::string& n, double truth) {
    const int i = r.estimate.index_of(n);
    ASSERT_GE(i, 0) << n;
    EXPECT_LT(std::abs(r.estimate.value[i] - truth), 4 * sig[i] + 1e-9) << n << " " << r.estimate.value[i] << " vs " << truth
                                                                       << " sigma " << sig[i];
  };
  check("accel.bias.x", s.ba[0]);
  check("accel.bias.z", s.ba[2]);
  check("accel.scale.x", s.Ma(0, 0));
  check("accel.scale.z", s.Ma(2, 2));
  check("accel.misalign.zy", s.Ma(2, 1));
  EXPECT_LT(r.gravity_rms_after, 2e-3);
}

TEST(Repeatability, ADayToDayBiasShiftIsFlaggedAndTheCoveringSigmaReported) {
  poses::Recording a, b;
  handtest::Sensor s = unit();
  handtest::generate(handtest::session(20, 4, 8, 41), s, 41, a);
  s.ba += Eigen::Vector3d(0.03, 0, 0);  // re-mounted / next day: 3 mg on x
  handtest::generate(handtest::session(20, 4, 8, 42), s, 42, b);
  const auto rep = solver::repeatability({&a, &b}, {"day 1", "day 2"}, basic());
  std::printf("%s", rep.report({"day 1", "day 2"}).c_str());
  const solver::ParameterSpread* bx = nullptr;
  for (const auto& p : rep.params)
    if (p.name == "accel.bias.x") bx = &p;
  ASSERT_NE(bx, nullptr);
  EXPECT_GT(bx->ratio, solver::kSpreadWarnRatio);
  EXPECT_NEAR(bx->spread, 0.03 / std::sqrt(2.0), 0.006);
  EXPECT_GE(bx->sigma_covering, bx->spread);
  bool warned = false;
  for (const auto& w : rep.warnings) warned = warned || w.find("accel.bias.x") != std::string::npos;
  EXPECT_TRUE(warned);
  // Each day's calibration on the other day's poses is worse than its self-fit by about the shift.
  EXPECT_GT(rep.cross_min, 3 * rep.self_max);
  EXPECT_THROW(solver::repeatability({&a}, {"one"}, basic()), solver::SolverError);
}

TEST(LogWordWidth, DeclaredBitsRoundTripAndBoundTheCountsByLine) {
  const std::string p = std::string(IMUFORGE_BINARY_DIR) + "/poses_bits.csv";
  io::LogMeta m;
  m.sample_rate_hz = 100;
  m.accel_lsb_mps2 = 1e-4;
  m.gyro_lsb_rad_s = 1e-6;
  m.accel_bits = 20;
  m.gyro_bits = 20;
  auto write = [&](std::int32_t g_count) {
    io::LogWriter w(p, m);
    for (int i = 0; i < 20; ++i) {
      io::LogRow r;
      r.t_s = 0.01 * i;
      r.raw[2] = 98067;
      r.raw[3] = i == 7 ? g_count : 40000;  // 40000 is fine in 20 bits, beyond int16
      w.write(r);
    }
    w.close();
  };
  write(524287);  // the 20-bit limit: clipped, not an error
  {
    io::LogReader r(p);
    EXPECT_EQ(r.meta().accel_bits, 20);
    EXPECT_EQ(r.meta().gyro_bits, 20);
    const poses::Recording rec = poses::read_recording(r);
    EXPECT_EQ(rec.clipped_samples, 1u);  // judged against 20 bits: 40000 is not clipped, 524287 is
    EXPECT_TRUE(rec.gyro_clipped[7]);
  }
  write(524288);  // one past: an error naming the line (9 metadata-free header lines + row 8)
  try {
    io::LogReader r(p);
    io::LogRow row;
    while (r.next(row)) {
    }
    FAIL() << "a count beyond the declared width was accepted";
  } catch (const io::LogError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("poses_bits.csv:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("gx count 524288"), std::string::npos) << msg;
    EXPECT_NE(msg.find("20-bit"), std::string::npos) << msg;
  }
  // A log without the keys (written before they existed) reads as 16-bit words.
  {
    std::FILE* f = std::fopen(p.c_str(), "w");
    std::fputs("# format=imuforge-log\n# format_version=1\n# accel_lsb_mps2=0.001\n# gyro_lsb_rad_s=0.0001\n"
               "t_s,segment,temp_C,chamber_C,f_ref_x,f_ref_y,f_ref_z,w_ref_x,w_ref_y,w_ref_z,ax,ay,az,gx,gy,gz\n"
               "0,-1,,,,,,,,,0,0,9807,32767,0,0\n0.01,-1,,,,,,,,,0,0,9807,40000,0,0\n", f);
    std::fclose(f);
    io::LogReader r(p);
    EXPECT_EQ(r.meta().gyro_bits, 16);
    io::LogRow row;
    EXPECT_TRUE(r.next(row));
    try {
      r.next(row);
      FAIL() << "40000 accepted as a 16-bit count";
    } catch (const io::LogError& e) {
      EXPECT_NE(std::string(e.what()).find(":7:"), std::string::npos) << e.what();
    }
  }
}

// One log, one set of poses: `imuforge solve` (poses::read_recording) and `imuforge diagnose` (its
// ReferenceFreeSource over a LogSource) go through the same front end and must agree pose for pose.
TEST(OneFrontEnd, SolveAndDiagnoseFindTheSamePoses) {
  poses::Recording rec;
  const handtest::Sensor s = unit();
  handtest::generate(handtest::session(14, 3, 8, 51, true), s, 51, rec);
  const std::string p = std::string(IMUFORGE_BINARY_DIR) + "/poses_one_front_end.bin";
  {
    io::LogMeta m;
    m.sample_rate_hz = 100;
    m.accel_lsb_mps2 = s.lsb_a;
    m.gyro_lsb_rad_s = s.lsb_g;
    m.accel_bits = m.gyro_bits = s.bits;
    io::LogWriter w(p, m);
    for (std::size_t i = 0; i < rec.y.size(); ++i) {
      io::LogRow r;
      r.t_s = rec.t_s[i];
      for (int c = 0; c < 6; ++c) r.raw[c] = static_cast<std::int32_t>(std::lround(rec.y[i][c] / (c < 3 ? s.lsb_a : s.lsb_g)));
      w.write(r);
    }
    w.close();
  }
  io::LogReader lr(p);
  const poses::Detection solve_side = poses::detect_poses(poses::read_recording(lr));
  diagnosis::LogSource src(p);
  diagnosis::ReferenceFreeSource rf(src, 9.80665, {}, s.lsb_a, s.lsb_g, 100);
  const poses::Detection& diag_side = rf.detection();
  EXPECT_EQ(solve_side.poses.size(), 14u);
  ASSERT_EQ(diag_side.poses.size(), solve_side.poses.size());
  for (std::size_t k = 0; k < solve_side.poses.size(); ++k) {
    EXPECT_EQ(diag_side.poses[k].begin, solve_side.poses[k].begin) << k;
    EXPECT_EQ(diag_side.poses[k].end, solve_side.poses[k].end) << k;
  }
  // Every sample of a pose carries that pose's pseudo-reference; the others none.
  diagnosis::Sample smp;
  rf.rewind();
  std::size_t i = 0, in_pose = 0;
  while (rf.next(smp)) {
    in_pose += smp.has_ref;
    ++i;
  }
  std::size_t expect = 0;
  for (const auto& q : solve_side.poses) expect += q.samples;
  EXPECT_EQ(i, rec.y.size());
  EXPECT_EQ(in_pose, expect);
  EXPECT_EQ(rf.info().poses, 14);
  EXPECT_EQ(rf.info().calibrated_params, 9);
}

namespace {
// Writes a hand-placed recording as a float export (t_s, m/s², rad/s), as a logger would.
std::string write_float_csv(const poses::Recording& rec, const std::string& name) {
  const std::string p = std::string(IMUFORGE_BINARY_DIR) + "/" + name;
  std::FILE* f = std::fopen(p.c_str(), "w");
  std::fprintf(f, "# exported floats\nt_s,ax,ay,az,gx,gy,gz\n");
  for (std::size_t i = 0; i < rec.y.size(); ++i)
    std::fprintf(f, "%.4f,%.6f,%.6f,%.6f,%.7f,%.7f,%.7f\n", rec.t_s[i] + 12.5, rec.y[i][0], rec.y[i][1], rec.y[i][2],
                 rec.y[i][3], rec.y[i][4], rec.y[i][5]);
  std::fclose(f);
  return p;
}
int run_cli(const std::string& args, const std::string& out) {
  const std::string cmd = std::string(IMUFORGE_BIN) + " " + args + " > " + out + " 2>&1";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
std::string slurp(const std::string& p) {
  std::FILE* f = std::fopen(p.c_str(), "r");
  std::string s;
  if (!f) return s;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  std::fclose(f);
  return s;
}
}  // namespace

// A float export with 8+ rad/s peaks: mapped to 32-bit counts nothing clips and every pose is found;
// forced into int16 at a coarse LSB the import refuses the first value beyond the word, by line.
TEST(FloatExport, ImportsToA32BitWordWithoutClippingAndRefusesAValueBeyondTheWord) {
  poses::Recording rec;
  handtest::generate(handtest::session(14, 4, 8, 61, false, 170, 0.45), unit(), 61, rec);
  const std::string csv = write_float_csv(rec, "poses_float.csv");
  const std::string bin = std::string(IMUFORGE_BINARY_DIR) + "/poses_float.bin";
  io::ImportOptions o;
  o.format = "si-csv";
  o.in = csv;
  io::import_recording(o, bin);
  io::LogReader r(bin);
  EXPECT_EQ(r.meta().gyro_bits, 32);
  const poses::Recording back = poses::read_recording(r);
  EXPECT_EQ(back.clipped_samples, 0u);
  EXPECT_NEAR(back.t_s.front(), 0.0, 1e-12);
  EXPECT_EQ(poses::detect_poses(back).poses.size(), 14u);
  o.bits = 16;
  o.gyro_lsb_rad_s = 1e-4;  // ±3.3 rad/s in int16: the fast moves do not fit
  try {
    io::import_recording(o, bin);
    FAIL() << "a rate beyond the 16-bit word was imported";
  } catch (const io::LogError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("poses_float.csv:"), std::string::npos) << m;
    EXPECT_NE(m.find("beyond the 16-bit word"), std::string::npos) << m;
  }
}

// The command line: import preview, solve --explain-poses, and solve --log A --log B (repeatability
// in cal.json and on the terminal).
TEST(FloatExport, CommandLinePreviewExplainAndTwoRecordings) {
  poses::Recording a, b;
  handtest::Sensor s = unit();
  handtest::generate(handtest::session(16, 4, 8, 71), s, 71, a);
  s.ba += Eigen::Vector3d(0, 0.02, 0);
  handtest::generate(handtest::session(16, 4, 8, 72), s, 72, b);
  const std::string dir = IMUFORGE_BINARY_DIR;
  const std::string la = dir + "/poses_cli_a.bin", lb = dir + "/poses_cli_b.bin", out = dir + "/poses_cli.txt";
  ASSERT_EQ(run_cli("import --format si-csv --in " + write_float_csv(a, "poses_cli_a.csv") + " --out " + la, out), 0)
      << slurp(out);
  EXPECT_NE(slurp(out).find("preview: 16 static poses"), std::string::npos) << slurp(out);
  ASSERT_EQ(run_cli("import --format si-csv --in " + write_float_csv(b, "poses_cli_b.csv") + " --out " + lb, out), 0);
  const std::string model = std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/model-basic.json";
  const std::string cal = dir + "/poses_cli_cal.json";
  ASSERT_EQ(run_cli("solve --mode reference-free --explain-poses --log " + la + " --model " + model + " --out " + cal, out), 0)
      << slurp(out);
  const std::string one = slurp(out);
  EXPECT_NE(one.find("start_s"), std::string::npos);
  EXPECT_NE(one.find("moving or settling"), std::string::npos);
  ASSERT_EQ(run_cli("solve --mode reference-free --log " + la + " --log " + lb + " --model " + model + " --out " + cal, out), 0)
      << slurp(out);
  const std::string two = slurp(out);
  EXPECT_NE(two.find("repeatability over 2 recordings"), std::string::npos) << two;
  EXPECT_NE(two.find("warning: accel.bias.y"), std::string::npos) << two;
  const auto j = nlohmann::json::parse(slurp(cal));
  ASSERT_TRUE(j.contains("repeatability")) << j.dump(1).substr(0, 500);
  EXPECT_EQ(j["repeatability"]["poses"], nlohmann::json({16, 16}));
  EXPECT_EQ(j["reference_free"]["static_poses"], 32);
  EXPECT_EQ(run_cli("solve --mode fixture --log " + la + " --log " + lb + " --model " + model + " --out " + cal, out), 2);
}

// ---- Issue 17: extra catalog terms by leave-poses-out cross-validation ---------------------------------
namespace {
// Pose means of a sensor y = (I+M) f + b + k2∘f² + noise over n random attitudes (plain formulas, not
// the catalog's regressors: the selection must find the term the catalog names for this physics).
std::vector<poses::Pose> nonlinear_poses(int n, const Eigen::Vector3d& k2, double noise_mps2, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Eigen::Matrix3d im = Eigen::Matrix3d::Identity();
  im << 1.002, 0, 0, 0.001, 0.9985, 0, -0.0007, 0.0011, 1.001;
  const Eigen::Vector3d b(0.08, -0.05, 0.12);
  std::vector<poses::Pose> out;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d u(n01(rng), n01(rng), n01(rng));
    const Eigen::Vector3d f = 9.80665 * u.normalized();
    poses::Pose p;
    p.acc = im * f + b + k2.cwiseProduct(f.cwiseAbs2()) + noise_mps2 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    p.samples = 300;
    out.push_back(p);
  }
  return out;
}
std::array<bool, 9> all9() {
  std::array<bool, 9> a;
  a.fill(true);
  return a;
}
}  // namespace

TEST(TermSelection, AQuadraticScaleNonlinearityIsChosenOnWithheldPosesAndRecovered) {
  const Eigen::Vector3d k2(2.4e-4, -1.8e-4, 2.0e-4);  // ≈ 5 mm/s² left by the 9-term model
  const auto ps = nonlinear_poses(36, k2, 1e-4, 5);
  const poses::TermSelection s = poses::select_gravity_terms(ps, 9.80665, all9());
  ASSERT_TRUE(s.tried);
  std::vector<std::string> names;
  for (auto id : s.added) names.push_back(model::param_info(id).name);
  std::printf("added:");
  for (const auto& n : names) std::printf(" %s", n.c_str());
  std::printf("; held-out RMS %.3e -> %.3e m/s^2 (in-sample %.3e)\n", s.heldout_rms.front(), s.heldout_rms.back(), s.fit.rms_after);
  for (const char* want : {"accel.scale_nonlinearity.x.k2", "accel.scale_nonlinearity.y.k2", "accel.scale_nonlinearity.z.k2"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  EXPECT_LT(s.heldout_rms.back(), 0.2 * s.heldout_rms.front());
  EXPECT_LT(s.fit.rms_after, 2e-4);  // the noise (1e-4) plus a little
  for (std::size_t k = 0; k < s.fit.extra.size(); ++k) {
    const auto& pi = model::param_info(s.fit.extra[k]);
    if (pi.effect == model::Effect::kScaleNonlinearity && pi.power == 2)
      EXPECT_NEAR(s.fit.q[static_cast<long>(k)], k2[pi.j], 0.1 * std::abs(k2[pi.j])) << pi.name;
  }
  // apply() inverts the whole model: a pose's calibrated |f| is g within the noise.
  for (const auto& p : ps) EXPECT_NEAR(s.fit.apply(p.acc).norm(), 9.80665, 6e-4);
}

TEST(TermSelection, NothingIsAddedWithoutASystematicTermAndNothingTriedOnFewPoses) {
  int false_adds = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const poses::TermSelection s = poses::select_gravity_terms(nonlinear_poses(36, Eigen::Vector3d::Zero(), 1e-3, seed), 9.80665, all9());
    ASSERT_TRUE(s.tried);
    false_adds += static_cast<int>(s.added.size());
  }
  std::printf("terms added on 10 noise-only pose sets: %d\n", false_adds);
  EXPECT_LE(false_adds, 1);
  const poses::TermSelection few = poses::select_gravity_terms(nonlinear_poses(15, Eigen::Vector3d(2e-4, 0, 0), 1e-4, 3), 9.80665, all9());
  EXPECT_FALSE(few.tried);
  EXPECT_TRUE(few.added.empty());
  EXPECT_NE(few.note.find("15 poses"), std::string::npos) << few.note;
}

TEST(TermSelection, TheSolverReportsTheAddedTermsAndTheirHeldOutGain) {
  // A hand-placed recording (hand_placed.h) with the accelerometer's quadratic term added to its counts.
  poses::Recording rec;
  const handtest::Sensor s = unit();
  handtest::generate(handtest::session(30, 4, 10, 31, true, 150, 0.8), s, 31, rec);
  const Eigen::Vector3d k2(3e-4, 0, -2.5e-4);
  for (auto& y : rec.y)
    for (int j = 0; j < 3; ++j) y[static_cast<std::size_t>(j)] += k2[j] * y[static_cast<std::size_t>(j)] * y[static_cast<std::size_t>(j)];
  const auto on = solver::solve_reference_free(rec, basic());
  solver::ReferenceFreeOptions off;
  off.select_terms = false;
  const auto plain = solver::solve_reference_free(rec, basic(), off);
  ASSERT_TRUE(on.terms_tried);
  EXPECT_FALSE(on.terms_added.empty());
  for (const auto& n : on.terms_added) EXPECT_GE(on.estimate.index_of(n), 0) << n;
  EXPECT_LT(on.heldout_rms_selected, 0.5 * on.heldout_rms_basic);
  EXPECT_LT(on.gravity_rms_after, 0.5 * plain.gravity_rms_after);
  // The estimate carries the extras, so the calibration read back applies the same model.
  const poses::GravityFit back = solver::accel_fit_from_estimate(on.estimate);
  for (const auto& p : on.intervals) EXPECT_NEAR(back.apply(p.acc).norm(), on.accel_fit.apply(p.acc).norm(), 1e-9);
  // A coefficient table cannot hold the extras: with one requested, none is tried, and the note says why.
  solver::ReferenceFreeOptions tbl;
  tbl.for_table = true;
  const auto for_table = solver::solve_reference_free(rec, basic(), tbl);
  EXPECT_FALSE(for_table.terms_tried);
  EXPECT_TRUE(for_table.terms_added.empty());
  EXPECT_NE(for_table.terms_note.find("table"), std::string::npos) << for_table.terms_note;
  EXPECT_EQ(for_table.estimate.names.size(), plain.estimate.names.size());
  const nlohmann::json j = solver::reference_free_summary(on, rec);
  EXPECT_EQ(j["term_selection"]["added"].size(), on.terms_added.size());
  std::printf("added %s; held-out %.3e -> %.3e; in-sample 9 terms %.3e, selected %.3e m/s^2\n",
              j["term_selection"]["added"].dump().c_str(), on.heldout_rms_basic, on.heldout_rms_selected,
              plain.gravity_rms_after, on.gravity_rms_after);
}

TEST(StillPart, AFixtureDwellLosesItsRingingAndAShakenDwellIsRejectedWithAReason) {
  // 8 s at 100 Hz: a table that rings for the first 0.8 s after "settled", then holds.
  poses::Recording r;
  r.rate_hz = 100;
  r.accel_lsb = 1e-4;
  r.gyro_lsb = 1e-5;
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n01;
  for (int i = 0; i < 800; ++i) {
    const double t = i / 100.0;
    const double ring = t < 0.8 ? 0.3 * std::exp(-t / 0.3) * std::sin(2 * M_PI * 12 * t) : 0.0;
    r.t_s.push_back(t);
    r.y.push_back({0.002 * n01(rng) + ring, 0.002 * n01(rng), -9.80665 + 0.002 * n01(rng), 1e-4 * n01(rng) + ring,
                   1e-4 * n01(rng), 1e-4 * n01(rng)});
  }
  const poses::StillPart sp = poses::still_part(r);
  ASSERT_FALSE(sp.rejected()) << sp.reason;
  EXPECT_GE(sp.parts.front().first, 80u);   // the ringing is not kept
  EXPECT_GT(sp.samples, 600u);              // the hold is
  EXPECT_NE(sp.reason.find("kept"), std::string::npos) << sp.reason;
  // A table that never stopped: a steady 0.5 rad/s turn for the whole dwell. Steady, so neither the noise
  // test nor the rate about the (median) bias sees it; the attitude does, and no piece is long enough.
  poses::Recording turning = r;
  for (std::size_t i = 0; i < turning.y.size(); ++i) {
    const double th = 0.5 * turning.t_s[i];
    turning.y[i] = {0.002 * n01(rng), 9.80665 * std::sin(th), -9.80665 * std::cos(th), 0.5 + 1e-4 * n01(rng),
                    1e-4 * n01(rng), 1e-4 * n01(rng)};
  }
  const poses::StillPart bad = poses::still_part(turning);
  EXPECT_TRUE(bad.rejected());
  EXPECT_NE(bad.reason.find("rejected"), std::string::npos) << bad.reason;
  std::printf("ringing dwell: %s; turning dwell: %s\n", sp.reason.c_str(), bad.reason.c_str());
}
}  // namespace poses_detect_test
