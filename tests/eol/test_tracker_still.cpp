// The tracker's static-data acceptance goes through the one pose detector (host/poses still_part): a
// position dwell's ringing after "settled" is dropped, a dwell that never held still is rejected with the
// detector's reason, and rate runs are not touched.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "host/eol/report.h"
#include "host/eol/tracker.h"
#include "host/model/sensor_model.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_tracker_still {

using namespace imuforge;

namespace {

io::LogMeta meta() {
  io::LogMeta m;
  m.sample_rate_hz = 100;
  m.accel_lsb_mps2 = 1e-4;
  m.gyro_lsb_rad_s = 1e-5;
  m.accel_bits = m.gyro_bits = 20;
  return m;
}

// 8 s on one face (f_ref = 0, 0, −g): the accelerometer reads f + b + noise, and for ring_s seconds
// after the start also a decaying sag and 12 Hz ringing of the mount (not in the reference; its mean over
// the dwell is ~0.02 m/s²). turn_rad_s > 0:
// the table is turning about x all along although the reference says it holds.
std::vector<io::LogRow> dwell(double ring_s, double turn_rad_s, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  const double g = 9.80665;
  const Eigen::Vector3d b(0.05, -0.03, 0.02);
  std::vector<io::LogRow> rows;
  for (int i = 0; i < 800; ++i) {
    io::LogRow r;
    r.t_s = i / 100.0;
    r.segment = 0;
    r.temp_C = 25.0;
    r.has_ref = true;
    r.f_ref[2] = -g;
    const double ring = r.t_s < ring_s ? 0.5 * std::exp(-r.t_s / 0.3) * (1 + std::sin(2 * M_PI * 12 * r.t_s)) : 0.0;
    const double th = turn_rad_s * r.t_s;
    const Eigen::Vector3d f(0, -g * std::sin(th), -g * std::cos(th));
    for (int j = 0; j < 3; ++j) {
      r.raw[j] = static_cast<std::int32_t>(std::lround((f[j] + b[j] + 0.002 * n01(rng) + (j == 0 ? ring : 0.0)) / 1e-4));
      r.raw[3 + j] = static_cast<std::int32_t>(std::lround(((j == 0 ? turn_rad_s + 0.3 * ring : 0.0) + 1e-4 * n01(rng)) / 1e-5));
    }
    for (int a = 0; a < 2; ++a) r.table_rate_rad_s[a] = 0.0;
    rows.push_back(r);
  }
  return rows;
}

model::ModelSpec basic() { return model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-basic.json"); }

double bias_x(const eol::Tracker& t) {
  const solver::Estimate e = t.estimate();
  return e.value[e.index_of("accel.bias.x")];
}

}  // namespace

TEST(TrackerStill, RingingAfterSettledIsDroppedByThePoseDetector) {
  eol::Tracker ringing(basic()), clean(basic());
  ringing.set_noise(0.002, 1e-4);
  clean.set_noise(0.002, 1e-4);
  const auto rows = dwell(1.0, 0.0, 7);
  ASSERT_TRUE(ringing.add_segment(meta(), rows, 0, "z down"));
  const std::string note = ringing.residuals().back().still_note;
  std::printf("ringing dwell: %s\n", note.c_str());
  EXPECT_NE(note.find("kept"), std::string::npos) << note;
  // Taking every row would shift accel.bias.x by the sag's mean over the dwell; the detector's part
  // must leave at most a tenth of that, against the same dwell from 1.3 s on (past the sag).
  double contamination = 0;
  for (int i = 0; i < 100; ++i) contamination += 0.5 * std::exp(-i / 30.0) * (1 + std::sin(2 * M_PI * 12 * i / 100.0)) / 800.0;
  std::vector<io::LogRow> tail(rows.begin() + 130, rows.end());
  ASSERT_TRUE(clean.add_segment(meta(), tail, 0, "z down"));
  std::printf("accel.bias.x: detector's part %.5f, clean tail %.5f, every row would add ~%.5f m/s^2\n", bias_x(ringing),
              bias_x(clean), contamination);
  EXPECT_NEAR(bias_x(ringing), bias_x(clean), 0.1 * contamination);
  EXPECT_TRUE(ringing.rejections().empty());
}

TEST(TrackerStill, ADwellThatNeverHeldIsRejectedWithTheDetectorsReason) {
  eol::Tracker t(basic());
  t.set_noise(0.002, 1e-4);
  EXPECT_FALSE(t.add_segment(meta(), dwell(0.0, 0.5, 8), 3, "x down"));
  ASSERT_EQ(t.rejections().size(), 1u);
  EXPECT_EQ(t.rejections()[0].segment, 3);
  EXPECT_EQ(t.rejections()[0].label, "x down");
  EXPECT_NE(t.rejections()[0].reason.find("rejected"), std::string::npos) << t.rejections()[0].reason;
  std::printf("turning dwell: %s\n", t.rejections()[0].reason.c_str());
  EXPECT_EQ(t.segments(), 0);
}

// The unit report shows the operator which static steps were left out and why (the runner also journals
// them as segment_rejected); a run without rejections has no such section.
TEST(TrackerStill, TheReportListsRejectedStepsWithTheirReason) {
  eol::Tracker t(basic());
  t.set_noise(0.002, 1e-4);
  EXPECT_FALSE(t.add_segment(meta(), dwell(0.0, 0.5, 8), 3, "x <down>"));
  eol::ReportData d;
  d.rejections = t.rejections();
  const std::string html = eol::render_report(d);
  const auto at = html.find("Static steps left out");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NE(html.find("x &lt;down&gt;", at), std::string::npos);
  EXPECT_NE(html.find(t.rejections()[0].reason.substr(0, 20), at), std::string::npos);
  EXPECT_EQ(eol::render_report(eol::ReportData{}).find("Static steps left out"), std::string::npos);
}

TEST(TrackerStill, ARateRunIsNotJudgedByThePoseDetector) {
  eol::Tracker t(basic());
  t.set_noise(0.002, 1e-4);
  auto rows = dwell(1.0, 0.0, 9);
  for (auto& r : rows) r.table_rate_rad_s[0] = 1.0;  // the table reports a rate: not a static step
  ASSERT_TRUE(t.add_segment(meta(), rows, 0, "z CW"));
  EXPECT_TRUE(t.residuals().back().still_note.empty());
}
}  // namespace eol_test_tracker_still
