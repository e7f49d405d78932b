#include "host/poses/recording.h"

#include <cmath>

#include "host/physics/earth.h"

namespace imuforge::poses {

namespace {

Recording start(const io::LogMeta& m, const std::string& what) {
  Recording rec;
  if (!(m.accel_lsb_mps2 > 0) || !(m.gyro_lsb_rad_s > 0))
    throw PoseError(what + " lacks positive accel_lsb/gyro_lsb metadata");
  if (std::isfinite(m.gravity_mps2) && m.gravity_mps2 > 0) {
    rec.gravity_mps2 = m.gravity_mps2;
    rec.gravity_source = "log metadata";
  } else if (std::isfinite(m.latitude_deg)) {
    physics::Site s;
    s.latitude_deg = m.latitude_deg;
    s.height_m = std::isfinite(m.height_m) ? m.height_m : 0.0;
    rec.gravity_mps2 = physics::normal_gravity_mps2(s);
    rec.gravity_source = "normal gravity at the log's latitude/height";
  } else {
    rec.gravity_mps2 = 9.80665;
    rec.gravity_source = "standard gravity (the log has no gravity or site)";
  }
  rec.accel_lsb = m.accel_lsb_mps2;
  rec.gyro_lsb = m.gyro_lsb_rad_s;
  rec.accel_bits = m.accel_bits;
  rec.gyro_bits = m.gyro_bits;
  return rec;
}

void append(Recording& rec, const io::LogMeta& m, const io::LogRow& row) {
    rec.t_s.push_back(row.t_s);
    std::array<double, 6> y;
    for (int c = 0; c < 6; ++c) y[static_cast<size_t>(c)] = row.raw[c] * (c < 3 ? m.accel_lsb_mps2 : m.gyro_lsb_rad_s);
    rec.y.push_back(y);
    bool ca = false, cg = false;
    for (int c = 0; c < 3; ++c) {
      ca = ca || io::raw_clipped(row.raw[c], m.accel_bits);
      cg = cg || io::raw_clipped(row.raw[c + 3], m.gyro_bits);
    }
    rec.gyro_clipped.push_back(cg);
    rec.accel_clipped.push_back(ca);
    rec.clipped_samples += cg ? 1 : 0;
    rec.accel_clipped_samples += ca ? 1 : 0;
}

void finish(Recording& rec, const io::LogMeta& m, const std::string& what) {
  if (rec.t_s.size() < 10) throw PoseError(what + " has too few samples for static-pose detection");
  for (size_t i = 1; i < rec.t_s.size(); ++i)
    if (!(rec.t_s[i] > rec.t_s[i - 1]))
      throw PoseError(what + ": time does not increase at row " + std::to_string(i));
  rec.rate_hz = m.sample_rate_hz > 0 ? m.sample_rate_hz
                                     : static_cast<double>(rec.t_s.size() - 1) / (rec.t_s.back() - rec.t_s.front());
}

}  // namespace

Recording read_recording(io::LogReader& log) {
  const std::string what = "log '" + log.path() + "'";
  Recording rec = start(log.meta(), what);
  io::LogRow row;
  while (log.next(row)) append(rec, log.meta(), row);
  finish(rec, log.meta(), what);
  return rec;
}

Recording recording_from_rows(const io::LogMeta& meta, const std::vector<io::LogRow>& rows, const std::string& what) {
  Recording rec = start(meta, what);
  for (const io::LogRow& r : rows) append(rec, meta, r);
  finish(rec, meta, what);
  return rec;
}

}  // namespace imuforge::poses
