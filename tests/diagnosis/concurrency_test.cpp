// The diagnosis's concurrent pieces (host/diagnosis/concurrency.h) give the single-threaded answer to the last bit:
// the chunk hand-off under them, the read-ahead source, the regressors' block sums, the whole-log wander search, the
// shape profiles, the line spectrum's cached sums, and a whole diagnosis of a rate-table log with the table known
// (every threaded path at once). Run under ThreadSanitizer too (preset host-tsan).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "host/diagnosis/concurrency.h"
#include "host/diagnosis/noise_model.h"
#include "host/diagnosis/prefetch.h"
#include "host/diagnosis/regressor_sums.h"
#include "host/diagnosis/stats.h"
#include "host/diagnosis/table_errors.h"
#include "host/model/measure.h"
#include "tests/diagnosis/sim_helpers.h"

namespace diagnosis_concurrency_test {

using namespace imuforge::diagnosis;

// IMUFORGE_DIAG_THREADS=1 for the scope of one object: the serial reference of each comparison.
struct OneThread {
  OneThread() { setenv("IMUFORGE_DIAG_THREADS", "1", 1); }
  ~OneThread() { setenv("IMUFORGE_DIAG_THREADS", "2", 1); }
};

// Each test's threaded side runs threaded whatever the machine's cores (IMUFORGE_DIAG_THREADS=2), so a comparison is
// never one thread against one thread; the other tests of the program keep the default.
class DiagnosisConcurrency : public ::testing::Test {
 protected:
  void SetUp() override { setenv("IMUFORGE_DIAG_THREADS", "2", 1); }
  void TearDown() override { unsetenv("IMUFORGE_DIAG_THREADS"); }
};

std::vector<imuforge::model::ParamId> deterministic_params(imuforge::model::Sensor s) {
  std::vector<imuforge::model::ParamId> ids;
  for (const auto& p : imuforge::model::params())
    if (p.sensor == s && p.deterministic) ids.push_back(p.id);
  return ids;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

std::vector<Sample> numbered(int n) {
  std::vector<Sample> v(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    v[static_cast<std::size_t>(i)].t_s = 0.01 * i;
    v[static_cast<std::size_t>(i)].segment = i / 100;
    v[static_cast<std::size_t>(i)].y[0] = i;
  }
  return v;
}

// Throws after `good` samples, as a log with a corrupt row does.
class BreaksAfter : public SampleSource {
 public:
  BreaksAfter(std::vector<Sample> v, std::size_t good) : v_(std::move(v)), good_(good) {}
  void rewind() override { i_ = 0; }
  bool next(Sample& s) override {
    if (i_ == good_) throw std::runtime_error("row " + std::to_string(i_) + ": corrupt");
    if (i_ >= v_.size()) return false;
    s = v_[i_++];
    return true;
  }

 private:
  std::vector<Sample> v_;
  std::size_t good_, i_ = 0;
};

TEST_F(DiagnosisConcurrency, ChunkQueueHandsOverInOrderThenTheErrorAndStops) {
  ChunkQueue<int> q(2);
  std::thread producer([&] {
    for (int k = 0; k < 50; ++k) {
      std::vector<int> c = q.blank();
      c.clear();  // a spent chunk comes back as the consumer left it
      for (int i = 0; i <= k % 7; ++i) c.push_back(k * 100 + i);
      ASSERT_TRUE(q.push(std::move(c)));
    }
    q.close(std::make_exception_ptr(std::runtime_error("end of log")));
  });
  std::vector<int> chunk;
  std::exception_ptr err;
  int k = 0;
  while (q.pop(chunk, err)) {
    ASSERT_EQ(chunk.size(), static_cast<std::size_t>(k % 7 + 1)) << "chunk " << k;
    for (std::size_t i = 0; i < chunk.size(); ++i) ASSERT_EQ(chunk[i], k * 100 + static_cast<int>(i));
    ++k;
  }
  producer.join();
  EXPECT_EQ(k, 50);  // every chunk before the error
  ASSERT_TRUE(err);
  EXPECT_THROW(std::rethrow_exception(err), std::runtime_error);
  std::exception_ptr again;
  EXPECT_FALSE(q.pop(chunk, again));  // the error is passed on once
  EXPECT_FALSE(again);

  // A producer waiting for room is released by the consumer's stop(), and its push() says so.
  q.reset();
  ASSERT_TRUE(q.push(std::vector<int>{1}));
  ASSERT_TRUE(q.push(std::vector<int>{2}));
  bool pushed = true;
  std::thread blocked([&] { pushed = q.push(std::vector<int>{3}); });
  q.stop();
  blocked.join();
  EXPECT_FALSE(pushed);
  EXPECT_FALSE(q.pop(chunk, err));
}

TEST_F(DiagnosisConcurrency, ReadAheadGivesTheSamplesInOrderAndRewinds) {
  ASSERT_TRUE(concurrency_allowed());
  VectorSource inner(numbered(10007));
  PrefetchSource src(inner, 64);  // many batches, the last one short
  for (int pass = 0; pass < 3; ++pass) {
    src.rewind();
    Sample s;
    int n = 0;
    // The second pass stops early: the rewind must still start the next one from the first sample.
    while ((pass != 1 || n < 777) && src.next(s)) {
      ASSERT_EQ(s.y[0], n) << "pass " << pass;
      ++n;
    }
    if (pass != 1) EXPECT_EQ(n, 10007);
    EXPECT_EQ(pass != 1 && src.next(s), false);
  }
  src.idle();
}

TEST_F(DiagnosisConcurrency, ReadAheadRaisesTheInnerErrorWhereItHappened) {
  BreaksAfter inner(numbered(5000), 3001);
  PrefetchSource src(inner, 100);
  Sample s;
  int n = 0;
  try {
    while (src.next(s)) ++n;
    FAIL() << "the inner source's error was lost";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "row 3001: corrupt");
  }
  EXPECT_EQ(n, 3001);  // every sample before the error, none after
  // A destroyed reader with batches still queued (the caller gave up mid-pass) stops cleanly.
  VectorSource more(numbered(100000));
  { PrefetchSource early(more, 16); ASSERT_TRUE(early.next(s)); }
}

TEST_F(DiagnosisConcurrency, RegressorSumsAreTheSerialSumsBitForBit) {
  using imuforge::model::MeasureInput;
  using imuforge::model::RegressorPlan;
  using imuforge::model::Sensor;
  const RegressorPlan accel(Sensor::kAccel, deterministic_params(Sensor::kAccel));
  const RegressorPlan gyro(Sensor::kGyro, deterministic_params(Sensor::kGyro));
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<std::pair<int, std::array<MeasureInput, 2>>> queue;
  int block = 0;
  for (int i = 0; i < 20000; ++i) {
    if (i % 333 == 0 && i > 0) block += 1 + (i % 999 == 0 ? 1 : 0);  // a block number skipped: its sums stay zero
    MeasureInput in;
    for (int k = 0; k < 3; ++k) {
      in.f[k] = 9.8 * g(rng);
      in.w[k] = g(rng);
      in.fdot[k] = g(rng);
      in.wdot[k] = g(rng);
    }
    in.T_C = 25.0 + 10.0 * g(rng);
    in.Tdot_C_s = 0.01 * g(rng);
    in.d = g(rng);
    in.t_s = 0.001 * i;
    MeasureInput other = in;
    other.w[0] += 0.1;  // the two triads' inputs differ (a sensor's own shifted time)
    queue.push_back({block, {in, other}});
  }
  auto run = [&] {
    RegressorSums sums(accel, gyro, 20.0);
    for (const auto& [b, ins] : queue) sums.add(b, ins.data());
    return sums.take();
  };
  std::vector<std::array<Eigen::MatrixXd, 2>> serial;
  {
    OneThread one;
    serial = run();
  }
  const auto threaded = run();
  ASSERT_EQ(threaded.size(), serial.size());
  ASSERT_EQ(static_cast<int>(serial.size()), block + 1);
  for (std::size_t b = 0; b < serial.size(); ++b)
    for (int s = 0; s < 2; ++s) {
      ASSERT_EQ(threaded[b][static_cast<std::size_t>(s)].size(), serial[b][static_cast<std::size_t>(s)].size());
      for (Eigen::Index i = 0; i < serial[b][static_cast<std::size_t>(s)].size(); ++i)
        ASSERT_TRUE(same_bits(threaded[b][static_cast<std::size_t>(s)](i), serial[b][static_cast<std::size_t>(s)](i))) << b << " " << s << " " << i;
    }
  // And they are what the plan sums directly, sample by sample.
  Eigen::MatrixXd direct = Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(gyro.size()));
  for (const auto& [b, ins] : queue)
    if (b == 0) gyro.accumulate(ins[1], 20.0, direct);
  for (Eigen::Index i = 0; i < direct.size(); ++i) ASSERT_TRUE(same_bits(direct(i), threaded[0][1](i))) << i;
}

// Block means of a bias random walk with a slow sinusoid and a column, as whole_log_wander takes them.
struct WanderCase {
  std::vector<double> t, dur;
  Eigen::MatrixXd rows;
  StochasticModel m;
};
WanderCase wander_case(unsigned seed) {
  WanderCase c;
  const int n = 900;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  c.rows.resize(n, 2);
  double walk = 0;
  for (int i = 0; i < n; ++i) {
    c.t.push_back(2.0 * i + 1.0);
    c.dur.push_back(1.5);
    walk += 2e-4 * g(rng);
    const double x = std::sin(0.01 * i) + 0.3 * g(rng);
    c.rows(i, 1) = x;
    c.rows(i, 0) = 0.02 * x + walk + 3e-4 * std::sin(2.0 * M_PI * c.t.back() / 400.0) + 1e-4 * g(rng);
  }
  c.m.N = 1e-4;
  c.m.bank_tau_s = {3.0, 30.0, 300.0};
  c.m.bank_sigma = 2e-5;
  c.m.bank_sigma_lik = 4e-5;
  return c;
}

TEST_F(DiagnosisConcurrency, ConcurrentWanderSearchGivesTheSerialAnswer) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const WanderCase c = wander_case(seed);
    std::array<WholeLogWander, 3> serial;
    {
      OneThread one;
      serial = whole_log_wander(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), 20.0);
    }
    const std::array<WholeLogWander, 3> threaded = whole_log_wander(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), 20.0);
    bool any = false;
    for (int l = 0; l < 3; ++l) {
      const auto &a = serial[static_cast<std::size_t>(l)], &b = threaded[static_cast<std::size_t>(l)];
      any = any || a.kind != WholeLogWander::kNone;
      EXPECT_EQ(a.kind, b.kind) << seed << " " << l;
      for (auto [x, y] : {std::pair{a.gain, b.gain}, {a.K, b.K}, {a.bank_sigma, b.bank_sigma}, {a.ratio, b.ratio},
                          {a.max_abs_z, b.max_abs_z}, {a.whiteness_p, b.whiteness_p}, {a.line_p, b.line_p},
                          {a.line_period_s, b.line_period_s}, {a.jump_persist_z, b.jump_persist_z}})
        EXPECT_TRUE(same_bits(x, y)) << seed << " line " << l << ": " << x << " vs " << y;
    }
    EXPECT_TRUE(any) << "the case raises no line: the comparison would be empty";
  }
}

// The shape profiles (trend_bias, input_bias, input_group_bias) fit the raise's 41 levels in two halves at once.
TEST_F(DiagnosisConcurrency, ShapeProfilesOverTheRaisesLevelsGiveTheSerialAnswer) {
  for (unsigned seed : {1u, 2u}) {
    const WanderCase c = wander_case(seed);
    for (const auto kind : {WholeLogWander::kRandomWalk, WholeLogWander::kFlicker}) {
      WholeLogWander raise;
      raise.kind = kind;
      raise.K = 3e-6;
      raise.bank_sigma = 6e-5;
      Eigen::MatrixXd fn(c.rows.rows(), 3);  // functions of the "inputs" for input_bias: x, x², a slow sine
      for (Eigen::Index i = 0; i < fn.rows(); ++i) {
        const double x = c.rows(i, 1);
        fn(i, 0) = x;
        fn(i, 1) = x * x;
        fn(i, 2) = std::sin(2.0 * M_PI * c.t[static_cast<std::size_t>(i)] / 400.0);
      }
      TrendBias tb1;
      InputBias ib1, gb1;
      {
        OneThread one;
        tb1 = trend_bias(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), raise);
        ib1 = input_bias(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), raise, fn);
        gb1 = input_group_bias(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), raise, fn);
      }
      const TrendBias tb2 = trend_bias(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), raise);
      const InputBias ib2 = input_bias(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), raise, fn);
      const InputBias gb2 = input_group_bias(c.m, c.t, c.dur, c.rows, 0.0, c.t.back(), raise, fn);
      for (auto [x, y] : {std::pair{tb1.gain, tb2.gain}, {tb1.line_gain, tb2.line_gain}, {tb1.slope_per_s, tb2.slope_per_s},
                          {tb1.settle_gain, tb2.settle_gain}, {tb1.settle_tau_s, tb2.settle_tau_s},
                          {tb1.settle_amplitude, tb2.settle_amplitude}, {ib1.gain, ib2.gain}, {ib1.own_gain, ib2.own_gain},
                          {gb1.gain, gb2.gain}, {gb1.own_gain, gb2.own_gain}})
        EXPECT_TRUE(same_bits(x, y)) << seed << " kind " << kind << ": " << x << " vs " << y;
      EXPECT_EQ(ib1.best, ib2.best);
      EXPECT_GT(tb1.gain + ib1.gain, 0.0) << "nothing to find: the comparison would be of zeros";
    }
  }
}

TEST_F(DiagnosisConcurrency, LineSpectrumFromCachedSumsIsTheFirstCallsToTheBit) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> t, t2;
  Eigen::VectorXd e(700), e2(700);
  for (int i = 0; i < 700; ++i) {
    t.push_back(1.3 * i + 0.2 * (i % 7));
    t2.push_back(1.3 * i + 0.2 * (i % 5));  // other times, the same count: must not hit the first's sums
    e[i] = std::sin(2.0 * M_PI * t.back() / 90.0) + g(rng);
    e2[i] = g(rng);
  }
  const SpectralLine first = line_power_spectrum(t, e), first2 = line_power_spectrum(t2, e2);
  // A fresh thread has no cache: its answer is computed in full.
  SpectralLine fresh, fresh2;
  std::thread([&] {
    fresh = line_power_spectrum(t, e);
    fresh2 = line_power_spectrum(t2, e2);
  }).join();
  for (int round = 0; round < 3; ++round) {
    const SpectralLine again = line_power_spectrum(t, e), again2 = line_power_spectrum(t2, e2);
    EXPECT_TRUE(same_bits(again.power, first.power) && same_bits(again.power, fresh.power));
    EXPECT_TRUE(same_bits(again.period_s, first.period_s) && same_bits(again.false_alarm_p, fresh.false_alarm_p));
    EXPECT_TRUE(same_bits(again2.power, first2.power) && same_bits(again2.power, fresh2.power));
    EXPECT_TRUE(same_bits(again2.period_s, fresh2.period_s));
  }
  EXPECT_NEAR(first.period_s, 90.0, 2.0);
}

// Every threaded path at once: the log read ahead and filtered, the regressors summed beside the pass, the
// reference re-evaluated at the table's errors on its own thread, the wander searches and the motion-lag probe
// split in two. The whole diagnosis.json must be the one-thread one.
TEST_F(DiagnosisConcurrency, TheDiagnosisOfATableLogIsTheSameOnOneThreadAndOnSeveral) {
  using diagtest::json;
  json camp = diagtest::rich_campaign({25.0, 35.0}, 50.0);
  camp["simulation"]["fixture_errors"] = {{"axes", {{{"tilt_a_deg", 0.02}, {"tilt_b_deg", -0.01}, {"zero_deg", 0.01}},
                                                    {{"tilt_a_deg", -0.01}, {"tilt_b_deg", 0.015}, {"zero_deg", -0.02}},
                                                    {{"tilt_a_deg", 0.01}, {"tilt_b_deg", 0.02}, {"zero_deg", 0.01}}}}};
  const json sensor = diagtest::base_sensor(true, {{"gyro.g_sensitivity", {{"xz", 2e-4}}},
                                                   {"gyro.rate_random_walk", {{"x", 2e-5}, {"y", 2e-5}, {"z", 2e-5}}}});
  const std::vector<Sample> log = diagtest::simulate(camp, sensor, 5, true);
  const auto c = imuforge::io::campaign_from_json(camp);
  auto run = [&] {
    VectorSource src(log);
    Options o;
    o.table = table_of_campaign(c, 3, "rich");
    return diagnose(src, basic_model(), o);
  };
  DiagnosisResult serial;
  {
    OneThread one;
    serial = run();
  }
  const DiagnosisResult threaded = run();
  EXPECT_TRUE(serial.fixture_known);
  EXPECT_GT(serial.fixture_iterations, 0);
  EXPECT_FALSE(serial.selected.empty());
  EXPECT_EQ(to_json(threaded).dump(), to_json(serial).dump());
}

}  // namespace diagnosis_concurrency_test
