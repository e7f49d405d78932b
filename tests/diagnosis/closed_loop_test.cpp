// The closed loop (issue 12, item 6; docs/diagnosis.md "Closed loop"): `imuforge diagnose --emit-model`
// writes the base model plus what it selected; `imuforge solve --model` on the same log then leaves a
// residual consistent with the diagnosis's held-out figure after selection.
//
// What is compared, per axis: the systematic part of the residual, i.e. the residual RMS with the noise
// floor taken out in quadrature.
//   diagnosis: s_d = √(max(heldout_rms² − noise_floor², 0)) of gap_before / gap_after (segment means,
//              held out, docs/diagnosis.md "Gap");
//   solver:    s_s = √(max(residual_rms² − noise_sigma², 0)) from cal.json (dwell samples, in sample).
// A steady effect shifts a segment's mean and each of its samples alike, so both estimate the same RMS
// of the unexplained systematic error. They weight segments differently (inverse variance vs samples)
// and one is held out, the other in sample, so they agree only to a fraction of the gap before: the
// tolerance is 20 % of the larger before-figure plus 3 noise floors of the diagnosis (the scatter of a
// held-out RMS over a few tens of segments). After the loop both must agree to within it on every axis;
// on the axes of the solvable effects both must see the gap before and see it closed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include "host/io/log.h"
#include "tests/diagnosis/sim_helpers.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace diagnosis_closed_loop_test {

namespace fs = std::filesystem;
using namespace diagtest;

namespace {

int run(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(IMUFORGE_BIN) + " " + args + " > " + log.string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

json read(const fs::path& p) {
  std::ifstream f(p);
  return json::parse(f);
}

double systematic(double rms, double floor) { return std::sqrt(std::max(rms * rms - floor * floor, 0.0)); }

const char* kAxes[6] = {"accel.x", "accel.y", "accel.z", "gyro.x", "gyro.y", "gyro.z"};

// The loop's first half: simulate the campaign with the sensor, diagnose against the basic model with
// --emit-model (dir/extended.json). Exit codes are returned for the caller to assert.
struct Loop {
  int simulate_rc = -1, diagnose_rc = -1;
  std::string log, base;
  fs::path ext;
  json d;                          // diagnosis.json
  std::set<std::string> selected; // "sensor.effect"
};

Loop simulate_and_diagnose(const fs::path& dir, const json& campaign, const json& sensor, int seed) {
  Loop L;
  std::ofstream(dir / "campaign.json") << campaign.dump(1);
  std::ofstream(dir / "sensor.json") << sensor.dump(1);
  L.log = (dir / "run.bin").string();
  L.simulate_rc = run("simulate --campaign " + (dir / "campaign.json").string() + " --sensor " +
                          (dir / "sensor.json").string() + " --seed " + std::to_string(seed) + " --out " + L.log,
                      dir / "sim.txt");
  if (L.simulate_rc != 0) return L;
  L.base = std::string(IMUFORGE_SOURCE_DIR) + "/docs/examples/model-basic.json";
  L.ext = dir / "extended.json";
  L.diagnose_rc = run("diagnose --log " + L.log + " --model " + L.base + " --out " + (dir / "diag").string() +
                          " --emit-model " + L.ext.string(),
                      dir / "diag.txt");
  if (L.diagnose_rc != 0) return L;
  L.d = read(dir / "diag" / "diagnosis.json");
  for (const auto& s : L.d["selected"]) L.selected.insert(s["sensor"].get<std::string>() + "." + s["effect"].get<std::string>());
  return L;
}

}  // namespace

TEST(DiagnosisClosedLoop, EmittedModelSolvesToTheDiagnosedGap) {
  const fs::path dir = fs::temp_directory_path() / ("imuforge-closed-loop-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // Three effects beyond the basic model: two the fixture solver can estimate, and a gyro latency, which
  // it cannot (dwell rows only: u̇ = 0) and which the emitted model must therefore leave out.
  // 50 Hz: at 10 Hz the linear timing term, with u̇ from neighbouring samples, cannot follow the table's
  // accelerations and the diagnosis leaves the gyro unexplained.
  const json sensor = base_sensor(false, {{"gyro.g_sensitivity", {{"yz", 3e-4}}},
                                          {"accel.scale_asymmetry", {{"x", 5e-3}}},
                                          {"gyro.timing", {{"latency_s", 0.002}}}});
  // Without the sine steps: the fixture solver takes u̇ = 0 on every row it uses (it does not
  // differentiate the reference), which is exact on dwells but not inside a sine, where a latency would
  // stay in its residual (docs/diagnosis.md, "Closed loop").
  json campaign = rich_campaign({25.0}, 50.0);
  for (auto& ph : campaign["phases"]) {
    json steps = json::array();
    for (const auto& st : ph["steps"])
      if (st["type"] != "sine") steps.push_back(st);
    ph["steps"] = steps;
  }
  const auto& [simulate_rc, diagnose_rc, log, base, ext, d, selected] = simulate_and_diagnose(dir, campaign, sensor, 7);
  ASSERT_EQ(simulate_rc, 0);
  ASSERT_EQ(diagnose_rc, 0);
  for (const char* e : {"gyro.g_sensitivity", "accel.scale_asymmetry", "gyro.timing"}) EXPECT_TRUE(selected.count(e)) << e;

  // The emitted model: base + selected, minus what the fixture solver cannot observe, which is named.
  const json m = read(ext);
  for (const char* e : {"accel.bias", "accel.scale", "accel.misalign", "gyro.bias", "gyro.scale", "gyro.misalign"})
    EXPECT_TRUE(m["effects"].contains(e)) << e;
  for (const auto& e : selected)
    if (e != "gyro.timing") EXPECT_TRUE(m["effects"].contains(e)) << e;
  EXPECT_FALSE(m["effects"].contains("gyro.timing"));
  ASSERT_TRUE(m.contains("_diagnosis"));
  bool named = false;
  for (const auto& n : m["_diagnosis"]["not_emitted"])
    if (n["effect"] == "gyro.timing") {
      named = true;
      EXPECT_NE(n["unobservable"].dump().find("gyro.timing.latency_s"), std::string::npos) << n.dump();
      EXPECT_FALSE(n["diagnosis_estimate"].empty());
    }
  EXPECT_TRUE(named) << m["_diagnosis"].dump();

  // With the timing term in, the fixture solve is rank-deficient and says which directions: why it is
  // left out (the emitted model must not be the thing that fails).
  {
    json with_timing = m;
    with_timing["effects"]["gyro.timing"] = json::object();
    std::ofstream(dir / "with_timing.json") << with_timing.dump(1);
  }
  EXPECT_EQ(run("solve --log " + log + " --model " + (dir / "with_timing.json").string() + " --out " +
                    (dir / "cal_t.json").string(),
                dir / "solve_t.txt"),
            1);
  EXPECT_FALSE(fs::exists(dir / "cal_t.json"));
  {
    std::ifstream f(dir / "solve_t.txt");
    const std::string txt((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(txt.find("rank-deficient"), std::string::npos) << txt;
    EXPECT_NE(txt.find("gyro.timing.latency_s"), std::string::npos) << txt;
  }

  ASSERT_EQ(run("solve --log " + log + " --model " + base + " --out " + (dir / "cal_base.json").string(), dir / "solve_b.txt"), 0);
  ASSERT_EQ(run("solve --log " + log + " --model " + ext.string() + " --out " + (dir / "cal_ext.json").string(), dir / "solve_e.txt"), 0);
  const json cb = read(dir / "cal_base.json"), ce = read(dir / "cal_ext.json");
  for (int a = 0; a < 6; ++a) {
    const std::string ax = kAxes[a];
    const double sd0 = systematic(d["gap_before"][ax]["heldout_rms"], d["gap_before"][ax]["noise_floor"]);
    const double sd1 = systematic(d["gap_after"][ax]["heldout_rms"], d["gap_after"][ax]["noise_floor"]);
    const double ss0 = systematic(cb["residual_rms"][ax], cb["noise_sigma"][ax]);
    const double ss1 = systematic(ce["residual_rms"][ax], ce["noise_sigma"][ax]);
    const double tol = 0.2 * std::max(sd0, ss0) + 3.0 * d["gap_after"][ax]["noise_floor"].get<double>();
    std::printf("%-8s systematic RMS  before: diagnosis %.3e solve %.3e   after: diagnosis %.3e solve %.3e   tol %.3e\n",
                ax.c_str(), sd0, ss0, sd1, ss1, tol);
    EXPECT_LE(std::fabs(ss1 - sd1), tol) << ax;
    // accel.x (asymmetry) and gyro.y (g-sensitivity yz) carry the solvable effects: both see the gap
    // before and both see it closed to under a quarter. (The latency acts only while the table moves,
    // which the diagnosis scores and the fixture solver does not read: no "before" figure to compare.)
    if (a == 0 || a == 4) {
      EXPECT_GT(ss0, tol) << ax;
      EXPECT_LT(ss1, 0.25 * ss0) << ax;
      EXPECT_LT(sd1, 0.25 * sd0) << ax;
    }
  }
  if (!std::getenv("KEEP")) fs::remove_all(dir);
}

// temp_hysteresis's threshold goes round the loop: the diagnosis profiles it, --emit-model writes it, and the
// solver builds d(t) at it. The sensor's threshold is 0.3 °C and its die reverses by 0.4 °C between plateaus,
// which turns d at 0.3 °C and not at the catalog's 0.5 °C; the logged temperature carries 0.02 °C of noise.
// Solved at the emitted threshold the hysteresis is read within 3σ; the same model without the key (0.5 °C)
// reads it short by more than 3 white-noise σ, and its σ (with the dwell drift) is widened past 3× that.
TEST(DiagnosisClosedLoop, HysteresisThresholdGoesRoundTheLoop) {
  const fs::path dir = fs::temp_directory_path() / ("imuforge-closed-loop-h-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  json sensor = base_sensor(false, {{"accel.temp_hysteresis", {{"x", 3e-3}, {"z", -2e-3}}}});
  sensor["thermal"]["hysteresis_threshold_C"] = 0.3;
  json steps = json::array();
  const double faces[6][3] = {{0, 0, 0}, {0, 180, 0}, {0, 90, 0}, {180, 90, 0}, {90, 90, 0}, {270, 90, 0}};
  for (auto& f : faces) steps.push_back(pos(f[0], f[1], f[2], 4));
  for (double inner : {45.0, 135.0}) steps.push_back(pos(inner, 45, 0, 4));
  json campaign = rich_campaign({25.0}, 50.0);
  json phases = json::array();
  for (double T : {25.0, 15.0, 15.4, 8.0, 8.4, 20.0, 19.6, 30.0, 29.6, 18.0})
    phases.push_back({{"type", "plateau"}, {"label", "p"}, {"setpoint_C", T}, {"soak_s", 30}, {"steps", steps}});
  campaign["phases"] = phases;
  campaign["simulation"]["temp_noise_C"] = 0.02;
  const auto& [simulate_rc, diagnose_rc, log, base, ext, d, selected] = simulate_and_diagnose(dir, campaign, sensor, 5);
  ASSERT_EQ(simulate_rc, 0);
  ASSERT_EQ(diagnose_rc, 0);
  EXPECT_TRUE(selected.count("accel.temp_hysteresis")) << d["selected"].dump();
  EXPECT_EQ(d["hysteresis_threshold"]["source"], "profiled") << d["hysteresis_threshold"].dump();
  EXPECT_DOUBLE_EQ(d["hysteresis_threshold"]["C"].get<double>(), 0.3) << d["hysteresis_threshold"].dump();
  const json m = read(ext);
  ASSERT_TRUE(m.contains("hysteresis_threshold_C")) << m.dump();
  EXPECT_DOUBLE_EQ(m["hysteresis_threshold_C"].get<double>(), 0.3);
  json at_default = m;
  at_default.erase("hysteresis_threshold_C");
  std::ofstream(dir / "at_default.json") << at_default.dump(1);
  // The same with σ from white noise alone: what the wrong threshold costs is judged against the noise, since the
  // default σ carries the misfit it leaves between dwells as drift (docs/calibration.md, "Dwell drift").
  json at_default_white = at_default;
  at_default_white["dwell_scatter"] = false;
  std::ofstream(dir / "at_default_white.json") << at_default_white.dump(1);
  ASSERT_EQ(run("solve --log " + log + " --model " + ext.string() + " --out " + (dir / "cal_ext.json").string(), dir / "solve_e.txt"), 0);
  ASSERT_EQ(run("solve --log " + log + " --model " + (dir / "at_default.json").string() + " --out " + (dir / "cal_05.json").string(),
                dir / "solve_05.txt"),
            0);
  ASSERT_EQ(run("solve --log " + log + " --model " + (dir / "at_default_white.json").string() + " --out " +
                    (dir / "cal_05w.json").string(),
                dir / "solve_05w.txt"),
            0);
  const json ce = read(dir / "cal_ext.json"), c5 = read(dir / "cal_05.json"), c5w = read(dir / "cal_05w.json");
  EXPECT_DOUBLE_EQ(ce["model"]["hysteresis_threshold_C"].get<double>(), 0.3);
  auto param = [](const json& cal, const std::string& name) {
    for (const auto& p : cal["parameters"])
      if (p["name"] == name) return std::make_pair(p["value"].get<double>(), p["sigma"].get<double>());
    return std::make_pair(std::nan(""), std::nan(""));
  };
  for (const auto& [name, truth] : {std::make_pair(std::string("accel.temp_hysteresis.x"), 3e-3), std::make_pair(std::string("accel.temp_hysteresis.z"), -2e-3)}) {
    const auto [v, sg] = param(ce, name);
    const auto [v5, sg5] = param(c5, name);
    const auto [v5w, sg5w] = param(c5w, name);
    std::printf("%s: %.4e +- %.2e at the emitted threshold, %.4e +- %.2e at 0.5 C (white-noise sigma %.2e; truth %.1e)\n",
                name.c_str(), v, sg, v5, sg5, sg5w, truth);
    EXPECT_NEAR(v, truth, 3.0 * sg) << name;
    EXPECT_DOUBLE_EQ(v5, v5w) << name;
    EXPECT_GT(std::fabs(v5w - truth), 3.0 * sg5w) << name << ": at 0.5 C the 0.4 C reversals are missed (else this shows nothing)";
    // The misfit the wrong threshold leaves moves the dwell means from one to the next: the drift takes it and σ
    // says the estimate is not worth its white-noise precision.
    EXPECT_GT(sg5, 3.0 * sg5w) << name;
  }
  if (!std::getenv("KEEP")) fs::remove_all(dir);
}

// What the emitted model leaves out must be exactly what the fixture solver cannot observe: each left-out
// effect, put back, makes the solve rank-deficient, and the solve of the emitted model succeeds. The
// campaign is campaign-eol's kind (±1 g faces and constant-rate dwells only): there a cubic scale term is
// the scale itself (k3·f³ = g²·f), timing has a zero regressor (u̇ = 0 on a dwell), and both at once make a
// degenerate null space. The size effect is observed on the rate dwells and must be emitted: before this
// test, an eigenvector mixing in that null space flagged it and it was left out (the automotive loop's
// accel residual stayed at 1.35e-2 for a noise of 9.9e-3 m/s²).
TEST(DiagnosisClosedLoop, LeftOutEffectsAreExactlyTheUnobservableOnes) {
  const fs::path dir = fs::temp_directory_path() / ("imuforge-closed-loop-nl-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const json sensor = base_sensor(false, {{"accel.size_effect", {{"x.rx", 0.004}, {"y.ry", 0.006}, {"z.rz", -0.003}}},
                                          {"accel.scale_nonlinearity", {{"x.k2", 2e-4}, {"z.k2", -2e-4}}},
                                          {"accel.timing", {{"latency_s", 0.002}}},
                                          {"gyro.timing", {{"latency_s", 0.002}}}});
  json campaign = rich_campaign({25.0}, 50.0);
  for (auto& ph : campaign["phases"]) {
    json steps = json::array();
    int k = 0;
    bool aligned = false;
    for (const auto& st : ph["steps"]) {
      // The six faces, then the rate blocks whose opening pose has gravity on one body axis; no tilts, no
      // 45° poses (they would separate f³ from f), no sines.
      const bool face = k++ < 6;
      if (st["type"] == "position" && st["dwell_s"] == 1) {
        aligned = true;
        for (const auto& a : st["position_deg"]) aligned = aligned && std::fmod(a.get<double>(), 90.0) == 0.0;
      }
      const bool rate_block = aligned && (st["type"] == "rate" || (st["type"] == "position" && st["dwell_s"] == 1));
      if (face || rate_block) steps.push_back(st);
    }
    ph["steps"] = steps;
  }
  const auto& [simulate_rc, diagnose_rc, log, base, ext, d, selected] = simulate_and_diagnose(dir, campaign, sensor, 11);
  ASSERT_EQ(simulate_rc, 0);
  ASSERT_EQ(diagnose_rc, 0);
  ASSERT_TRUE(selected.count("accel.size_effect")) << d["selected"].dump();
  const json m = read(ext);
  EXPECT_TRUE(m["effects"].contains("accel.size_effect")) << m.dump();
  ASSERT_EQ(run("solve --log " + log + " --model " + ext.string() + " --out " + (dir / "cal_ext.json").string(), dir / "solve_e.txt"), 0);
  int left_out = 0;
  for (const auto& n : m["_diagnosis"]["not_emitted"]) {
    const std::string e = n["effect"];
    ++left_out;
    EXPECT_TRUE(selected.count(e)) << e << " left out but not selected";
    if (n.contains("solve_sigma")) {
      // Observable but not determined (cmd_diagnose.cpp, leave_out_undetermined): no unobservable direction, each
      // component's σ in the solve at or past its plausible limit, and put back the solve still succeeds (it is
      // not rank that left them out) and reports them that loosely.
      EXPECT_TRUE(n["unobservable"].empty()) << n.dump();
      json back = m;
      back.erase("_diagnosis");
      if (n.contains("components_left_out")) {
        ASSERT_TRUE(m["effects"].contains(e)) << e;
        json comps = m["effects"][e]["components"];
        for (const auto& c : n["components_left_out"]) {
          EXPECT_EQ(std::find(comps.begin(), comps.end(), c), comps.end()) << e << "." << c.get<std::string>() << " left out and emitted";
          comps.push_back(c);
        }
        back["effects"][e]["components"] = comps;
      } else {
        EXPECT_FALSE(m["effects"].contains(e)) << e;
        back["effects"][e] = json::object();
      }
      const fs::path p = dir / ("undet_" + e + ".json"), cal = dir / ("cal_undet_" + e + ".json");
      std::ofstream(p) << back.dump(1);
      ASSERT_EQ(run("solve --log " + log + " --model " + p.string() + " --out " + cal.string(), dir / ("solve_undet_" + e + ".txt")), 0) << e;
      const json c = read(cal);
      for (const auto& ss : n["solve_sigma"]) {
        const std::string name = ss["name"];
        EXPECT_GE(ss["sigma"].get<double>(), ss["plausible_limit"].get<double>()) << name;
        double solve_sigma = std::nan("");
        for (const auto& q : c["parameters"])
          if (q["name"] == name) solve_sigma = q["sigma"].get<double>();
        EXPECT_GT(solve_sigma, 0.5 * ss["plausible_limit"].get<double>()) << name << " (NaN: not in the solve)";
      }
      continue;
    }
    EXPECT_FALSE(n["unobservable"].empty()) << e << ": left out without an unobservable direction";
    json back = m;
    back["effects"][e] = json::object();
    back.erase("_diagnosis");
    const fs::path p = dir / ("back_" + e + ".json");
    std::ofstream(p) << back.dump(1);
    const fs::path out = dir / ("solve_" + e + ".txt");
    EXPECT_EQ(run("solve --log " + log + " --model " + p.string() + " --out " + (dir / ("cal_" + e + ".json")).string(), out), 1)
        << e << " was left out, yet the solve with it put back succeeds";
    std::ifstream f(out);
    const std::string txt((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(txt.find("rank-deficient"), std::string::npos) << e << ": " << txt;
    // The reason names the cause: a zero regressor (timing) or the parameters it cannot be told from.
    const std::string why = n["reason"];
    if (e.find(".timing") != std::string::npos) EXPECT_NE(why.find("u-dot = 0"), std::string::npos) << why;
    if (e == "accel.scale_nonlinearity") EXPECT_NE(why.find("accel.scale."), std::string::npos) << why;
    // Only some components unobservable (k3·f³ = g²·f beside k2·f², which the faces observe): the effect is
    // emitted without them, and the solve above observes what is left.
    if (n.contains("components_left_out")) {
      ASSERT_TRUE(m["effects"].contains(e)) << e << ": components left out, yet the effect is gone";
      const json& kept = m["effects"][e]["components"];
      EXPECT_FALSE(kept.empty()) << e;
      for (const auto& c : n["components_left_out"])
        EXPECT_EQ(std::find(kept.begin(), kept.end(), c), kept.end()) << e << "." << c.get<std::string>() << " left out and emitted";
      for (const auto& c : n["components_left_out"])
        EXPECT_NE(n["unobservable"].dump().find(e + "." + c.get<std::string>()), std::string::npos) << c << ": in no direction";
    } else {
      EXPECT_FALSE(m["effects"].contains(e)) << e << " noted as left out, yet emitted";
    }
  }
  EXPECT_GE(left_out, 1) << "the timing effects at least cannot be observed on dwells: " << m["_diagnosis"].dump();
  if (!std::getenv("KEEP")) fs::remove_all(dir);
}

// An effect whose components on one axis were withdrawn (a stand-in there for an out-of-catalog function) is
// emitted without them. The log of DiagnosisPipeline.AFormThatFailsOnOneAxisIsWithdrawnThereOnly, written as a
// file: gyro.z carries a true g-sensitivity in f_x, gyro.y a bias in f_y³ that the g-sensitivity's y
// components would stand in for. Emitted whole, the solve fitted the cubic with them again.
TEST(DiagnosisClosedLoop, ComponentsWithdrawnOnOneAxisAreNotEmitted) {
  const fs::path dir = fs::temp_directory_path() / ("imuforge-closed-loop-trim-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const double g = 9.80665, amp_rad_s = 3e-3;
  imuforge::io::LogMeta meta;
  meta.sample_rate_hz = 100.0;
  meta.accel_lsb_mps2 = 1e-6;
  meta.gyro_lsb_rad_s = 1e-7;
  meta.accel_bits = meta.gyro_bits = 32;
  meta.gravity_mps2 = g;
  const std::string log = (dir / "form.bin").string();
  {
    imuforge::io::LogWriter w(log, meta);
    std::mt19937_64 rng(11);
    std::normal_distribution<double> n01;
    int seg = 0, n = 0;
    for (int pass = 0; pass < 2; ++pass)
      for (int k = 0; k < 24; ++k, ++seg) {
        const double th = (k / 2) * M_PI / 6.0;
        const double f[3] = {k % 2 ? g * std::sin(th) : 0.0, k % 2 ? 0.0 : g * std::sin(th), g * std::cos(th)};
        for (int i = 0; i < 800; ++i, ++n) {
          imuforge::io::LogRow row;
          row.t_s = n / 100.0;
          row.segment = seg;
          row.temp_C = 25.0;
          row.has_ref = true;
          double y[6];
          for (int j = 0; j < 3; ++j) row.f_ref[j] = f[j], y[j] = f[j] + 2e-3 * n01(rng);
          y[3] = 5e-4 * n01(rng);
          y[4] = amp_rad_s * std::pow(f[1] / g, 3) + 5e-4 * n01(rng);
          y[5] = amp_rad_s * f[0] / g + 5e-4 * n01(rng);
          for (int j = 0; j < 6; ++j) row.raw[j] = static_cast<std::int32_t>(std::lround(y[j] / (j < 3 ? meta.accel_lsb_mps2 : meta.gyro_lsb_rad_s)));
          w.write(row);
        }
      }
    w.close();
  }
  // Static poses: the gyro's scale and misalignment are not excited, and the solver refuses a model with them.
  const std::string base = (dir / "model.json").string();
  std::ofstream(base) << json{{"format", "imuforge-model"}, {"version", 1}, {"name", "static"},
                              {"effects", {"accel.bias", "accel.scale", "accel.misalign", "gyro.bias"}}}
                             .dump(1);
  const fs::path ext = dir / "extended.json";
  ASSERT_EQ(run("diagnose --log " + log + " --model " + base + " --out " + (dir / "diag").string() + " --emit-model " + ext.string(),
                dir / "diag.txt"),
            0);
  const json m = read(ext);
  ASSERT_TRUE(m["effects"].contains("gyro.g_sensitivity")) << m.dump(1);
  const json& comps = m["effects"]["gyro.g_sensitivity"]["components"];
  ASSERT_TRUE(comps.is_array()) << "the effect's y components were withdrawn, so not all of it is emitted: " << m.dump(1);
  bool zx = false;
  for (const auto& c : comps) {
    EXPECT_NE(c.get<std::string>()[0], 'y') << c << ": withdrawn on gyro.y, yet emitted";
    zx = zx || c == "zx";
  }
  EXPECT_TRUE(zx) << comps.dump();
  EXPECT_EQ(run("solve --log " + log + " --model " + ext.string() + " --out " + (dir / "cal.json").string(), dir / "solve.txt"), 0);
  if (!std::getenv("KEEP")) fs::remove_all(dir);
}
}  // namespace diagnosis_closed_loop_test
