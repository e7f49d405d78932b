#include "host/benchsim/imu_link.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "host/model/measure.h"
#include "host/model/sensor_model.h"
#include "host/sim/noise.h"

#if defined(IMUFORGE_HAVE_VIMU)
#include "host/vimu/virtual_imu.h"
#endif

namespace imuforge::benchsim {

namespace {
// Ideal sensor without a model: +-16 g and +-2000 deg/s full scale on 16 bits.
constexpr double kDefaultAccelLsb = 16.0 * 9.80665 / 32768.0;
constexpr double kDefaultGyroLsb = 2000.0 * 3.14159265358979323846 / 180.0 / 32768.0;

int16_t to_counts(double y, double lsb, int bits) {
  const double hi = std::ldexp(1.0, std::min(bits, 16) - 1) - 1.0, lo = -hi - 1.0;
  const double c = std::round(y / lsb);
  return static_cast<int16_t>(std::clamp(std::isfinite(c) ? c : 0.0, lo, hi));
}
}  // namespace

struct ImuSampler::Impl {
  Bench* bench = nullptr;
  bool have_model = false;
  model::SensorModel m;
  model::CompiledTriad acc, gyr;
  model::HysteresisTracker hyst;
  // Stochastic part, realised with the simulator's processes (host/sim/noise.h), one stream per channel.
  sim::AxisNoise noise[6];
  sim::Rng rng[6];
  double turn_on[6] = {};
  double q[6] = {}, sat[6] = {};
  Eigen::Matrix3d nest = Eigen::Matrix3d::Identity();  // Exp([e×]) of the nest error
};

namespace {
// Nominal sample interval for the noise discretisation: the virtual IMU's 1 kHz sample clock.
constexpr double kNoiseDt_s = 0.001;
}  // namespace

ImuSampler::ImuSampler(Bench& bench, const std::string& sensor_path, uint64_t seed, const Eigen::Vector3d& nest_error_rad)
    : impl_(std::make_unique<Impl>()) {
  impl_->bench = &bench;
  if (nest_error_rad.norm() > 0)
    impl_->nest = Eigen::AngleAxisd(nest_error_rad.norm(), nest_error_rad.normalized()).toRotationMatrix();
  if (!sensor_path.empty()) {
    impl_->m = model::load_sensor_model(sensor_path);
    impl_->have_model = true;
    impl_->acc = model::compile(impl_->m, model::Sensor::kAccel);
    impl_->gyr = model::compile(impl_->m, model::Sensor::kGyro);
    impl_->hyst = model::HysteresisTracker(impl_->m.thermal.hysteresis_threshold_C);
    const model::ParamSet P = impl_->m.effective_params();
    sim::Rng rng_turn_on(seed * 0x9E3779B97F4A7C15ULL + 1);
    for (int si = 0; si < 2; ++si) {
      const auto sn = static_cast<model::Sensor>(si);
      const auto wn = model::effect_params(sn, model::Effect::kWhiteNoise);
      const auto bi = model::effect_params(sn, model::Effect::kBiasInstability);
      const auto rw = model::effect_params(sn, model::Effect::kRateRandomWalk);
      const auto tb = model::effect_params(sn, model::Effect::kTurnOnBias);
      const auto qz = model::effect_params(sn, model::Effect::kQuantization);
      const auto st = model::effect_params(sn, model::Effect::kSaturation);
      for (size_t j = 0; j < 3; ++j) {
        const int ch = 3 * si + static_cast<int>(j);
        impl_->rng[ch].seed(seed * 0x9E3779B97F4A7C15ULL + 11 + static_cast<uint64_t>(ch));
        impl_->noise[ch].configure(P[wn[j]], P[bi[j]], P[bi[3]], P[rw[j]], kNoiseDt_s, impl_->rng[ch]);
        impl_->turn_on[ch] = P[tb[j]] * rng_turn_on.normal();
        impl_->q[ch] = P[qz[j]];
        impl_->sat[ch] = P[st[j]];
      }
    }
  }
}

ImuSampler::~ImuSampler() = default;

double ImuSampler::accel_lsb() const {
  return impl_->have_model && impl_->m.triad(model::Sensor::kAccel).lsb > 0 ? impl_->m.triad(model::Sensor::kAccel).lsb
                                                                            : kDefaultAccelLsb;
}
double ImuSampler::gyro_lsb() const {
  return impl_->have_model && impl_->m.triad(model::Sensor::kGyro).lsb > 0 ? impl_->m.triad(model::Sensor::kGyro).lsb
                                                                           : kDefaultGyroLsb;
}

hal::ImuRawSample ImuSampler::sample(double t_s) {
  ImuTruth tr;
  {
    std::lock_guard<std::mutex> lock(impl_->bench->mutex());
    impl_->bench->world().advance_to(t_s);
    tr = impl_->bench->world().imu_truth();
  }
  tr.f_mps2 = impl_->nest * tr.f_mps2;
  tr.w_rad_s = impl_->nest * tr.w_rad_s;
  tr.wdot_rad_s2 = impl_->nest * tr.wdot_rad_s2;
  Eigen::Vector3d ya = tr.f_mps2, yg = tr.w_rad_s;
  int abits = 16, gbits = 16;
  if (impl_->have_model) {
    model::MeasureInput in;
    in.f = tr.f_mps2;
    in.w = tr.w_rad_s;
    in.wdot = tr.wdot_rad_s2;
    in.T_C = tr.die_C;
    in.Tdot_C_s = tr.die_rate_C_s;
    in.d = impl_->hyst.update(tr.die_C);
    in.t_s = tr.t_s;
    ya = model::measure(impl_->acc, in);
    yg = model::measure(impl_->gyr, in);
    abits = impl_->m.triad(model::Sensor::kAccel).bits;
    gbits = impl_->m.triad(model::Sensor::kGyro).bits;
  }
  if (impl_->have_model) {
    // Noise, turn-on bias, quantization step and saturation, in the simulator's order.
    for (int ch = 0; ch < 6; ++ch) {
      double& y = ch < 3 ? ya[ch] : yg[ch - 3];
      y += impl_->turn_on[ch] + impl_->noise[ch].step(impl_->rng[ch]);
      if (impl_->q[ch] > 0) y = impl_->q[ch] * std::round(y / impl_->q[ch]);
      if (impl_->sat[ch] > 0) y = std::clamp(y, -impl_->sat[ch], impl_->sat[ch]);
    }
  }
  hal::ImuRawSample s;
  for (int i = 0; i < 3; ++i) {
    s.accel_counts[i] = to_counts(ya[i], accel_lsb(), abits);
    s.gyro_counts[i] = to_counts(yg[i], gyro_lsb(), gbits);
  }
  s.temp_cdegC = static_cast<int16_t>(std::clamp(std::round(tr.die_C * 100.0), -32768.0, 32767.0));
  return s;
}

std::vector<ImuOptions> slot_imus(const SlotPlan& p) {
  if (p.buses.empty()) throw std::invalid_argument("bench-sim slots: no CAN bus");
  if (p.slots < 1) throw std::invalid_argument("bench-sim slots: --slots must be >= 1");
  if (p.first_node + p.slots - 1 > 127)
    throw std::invalid_argument("bench-sim slots: node ids " + std::to_string(p.first_node) + ".." +
                                std::to_string(p.first_node + p.slots - 1) + " go beyond 127");
  std::vector<ImuOptions> out;
  for (int k = 0; k < p.slots; ++k) {
    if (std::find(p.dead.begin(), p.dead.end(), k + 1) != p.dead.end()) continue;
    ImuOptions o;
    o.bus = p.buses[static_cast<std::size_t>(k) % p.buses.size()];
    const bool odd = std::find(p.outlier.begin(), p.outlier.end(), k + 1) != p.outlier.end();
    if (odd && p.outlier_sensor_path.empty()) throw std::invalid_argument("bench-sim slots: --outlier-slot needs --outlier-sensor");
    o.sensor_path = odd ? p.outlier_sensor_path : p.sensor_path;
    o.seed = p.seed + static_cast<uint64_t>(k);
    o.serial = p.first_serial + static_cast<uint64_t>(k);
    o.node_id = p.first_node + k;
    sim::Rng rng(o.seed * 0x9E3779B97F4A7C15ULL + 7);
    for (int i = 0; i < 3; ++i) o.nest_error_rad[i] = p.nest_sigma_rad * rng.normal();
    out.push_back(o);
  }
  return out;
}

#if defined(IMUFORGE_HAVE_VIMU)
namespace {
class VimuLink final : public ImuLink {
 public:
  VimuLink(Bench& bench, const ImuOptions& o) : sampler_(bench, o.sensor_path, o.seed, o.nest_error_rad) {
    vimu::VirtualImuConfig cfg;
    cfg.bus = o.bus;
    cfg.serial = o.serial;
    cfg.node_id = static_cast<std::uint8_t>(o.node_id);
    node_ = o.node_id;
    // The node's clock starts at 0 when it starts; the world may already be running. Node time is
    // wall time, so it is scaled into simulated time here.
    const double t0 = bench.now_s();
    const double k = bench.time_scale();
    cfg.truth = [this, t0, k](double t_node_s) { return sampler_.sample(t0 + k * t_node_s); };
    imu_ = std::make_unique<vimu::VirtualImu>(cfg);
    imu_->start();
  }
  ~VimuLink() override { stop(); }
  void stop() override {
    if (imu_) imu_->stop();
  }
  std::string summary() const override {
    const fw::NodeCounters k = imu_->counters();
    return "node " + std::to_string(node_) + ": samples_sent " + std::to_string(k.samples_sent) + ", stream_frames_tx " +
           std::to_string(k.stream_frames_tx) + ", stream_frames_dropped " + std::to_string(k.stream_frames_dropped) +
           ", fifo_overflow " + std::to_string(k.samples_fifo_overflow) + ", bus_tx_dropped " +
           std::to_string(imu_->bus_tx_dropped());
  }

 private:
  ImuSampler sampler_;
  std::unique_ptr<vimu::VirtualImu> imu_;
  int node_ = 0;
};
}  // namespace

std::unique_ptr<ImuLink> start_imu(Bench& bench, const ImuOptions& opt) {
  return std::make_unique<VimuLink>(bench, opt);
}
#else
std::unique_ptr<ImuLink> start_imu(Bench&, const ImuOptions& opt) {
  throw std::runtime_error("this build has no virtual IMU (host/vimu is missing), cannot serve " + opt.bus);
}
#endif

}  // namespace imuforge::benchsim
