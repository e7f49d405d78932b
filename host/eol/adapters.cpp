#include "host/eol/adapters.h"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <thread>

#include "host/can/client.h"
#include "host/fixture/fixture.h"
#include "host/model/catalog.h"
#include "host/model/sensor_model.h"
#include "host/table/host_kernel.h"
#include "host/table/table_writer.h"
#include "host/vimu/virtual_imu.h"

namespace imuforge::eol {

namespace {

// ---- fixture -------------------------------------------------------------------------------------
class FixtureBench final : public Bench {
 public:
  explicit FixtureBench(const StationConfig& st) : k_(st.time_scale) {
    if (!st.fixtures.is_object() || !st.fixtures.contains("table") || !st.fixtures.contains("chamber"))
      throw StationError("station: \"fixtures\" needs a \"table\" and a \"chamber\" (docs/eol.md)");
    table_ = fixture::open_rate_table(fixture::fixture_config_from_json(st.fixtures["table"], st.dir));
    chamber_ = fixture::open_chamber(fixture::fixture_config_from_json(st.fixtures["chamber"], st.dir));
    auto notice = [](const std::string& m) { std::fprintf(stderr, "fixture: %s\n", m.c_str()); };
    table_->set_notice_handler(notice);
    chamber_->set_notice_handler(notice);
    axes_ = std::min(3, table_->axes());
  }
  std::string describe() const override { return table_->name() + " + " + chamber_->name(); }
  void set_chamber(double sp, double ramp) override {
    if (chamber_->has_ramp()) chamber_->set_ramp(std::min(ramp, chamber_->config().limits.max_ramp_degC_min));
    chamber_->set_setpoint(sp);
    chamber_->run(true);
  }
  double chamber_air_C() override { return chamber_->status().air_degC; }
  void command_position(const std::array<double, 3>& a) override {
    for (int i = 0; i < axes_; ++i) {
      table_->command_position(i, a[static_cast<std::size_t>(i)]);
      rate_mode_[i] = false;
    }
  }
  void command_rate(const std::array<double, 3>& r) override {
    for (int i = 0; i < axes_; ++i) {
      double v = r[static_cast<std::size_t>(i)];
      if (v != 0.0) {
        table_->command_rate(i, v);
        rate_mode_[i] = true;
      } else if (rate_mode_[i]) {
        table_->stop(i);
        rate_mode_[i] = false;
      }
    }
  }
  TableReading table() override {
    TableReading r;
    r.in_position = r.settled = true;
    for (int i = 0; i < axes_; ++i) {
      fixture::AxisStatus s = table_->status(i);
      r.angle_deg[static_cast<std::size_t>(i)] = s.angle_deg;
      r.rate_dps[static_cast<std::size_t>(i)] = s.rate_deg_s;
      r.in_position = r.in_position && (s.in_position || (rate_mode_[i] && s.settled));
      r.settled = r.settled && s.settled;
      if (s.fault) {
        r.fault = true;
        r.fault_text += "axis " + std::to_string(i) + " fault code " + std::to_string(s.fault_code) + "; ";
      }
    }
    return r;
  }
  double time_s() override {
    double t = table_->fixture_time_s();
    if (std::isfinite(t)) return t;
    // A controller without a clock register: the host's monotonic clock (a real lab runs at scale 1).
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count() * k_;
  }
  void wait(double s) override {
    if (s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(s / k_));
  }

 private:
  double k_;
  int axes_ = 0;
  bool rate_mode_[3] = {false, false, false};
  std::unique_ptr<fixture::RateTable> table_;
  std::unique_ptr<fixture::Chamber> chamber_;
};

// ---- CAN -----------------------------------------------------------------------------------------
class CanDevice final : public Device {
 public:
  explicit CanDevice(const StationConfig& st) : st_(st), k_(st.time_scale) {
    accel_lsb_ = st.accel_lsb_mps2;
    gyro_lsb_ = st.gyro_lsb_rad_s;
    if ((!(accel_lsb_ > 0) || !(gyro_lsb_ > 0)) && !st.sensor_hint.empty()) {
      std::string p = st.sensor_hint[0] == '/' ? st.sensor_hint : st.dir + "/" + st.sensor_hint;
      auto m = model::load_sensor_model(p);
      if (!(accel_lsb_ > 0)) accel_lsb_ = m.triad(model::Sensor::kAccel).lsb;
      if (!(gyro_lsb_ > 0)) gyro_lsb_ = m.triad(model::Sensor::kGyro).lsb;
    }
    if (!(accel_lsb_ > 0) || !(gyro_lsb_ > 0))
      throw StationError("station: the IMU's LSBs are unknown: set \"imu\": {\"accel_lsb_mps2\", \"gyro_lsb_rad_s\"} or \"sensor\"");
    if (st.can_node_id < 1 || st.can_node_id > 127) throw StationError("station: can.node_id must be 1..127");
    client_ = can::Client::connect(st.can_bus, static_cast<std::uint8_t>(st.can_node_id));
  }
  DeviceInfo identify() override {
    can::Identity id = client_->identify();
    serial_ = id.serial;
    DeviceInfo d;
    d.serial = std::to_string(id.serial);
    d.firmware_version = id.fw_version;
    d.accel_lsb_mps2 = accel_lsb_;
    d.gyro_lsb_rad_s = gyro_lsb_;
    d.table_present = id.table_present;
    d.table_crc32 = id.table_crc32;
    d.table_seq = id.table_seq;
    return d;
  }
  double node_rate(double rate_hz) const { return std::clamp(std::round(rate_hz * k_), 1.0, kCanDeviceMaxNodeRateHz); }
  double effective_rate_hz(double rate_hz) override { return node_rate(rate_hz) / k_; }
  StreamStats stream(double rate_hz, const std::function<bool(const ImuSample&)>& cb) override {
    std::mutex mu;
    std::condition_variable cv;
    std::deque<can::StreamSample> q;
    bool overflow = false;
    auto before = client_->stream_counters();
    client_->start_stream(static_cast<std::uint16_t>(node_rate(rate_hz)), proto::kChAll,
                          [&](const can::StreamSample& s) {
                            std::lock_guard<std::mutex> lk(mu);
                            if (q.size() > 200000) overflow = true;
                            else q.push_back(s);
                            cv.notify_one();
                          },
                          st_.can_fd);
    struct Stopper {
      can::Client* c;
      bool on = true;
      ~Stopper() {
        if (on) try { c->stop_stream(); } catch (...) {}
      }
    } stopper{client_.get()};
    for (;;) {
      can::StreamSample s;
      {
        std::unique_lock<std::mutex> lk(mu);
        if (!cv.wait_for(lk, std::chrono::seconds(3), [&] { return !q.empty(); }))
          throw std::runtime_error("CAN stream on " + st_.can_bus + ": no sample for 3 s");
        if (overflow) throw std::runtime_error("CAN stream: the host fell behind (queue overflow)");
        s = q.front();
        q.pop_front();
      }
      ImuSample x;
      x.t_s = static_cast<double>(s.t_us) * 1e-6 * k_;
      x.temp_C = s.temp_cdegC / 100.0;
      for (int j = 0; j < 3; ++j) {
        x.raw[j] = s.accel_counts[j];
        x.raw[3 + j] = s.gyro_counts[j];
      }
      if (!cb(x)) break;
    }
    stopper.on = false;
    client_->stop_stream();
    auto after = client_->stream_counters();
    StreamStats r;
    r.received = after.received - before.received;
    r.lost = after.lost - before.lost;
    r.duplicated = after.duplicated - before.duplicated;
    r.reordered = after.reordered - before.reordered;
    return r;
  }
  void flash_table(const std::vector<std::uint8_t>& blob, std::uint32_t seq) override {
    can::Key key = st_.hmac_key_hex.empty() ? vimu::dev_key_for_serial(serial_) : can::key_from_hex(st_.hmac_key_hex);
    client_->flash_table(blob, seq, key, serial_);
  }
  std::vector<std::uint8_t> read_table() override { return client_->read_table(); }

 private:
  StationConfig st_;
  double k_;
  double accel_lsb_ = 0, gyro_lsb_ = 0;
  std::uint64_t serial_ = 0;
  std::unique_ptr<can::Client> client_;
};

// ---- table + kernel ------------------------------------------------------------------------------
class KernelTableOps final : public TableOps {
 public:
  std::vector<std::uint8_t> build(const solver::Estimate& e, double T_ref_C, const std::vector<double>& bps,
                                  const DeviceInfo& dev, std::uint32_t seq) override {
    table::TableSpec spec;
    try {
      spec.device_serial = std::stoull(dev.serial);
    } catch (const std::exception&) {
      throw std::invalid_argument("table: device serial '" + dev.serial + "' is not a number");
    }
    spec.table_sequence = seq;
    spec.accel_lsb_mps2 = dev.accel_lsb_mps2;
    spec.gyro_lsb_rad_s = dev.gyro_lsb_rad_s;
    spec.accel_raw_bits = dev.accel_raw_bits;
    spec.gyro_raw_bits = dev.gyro_raw_bits;
    spec.kind = table::SpecKind::kSensorModel;
    for (double T : bps) {
      table::BreakpointSpec b;
      b.temp_degC = T;
      const double tau = T - T_ref_C;
      for (std::size_t i = 0; i < e.names.size(); ++i) {
        const double v = e.value[static_cast<Eigen::Index>(i)];
        model::ParamId id = model::find_param(e.names[i]);
        if (id < 0) throw std::invalid_argument("table: unknown parameter " + e.names[i]);
        const model::ParamInfo& p = model::param_info(id);
        const bool acc = p.sensor == model::Sensor::kAccel;
        Eigen::Vector3d& bias = acc ? b.accel_b : b.gyro_b;
        Eigen::Matrix3d& M = acc ? b.accel_M : b.gyro_M;
        const double tp = p.power > 0 ? std::pow(tau, p.power) : 1.0;
        using model::Effect;
        switch (p.effect) {
          case Effect::kBias: bias[p.j] += v; break;
          case Effect::kBiasTemp: bias[p.j] += v * tp; break;
          case Effect::kScale: M(p.j, p.j) += v; break;
          case Effect::kScaleTemp: M(p.j, p.j) += v * tp; break;
          case Effect::kMisalign: M(p.j, p.k) += v; break;
          case Effect::kMisalignTemp: M(p.j, p.k) += v * tp; break;
          case Effect::kGSensitivity:
            if (acc) throw std::invalid_argument("table: g_sensitivity on the accelerometer");
            b.gyro_G_sensor(p.j, p.k) += v;
            break;
          default:
            throw std::invalid_argument("table v1 cannot express " + e.names[i] +
                                        " (bias, scale, misalignment, their temperature terms and gyro g-sensitivity only)");
        }
      }
      spec.breakpoints.push_back(b);
    }
    return table::serialize_table(spec);
  }
  void compensate(const std::vector<std::uint8_t>& bytes, const ImuSample& s, double out[6]) override {
    if (!kernel_ || bytes != cached_) {
      kernel_ = std::make_unique<table::HostKernel>(table::parse_table(bytes, "table read back"), table::KernelPath::kF32);
      cached_ = bytes;
    }
    table::CompensatedSample c = kernel_->run(s.raw, s.temp_C);
    for (int j = 0; j < 3; ++j) {
      out[j] = c.accel_mps2[j];
      out[3 + j] = c.gyro_rad_s[j];
    }
  }

 private:
  std::vector<std::uint8_t> cached_;
  std::unique_ptr<table::HostKernel> kernel_;
};

}  // namespace

std::unique_ptr<Bench> make_fixture_bench(const StationConfig& st) { return std::make_unique<FixtureBench>(st); }
std::unique_ptr<Device> make_can_device(const StationConfig& st) { return std::make_unique<CanDevice>(st); }
std::unique_ptr<TableOps> make_table_ops() { return std::make_unique<KernelTableOps>(); }

}  // namespace imuforge::eol
