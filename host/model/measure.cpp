#include "host/model/measure.h"

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace imuforge::model {

namespace {

// A = [ω×]² + [ω̇×]: size-effect term of axis j is A.row(j) · r_j.
Eigen::Matrix3d size_matrix(const Vec3& w, const Vec3& wdot) {
  Eigen::Matrix3d W, Wd;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  Wd << 0, -wdot.z(), wdot.y(), wdot.z(), 0, -wdot.x(), -wdot.y(), wdot.x(), 0;
  return W * W + Wd;
}

// G2 terms: products "j.xy" -> 0, "j.yz" -> 1, "j.zx" -> 2, squares (IEEE 1431) "j.xx" -> 3, "j.yy" -> 4, "j.zz" -> 5.
int g2_pair(int k, int l) {
  if (k == l) return 3 + k;
  if ((k == 0 && l == 1) || (k == 1 && l == 0)) return 0;
  if ((k == 1 && l == 2) || (k == 2 && l == 1)) return 1;
  return 2;
}
constexpr int kPairK[6] = {0, 1, 2, 0, 1, 2};
constexpr int kPairL[6] = {1, 2, 0, 0, 1, 2};

}  // namespace

CompiledTriad compile(const ParamSet& p, Sensor s, double T_ref_C) {
  CompiledTriad c;
  c.sensor = s;
  c.T_ref_C = T_ref_C;
  for (const auto& info : params()) {
    if (info.sensor != s || !info.deterministic) continue;
    double v = p[info.id];
    if (v == 0.0) continue;
    const int j = info.j, k = info.k, l = info.l, pw = info.power;
    switch (info.effect) {
      case Effect::kBias: c.b[j] = v; break;
      case Effect::kScale: c.M[j][j] = v; break;
      case Effect::kMisalign: c.M[j][k] = v; break;
      case Effect::kBiasTemp: c.bt[j][pw - 1] = v; break;
      case Effect::kScaleTemp: c.Mt[j][j][pw - 1] = v; break;
      case Effect::kMisalignTemp: c.Mt[j][k][pw - 1] = v; break;
      case Effect::kScaleNonlinearity: (pw == 2 ? c.k2 : c.k3)[j] = v; break;
      case Effect::kScaleAsymmetry: c.asym[j] = v; break;
      case Effect::kCrossCoupling: c.cc[j][k] = v; break;
      case Effect::kGSensitivity: c.G[j][k] = v; break;
      case Effect::kG2Sensitivity: c.G2[j][g2_pair(k, l)] = v; break;
      case Effect::kCrossAxisNonlinearity: c.xn[j][g2_pair(k, l)] = v; break;
      case Effect::kSizeEffect: c.r[j][k] = v; break;
      case Effect::kTempHysteresis: c.hyst[j] = v; break;
      case Effect::kTempRate: c.trate[j] = v; break;
      case Effect::kTiming:
        if (info.component == "latency_s") c.latency_s = v;
        else c.ppm = v;
        break;
      default: break;
    }
  }
  return c;
}

CompiledTriad compile(const SensorModel& m, Sensor s) { return compile(m.effective_params(), s, m.T_ref_C); }

Vec3 size_effect_term(const double r[3][3], const Vec3& w, const Vec3& wdot) {
  Eigen::Matrix3d A = size_matrix(w, wdot);
  Vec3 out;
  for (int j = 0; j < 3; ++j) out[j] = A(j, 0) * r[j][0] + A(j, 1) * r[j][1] + A(j, 2) * r[j][2];
  return out;
}

Vec3 measure(const CompiledTriad& c, const MeasureInput& in, const MeasureOptions& opt) {
  const Vec3& u = nominal(c.sensor, in);
  const Vec3& ud = nominal_rate(c.sensor, in);
  const double tau = in.T_C - c.T_ref_C;
  const double tp[3] = {tau, tau * tau, tau * tau * tau};
  const bool gyro = c.sensor == Sensor::kGyro;
  Vec3 y;
  for (int j = 0; j < 3; ++j) {
    double acc = u[j] + c.b[j] + c.bt[j][0] * tp[0] + c.bt[j][1] * tp[1] + c.bt[j][2] * tp[2];
    for (int k = 0; k < 3; ++k) {
      double m = c.M[j][k] + c.Mt[j][k][0] * tp[0] + c.Mt[j][k][1] * tp[1] + c.Mt[j][k][2] * tp[2];
      acc += m * u[k];
      if (k != j) acc += c.cc[j][k] * u[j] * u[k];
    }
    acc += c.k2[j] * u[j] * u[j] + c.k3[j] * u[j] * u[j] * u[j];
    acc += c.asym[j] * std::min(u[j], 0.0);
    if (gyro) {
      for (int k = 0; k < 3; ++k) acc += c.G[j][k] * in.f[k];
      for (int q = 0; q < 6; ++q) acc += c.G2[j][q] * in.f[kPairK[q]] * in.f[kPairL[q]];
    } else {
      for (int q = 0; q < 6; ++q) acc += c.xn[j][q] * u[kPairK[q]] * u[kPairL[q]];
    }
    acc += c.hyst[j] * in.d + c.trate[j] * in.Tdot_C_s;
    if (opt.include_timing) acc -= (c.latency_s + c.ppm * 1e-6 * in.t_s) * ud[j];
    y[j] = acc;
  }
  if (!gyro) y += size_effect_term(c.r, in.w, in.wdot);
  return y;
}

Vec3 measure(const SensorModel& m, Sensor s, const MeasureInput& in, const MeasureOptions& opt) {
  return measure(compile(m, s), in, opt);
}

namespace {

// What one sample gives every column of a triad: its input, the input's rate, the size-effect matrix and the
// temperature's powers (τ^p once per power and sample: pow() per column and sample was a quarter of a 1 h
// diagnosis; τ¹ is τ exactly and the higher powers still come from pow(), so every column is what it was).
struct SampleTerms {
  const Vec3& u;
  const Vec3& ud;
  const MeasureInput& in;
  double tau;
  Eigen::Matrix3d A;
  std::array<double, 4> tau_pows;
  SampleTerms(Sensor s, const MeasureInput& in_, double T_ref_C, bool need_size)
      : u(nominal(s, in_)), ud(nominal_rate(s, in_)), in(in_), tau(in_.T_C - T_ref_C),
        A(need_size ? size_matrix(in_.w, in_.wdot) : Eigen::Matrix3d::Zero()),
        tau_pows{1.0, tau, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()} {}
  double tau_pow(int pw) {
    if (pw <= 0) return 1.0;
    if (pw > 3) return std::pow(tau, pw);
    double& v = tau_pows[static_cast<std::size_t>(pw)];
    if (std::isnan(v)) v = std::pow(tau, pw);
    return v;
  }
};

// The one statement of each column's physics (docs/error-model.md), for regressors() and RegressorPlan: col (the
// column's three rows, contiguous) += ∂y/∂θ. Raw rows, not an Eigen block: a block per column and sample, with its
// bounds checks, cost more than the physics.
inline void add_column(const RegressorPlan::Column& c, SampleTerms& x, double* col) {
  const int j = c.j, k = c.k, l = c.l;
  const Vec3& u = x.u;
  switch (c.effect) {
    case Effect::kBias: col[j] += 1.0; break;
    case Effect::kScale: col[j] += u[j]; break;
    case Effect::kMisalign: col[j] += u[k]; break;
    case Effect::kBiasTemp: col[j] += x.tau_pow(c.power); break;
    case Effect::kScaleTemp: col[j] += x.tau_pow(c.power) * u[j]; break;
    case Effect::kMisalignTemp: col[j] += x.tau_pow(c.power) * u[k]; break;
    case Effect::kScaleNonlinearity: col[j] += c.power == 2 ? u[j] * u[j] : u[j] * u[j] * u[j]; break;
    case Effect::kScaleAsymmetry: col[j] += std::min(u[j], 0.0); break;
    case Effect::kCrossCoupling: col[j] += u[j] * u[k]; break;
    case Effect::kGSensitivity: col[j] += x.in.f[k]; break;
    case Effect::kG2Sensitivity: col[j] += x.in.f[k] * x.in.f[l]; break;
    case Effect::kCrossAxisNonlinearity: col[j] += u[k] * u[l]; break;
    case Effect::kSizeEffect: col[j] += x.A(j, k); break;
    case Effect::kTempHysteresis: col[j] += x.in.d; break;
    case Effect::kTempRate: col[j] += x.in.Tdot_C_s; break;
    case Effect::kTiming:
      for (int r = 0; r < 3; ++r) col[r] -= c.latency ? x.ud[r] : 1e-6 * x.in.t_s * x.ud[r];
      break;
    default: break;
  }
}

}  // namespace

RegressorPlan::Column RegressorPlan::column(Sensor s, ParamId id, const MeasureOptions& opt) {
  const ParamInfo& p = params()[static_cast<std::size_t>(id)];
  Column c;
  c.effect = p.effect;
  c.j = static_cast<std::int8_t>(p.j);
  c.k = static_cast<std::int8_t>(p.k);
  c.l = static_cast<std::int8_t>(p.l);
  const bool thermal = p.effect == Effect::kBiasTemp || p.effect == Effect::kScaleTemp || p.effect == Effect::kMisalignTemp;
  c.power = static_cast<std::int8_t>(thermal || p.effect == Effect::kScaleNonlinearity ? p.power : 0);
  c.latency = p.effect == Effect::kTiming && p.component == "latency_s";
  c.active = p.sensor == s && p.deterministic && (p.effect != Effect::kTiming || opt.include_timing);
  return c;
}

RegressorPlan::RegressorPlan(Sensor s, const std::vector<ParamId>& ids, const MeasureOptions& opt) : sensor_(s) {
  cols_.reserve(ids.size());
  for (ParamId id : ids) {
    cols_.push_back(column(s, id, opt));
    need_size_ = need_size_ || (cols_.back().active && cols_.back().effect == Effect::kSizeEffect);
  }
}

void RegressorPlan::accumulate(const MeasureInput& in, double T_ref_C, Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> J) const {
  if (J.cols() != static_cast<Eigen::Index>(cols_.size()))
    throw std::invalid_argument("RegressorPlan::accumulate: J must have one column per parameter");
  SampleTerms x(sensor_, in, T_ref_C, need_size_);
  double* const base = J.data();
  const Eigen::Index stride = J.outerStride();
  for (std::size_t i = 0; i < cols_.size(); ++i)
    if (cols_[i].active) add_column(cols_[i], x, base + static_cast<Eigen::Index>(i) * stride);
}

void regressors(Sensor s, const std::vector<ParamId>& ids, const MeasureInput& in, double T_ref_C,
                Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> J, const MeasureOptions& opt) {
  if (J.cols() != static_cast<Eigen::Index>(ids.size()))
    throw std::invalid_argument("regressors: J must have one column per parameter");
  const std::vector<ParamInfo>& all = params();
  bool need_size = false;
  for (ParamId id : ids) need_size = need_size || all[static_cast<std::size_t>(id)].effect == Effect::kSizeEffect;
  SampleTerms x(s, in, T_ref_C, need_size);
  J.setZero();
  double* const base = J.data();
  const Eigen::Index stride = J.outerStride();
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const RegressorPlan::Column c = RegressorPlan::column(s, ids[i], opt);
    if (c.active) add_column(c, x, base + static_cast<Eigen::Index>(i) * stride);
  }
}

// ---------------------------------------------------------------- thermal history

double LowPass::update(double x, double t_s) {
  if (!have_ || t_s < t_prev_ || !std::isfinite(t_s)) {
    y_ = x;
  } else if (t_s > t_prev_) {
    const double dt = t_s - t_prev_;
    if (std::fabs(dt - dt_gain_) > 1e-9 * dt) {
      dt_gain_ = dt;
      gain_ = 1.0 - std::exp(-dt / tau_);
    }
    y_ += gain_ * (x - y_);
  }
  have_ = true;
  t_prev_ = t_s;
  return y_;
}

double HysteresisTracker::update(double T_C, double t_s) {
  if (std::isnan(T_C)) return d_;
  if (smooth_) T_C = lp_.update(T_C, t_s);
  if (!init_) {
    init_ = true;
    extreme_ = T_C;
    return d_;
  }
  if (d_ > 0) {
    // Heating: track the maximum; a drop of more than the threshold from it is a turn to cooling.
    if (T_C > extreme_) extreme_ = T_C;
    else if (extreme_ - T_C > thr_) { d_ = -1.0; extreme_ = T_C; }
  } else if (d_ < 0) {
    if (T_C < extreme_) extreme_ = T_C;
    else if (T_C - extreme_ > thr_) { d_ = 1.0; extreme_ = T_C; }
  } else {
    // Before the first significant change extreme_ is the starting temperature.
    if (T_C - extreme_ > thr_) { d_ = 1.0; extreme_ = T_C; }
    else if (extreme_ - T_C > thr_) { d_ = -1.0; extreme_ = T_C; }
  }
  return d_;
}

std::vector<double> temp_rate_centered(const std::vector<double>& t_s, const std::vector<double>& T_C,
                                       double window_s) {
  const std::size_t n = t_s.size();
  if (T_C.size() != n) throw std::invalid_argument("temp_rate_centered: t and T differ in length");
  std::vector<double> out(n, 0.0);
  std::size_t lo = 0, hi = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (lo < i && t_s[lo] < t_s[i] - window_s) ++lo;
    if (hi < i) hi = i;
    while (hi + 1 < n && t_s[hi + 1] <= t_s[i] + window_s) ++hi;
    double dt = t_s[hi] - t_s[lo];
    if (dt > 0 && !std::isnan(T_C[hi]) && !std::isnan(T_C[lo])) out[i] = (T_C[hi] - T_C[lo]) / dt;
  }
  return out;
}

}  // namespace imuforge::model
