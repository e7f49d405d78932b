#include "host/eol/tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "host/poses/detect.h"
#include "host/solver/fixture.h"
#include "host/solver/fixture_errors.h"

namespace imuforge::eol {

using model::Sensor;

Tracker::Tracker(const model::ModelSpec& spec)
    : ids_(spec.parameters()), T_ref_C_(spec.T_ref_C), srif_([&] {
        std::vector<std::string> n;
        for (auto id : spec.parameters()) n.push_back(model::param_info(id).name);
        return n;
      }()) {
  names_ = srif_.names();
  if (ids_.empty()) throw std::invalid_argument("tracker: the model estimates no parameters");
  hyst_ = solver::logged_hysteresis_tracker(spec);  // the batch solver's: the model's threshold, smoothed
}

void Tracker::set_noise(double a, double g) {
  fixed_noise_[0] = a;
  fixed_noise_[1] = g;
}

double Tracker::accel_noise() const {
  if (fixed_noise_[0] > 0) return fixed_noise_[0];
  double q = lsb_[0] > 0 ? lsb_[0] / std::sqrt(12.0) : 1e-3;
  if (pooled_dof_[0] < 10) return std::max(q, 1e-3);
  return std::max(q, std::sqrt(pooled_ss_[0] / pooled_dof_[0]));
}
double Tracker::gyro_noise() const {
  if (fixed_noise_[1] > 0) return fixed_noise_[1];
  double q = lsb_[1] > 0 ? lsb_[1] / std::sqrt(12.0) : 1e-4;
  if (pooled_dof_[1] < 10) return std::max(q, 1e-4);
  return std::max(q, std::sqrt(pooled_ss_[1] / pooled_dof_[1]));
}

bool Tracker::add_segment(const io::LogMeta& meta, const std::vector<io::LogRow>& rows, int segment,
                          const std::string& label) {
  const int n = size();
  lsb_[0] = meta.accel_lsb_mps2;
  lsb_[1] = meta.gyro_lsb_rad_s;
  if (!(lsb_[0] > 0) || !(lsb_[1] > 0)) throw std::invalid_argument("tracker: log metadata has no accel/gyro LSB");
  std::size_t block = static_cast<std::size_t>(std::max(1.0, std::round(0.1 * meta.sample_rate_hz)));

  // Pass 1: noise from within-block scatter, and the segment's temperature slope (Ṫ).
  std::vector<const io::LogRow*> use;
  use.reserve(rows.size());
  for (const auto& r : rows)
    if (r.has_ref && std::isfinite(r.temp_C)) use.push_back(&r);
  if (use.size() < 2) return false;
  // Static step: the still samples are the pose detector's (one front end for every consumer).
  std::string still_note;
  {
    bool turning = false, ref_const = true;
    double tmin = use.front()->temp_C, tmax = tmin;
    for (auto* r : use) {
      for (int a = 0; a < 3; ++a) turning = turning || std::fabs(r->table_rate_rad_s[a]) > 1e-3;  // NaN: not logged
      for (int j = 0; j < 3; ++j) ref_const = ref_const && std::fabs(r->f_ref[j] - use.front()->f_ref[j]) < 1e-3;
      tmin = std::min(tmin, r->temp_C);
      tmax = std::max(tmax, r->temp_C);
    }
    if (!turning && ref_const && tmax - tmin < 0.5 && use.size() >= 10) {
      std::vector<io::LogRow> seg;
      seg.reserve(use.size());
      for (auto* r : use) seg.push_back(*r);
      poses::StillPart sp;
      try {
        sp = poses::still_part(poses::recording_from_rows(meta, seg, "segment '" + label + "'"));
      } catch (const poses::PoseError& e) {  // e.g. stream times out of order: judge nothing, keep every row
        sp.parts = {{0, use.size()}};
        sp.samples = sp.total = use.size();
        sp.reason = std::string("not judged: ") + e.what();
      }
      if (sp.rejected()) {
        rejections_.push_back({segment, label, sp.reason});
        return false;
      }
      std::vector<const io::LogRow*> kept;
      kept.reserve(sp.samples);
      for (const auto& [a, b] : sp.parts)
        for (std::size_t k = a; k < b; ++k) kept.push_back(use[k]);
      use.swap(kept);
      still_note = sp.reason;
    }
  }
  double st = 0, sT = 0, stt = 0, stT = 0, m = 0;
  for (auto* r : use) {
    st += r->t_s; sT += r->temp_C; stt += r->t_s * r->t_s; stT += r->t_s * r->temp_C; m += 1;
  }
  double den = m * stt - st * st;
  double tdot = den > 0 ? (m * stT - st * sT) / den : 0.0;

  // Noise: scatter of (y − u) about its segment mean, pooled over segments (dof N − 1 each). Works at any
  // sample rate (0.1 s blocks may hold a single sample) and in constant-rate runs alike.
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < 3; ++j) {
      double mean = 0;
      for (auto* r : use) mean += r->raw[3 * s + j] * lsb_[s] - (s ? r->w_ref[j] : r->f_ref[j]);
      mean /= static_cast<double>(use.size());
      double ss = 0;
      for (auto* r : use) {
        double e = r->raw[3 * s + j] * lsb_[s] - (s ? r->w_ref[j] : r->f_ref[j]) - mean;
        ss += e * e;
      }
      pooled_ss_[s] += ss;
      pooled_dof_[s] += static_cast<double>(use.size() - 1);
    }
  const double sigma[2] = {accel_noise(), gyro_noise()};
  bool accel_ok = true;
  for (auto* r : use)
    for (int j = 0; j < 3; ++j) accel_ok = accel_ok && std::fabs(r->f_ref[j] - use.front()->f_ref[j]) < 1e-3;

  // Pass 2: block rows into normal equations.
  solver::NormalEquations ne(n);
  Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, n);
  SegmentResidual res;
  res.segment = segment;
  res.label = label;
  res.t_s = use.front()->t_s;
  res.still_note = still_note;
  res.mean_j = Eigen::MatrixXd::Zero(6, n);
  double tsum = 0;
  std::size_t nblocks = 0;
  for (std::size_t b0 = 0; b0 < use.size(); b0 += block) {
    std::size_t b1 = std::min(use.size(), b0 + block);
    double cnt = static_cast<double>(b1 - b0);
    model::MeasureInput in;
    Eigen::Vector3d yA = Eigen::Vector3d::Zero(), yG = Eigen::Vector3d::Zero();
    in.f.setZero();
    in.w.setZero();
    double T = 0, t = 0;
    for (std::size_t i = b0; i < b1; ++i) {
      const io::LogRow& r = *use[i];
      for (int j = 0; j < 3; ++j) {
        in.f[j] += r.f_ref[j];
        in.w[j] += r.w_ref[j];
        yA[j] += r.raw[j] * lsb_[0];
        yG[j] += r.raw[3 + j] * lsb_[1];
      }
      T += r.temp_C;
      t += r.t_s;
    }
    in.f /= cnt; in.w /= cnt; yA /= cnt; yG /= cnt;
    in.T_C = T / cnt;
    in.t_s = t / cnt;
    in.Tdot_C_s = tdot;
    in.d = hyst_.update(in.T_C, in.t_s);
    tsum += in.T_C;
    ++nblocks;
    for (int s = accel_ok ? 0 : 1; s < 2; ++s) {
      Sensor sen = s ? Sensor::kGyro : Sensor::kAccel;
      model::regressors(sen, ids_, in, T_ref_C_, J);
      const Eigen::Vector3d& y = s ? yG : yA;
      const Eigen::Vector3d& u = s ? in.w : in.f;
      double w = cnt / (sigma[s] * sigma[s]);
      for (int j = 0; j < 3; ++j) {
        double e = y[j] - u[j];
        ne.add_row(J.row(j).transpose(), e, w);
        res.before[3 * s + j] += e * cnt;
        res.mean_j.row(3 * s + j) += J.row(j) * cnt;
      }
    }
  }
  double total = static_cast<double>(use.size());
  for (auto& b : res.before) b /= total;
  res.mean_j /= total;
  res.temp_C = tsum / static_cast<double>(nblocks);
  srif_.add_information(ne.info, ne.rhs);
  residuals_.push_back(std::move(res));
  return true;
}

Eigen::MatrixXd Tracker::predicted_information(const Eigen::Vector3d& f, const Eigen::Vector3d& w, double T_C,
                                               double duration_s, double rate_hz, bool accel_ok) const {
  const int n = size();
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
  model::MeasureInput in;
  in.f = f;
  in.w = w;
  in.T_C = T_C;
  Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, n);
  double samples = std::max(0.0, duration_s * rate_hz);
  const double sigma[2] = {accel_noise(), gyro_noise()};
  for (int s = accel_ok ? 0 : 1; s < 2; ++s) {
    model::regressors(s ? Sensor::kGyro : Sensor::kAccel, ids_, in, T_ref_C_, J);
    h += J.transpose() * J * (samples / (sigma[s] * sigma[s]));
  }
  return h;
}

Eigen::VectorXd Tracker::sigma_of(const Eigen::MatrixXd& info) const {
  Eigen::VectorXd z = Eigen::VectorXd::Zero(info.rows());
  solver::Estimate e = solver::solve_partial(info, z, names_);
  return e.sigma();
}

void Tracker::set_fixture_tolerance(const solver::FixtureTolerance& tol, const model::ModelSpec& spec,
                                    const physics::Campaign& campaign) {
  spec_ = spec;
  campaign_ = campaign;
  considered_.clear();
  std::vector<double> sig;
  for (const std::string& name : solver::fixture_nuisance_names(static_cast<int>(campaign.axes.size())))
    if (tol.sigma_of(name) > 0) {
      considered_.push_back(name);
      sig.push_back(tol.sigma_of(name));
    }
  considered_sigma_ = Eigen::Map<Eigen::VectorXd>(sig.data(), static_cast<Eigen::Index>(sig.size()));
  h_theta_eta_ = Eigen::MatrixXd::Zero(size(), static_cast<Eigen::Index>(considered_.size()));
}

void Tracker::add_fixture_segment(const std::string& segment_file) {
  if (considered_.empty() || !fixture_error_.empty()) return;
  const int n = size(), nc = static_cast<int>(considered_.size());
  const double a = accel_noise(), g = gyro_noise();
  const solver::Sigma6 sigma{a, a, a, g, g, g};
  try {
    io::LogReader r(segment_file);
    // Linearised at nominal (θ = 0, η = 0): H_θη of a linear model barely depends on θ.
    const Eigen::MatrixXd h = solver::fixture_joint_information(r, spec_, campaign_, considered_,
                                                                Eigen::VectorXd::Zero(n + nc), sigma);
    h_theta_eta_ += h.block(0, n, n, nc);
  } catch (const std::exception& e) {
    fixture_error_ = std::string("fixture tolerance not tracked: ") + e.what();
  }
}

Eigen::VectorXd Tracker::fixture_variance() const {
  const int n = size();
  if (considered_.empty() || !fixture_error_.empty() || segments() == 0) return Eigen::VectorXd::Zero(n);
  const Eigen::MatrixXd P = estimate().covariance;
  if (!P.allFinite()) return Eigen::VectorXd::Zero(n);
  const Eigen::MatrixXd ss = P * h_theta_eta_ * considered_sigma_.asDiagonal();
  return ss.rowwise().squaredNorm();
}

Eigen::VectorXd Tracker::honest_sigma() const {
  const Eigen::VectorXd s = estimate().sigma();
  const Eigen::VectorXd f = fixture_variance();
  Eigen::VectorXd h(s.size());
  for (Eigen::Index i = 0; i < s.size(); ++i) h[i] = std::isfinite(s[i]) ? std::sqrt(s[i] * s[i] + f[i]) : s[i];
  return h;
}

void Tracker::finalize_residuals(const Eigen::VectorXd& theta) {
  for (auto& r : residuals_) {
    if (r.mean_j.cols() != theta.size()) continue;
    Eigen::VectorXd pred = r.mean_j * theta;
    for (int k = 0; k < 6; ++k) r.after[static_cast<std::size_t>(k)] = r.before[static_cast<std::size_t>(k)] - pred[k];
  }
}

}  // namespace imuforge::eol
