#include "host/benchsim/imu_link.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "host/model/measure.h"
#include "host/model/sensor_model.h"

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
  double t0_world = 0.0;
};

ImuSampler::ImuSampler(Bench& bench, const std::string& sensor_path, uint64_t /*seed*/) : impl_(std::make_unique<Impl>()) {
  impl_->bench = &bench;
  if (!sensor_path.empty()) {
    impl_->m = model::load_sensor_model(sensor_path);
    impl_->have_model = true;
    impl_->acc = model::compile(impl_->m, model::Sensor::kAccel);
    impl_->gyr = model::compile(impl_->m, model::Sensor::kGyro);
    impl_->hyst = model::HysteresisTracker(impl_->m.thermal.hysteresis_threshold_C);
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
  hal::ImuRawSample s;
  for (int i = 0; i < 3; ++i) {
    s.accel_counts[i] = to_counts(ya[i], accel_lsb(), abits);
    s.gyro_counts[i] = to_counts(yg[i], gyro_lsb(), gbits);
  }
  s.temp_cdegC = static_cast<int16_t>(std::clamp(std::round(tr.die_C * 100.0), -32768.0, 32767.0));
  return s;
}

#if defined(IMUFORGE_HAVE_VIMU)
namespace {
class VimuLink final : public ImuLink {
 public:
  VimuLink(Bench& bench, const ImuOptions& o) : sampler_(bench, o.sensor_path, o.seed) {
    vimu::VirtualImuConfig cfg;
    cfg.bus = o.bus;
    cfg.serial = o.serial;
    cfg.node_id = static_cast<std::uint8_t>(o.node_id);
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

 private:
  ImuSampler sampler_;
  std::unique_ptr<vimu::VirtualImu> imu_;
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
