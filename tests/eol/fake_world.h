// Test doubles for the runner's ports: a small deterministic lab in one process. The physics is kept
// simple on purpose (first-order chamber and die, instant-ish table moves) but the sensor output comes
// from the catalog's own measurement equation (host/model/measure.h) with seeded white noise, so the
// runner's estimate can be checked against known true parameters.
#pragma once
#include <cmath>
#include <random>
#include <sstream>

#include "host/eol/ports.h"
#include "host/model/measure.h"
#include "host/model/sensor_model.h"
#include "host/physics/earth.h"
#include "host/physics/table.h"

namespace imuforge::eoltest {

using namespace imuforge::eol;

// The lab's physical state, as plain data: a test that kills the host process can keep it in shared
// memory so that the lab runs on across the crash, as a real one does (tests/eol/test_crash.cpp).
struct LabState {
  bool valid = false;
  double t, setpoint, slewed, ramp, air, die, ready_t;
  std::array<double, 3> ang, rate;
  std::uint32_t flashed_len;
  std::uint8_t flashed[16384];
};

struct FakeWorld {
  double t = 0;
  // chamber + die
  double setpoint = 25, slewed = 25, ramp = 3, air = 25, die = 25;
  double tau_air = 60, tau_die = 40, self_heat = 0.8;
  // table (2 axes: inner z, outer x)
  std::array<double, 3> ang{}, rate{}, target{};
  double ready_t = 0;
  bool rate_mode = false;
  // sensor
  model::SensorModel sensor;
  model::CompiledTriad ca, cg;
  double noise_a = 2e-3, noise_g = 2e-4;
  std::mt19937_64 rng{42};
  // When set, every stream starts from a seed made of the pose, the table rate and the chamber setpoint:
  // a segment collected again (after a crash) sees the same noise, so a resumed run can be compared with
  // an uninterrupted one far below σ (tests/eol/test_crash.cpp).
  bool noise_per_stream = false;
  LabState* persist = nullptr;  // when set: restored from at start (if valid), saved after every step
  void save(LabState& s) const {
    s.t = t, s.setpoint = setpoint, s.slewed = slewed, s.ramp = ramp, s.air = air, s.die = die, s.ready_t = ready_t;
    s.ang = ang, s.rate = rate;
    s.flashed_len = static_cast<std::uint32_t>(std::min(flashed.size(), sizeof s.flashed));
    std::copy_n(flashed.begin(), s.flashed_len, s.flashed);
    s.valid = true;
  }
  void restore(const LabState& s) {
    t = s.t, setpoint = s.setpoint, slewed = s.slewed, ramp = s.ramp, air = s.air, die = s.die, ready_t = s.ready_t;
    ang = s.ang, rate = s.rate;
    flashed.assign(s.flashed, s.flashed + s.flashed_len);
  }
  std::uint64_t stream_seed() const {
    std::uint64_t h = 1469598103934665603ull;
    auto mix = [&h](double v) {
      const auto q = static_cast<std::int64_t>(std::llround(v * 1000.0));
      h = (h ^ static_cast<std::uint64_t>(q)) * 1099511628211ull;
    };
    const bool turning = rate != std::array<double, 3>{};
    for (int i = 0; i < 3; ++i) {
      if (!turning) mix(ang[static_cast<std::size_t>(i)]);  // a turning table's angle depends on when
      mix(rate[static_cast<std::size_t>(i)]);
    }
    mix(setpoint);
    return h;
  }
  physics::TableGeometry geom;
  Eigen::Vector3d g_ned, wie_ned;
  std::vector<std::uint8_t> flashed;
  std::uint64_t samples = 0;

  FakeWorld() {
    sensor.T_ref_C = 25;
    sensor.out[0].lsb = 1e-4;
    sensor.out[0].bits = 24;
    sensor.out[1].lsb = 1e-6;
    sensor.out[1].bits = 24;
    auto on = [&](model::Sensor s, model::Effect e) { sensor.enabled[static_cast<int>(s)][static_cast<int>(e)] = true; };
    using model::Effect;
    using model::Sensor;
    for (auto s : {Sensor::kAccel, Sensor::kGyro})
      for (auto e : {Effect::kBias, Effect::kScale, Effect::kMisalign, Effect::kBiasTemp}) on(s, e);
    sensor.params.set("accel.bias.x", 0.05);
    sensor.params.set("accel.bias.y", -0.03);
    sensor.params.set("accel.bias.z", 0.02);
    sensor.params.set("accel.scale.x", 1e-3);
    sensor.params.set("accel.scale.y", -2e-3);
    sensor.params.set("accel.scale.z", 5e-4);
    sensor.params.set("accel.misalign.xy", 1e-3);
    sensor.params.set("accel.misalign.zx", -5e-4);
    sensor.params.set("accel.bias_temp.x.t1", 2e-4);
    sensor.params.set("accel.bias_temp.z.t1", -1e-4);
    sensor.params.set("gyro.bias.x", 2e-3);
    sensor.params.set("gyro.bias.y", -1e-3);
    sensor.params.set("gyro.bias.z", 5e-4);
    sensor.params.set("gyro.scale.x", 2e-3);
    sensor.params.set("gyro.scale.z", -1e-3);
    sensor.params.set("gyro.misalign.yz", 8e-4);
    sensor.params.set("gyro.bias_temp.y.t1", 2e-5);
    ca = model::compile(sensor, model::Sensor::kAccel);
    cg = model::compile(sensor, model::Sensor::kGyro);
    geom.n_axes = 2;
    geom.axes[0].axis_nominal = Eigen::Vector3d::UnitZ();
    geom.axes[1].axis_nominal = Eigen::Vector3d::UnitX();
    physics::Site site{45, 0};
    g_ned = physics::gravity_ned(site);
    wie_ned = physics::earth_rate_ned(site);
  }

  void step(double dt) {
    // Sub-steps keep the first-order models stable for long waits.
    int n = std::max(1, static_cast<int>(std::ceil(dt / 0.5)));
    double h = dt / n;
    for (int i = 0; i < n; ++i) {
      double max_step = ramp / 60.0 * h;
      slewed += std::clamp(setpoint - slewed, -max_step, max_step);
      air += (slewed - air) * h / tau_air;
      die += (air + self_heat - die) * h / tau_die;
    }
    for (int i = 0; i < 3; ++i) ang[static_cast<std::size_t>(i)] += rate[static_cast<std::size_t>(i)] * dt;
    t += dt;
    if (persist != nullptr) save(*persist);
  }

  ImuSample sample() {
    physics::TableState ts;
    for (int i = 0; i < 3; ++i) {
      ts.angle_rad[static_cast<std::size_t>(i)] = ang[static_cast<std::size_t>(i)] * M_PI / 180;
      ts.rate_rad_s[static_cast<std::size_t>(i)] = rate[static_cast<std::size_t>(i)] * M_PI / 180;
    }
    auto k = physics::table_kinematics(geom, ts, g_ned, wie_ned);
    model::MeasureInput in;
    in.f = k.f_mps2;
    in.w = k.w_rad_s;
    in.T_C = die;
    Eigen::Vector3d ya = model::measure(ca, in), yg = model::measure(cg, in);
    std::normal_distribution<double> na(0, noise_a), ng(0, noise_g);
    ImuSample s;
    s.t_s = t;
    s.temp_C = std::round(die * 100) / 100;
    for (int j = 0; j < 3; ++j) {
      s.raw[j] = static_cast<std::int32_t>(std::lround((ya[j] + na(rng)) / sensor.out[0].lsb));
      s.raw[3 + j] = static_cast<std::int32_t>(std::lround((yg[j] + ng(rng)) / sensor.out[1].lsb));
    }
    ++samples;
    return s;
  }
};

class FakeBench : public Bench {
 public:
  explicit FakeBench(FakeWorld& w) : w_(w) {}
  std::string describe() const override { return "fake-table + fake-chamber"; }
  void set_chamber(double sp, double ramp) override {
    w_.setpoint = sp;
    w_.ramp = ramp;
  }
  double chamber_air_C() override { return w_.air; }
  void command_position(const std::array<double, 3>& a) override {
    double d = 0;
    for (int i = 0; i < 3; ++i)
      d = std::max(d, std::fabs(std::remainder(a[static_cast<std::size_t>(i)] - w_.ang[static_cast<std::size_t>(i)], 360.0)));
    w_.rate = {0, 0, 0};
    w_.ang = a;  // the move happens during the wait below
    w_.ready_t = w_.t + d / 60.0 + 1.0;
  }
  void command_rate(const std::array<double, 3>& r) override {
    bool same = r == w_.rate;
    w_.rate = r;
    if (!same) w_.ready_t = w_.t + 2.0;
  }
  TableReading table() override {
    TableReading r;
    r.angle_deg = w_.ang;
    r.rate_dps = w_.rate;
    r.in_position = r.settled = w_.t >= w_.ready_t;
    return r;
  }
  double time_s() override { return w_.t; }
  void wait(double s) override { w_.step(s); }

 private:
  FakeWorld& w_;
};

class FakeDevice : public Device {
 public:
  FakeDevice(FakeWorld& w, std::string serial) : w_(w), serial_(std::move(serial)) {}
  DeviceInfo identify() override {
    DeviceInfo d;
    d.serial = serial_;
    d.firmware_version = "fake-fw 1";
    d.accel_lsb_mps2 = w_.sensor.out[0].lsb;
    d.gyro_lsb_rad_s = w_.sensor.out[1].lsb;
    d.accel_raw_bits = w_.sensor.out[0].bits;
    d.gyro_raw_bits = w_.sensor.out[1].bits;
    d.table_present = !w_.flashed.empty();
    return d;
  }
  StreamStats stream(double rate_hz, const std::function<bool(const ImuSample&)>& cb) override {
    StreamStats st;
    if (w_.noise_per_stream) w_.rng.seed(w_.stream_seed());
    for (;;) {
      w_.step(1.0 / rate_hz);
      ++st.received;
      if (!cb(w_.sample())) return st;
    }
  }
  void flash_table(const std::vector<std::uint8_t>& b, std::uint32_t) override {
    w_.flashed = b;
    if (w_.persist != nullptr) w_.save(*w_.persist);
  }
  std::vector<std::uint8_t> read_table() override { return w_.flashed; }

 private:
  FakeWorld& w_;
  std::string serial_;
};

// A stand-in table: the estimate as text; compensation subtracts the model's J·θ evaluated at the
// measured output (first-order inverse, enough for a verification test).
class FakeTableOps : public TableOps {
 public:
  std::vector<std::uint8_t> build(const solver::Estimate& e, double T_ref_C, const std::vector<double>&,
                                  const DeviceInfo&, std::uint32_t) override {
    std::ostringstream o;
    o.precision(17);
    o << T_ref_C << "\n";
    for (std::size_t i = 0; i < e.names.size(); ++i) o << e.names[i] << " " << e.value[static_cast<Eigen::Index>(i)] << "\n";
    std::string s = o.str();
    return std::vector<std::uint8_t>(s.begin(), s.end());
  }
  void compensate(const std::vector<std::uint8_t>& table, const ImuSample& s, double out[6]) override {
    std::istringstream in(std::string(table.begin(), table.end()));
    double tref;
    in >> tref;
    std::vector<model::ParamId> ids;
    std::vector<double> v;
    std::string n;
    double x;
    while (in >> n >> x) {
      ids.push_back(model::find_param(n));
      v.push_back(x);
    }
    model::MeasureInput mi;
    for (int j = 0; j < 3; ++j) {
      mi.f[j] = s.raw[j] * 1e-4;
      mi.w[j] = s.raw[3 + j] * 1e-6;
    }
    mi.T_C = s.temp_C;
    Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, static_cast<Eigen::Index>(ids.size()));
    Eigen::Map<Eigen::VectorXd> th(v.data(), static_cast<Eigen::Index>(v.size()));
    model::regressors(model::Sensor::kAccel, ids, mi, tref, J);
    Eigen::Vector3d ca = mi.f - J * th;
    model::regressors(model::Sensor::kGyro, ids, mi, tref, J);
    Eigen::Vector3d cg = mi.w - J * th;
    for (int j = 0; j < 3; ++j) {
      out[j] = ca[j];
      out[3 + j] = cg[j];
    }
  }
};

}  // namespace imuforge::eoltest
