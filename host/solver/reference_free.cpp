#include "host/solver/reference_free.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <Eigen/Geometry>

#include "host/model/catalog.h"
#include "host/physics/earth.h"

namespace imuforge::solver {

namespace {

// Least squares on a residual function e(θ) with a central-difference Jacobian: the reference-free
// residuals (norms, integrated rotations) have no closed-form Jacobian worth the risk.
class ResidualProblem : public NonlinearProblem {
 public:
  ResidualProblem(int n, std::function<Eigen::VectorXd(const Eigen::VectorXd&)> f, Eigen::VectorXd step)
      : n_(n), f_(std::move(f)), step_(std::move(step)) {}
  int num_params() const override { return n_; }
  Eigen::MatrixXd jacobian(const Eigen::VectorXd& th, const Eigen::VectorXd& e0) const {
    Eigen::MatrixXd j(e0.size(), n_);
    for (int k = 0; k < n_; ++k) {
      Eigen::VectorXd a = th, b = th;
      a[k] += step_[k];
      b[k] -= step_[k];
      j.col(k) = (f_(a) - f_(b)) / (2 * step_[k]);
    }
    return j;
  }
  void linearize(const Eigen::VectorXd& th, NormalEquations& ne) const override {
    const Eigen::VectorXd e = f_(th);
    ne.reset(n_);
    if (!e.allFinite()) {
      ne.cost = std::numeric_limits<double>::infinity();
      return;
    }
    const Eigen::MatrixXd j = jacobian(th, e);
    ne.info = j.transpose() * j;
    ne.rhs = -j.transpose() * e;
    ne.cost = e.squaredNorm();
    ne.n_obs = e.size();
  }
  double cost(const Eigen::VectorXd& th) const override { return f_(th).squaredNorm(); }
  Eigen::VectorXd residual(const Eigen::VectorXd& th) const { return f_(th); }

 private:
  int n_;
  std::function<Eigen::VectorXd(const Eigen::VectorXd&)> f_;
  Eigen::VectorXd step_;
};

const char* kAx = "xyz";
// Accelerometer unknowns in a fixed order; the misalignments are the gauge-free lower triangle.
const char* kAccNames[9] = {"accel.bias.x",  "accel.bias.y",  "accel.bias.z",     "accel.scale.x",    "accel.scale.y",
                            "accel.scale.z", "accel.misalign.yx", "accel.misalign.zx", "accel.misalign.zy"};
const char* kGyroNames[9] = {"gyro.scale.x",    "gyro.scale.y",    "gyro.scale.z",    "gyro.misalign.xy", "gyro.misalign.xz",
                             "gyro.misalign.yx", "gyro.misalign.yz", "gyro.misalign.zx", "gyro.misalign.zy"};

TriadCal accel_cal(const Eigen::VectorXd& p) {
  TriadCal c;
  c.b = p.head<3>();
  c.IM = Eigen::Matrix3d::Identity();
  for (int j = 0; j < 3; ++j) c.IM(j, j) += p[3 + j];
  c.IM(1, 0) = p[6];
  c.IM(2, 0) = p[7];
  c.IM(2, 1) = p[8];
  return c;
}

TriadCal gyro_cal(const Eigen::VectorXd& p, const Eigen::Vector3d& bias) {
  TriadCal c;
  c.b = bias;
  c.IM = Eigen::Matrix3d::Identity();
  for (int j = 0; j < 3; ++j) c.IM(j, j) += p[j];
  c.IM(0, 1) = p[3];
  c.IM(0, 2) = p[4];
  c.IM(1, 0) = p[5];
  c.IM(1, 2) = p[6];
  c.IM(2, 0) = p[7];
  c.IM(2, 1) = p[8];
  return c;
}

Eigen::Quaterniond qdot(const Eigen::Quaterniond& q, const Eigen::Vector3d& w) {
  const Eigen::Quaterniond p = q * Eigen::Quaterniond(0, w.x(), w.y(), w.z());
  return Eigen::Quaterniond(0.5 * p.w(), 0.5 * p.x(), 0.5 * p.y(), 0.5 * p.z());
}
Eigen::Quaterniond axpy(const Eigen::Quaterniond& q, double a, const Eigen::Quaterniond& k) {
  return Eigen::Quaterniond(q.w() + a * k.w(), q.x() + a * k.x(), q.y() + a * k.y(), q.z() + a * k.z());
}

Eigen::Matrix3d integrate_with(const RawRecording& rec, const Eigen::Matrix3d& inv_im, const Eigen::Vector3d& b,
                               std::size_t i0, std::size_t i1) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  auto omega = [&](std::size_t k) {
    const auto& y = rec.y[k];
    return Eigen::Vector3d(inv_im * (Eigen::Vector3d(y[3], y[4], y[5]) - b));
  };
  if (i1 <= i0) return Eigen::Matrix3d::Identity();
  Eigen::Vector3d w0 = omega(i0);
  for (std::size_t k = i0; k < i1; ++k) {
    const Eigen::Vector3d w1 = omega(k + 1);
    const double dt = rec.t_s[k + 1] - rec.t_s[k];
    const Eigen::Vector3d wm = 0.5 * (w0 + w1);
    const Eigen::Quaterniond k1 = qdot(q, w0);
    const Eigen::Quaterniond k2 = qdot(axpy(q, 0.5 * dt, k1), wm);
    const Eigen::Quaterniond k3 = qdot(axpy(q, 0.5 * dt, k2), wm);
    const Eigen::Quaterniond k4 = qdot(axpy(q, dt, k3), w1);
    q = Eigen::Quaterniond(q.w() + dt / 6 * (k1.w() + 2 * k2.w() + 2 * k3.w() + k4.w()),
                           q.x() + dt / 6 * (k1.x() + 2 * k2.x() + 2 * k3.x() + k4.x()),
                           q.y() + dt / 6 * (k1.y() + 2 * k2.y() + 2 * k3.y() + k4.y()),
                           q.z() + dt / 6 * (k1.z() + 2 * k2.z() + 2 * k3.z() + k4.z()));
    q.normalize();
    w0 = w1;
  }
  return q.toRotationMatrix();
}

double rms(const Eigen::VectorXd& v) { return v.size() ? std::sqrt(v.squaredNorm() / static_cast<double>(v.size())) : 0.0; }

struct AccelFit {
  Eigen::VectorXd p;
  Eigen::MatrixXd info;  // JᵀJ / σ²
  double rms_after = 0.0;
  int dof = 0;
};

AccelFit fit_accel(const std::vector<StaticInterval>& iv, double g, const std::vector<bool>& active) {
  const int na = static_cast<int>(std::count(active.begin(), active.end(), true));
  auto full = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(9);
    for (int k = 0, a = 0; k < 9; ++k)
      if (active[static_cast<size_t>(k)]) p[k] = x[a++];
    return p;
  };
  auto f = [&](const Eigen::VectorXd& x) {
    const TriadCal c = accel_cal(full(x));
    const Eigen::Matrix3d inv = c.IM.inverse();
    Eigen::VectorXd e(static_cast<long>(iv.size()));
    for (size_t i = 0; i < iv.size(); ++i) e[static_cast<long>(i)] = (inv * (iv[i].acc - c.b)).norm() - g;
    return e;
  };
  Eigen::VectorXd step(na);
  for (int k = 0, a = 0; k < 9; ++k)
    if (active[static_cast<size_t>(k)]) step[a++] = k < 3 ? 1e-6 : 1e-7;
  ResidualProblem prob(na, f, step);
  LmOptions lo;
  lo.step_tolerance_sq = 1e-10;  // numeric Jacobian: stop at 1e-5 σ steps
  LmResult r = levenberg_marquardt(prob, Eigen::VectorXd::Zero(na), lo);
  AccelFit out;
  out.p = full(r.theta);
  const Eigen::VectorXd e = prob.residual(r.theta);
  out.dof = static_cast<int>(e.size()) - na;
  const double s2 = out.dof > 0 ? e.squaredNorm() / out.dof : std::numeric_limits<double>::infinity();
  out.info = r.normal.info / s2;
  out.rms_after = rms(e);
  return out;
}

}  // namespace

RawRecording read_recording(io::LogReader& log) {
  RawRecording rec;
  const auto& m = log.meta();
  if (!(m.accel_lsb_mps2 > 0) || !(m.gyro_lsb_rad_s > 0))
    throw SolverError("log '" + log.path() + "' lacks positive accel_lsb/gyro_lsb metadata");
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
  io::LogRow row;
  while (log.next(row)) {
    rec.t_s.push_back(row.t_s);
    std::array<double, 6> y;
    for (int c = 0; c < 6; ++c) y[static_cast<size_t>(c)] = row.raw[c] * (c < 3 ? m.accel_lsb_mps2 : m.gyro_lsb_rad_s);
    rec.y.push_back(y);
    bool clip = false;
    for (int c = 3; c < 6; ++c) clip = clip || row.raw[c] <= -32768 || row.raw[c] >= 32767;
    rec.gyro_clipped.push_back(clip);
    rec.clipped_samples += clip ? 1 : 0;
  }
  if (rec.t_s.size() < 10) throw SolverError("log '" + log.path() + "' has too few samples for reference-free mode");
  for (size_t i = 1; i < rec.t_s.size(); ++i)
    if (!(rec.t_s[i] > rec.t_s[i - 1]))
      throw SolverError("log '" + log.path() + "': time does not increase at row " + std::to_string(i));
  rec.rate_hz = m.sample_rate_hz > 0 ? m.sample_rate_hz
                                     : static_cast<double>(rec.t_s.size() - 1) / (rec.t_s.back() - rec.t_s.front());
  return rec;
}

std::vector<StaticInterval> detect_static(const RawRecording& rec, double window_s, double min_duration_s,
                                          double k_threshold, StaticSignal signal) {
  const std::size_t n = rec.y.size();
  const std::size_t half = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(window_s * rec.rate_hz / 2)));
  // Prefix sums of centred values (centring on the channel mean keeps Σy² − (Σy)²/n well conditioned).
  std::array<double, 6> mean{};
  for (const auto& y : rec.y)
    for (int c = 0; c < 6; ++c) mean[static_cast<size_t>(c)] += y[static_cast<size_t>(c)] / static_cast<double>(n);
  std::vector<std::array<double, 12>> ps(n + 1);
  ps[0].fill(0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 6; ++c) {
      const double v = rec.y[i][static_cast<size_t>(c)] - mean[static_cast<size_t>(c)];
      ps[i + 1][static_cast<size_t>(c)] = ps[i][static_cast<size_t>(c)] + v;
      ps[i + 1][static_cast<size_t>(6 + c)] = ps[i][static_cast<size_t>(6 + c)] + v * v;
    }
  std::vector<double> va(n), vg(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(n, i + half + 1);
    const double m = static_cast<double>(b - a);
    double sa = 0, sg = 0;
    for (int c = 0; c < 6; ++c) {
      const double s1 = ps[b][static_cast<size_t>(c)] - ps[a][static_cast<size_t>(c)];
      const double s2 = ps[b][static_cast<size_t>(6 + c)] - ps[a][static_cast<size_t>(6 + c)];
      const double var = std::max(0.0, (s2 - s1 * s1 / m) / std::max(1.0, m - 1));
      (c < 3 ? sa : sg) += var;
    }
    va[i] = sa;
    vg[i] = sg;
  }
  auto floor_of = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 10), v.end());
    return std::max(v[v.size() / 10], 1e-300);
  };
  // Accelerometer only, as in Tedaldi et al.: a hand holding a pose still trembles enough to lift the
  // gyro's windowed variance well above its floor while the accelerometer's stays near it.
  const bool gyro = signal == StaticSignal::kGyro;
  const std::vector<double>& v = gyro ? vg : va;
  const double fa = floor_of(v);
  std::vector<StaticInterval> out;
  const std::size_t min_len = static_cast<std::size_t>(std::ceil(min_duration_s * rec.rate_hz));
  std::size_t i = 0;
  while (i < n) {
    if (!(v[i] < k_threshold * fa)) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < n && v[j] < k_threshold * fa) ++j;
    if (j - i >= std::max<std::size_t>(min_len, 2)) {
      StaticInterval s;
      s.begin = i;
      s.end = j;
      for (std::size_t k = i; k < j; ++k) {
        s.acc += Eigen::Vector3d(rec.y[k][0], rec.y[k][1], rec.y[k][2]);
        s.gyro += Eigen::Vector3d(rec.y[k][3], rec.y[k][4], rec.y[k][5]);
      }
      s.acc /= static_cast<double>(j - i);
      s.gyro /= static_cast<double>(j - i);
      out.push_back(s);
    }
    i = j;
  }
  return out;
}

Eigen::Matrix3d integrate_rotation(const RawRecording& rec, const TriadCal& gyro, std::size_t i0, std::size_t i1) {
  return integrate_with(rec, gyro.IM.inverse(), gyro.b, i0, i1);
}

TriadCal triad_from_estimate(const Estimate& e, const std::string& sensor) {
  TriadCal c;
  for (int j = 0; j < 3; ++j) {
    int i = e.index_of(sensor + ".bias." + kAx[j]);
    if (i >= 0) c.b[j] = e.value[i];
    i = e.index_of(sensor + ".scale." + kAx[j]);
    if (i >= 0) c.IM(j, j) += e.value[i];
    for (int k = 0; k < 3; ++k) {
      if (k == j) continue;
      i = e.index_of(sensor + ".misalign." + kAx[j] + kAx[k]);
      if (i >= 0) c.IM(j, k) = e.value[i];
    }
  }
  return c;
}

namespace {
bool clipped_in(const RawRecording& rec, std::size_t i0, std::size_t i1) {
  if (rec.gyro_clipped.empty()) return false;
  for (std::size_t k = i0; k <= i1 && k < rec.gyro_clipped.size(); ++k)
    if (rec.gyro_clipped[k]) return true;
  return false;
}
}  // namespace

RotationCheck rotation_check(const RawRecording& rec, const Estimate& cal, double window_s) {
  RotationCheck rc = rotation_check(rec, triad_from_estimate(cal, "gyro"), window_s);
  // dθ/dp for every gyro scale/misalignment in the estimate, by central differences (the angle is
  // smooth in them), then σ² = J C Jᵀ over that block of the covariance.
  std::vector<int> idx;
  for (int i = 0; i < static_cast<int>(cal.names.size()); ++i)
    if (cal.names[static_cast<size_t>(i)].rfind("gyro.scale.", 0) == 0 ||
        cal.names[static_cast<size_t>(i)].rfind("gyro.misalign.", 0) == 0)
      idx.push_back(i);
  if (idx.empty() || cal.covariance.rows() != static_cast<long>(cal.names.size())) return rc;
  const double h = 1e-5;
  Eigen::VectorXd jac(static_cast<long>(idx.size()));
  for (size_t a = 0; a < idx.size(); ++a) {
    Estimate p = cal, m = cal;
    p.value[idx[a]] += h;
    m.value[idx[a]] -= h;
    jac[static_cast<long>(a)] = (rotation_check(rec, triad_from_estimate(p, "gyro"), window_s).angle_deg -
                                 rotation_check(rec, triad_from_estimate(m, "gyro"), window_s).angle_deg) / (2 * h);
  }
  Eigen::MatrixXd c(jac.size(), jac.size());
  for (long a = 0; a < jac.size(); ++a)
    for (long b = 0; b < jac.size(); ++b) c(a, b) = cal.covariance(idx[static_cast<size_t>(a)], idx[static_cast<size_t>(b)]);
  rc.angle_sigma_deg = std::sqrt(std::max(0.0, jac.dot(c * jac)));
  return rc;
}

RotationCheck rotation_check(const RawRecording& rec, const TriadCal& gyro, double window_s) {
  // The gyro shows a rotation even where the accelerometer barely changes (rotation about the vertical).
  const auto iv = detect_static(rec, window_s, 2.0, 4.0, StaticSignal::kGyro);
  if (iv.empty()) throw SolverError("rotation check: no static interval to take the gyro bias from");
  if (rec.clipped_samples > 0)
    throw SolverError("rotation check: " + std::to_string(rec.clipped_samples) +
                      " gyro samples at a 16-bit full-scale limit; the integrated angle would be short");
  TriadCal g = gyro;
  // Turn-on bias differs at every power-up: take it from this recording's first still period, in output
  // units, so the calibration's scale/misalignment apply to rate only.
  g.b = iv.front().gyro;
  RotationCheck rc;
  const Eigen::Matrix3d r = integrate_rotation(rec, g, 0, rec.y.size() - 1);
  const Eigen::AngleAxisd aa(r);
  rc.angle_deg = aa.angle() * 180 / M_PI;
  rc.axis = aa.axis();
  TriadCal nom;
  nom.b = g.b;
  rc.angle_nominal_deg = Eigen::AngleAxisd(integrate_rotation(rec, nom, 0, rec.y.size() - 1)).angle() * 180 / M_PI;
  return rc;
}

ReferenceFreeResult solve_reference_free(const RawRecording& rec, const model::ModelSpec& spec,
                                         const ReferenceFreeOptions& opt) {
  using model::Effect;
  using model::Sensor;
  // Which of the supported unknowns the model asks for; anything else is refused by name.
  std::vector<std::string> wanted;
  for (model::ParamId id : spec.parameters()) wanted.push_back(model::param_info(id).name);
  ReferenceFreeResult res;
  for (const auto& w : wanted) {
    const bool basic = w.find(".bias.") != std::string::npos || w.find(".scale.") != std::string::npos ||
                       w.find(".misalign.") != std::string::npos;
    if (w.find(".temp_rate.") != std::string::npos)
      throw SolverError("reference-free mode cannot estimate " + w +
                        ": the mode has no temperature model (its hand-held recordings are short, at nearly constant "
                        "temperature or without temp_C, so r*dT/dt is not observable, and during a static pose it "
                        "would be indistinguishable from the bias); estimate temp_rate in fixture mode from a "
                        "campaign with temperature ramps (docs/calibration.md)");
    if (!basic)
      throw SolverError("reference-free mode estimates bias, scale and misalign only; the model also asks for " + w);
    if (w == "accel.misalign.xy" || w == "accel.misalign.xz" || w == "accel.misalign.yz") res.gauge_fixed.push_back(w);
  }
  auto want = [&](const std::string& n) { return std::find(wanted.begin(), wanted.end(), n) != wanted.end(); };
  std::vector<bool> acc_active(9), gyro_active(9);
  for (int k = 0; k < 9; ++k) {
    acc_active[static_cast<size_t>(k)] = want(kAccNames[k]);
    gyro_active[static_cast<size_t>(k)] = want(kGyroNames[k]);
  }
  const double g = rec.gravity_mps2;
  res.gravity_mps2 = g;

  // 1-2: static detection swept over thresholds; keep the lowest gravity residual (Tedaldi §IV).
  AccelFit best;
  best.rms_after = std::numeric_limits<double>::infinity();
  const int na = static_cast<int>(std::count(acc_active.begin(), acc_active.end(), true));
  for (double k : opt.thresholds) {
    auto iv = detect_static(rec, opt.window_s, opt.min_duration_s, k);
    if (static_cast<int>(iv.size()) < std::max(opt.min_intervals, na + 1)) continue;
    AccelFit fit = fit_accel(iv, g, acc_active);
    if (fit.rms_after < best.rms_after) {
      best = fit;
      res.intervals = iv;
      res.threshold_k = k;
    }
  }
  if (res.intervals.empty())
    throw SolverError("reference-free mode: fewer than " + std::to_string(std::max(opt.min_intervals, na + 1)) +
                      " static poses found at every threshold; the recording needs more still poses of >= " +
                      std::to_string(opt.min_duration_s) + " s");
  const auto& iv = res.intervals;
  Eigen::VectorXd before(static_cast<long>(iv.size()));
  for (size_t i = 0; i < iv.size(); ++i) before[static_cast<long>(i)] = iv[i].acc.norm() - g;
  res.gravity_rms_before = rms(before);
  res.gravity_rms_after = best.rms_after;
  const TriadCal acal = accel_cal(best.p);
  const Eigen::Matrix3d ainv = acal.IM.inverse();

  // 3: gyro bias from the static intervals (sample-weighted), σ from the scatter between intervals.
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  double nsum = 0;
  for (const auto& s : iv) {
    const double w = static_cast<double>(s.end - s.begin);
    bg += w * s.gyro;
    nsum += w;
  }
  bg /= nsum;
  Eigen::Vector3d bvar = Eigen::Vector3d::Zero();
  for (const auto& s : iv) bvar += (s.gyro - bg).cwiseAbs2();
  bvar /= static_cast<double>(iv.size() - 1) * static_cast<double>(iv.size());

  // 4: gyro scale/misalignment from the gravity direction across transitions.
  const int ng = static_cast<int>(std::count(gyro_active.begin(), gyro_active.end(), true));
  auto gfull = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(9);
    for (int k = 0, a = 0; k < 9; ++k)
      if (gyro_active[static_cast<size_t>(k)]) p[k] = x[a++];
    return p;
  };
  std::vector<size_t> used;  // transitions i -> i+1 without a clipped gyro sample
  for (size_t i = 0; i + 1 < iv.size(); ++i)
    if (!clipped_in(rec, iv[i].end - 1, iv[i + 1].begin)) used.push_back(i);
  res.transitions_used = static_cast<int>(used.size());
  res.transitions_clipped = static_cast<int>(iv.size() - 1 - used.size());
  // The residual as a function of the gyro unknowns AND the upstream estimates it is conditioned on
  // (accelerometer parameters through the gravity directions, gyro bias through the integration).
  auto gres_at = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& pa9, const Eigen::Vector3d& bias) {
    const TriadCal ac = accel_cal(pa9);
    const Eigen::Matrix3d ai = ac.IM.inverse();
    std::vector<Eigen::Vector3d> gdir;
    for (const auto& s : iv) gdir.push_back((ai * (s.acc - ac.b)).normalized());
    const TriadCal c = gyro_cal(gfull(x), bias);
    const Eigen::Matrix3d inv = c.IM.inverse();
    Eigen::VectorXd e(3 * static_cast<long>(used.size()));
    for (size_t u = 0; u < used.size(); ++u) {
      const size_t i = used[u];
      const Eigen::Matrix3d r = integrate_with(rec, inv, c.b, iv[i].end - 1, iv[i + 1].begin);
      e.segment<3>(3 * static_cast<long>(u)) = r.transpose() * gdir[i] - gdir[i + 1];
    }
    return e;
  };
  auto gres = [&](const Eigen::VectorXd& x) { return gres_at(x, best.p, bg); };
  Eigen::VectorXd gtheta = Eigen::VectorXd::Zero(ng);
  Eigen::MatrixXd ginfo = Eigen::MatrixXd::Zero(ng, ng);
  // Sensitivity of the gyro estimate to the upstream estimates u = (active accel parameters, gyro bias):
  // D = −(JgᵀJg)⁻¹ Jgᵀ Ju, so Cov(gyro) = Cov(gyro | u) + D Cov(u) Dᵀ and Cov(gyro, u) = D Cov(u).
  Eigen::MatrixXd dgu = Eigen::MatrixXd::Zero(ng, na + 3);
  res.rotation_rms_before = rms(gres(Eigen::VectorXd::Zero(ng)));
  if (ng > 0) {
    ResidualProblem gp(ng, gres, Eigen::VectorXd::Constant(ng, 1e-6));
    LmOptions lo;
    lo.step_tolerance_sq = 1e-10;
    LmResult r = levenberg_marquardt(gp, Eigen::VectorXd::Zero(ng), lo);
    gtheta = r.theta;
    const Eigen::VectorXd e = gp.residual(gtheta);
    // Each transition's residual is a difference of unit vectors: 2 degrees of freedom, not 3.
    const int dof = 2 * static_cast<int>(used.size()) - ng;
    if (dof <= 0)
      throw SolverError("reference-free mode: " + std::to_string(used.size()) + " usable pose transitions (" +
                        std::to_string(res.transitions_clipped) + " left out: gyro clipped at full scale) are too few for " +
                        std::to_string(ng) + " gyro unknowns");
    ginfo = r.normal.info / (e.squaredNorm() / dof);
    res.rotation_rms_after = rms(e);
    const Eigen::MatrixXd jg = gp.jacobian(gtheta, e);
    Eigen::MatrixXd ju(e.size(), na + 3);
    for (int k = 0, a = 0; k < 9; ++k) {
      if (!acc_active[static_cast<size_t>(k)]) continue;
      const double h = k < 3 ? 1e-6 : 1e-7;
      Eigen::VectorXd pp = best.p, pm = best.p;
      pp[k] += h;
      pm[k] -= h;
      ju.col(a++) = (gres_at(gtheta, pp, bg) - gres_at(gtheta, pm, bg)) / (2 * h);
    }
    for (int j = 0; j < 3; ++j) {
      const double h = 1e-6;
      Eigen::Vector3d bp = bg, bm = bg;
      bp[j] += h;
      bm[j] -= h;
      ju.col(na + j) = (gres_at(gtheta, best.p, bp) - gres_at(gtheta, best.p, bm)) / (2 * h);
    }
    dgu = -(jg.transpose() * jg).ldlt().solve(jg.transpose() * ju);
  } else {
    res.rotation_rms_after = res.rotation_rms_before;
  }
  const Eigen::VectorXd gp9 = gfull(gtheta);

  // Assemble the requested parameters with a block-diagonal information.
  std::vector<std::string> names;
  std::vector<double> values;
  std::vector<std::pair<int, int>> src;  // (block, index in block)
  for (int k = 0; k < 9; ++k)
    if (acc_active[static_cast<size_t>(k)]) { names.push_back(kAccNames[k]); values.push_back(best.p[k]); src.emplace_back(0, k); }
  for (int j = 0; j < 3; ++j) {
    const std::string n = std::string("gyro.bias.") + kAx[j];
    if (want(n)) { names.push_back(n); values.push_back(bg[j]); src.emplace_back(1, j); }
  }
  for (int k = 0; k < 9; ++k)
    if (gyro_active[static_cast<size_t>(k)]) { names.push_back(kGyroNames[k]); values.push_back(gp9[k]); src.emplace_back(2, k); }
  const int n = static_cast<int>(names.size());
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(n, n);
  // Map each block's active index to the output index.
  std::vector<int> acc_pos(9, -1), gyr_pos(9, -1);
  for (int k = 0, a = 0; k < 9; ++k) if (acc_active[static_cast<size_t>(k)]) acc_pos[static_cast<size_t>(k)] = a++;
  for (int k = 0, a = 0; k < 9; ++k) if (gyro_active[static_cast<size_t>(k)]) gyr_pos[static_cast<size_t>(k)] = a++;
  for (int i = 0; i < n; ++i)
    for (int l = 0; l < n; ++l) {
      const auto [bi, ki] = src[static_cast<size_t>(i)];
      const auto [bl, kl] = src[static_cast<size_t>(l)];
      if (bi != bl) continue;
      if (bi == 0) info(i, l) = best.info(acc_pos[static_cast<size_t>(ki)], acc_pos[static_cast<size_t>(kl)]);
      else if (bi == 2) info(i, l) = ginfo(gyr_pos[static_cast<size_t>(ki)], gyr_pos[static_cast<size_t>(kl)]);
      else if (ki == kl) info(i, l) = 1.0 / std::max(bvar[ki], 1e-30);
    }
  res.estimate.names = names;
  res.estimate.value = Eigen::Map<Eigen::VectorXd>(values.data(), n);
  res.estimate.covariance = covariance_from_information(info, names, &res.observability);
  if (ng > 0) {
    // Propagate the upstream uncertainty into the gyro block (sequential estimate: the accelerometer
    // and bias blocks keep their own covariance).
    Eigen::MatrixXd cu = Eigen::MatrixXd::Zero(na + 3, na + 3);
    if (na > 0) cu.topLeftCorner(na, na) = best.info.ldlt().solve(Eigen::MatrixXd::Identity(na, na));
    for (int j = 0; j < 3; ++j) cu(na + j, na + j) = bvar[j];
    const Eigen::MatrixXd dcu = dgu * cu;
    const Eigen::MatrixXd add = dcu * dgu.transpose();
    auto upos = [&](int i) {  // index of output i in u, or −1
      const auto [b, k] = src[static_cast<size_t>(i)];
      return b == 0 ? acc_pos[static_cast<size_t>(k)] : b == 1 ? na + k : -1;
    };
    for (int i = 0; i < n; ++i) {
      const auto [bi, ki] = src[static_cast<size_t>(i)];
      if (bi != 2) continue;
      const int gi = gyr_pos[static_cast<size_t>(ki)];
      for (int l = 0; l < n; ++l) {
        const auto [bl, kl] = src[static_cast<size_t>(l)];
        if (bl == 2) {
          res.estimate.covariance(i, l) += add(gi, gyr_pos[static_cast<size_t>(kl)]);
        } else {
          res.estimate.covariance(i, l) = res.estimate.covariance(l, i) = dcu(gi, upos(l));
        }
      }
    }
  }

  // Within-pose scatter of the calibrated outputs per channel (the noise level seen at rest).
  const TriadCal gcal = gyro_cal(gp9, bg);
  const Eigen::Matrix3d ginv = gcal.IM.inverse();
  std::array<double, 6> ss{};
  double cnt = 0;
  for (const auto& s : iv) {
    Eigen::Vector3d ma = ainv * (s.acc - acal.b), mg = ginv * (s.gyro - gcal.b);
    for (std::size_t k = s.begin; k < s.end; ++k) {
      const auto& y = rec.y[k];
      const Eigen::Vector3d a = ainv * (Eigen::Vector3d(y[0], y[1], y[2]) - acal.b) - ma;
      const Eigen::Vector3d w = ginv * (Eigen::Vector3d(y[3], y[4], y[5]) - gcal.b) - mg;
      for (int c = 0; c < 3; ++c) {
        ss[static_cast<size_t>(c)] += a[c] * a[c];
        ss[static_cast<size_t>(3 + c)] += w[c] * w[c];
      }
    }
    cnt += static_cast<double>(s.end - s.begin - 1);
  }
  for (int c = 0; c < 6; ++c) res.residual_rms[static_cast<size_t>(c)] = std::sqrt(ss[static_cast<size_t>(c)] / std::max(1.0, cnt));
  return res;
}

}  // namespace imuforge::solver
