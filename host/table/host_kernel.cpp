#include "host/table/host_kernel.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "host/table/table_writer.h"

namespace imuforge::table {

namespace {
std::int32_t temp_to_q16(double temp_degC) {
  if (std::isnan(temp_degC)) return std::numeric_limits<std::int32_t>::min();  // below range: clamped + flagged
  const double q = std::round(temp_degC * 65536.0);
  if (q >= 2147483647.0) return std::numeric_limits<std::int32_t>::max();
  if (q <= -2147483648.0) return std::numeric_limits<std::int32_t>::min();
  return static_cast<std::int32_t>(q);
}
}  // namespace

HostKernel::HostKernel(const fw::Table& table, KernelPath path, double step_degC)
    : table_(std::make_unique<fw::Table>(table)), path_(path) {
  if (!(step_degC >= 0.0) || step_degC > 1000.0) throw TableError("re-interpolation step must be in [0, 1000] degC", 0);
  int rc;
  if (path == KernelPath::kF32) {
    kf_ = std::make_unique<fw::KernelF32>();
    fw::kernel_f32_init(kf_.get(), static_cast<float>(step_degC));
    rc = fw::kernel_f32_load(kf_.get(), table_.get());
  } else {
    kq_ = std::make_unique<fw::KernelQ>();
    fw::kernel_q_init(kq_.get(), static_cast<std::int32_t>(std::lround(step_degC * 65536.0)));
    rc = fw::kernel_q_load(kq_.get(), table_.get());
  }
  if (rc != 0)
    throw TableError(std::string("kernel refused the table: ") + fw::kernel_strerror(rc) + " (code " +
                         std::to_string(rc) + ")",
                     rc);
}

CompensatedSample HostKernel::run(const std::int32_t raw[6], double temp_degC) {
  fw::RawSample32 r;
  for (int k = 0; k < 3; ++k) {
    r.accel[k] = raw[k];
    r.gyro[k] = raw[3 + k];
  }
  CompensatedSample s{};
  if (path_ == KernelPath::kF32) {
    fw::ImuF32 o;
    s.status = fw::kernel_f32_run32(kf_.get(), &r, static_cast<float>(temp_degC), &o);
    for (int k = 0; k < 3; ++k) {
      s.accel_mps2[k] = static_cast<double>(o.accel_mps2[k]);
      s.gyro_rad_s[k] = static_cast<double>(o.gyro_rad_s[k]);
    }
  } else {
    fw::ImuQ o;
    s.status = fw::kernel_q_run32(kq_.get(), &r, temp_to_q16(temp_degC), &o);
    for (int k = 0; k < 3; ++k) {
      s.accel_mps2[k] = std::ldexp(static_cast<double>(o.accel[k]), -fw::kQAccelFracBits);
      s.gyro_rad_s[k] = std::ldexp(static_cast<double>(o.gyro[k]), -fw::kQGyroFracBits);
    }
  }
  return s;
}

CompensateSummary compensate_log(const fw::Table& table, KernelPath path, double step_degC, const std::string& in_path,
                                 const std::string& out_path, double temp_override_degC) {
  io::LogReader in(in_path);
  const io::LogMeta& meta = in.meta();
  auto lsb_mismatch = [](double log_lsb, float table_lsb) {
    return log_lsb > 0.0 && std::abs(log_lsb - static_cast<double>(table_lsb)) > 1e-6 * log_lsb;
  };
  if (lsb_mismatch(meta.accel_lsb_mps2, table.accel_lsb_mps2) || lsb_mismatch(meta.gyro_lsb_rad_s, table.gyro_lsb_rad_s)) {
    char msg[256];
    std::snprintf(msg, sizeof msg,
                  "%s: LSB of the log (accel %.9g m/s^2, gyro %.9g rad/s) differs from the table's (%.9g, %.9g): "
                  "the table is for another sensor configuration",
                  in_path.c_str(), meta.accel_lsb_mps2, meta.gyro_lsb_rad_s, static_cast<double>(table.accel_lsb_mps2),
                  static_cast<double>(table.gyro_lsb_rad_s));
    throw std::runtime_error(msg);
  }
  HostKernel kernel(table, path, step_degC);
  std::FILE* out = std::fopen(out_path.c_str(), "w");
  if (!out) throw std::runtime_error(out_path + ": cannot open for writing: " + std::strerror(errno));
  std::fprintf(out, "# imuforge compensate: kernel path %s, table serial %llu sequence %u, step %g degC\n",
               path == KernelPath::kF32 ? "f32" : "fixed", static_cast<unsigned long long>(table.device_serial),
               static_cast<unsigned>(table.table_sequence), step_degC);
  std::fprintf(out, "t_s,segment,temp_C,ax_mps2,ay_mps2,az_mps2,gx_rad_s,gy_rad_s,gz_rad_s,status\n");
  CompensateSummary sum;
  io::LogRow row;
  while (in.next(row)) {
    const double T = std::isfinite(temp_override_degC) ? temp_override_degC : row.temp_C;
    const CompensatedSample s = kernel.run(row.raw, T);
    std::fprintf(out, "%.9g,%d,%.6g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%u\n", row.t_s, static_cast<int>(row.segment), T,
                 s.accel_mps2[0], s.accel_mps2[1], s.accel_mps2[2], s.gyro_rad_s[0], s.gyro_rad_s[1], s.gyro_rad_s[2],
                 static_cast<unsigned>(s.status));
    ++sum.rows;
    if (s.status & fw::kStatusTempClamped) ++sum.temp_clamped;
    if (s.status & fw::kStatusAccelSaturated) ++sum.accel_saturated;
    if (s.status & fw::kStatusGyroSaturated) ++sum.gyro_saturated;
  }
  const bool err = std::ferror(out) != 0;
  if (std::fclose(out) != 0 || err) throw std::runtime_error(out_path + ": write failed");
  return sum;
}

}  // namespace imuforge::table
