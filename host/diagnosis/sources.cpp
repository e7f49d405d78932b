#include <limits>
#include "host/diagnosis/sources.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace imuforge::diagnosis {

LogSource::LogSource(const std::string& path) : r_(path) {
  const auto& m = r_.meta();
  if (!(m.accel_lsb_mps2 > 0) || !(m.gyro_lsb_rad_s > 0))
    throw DiagnosisError(path + ": metadata lacks a positive accel/gyro LSB (accel_lsb, gyro_lsb)");
}

bool LogSource::next(Sample& s) {
  io::LogRow row;
  if (!r_.next(row)) return false;
  const auto& m = r_.meta();
  s.t_s = row.t_s;
  s.segment = row.segment;
  s.temp_C = row.temp_C;
  s.has_ref = row.has_ref;
  for (int k = 0; k < 3; ++k) {
    s.f[k] = row.f_ref[k];
    s.w[k] = row.w_ref[k];
    s.y[k] = row.raw[k] * m.accel_lsb_mps2;
    s.y[k + 3] = row.raw[k + 3] * m.gyro_lsb_rad_s;
    s.table_angle_rad[k] = k < m.table_axes ? row.table_angle_rad[k] : std::numeric_limits<double>::quiet_NaN();
  }
  return true;
}

bool PairedSource::next(Sample& s) {
  Sample q;
  const bool a = real_.next(s), b = sim_.next(q);
  if (a != b)
    throw DiagnosisError("--sim log and real log differ in length (one ends at row " + std::to_string(row_) + ")");
  if (!a) return false;
  ++row_;
  if (!s.has_ref && q.has_ref) {
    s.has_ref = true;
    for (int k = 0; k < 3; ++k) {
      s.f[k] = q.f[k];
      s.w[k] = q.w[k];
    }
    s.segment = q.segment;
  }
  if (!std::isfinite(s.temp_C)) s.temp_C = q.temp_C;
  return true;
}

ReferenceFreeSource::ReferenceFreeSource(SampleSource& inner, double g, double window_s, double min_pose_s)
    : inner_(inner), window_s_(window_s) {
  info_.gravity_mps2 = std::isfinite(g) && g > 0 ? g : 9.80665;
  // Pass A: per-window accelerometer and gyro variance and sums.
  struct W {
    double n = 0, s[6] = {}, s2[6] = {};
  };
  std::vector<W> win;
  inner_.rewind();
  Sample s;
  bool first = true;
  while (inner_.next(s)) {
    if (first) {
      t0_ = s.t_s;
      first = false;
    }
    const auto i = static_cast<std::size_t>(std::max(0.0, (s.t_s - t0_) / window_s_));
    if (i >= win.size()) win.resize(i + 1);
    win[i].n += 1;
    for (int a = 0; a < 6; ++a) {
      win[i].s[a] += s.y[a];
      win[i].s2[a] += s.y[a] * s.y[a];
    }
  }
  if (win.empty()) throw DiagnosisError("reference-free: empty log");
  std::vector<double> var(win.size(), 1e300);
  for (std::size_t i = 0; i < win.size(); ++i) {
    if (win[i].n < 5) continue;
    double v = 0;
    for (int a = 0; a < 3; ++a) {
      const double m = win[i].s[a] / win[i].n;
      v += std::max(0.0, win[i].s2[a] / win[i].n - m * m);
    }
    var[i] = v;
  }
  std::vector<double> sorted = var;
  std::sort(sorted.begin(), sorted.end());
  const double thr = 6.0 * sorted[sorted.size() / 4];
  // Static runs of windows; a window next to motion is dropped (hand settling).
  window_pose_.assign(win.size(), -1);
  const std::size_t min_w = static_cast<std::size_t>(std::ceil(min_pose_s / window_s_));
  std::size_t i = 0;
  std::vector<Eigen::Vector3d> means;
  while (i < win.size()) {
    if (!(var[i] < thr)) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < win.size() && var[j] < thr) ++j;
    // [i, j) static; trim one window each side when it is long enough.
    std::size_t a = i, b = j;
    if (b - a >= min_w + 2) {
      if (a > 0) ++a;
      if (b < win.size()) --b;
    }
    if (b - a >= min_w) {
      const int pose = static_cast<int>(means.size());
      Eigen::Vector3d m = Eigen::Vector3d::Zero();
      double n = 0;
      for (std::size_t k = a; k < b; ++k) {
        window_pose_[k] = pose;
        for (int c = 0; c < 3; ++c) m[c] += win[k].s[c];
        n += win[k].n;
      }
      means.push_back(m / n);
      info_.static_s += static_cast<double>(b - a) * window_s_;
    }
    i = j;
  }
  info_.poses = static_cast<int>(means.size());
  if (info_.poses < 1) throw DiagnosisError("reference-free: no static interval detected");
  // Gravity-magnitude calibration, f = T (y − b), T lower triangular (6) + b (3), Gauss-Newton with a
  // numerical Jacobian (9 parameters, a few dozen poses: cost is negligible).
  Eigen::VectorXd p = Eigen::VectorXd::Zero(9);
  p[0] = p[3] = p[5] = 1.0;  // T00, T11, T22 in slots 0,3,5: layout T = [p0 0 0; p1 p3 0; p2 p4 p5]
  auto Tof = [](const Eigen::VectorXd& q) {
    Eigen::Matrix3d T;
    T << q[0], 0, 0, q[1], q[3], 0, q[2], q[4], q[5];
    return T;
  };
  auto resid = [&](const Eigen::VectorXd& q) {
    Eigen::VectorXd r(static_cast<Eigen::Index>(means.size()));
    const Eigen::Matrix3d T = Tof(q);
    const Eigen::Vector3d b(q[6], q[7], q[8]);
    for (std::size_t k = 0; k < means.size(); ++k) r[static_cast<Eigen::Index>(k)] = (T * (means[k] - b)).norm() - info_.gravity_mps2;
    return r;
  };
  info_.accel_rms_before = std::sqrt(resid(p).squaredNorm() / static_cast<double>(means.size()));
  // 9 parameters need clearly more poses than that; with 7..11 poses only bias and the three scales are
  // fitted (the off-diagonal terms stay 0); with fewer the raw directions are used as they are.
  const bool full = means.size() >= 12, diag_only = !full && means.size() >= 7;
  info_.calibrated_params = full ? 9 : diag_only ? 6 : 0;
  if (full || diag_only) {
    for (int it = 0; it < 50; ++it) {
      Eigen::VectorXd r = resid(p);
      Eigen::MatrixXd Jm(r.size(), 9);
      for (int c = 0; c < 9; ++c) {
        if (diag_only && (c == 1 || c == 2 || c == 4)) {
          Jm.col(c).setZero();
          continue;
        }
        Eigen::VectorXd q = p;
        const double h = 1e-7 * std::max(1.0, std::fabs(p[c]));
        q[c] += h;
        Jm.col(c) = (resid(q) - r) / h;
      }
      Eigen::VectorXd dp = (Jm.transpose() * Jm + 1e-9 * Eigen::MatrixXd::Identity(9, 9)).ldlt().solve(-Jm.transpose() * r);
      p += dp;
      if (dp.norm() < 1e-12) break;
    }
  } else {
    // Too few poses for 9 parameters: bias only plus a common scale would still be underdetermined
    // in general; keep the identity (the diagnosis then refits bias/scale/misalign linearly).
  }
  info_.accel_rms_after = std::sqrt(resid(p).squaredNorm() / static_cast<double>(means.size()));
  const Eigen::Matrix3d T = Tof(p);
  const Eigen::Vector3d b(p[6], p[7], p[8]);
  for (const auto& m : means) {
    Eigen::Vector3d d = T * (m - b);
    d *= info_.gravity_mps2 / d.norm();
    dir_.push_back({d[0], d[1], d[2]});
  }
}

void ReferenceFreeSource::rewind() { inner_.rewind(); }

bool ReferenceFreeSource::next(Sample& s) {
  if (!inner_.next(s)) return false;
  const auto i = static_cast<std::size_t>(std::max(0.0, (s.t_s - t0_) / window_s_));
  const int pose = i < window_pose_.size() ? window_pose_[i] : -1;
  if (pose < 0) {
    s.has_ref = false;
    s.segment = -1;
    return true;
  }
  s.has_ref = true;
  s.segment = pose;
  for (int k = 0; k < 3; ++k) {
    s.f[k] = dir_[static_cast<std::size_t>(pose)][static_cast<std::size_t>(k)];
    s.w[k] = 0.0;
  }
  return true;
}

}  // namespace imuforge::diagnosis
