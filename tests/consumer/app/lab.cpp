// The lab side of the consumer test (host packages only): a program outside the tree that links the
// installed host libraries. It writes a log with io::LogWriter and reads it back, builds a coefficient
// table from a sensor model with table::build_table, and checks that the firmware kernel undoes the
// model (and that the reference-free reader of the solver accepts the log).
#include <cmath>
#include <cstdio>

#include "firmware/kernel/compensation.h"
#include "host/io/log.h"
#include "host/solver/reference_free.h"
#include "host/table/table_writer.h"

namespace io = imuforge::io;
namespace tb = imuforge::table;
namespace fw = imuforge::fw;

int main() {
  // Sensor model: 0.3 % scale error and 1 mrad misalignment on the accelerometer, 0.05 m/s² bias.
  tb::TableSpec spec;
  spec.device_serial = 42;
  spec.created_unix_s = 1790000000;
  spec.accel_lsb_mps2 = 16.0 * 9.80665 / 32768.0;
  spec.gyro_lsb_rad_s = 2000.0 * M_PI / 180.0 / 32768.0;
  tb::BreakpointSpec bp;
  bp.accel_M << 3e-3, 1e-3, 0, 0, -2e-3, 0, 0, 0, 1e-3;
  bp.accel_b << 0.05, -0.02, 0.01;
  spec.breakpoints.push_back(bp);
  static fw::Table table = tb::parse_table(tb::serialize_table(spec));

  // A count the sensor would emit for f = (0, 0, g): y = b + (I+M) f.
  const Eigen::Vector3d f(0, 0, 9.80665);
  const Eigen::Vector3d y = bp.accel_b + (Eigen::Matrix3d::Identity() + bp.accel_M) * f;
  io::LogMeta meta;
  meta.serial = "lab-42";
  meta.sample_rate_hz = 100;
  meta.accel_lsb_mps2 = spec.accel_lsb_mps2;
  meta.gyro_lsb_rad_s = spec.gyro_lsb_rad_s;
  {
    io::LogWriter w("lab.csv", meta);
    for (int i = 0; i < 200; ++i) {
      io::LogRow r;
      r.t_s = i * 0.01;
      for (int k = 0; k < 3; ++k) r.raw[k] = static_cast<std::int32_t>(std::lround(y[k] / spec.accel_lsb_mps2));
      w.write(r);
    }
    w.close();
  }
  io::LogReader rd("lab.csv");
  const auto rec = imuforge::solver::read_recording(rd);
  if (rec.t_s.size() != 200) {
    std::printf("lab: read %zu rows, expected 200\n", rec.t_s.size());
    return 1;
  }
  rd.rewind();
  io::LogRow row;
  rd.next(row);

  static fw::KernelF32 k;
  fw::kernel_f32_init(&k, 0.0f);
  if (fw::kernel_f32_load(&k, &table) != 0) return 2;
  const fw::RawSample32 raw = {{row.raw[0], row.raw[1], row.raw[2]}, {0, 0, 0}};
  fw::ImuF32 out;
  fw::kernel_f32_run32(&k, &raw, 25.0f, &out);
  double err = 0;
  for (int i = 0; i < 3; ++i) err = std::fmax(err, std::fabs(out.accel_mps2[i] - f[i]));
  // Quantisation of the count (half an LSB, 2.4e-3 m/s²) bounds the error.
  std::printf("lab: compensated (%.5f %.5f %.5f), max error %.2e m/s^2\n", out.accel_mps2[0], out.accel_mps2[1],
              out.accel_mps2[2], err);
  return err < 3e-3 ? 0 : 3;
}
