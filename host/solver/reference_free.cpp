#include "host/solver/reference_free.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <Eigen/Geometry>

#include "host/model/catalog.h"
#include "host/poses/gravity_fit.h"

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
const char* const* kAccNames = poses::kGravityFitNames;
const char* kGyroNames[9] = {"gyro.scale.x",    "gyro.scale.y",    "gyro.scale.z",    "gyro.misalign.xy", "gyro.misalign.xz",
                             "gyro.misalign.yx", "gyro.misalign.yz", "gyro.misalign.zx", "gyro.misalign.zy"};

TriadCal accel_cal(const Eigen::VectorXd& p) {
  poses::GravityFit f;
  f.p = p;
  TriadCal c;
  c.b = f.bias();
  c.IM = f.im();
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

}  // namespace

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

poses::GravityFit accel_fit_from_estimate(const Estimate& e) {
  poses::GravityFit f;
  for (int k = 0; k < 9; ++k) {
    const int i = e.index_of(kAccNames[k]);
    f.active[static_cast<std::size_t>(k)] = i >= 0;
    if (i >= 0) f.p[k] = e.value[i];
  }
  for (const char* up : {"accel.misalign.xy", "accel.misalign.xz", "accel.misalign.yz"}) {
    const int i = e.index_of(up);
    if (i >= 0 && e.value[i] != 0.0)
      throw SolverError(std::string("accelerometer calibration with ") + up + " != 0: not a gravity-fit gauge");
  }
  std::vector<double> q;
  for (model::ParamId id : poses::gravity_candidate_terms()) {
    const int i = e.index_of(model::param_info(id).name);
    if (i < 0) continue;
    f.extra.push_back(id);
    q.push_back(e.value[i]);
  }
  f.q = Eigen::Map<Eigen::VectorXd>(q.data(), static_cast<long>(q.size()));
  return f;
}

namespace {
bool clipped_in(const RawRecording& rec, std::size_t i0, std::size_t i1) {
  if (rec.gyro_clipped.empty()) return false;
  for (std::size_t k = i0; k <= i1 && k < rec.gyro_clipped.size(); ++k)
    if (rec.gyro_clipped[k]) return true;
  return false;
}
}  // namespace

RotationCheck rotation_check(const RawRecording& rec, const Estimate& cal, const poses::DetectOptions& det) {
  RotationCheck rc = rotation_check(rec, triad_from_estimate(cal, "gyro"), det);
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
    jac[static_cast<long>(a)] = (rotation_check(rec, triad_from_estimate(p, "gyro"), det).angle_deg -
                                 rotation_check(rec, triad_from_estimate(m, "gyro"), det).angle_deg) / (2 * h);
  }
  Eigen::MatrixXd c(jac.size(), jac.size());
  for (long a = 0; a < jac.size(); ++a)
    for (long b = 0; b < jac.size(); ++b) c(a, b) = cal.covariance(idx[static_cast<size_t>(a)], idx[static_cast<size_t>(b)]);
  rc.angle_sigma_deg = std::sqrt(std::max(0.0, jac.dot(c * jac)));
  return rc;
}

RotationCheck rotation_check(const RawRecording& rec, const TriadCal& gyro, const poses::DetectOptions& det) {
  const auto iv = poses::detect_poses(rec, det).poses;
  if (iv.empty()) throw SolverError("rotation check: no static interval to take the gyro bias from");
  if (rec.clipped_samples > 0)
    throw SolverError("rotation check: " + std::to_string(rec.clipped_samples) +
                      " gyro samples at a full-scale limit of the " + std::to_string(rec.gyro_bits) +
                      "-bit raw word; the integrated angle would be short");
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
  return solve_reference_free(std::vector<const RawRecording*>{&rec}, spec, opt);
}

ReferenceFreeResult solve_reference_free(const std::vector<const RawRecording*>& recs, const model::ModelSpec& spec,
                                         const ReferenceFreeOptions& opt) {
  if (recs.empty()) throw SolverError("reference-free mode: no recording");
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
  const double g = recs.front()->gravity_mps2;
  res.gravity_mps2 = g;
  for (const RawRecording* r : recs)
    if (std::abs(r->gravity_mps2 - g) > 1e-6 * g)
      throw SolverError("reference-free mode: the recordings state different gravity (" + std::to_string(g) + " vs " +
                        std::to_string(r->gravity_mps2) + " m/s²); one unit calibrated together needs one site");

  // 1-2: the shared front end: static poses, then the gravity-magnitude accelerometer fit.
  const int na = static_cast<int>(std::count(acc_active.begin(), acc_active.end(), true));
  // Poses of every recording, in order; owner[i] = the recording pose i comes from.
  std::vector<std::size_t> owner;
  for (std::size_t r = 0; r < recs.size(); ++r) {
    poses::Detection d = poses::detect_poses(*recs[r], opt.detect);
    for (const auto& p : d.poses) {
      res.intervals.push_back(p);
      owner.push_back(r);
    }
    if (r == 0) res.detection = std::move(d);
  }
  const int need = std::max(opt.min_intervals, na + 1);
  if (static_cast<int>(res.intervals.size()) < need)
    throw SolverError("reference-free mode: " + std::to_string(res.intervals.size()) + " static poses found, " +
                      std::to_string(need) + " needed; the recording needs more still poses of >= " +
                      std::to_string(opt.detect.min_dwell_s) + " s (--explain-poses shows what was rejected and why)");
  std::array<bool, 9> act9{};
  for (int k = 0; k < 9; ++k) act9[static_cast<size_t>(k)] = acc_active[static_cast<size_t>(k)];
  // Extra catalog terms only where they predict withheld poses better (never on in-sample gain).
  poses::GravityFit best;
  if (opt.select_terms && !opt.for_table) {
    poses::TermSelection ts = poses::select_gravity_terms(res.intervals, g, act9, opt.term_select);
    best = std::move(ts.fit);
    for (model::ParamId id : ts.added) res.terms_added.push_back(model::param_info(id).name);
    res.terms_tried = ts.tried;
    res.terms_note = ts.note;
    if (ts.tried) {
      res.heldout_rms_basic = ts.heldout_rms.front();
      res.heldout_rms_selected = ts.heldout_rms.back();
    }
  } else {
    best = poses::fit_gravity(res.intervals, g, act9);
    res.terms_note = opt.for_table ? "not tried: the coefficient table v1 cannot express the extra terms"
                                   : "not tried: switched off";
  }
  res.accel_fit = best;
  const int nx = static_cast<int>(best.extra.size());
  const auto& iv = res.intervals;
  res.gravity_rms_before = best.rms_before;
  res.gravity_rms_after = best.rms_after;
  const TriadCal acal = accel_cal(best.p);
  const Eigen::Matrix3d ainv = acal.IM.inverse();

  // 3: gyro bias from the static intervals (sample-weighted), σ from the scatter between intervals.
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  double nsum = 0;
  for (const auto& s : iv) {
    const double w = static_cast<double>(s.samples);
    bg += w * s.gyro;
    nsum += w;
  }
  bg /= nsum;
  // Turn-on bias differs at every power-up: each recording's transitions are integrated about its own.
  std::vector<Eigen::Vector3d> bg_rec(recs.size(), Eigen::Vector3d::Zero());
  {
    std::vector<double> wr(recs.size(), 0.0);
    for (std::size_t i = 0; i < iv.size(); ++i) {
      bg_rec[owner[i]] += static_cast<double>(iv[i].samples) * iv[i].gyro;
      wr[owner[i]] += static_cast<double>(iv[i].samples);
    }
    for (std::size_t r = 0; r < recs.size(); ++r) bg_rec[r] = wr[r] > 0 ? Eigen::Vector3d(bg_rec[r] / wr[r]) : bg;
  }
  Eigen::Vector3d bvar = Eigen::Vector3d::Zero();
  for (const auto& s : iv) bvar += (s.gyro - bg).cwiseAbs2();
  bvar /= static_cast<double>(iv.size() - 1) * static_cast<double>(iv.size());

  // 4: gyro scale/misalignment from the gravity direction across transitions.
  const int ng = static_cast<int>(std::count(gyro_active.begin(), gyro_active.end(), true));
  const Eigen::VectorXd pa = best.p;
  auto gfull = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd p = Eigen::VectorXd::Zero(9);
    for (int k = 0, a = 0; k < 9; ++k)
      if (gyro_active[static_cast<size_t>(k)]) p[k] = x[a++];
    return p;
  };
  std::vector<size_t> used;  // transitions i -> i+1 without a clipped gyro sample
  int transitions = 0;
  for (size_t i = 0; i + 1 < iv.size(); ++i) {
    if (owner[i] != owner[i + 1]) continue;  // no transition between two recordings
    ++transitions;
    if (!clipped_in(*recs[owner[i]], iv[i].end - 1, iv[i + 1].begin)) used.push_back(i);
  }
  res.transitions_used = static_cast<int>(used.size());
  res.transitions_clipped = transitions - static_cast<int>(used.size());
  // The residual as a function of the gyro unknowns AND the upstream estimates it is conditioned on
  // (accelerometer parameters through the gravity directions, gyro bias through the integration).
  auto gres_at = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& pa9, const Eigen::Vector3d& bias) {
    poses::GravityFit ac = best;  // with its extras
    ac.p = pa9;
    std::vector<Eigen::Vector3d> gdir;
    for (const auto& s : iv) gdir.push_back(ac.apply(s.acc).normalized());
    const TriadCal c = gyro_cal(gfull(x), bias);
    const Eigen::Matrix3d inv = c.IM.inverse();
    Eigen::VectorXd e(3 * static_cast<long>(used.size()));
    for (size_t u = 0; u < used.size(); ++u) {
      const size_t i = used[u];
      const Eigen::Vector3d b_rec = bg_rec[owner[i]] + (c.b - bg);
      const Eigen::Matrix3d r = integrate_with(*recs[owner[i]], inv, b_rec, iv[i].end - 1, iv[i + 1].begin);
      e.segment<3>(3 * static_cast<long>(u)) = r.transpose() * gdir[i] - gdir[i + 1];
    }
    return e;
  };
  auto gres = [&](const Eigen::VectorXd& x) { return gres_at(x, pa, bg); };
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
      Eigen::VectorXd pp = pa, pm = pa;
      pp[k] += h;
      pm[k] -= h;
      ju.col(a++) = (gres_at(gtheta, pp, bg) - gres_at(gtheta, pm, bg)) / (2 * h);
    }
    for (int j = 0; j < 3; ++j) {
      const double h = 1e-6;
      Eigen::Vector3d bp = bg, bm = bg;
      bp[j] += h;
      bm[j] -= h;
      ju.col(na + j) = (gres_at(gtheta, pa, bp) - gres_at(gtheta, pa, bm)) / (2 * h);
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
  for (int x = 0; x < nx; ++x) {
    names.push_back(model::param_info(best.extra[static_cast<size_t>(x)]).name);
    values.push_back(best.q[x]);
    src.emplace_back(0, 9 + x);
  }
  for (int j = 0; j < 3; ++j) {
    const std::string n = std::string("gyro.bias.") + kAx[j];
    if (want(n)) { names.push_back(n); values.push_back(bg[j]); src.emplace_back(1, j); }
  }
  for (int k = 0; k < 9; ++k)
    if (gyro_active[static_cast<size_t>(k)]) { names.push_back(kGyroNames[k]); values.push_back(gp9[k]); src.emplace_back(2, k); }
  const int n = static_cast<int>(names.size());
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(n, n);
  // Map each block's active index to the output index.
  std::vector<int> acc_pos(static_cast<size_t>(9 + nx), -1), gyr_pos(9, -1);
  for (int k = 0, a = 0; k < 9; ++k) if (acc_active[static_cast<size_t>(k)]) acc_pos[static_cast<size_t>(k)] = a++;
  for (int x = 0; x < nx; ++x) acc_pos[static_cast<size_t>(9 + x)] = na + x;  // the extras follow in best.info
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
    // The marginal covariance of the basic accelerometer block (the extras, if any, are integrated out).
    if (na > 0) cu.topLeftCorner(na, na) = best.info.ldlt().solve(Eigen::MatrixXd::Identity(na + nx, na + nx)).topLeftCorner(na, na);
    for (int j = 0; j < 3; ++j) cu(na + j, na + j) = bvar[j];
    const Eigen::MatrixXd dcu = dgu * cu;
    const Eigen::MatrixXd add = dcu * dgu.transpose();
    auto upos = [&](int i) {  // index of output i in u, or −1
      const auto [b, k] = src[static_cast<size_t>(i)];
      // The extras (k ≥ 9) are not in u: the gyro fit was linearised about the basic block only.
      return b == 0 ? (k < 9 ? acc_pos[static_cast<size_t>(k)] : -1) : b == 1 ? na + k : -1;
    };
    for (int i = 0; i < n; ++i) {
      const auto [bi, ki] = src[static_cast<size_t>(i)];
      if (bi != 2) continue;
      const int gi = gyr_pos[static_cast<size_t>(ki)];
      for (int l = 0; l < n; ++l) {
        const auto [bl, kl] = src[static_cast<size_t>(l)];
        if (bl == 2) {
          res.estimate.covariance(i, l) += add(gi, gyr_pos[static_cast<size_t>(kl)]);
        } else if (upos(l) >= 0) {
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
  for (std::size_t pi = 0; pi < iv.size(); ++pi) {
    const auto& s = iv[pi];
    const RawRecording& rec = *recs[owner[pi]];
    Eigen::Vector3d ma = ainv * (s.acc - acal.b), mg = ginv * (s.gyro - gcal.b);
    for (const auto& [pb, pe] : s.parts)
    for (std::size_t k = pb; k < pe; ++k) {
      const auto& y = rec.y[k];
      const Eigen::Vector3d a = ainv * (Eigen::Vector3d(y[0], y[1], y[2]) - acal.b) - ma;
      const Eigen::Vector3d w = ginv * (Eigen::Vector3d(y[3], y[4], y[5]) - gcal.b) - mg;
      for (int c = 0; c < 3; ++c) {
        ss[static_cast<size_t>(c)] += a[c] * a[c];
        ss[static_cast<size_t>(3 + c)] += w[c] * w[c];
      }
    }
    cnt += static_cast<double>(s.samples - 1);
  }
  for (int c = 0; c < 6; ++c) res.residual_rms[static_cast<size_t>(c)] = std::sqrt(ss[static_cast<size_t>(c)] / std::max(1.0, cnt));
  return res;
}

nlohmann::json reference_free_summary(const ReferenceFreeResult& r, const RawRecording& rec) {
  return {{"static_poses", r.intervals.size()},
          {"gravity_mps2", r.gravity_mps2},
          {"gravity_source", rec.gravity_source},
          {"gravity_rms_before_mps2", r.gravity_rms_before},
          {"gravity_rms_after_mps2", r.gravity_rms_after},
          {"gravity_direction_rms_before", r.rotation_rms_before},
          {"gravity_direction_rms_after", r.rotation_rms_after},
          {"transitions_used", r.transitions_used},
          {"transitions_clipped", r.transitions_clipped},
          {"gyro_bits", rec.gyro_bits},
          {"accel_bits", rec.accel_bits},
          {"gauge_fixed_zero", r.gauge_fixed},
          {"term_selection",
           {{"tried", r.terms_tried},
            {"added", r.terms_added},
            {"heldout_rms_basic_mps2", r.heldout_rms_basic},
            {"heldout_rms_selected_mps2", r.heldout_rms_selected},
            {"folds", poses::kHeldoutFolds},
            {"note", r.terms_note}}}};
}

}  // namespace imuforge::solver
