#include "host/io/campaign_file.h"
#include "host/solver/fixture_errors.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>

#include "host/model/measure.h"
#include "host/physics/earth.h"
#include "host/physics/table.h"
#include "host/physics/timeline.h"

namespace imuforge::solver {

namespace {

using model::Sensor;

struct Nuisance {
  std::string name;
  int axis;   // table axis, or -1 for the mount
  int what;   // 0 tilt_a, 1 tilt_b, 2 zero; mount: component 0..2
};

// Every nuisance parameter of an n_axes table; the mount's three last.
std::vector<Nuisance> all_nuisance(int n_axes) {
  std::vector<Nuisance> nu;
  for (int a = 0; a < n_axes; ++a)
    for (int part = 0; part < 3; ++part) nu.push_back({physics::axis_error_name(a, part), a, part});
  for (int k = 0; k < 3; ++k) nu.push_back({std::string("fixture.mount.r") + "xyz"[k], -1, k});
  return nu;
}

physics::TableGeometry apply(const physics::TableGeometry& nominal, const std::vector<Nuisance>& nu, const Eigen::VectorXd& eta) {
  physics::TableGeometry g = nominal;
  for (size_t k = 0; k < nu.size(); ++k) {
    const Nuisance& n = nu[k];
    const double v = eta[static_cast<long>(k)];
    if (n.axis < 0) {
      g.mount.rot_error_rad[n.what] = v;
    } else {
      g.axes[static_cast<size_t>(n.axis)].error.part(n.what) = v;
    }
  }
  return g;
}

class FixtureErrorsProblem : public NonlinearProblem {
 public:
  FixtureErrorsProblem(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& c, std::vector<Nuisance> nu,
                       const Sigma6& sigma)
      : log_(log), spec_(spec), nu_(std::move(nu)), sigma_(sigma) {
    ids_all_ = spec.parameters();
    for (size_t i = 0; i < ids_all_.size(); ++i) {
      const int s = static_cast<int>(model::param_info(ids_all_[i]).sensor);
      ids_[static_cast<size_t>(s)].push_back(ids_all_[i]);
      pos_[static_cast<size_t>(s)].push_back(static_cast<int>(i));
    }
    for (const auto& e : spec.effects)
      if (e.per_plateau) throw SolverError("fixture+errors mode: per-plateau parameters are not supported; use polynomials");
    nominal_ = physics::geometry_from_campaign(c).nominal();
    physics::Site site;
    site.latitude_deg = c.latitude_deg;
    site.height_m = c.height_m;
    g_ned_ = physics::gravity_ned(site);
    wie_ned_ = physics::earth_rate_ned(site);
    for (model::ParamId id : ids_all_) has_temp_rate_ = has_temp_rate_ || model::param_info(id).effect == model::Effect::kTempRate;
    dTdt_window_s_ = dTdt_window_of(spec);
    dwell_guard_s_ = dwell_guard_of(spec);
    lsb_[0] = log.meta().accel_lsb_mps2;
    lsb_[1] = log.meta().gyro_lsb_rad_s;
    if (log.meta().table_axes != nominal_.n_axes)
      throw SolverError("fixture+errors: the log has " + std::to_string(log.meta().table_axes) +
                        " table angle columns but the campaign's table has " + std::to_string(nominal_.n_axes) + " axes");
  }
  int n_model() const { return static_cast<int>(ids_all_.size()); }
  int num_params() const override { return n_model() + static_cast<int>(nu_.size()); }
  long long samples() const { return samples_; }
  Sigma6 residual_rms() const { return rms_; }

  void linearize(const Eigen::VectorXd& x, NormalEquations& ne) const override {
    const int nm = n_model(), nn = static_cast<int>(nu_.size()), n = nm + nn;
    ne.reset(n);
    model::ParamSet ps;
    for (int i = 0; i < nm; ++i) ps[ids_all_[static_cast<size_t>(i)]] = x[i];
    const model::CompiledTriad ct[2] = {model::compile(ps, Sensor::kAccel, spec_.T_ref_C),
                                        model::compile(ps, Sensor::kGyro, spec_.T_ref_C)};
    const Eigen::VectorXd eta = x.tail(nn);
    constexpr double h = 1e-7;  // rad: central differences on the kinematics
    std::vector<physics::PreparedTable> tables;
    tables.emplace_back(apply(nominal_, nu_, eta));
    for (int k = 0; k < nn; ++k)
      for (double sgn : {1.0, -1.0}) {
        Eigen::VectorXd e2 = eta;
        e2[k] += sgn * h;
        tables.emplace_back(apply(nominal_, nu_, e2));
      }
    log_.rewind();
    model::HysteresisTracker hyst = logged_hysteresis_tracker(spec_);
    physics::TableState last{};
    bool have_last = false;
    std::vector<physics::ImuKinematics> kin(tables.size());
    Eigen::MatrixXd info = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd jrow(n);
    std::array<Eigen::Matrix<double, 3, Eigen::Dynamic>, 2> J;
    Eigen::Matrix<double, 3, Eigen::Dynamic> dn(3, nn);  // ∂prediction/∂nuisance of one triad
    for (int s = 0; s < 2; ++s) J[static_cast<size_t>(s)].resize(3, static_cast<long>(ids_[static_cast<size_t>(s)].size()));
    Sigma6 rss{};
    long long count = 0;
    dwell_sums_.clear();
    int cur_seg = -1;
    // Ṫ for temp_rate: the same streaming centred difference as fixture mode (rows come out delayed).
    std::optional<CenteredTempRate> tdot;
    if (has_temp_rate_) tdot.emplace(dTdt_window_s_);
    // The same dwell guard as fixture mode: dwell rows next to a reference change are left out.
    DwellGuard guard(dwell_guard_s_);
    auto process = [&](const io::LogRow& row, double Tdot_C_s, bool keep) {
      const double d = hyst.update(row.temp_C, row.t_s);
      if (row.segment < 0 || !row.has_ref || !keep) return;
      physics::TableState st{};
      bool ok = true;
      for (int a = 0; a < nominal_.n_axes; ++a) {
        st.angle_rad[static_cast<size_t>(a)] = row.table_angle_rad[a];
        st.rate_rad_s[static_cast<size_t>(a)] = row.table_rate_rad_s[a];
        ok = ok && std::isfinite(row.table_angle_rad[a]) && std::isfinite(row.table_rate_rad_s[a]);
      }
      if (!ok) return;
      if (!have_last || st.angle_rad != last.angle_rad || st.rate_rad_s != last.rate_rad_s) {
        for (size_t t = 0; t < tables.size(); ++t) kin[t] = physics::table_kinematics(tables[t], st, g_ned_, wie_ned_);
        last = st;
        have_last = true;
      }
      const double T = std::isfinite(row.temp_C) ? row.temp_C : spec_.T_ref_C;
      auto input = [&](const physics::ImuKinematics& k) {
        model::MeasureInput in;
        in.f = k.f_mps2;
        in.w = k.w_rad_s;
        in.wdot = k.wdot_rad_s2;
        in.T_C = T;
        in.d = d;
        in.t_s = row.t_s;
        in.Tdot_C_s = Tdot_C_s;
        return in;
      };
      const model::MeasureInput in0 = input(kin[0]);
      if (keep_dwell_sums_ && (dwell_sums_.empty() || row.segment != cur_seg)) {
        cur_seg = row.segment;
        dwell_sums_.emplace_back();
        for (DwellSums& ds : dwell_sums_.back()) ds.sphi = Eigen::VectorXd::Zero(n);
      }
      for (int s = 0; s < 2; ++s) {
        const auto& ids = ids_[static_cast<size_t>(s)];
        if (!ids.empty()) model::regressors(static_cast<Sensor>(s), ids, in0, spec_.T_ref_C, J[static_cast<size_t>(s)]);
        const Eigen::Vector3d p0 = model::measure(ct[s], in0);
        for (int k = 0; k < nn; ++k) {
          const Eigen::Vector3d pp = model::measure(ct[s], input(kin[static_cast<size_t>(1 + 2 * k)]));
          const Eigen::Vector3d pm = model::measure(ct[s], input(kin[static_cast<size_t>(2 + 2 * k)]));
          dn.col(k) = (pp - pm) / (2 * h);
        }
        for (int j = 0; j < 3; ++j) {
          const int c = 3 * s + j;
          jrow.setZero();
          for (size_t i = 0; i < ids.size(); ++i) jrow[pos_[static_cast<size_t>(s)][i]] = J[static_cast<size_t>(s)](j, static_cast<long>(i));
          jrow.tail(nn) = dn.row(j).transpose();
          const double r = row.raw[c] * lsb_[s] - p0[j];
          const double w = 1.0 / (sigma_[static_cast<size_t>(c)] * sigma_[static_cast<size_t>(c)]);
          info.selfadjointView<Eigen::Lower>().rankUpdate(jrow, w);
          ne.rhs.noalias() += (w * r) * jrow;
          ne.cost += w * r * r;
          rss[static_cast<size_t>(c)] += r * r;
          if (keep_dwell_sums_) {
            DwellSums& ds = dwell_sums_.back()[static_cast<size_t>(c)];
            ds.n += 1;
            ds.t_mid_s += row.t_s;  // a sum until the pass ends
            ds.sz += r;
            ds.sphi += jrow;
          }
        }
      }
      ++count;
    };
    auto guarded = [&](const io::LogRow& r, double q) { guard.feed(r, q, process); };
    io::LogRow row;
    while (log_.next(row)) {
      if (tdot) tdot->feed(row, guarded);
      else guarded(row, 0.0);
    }
    if (tdot) tdot->finish(guarded);
    guard.finish(process);
    ne.info = info.selfadjointView<Eigen::Lower>();
    ne.n_obs = 6 * count;
    samples_ = count;
    for (int c = 0; c < 6; ++c) rms_[static_cast<size_t>(c)] = count ? std::sqrt(rss[static_cast<size_t>(c)] / count) : 0.0;
    for (auto& d : dwell_sums_)
      for (DwellSums& ds : d) ds.t_mid_s /= static_cast<double>(std::max(1LL, ds.n));
  }
  // From the next linearize on, keep per dwell its residual and Jacobian-row sums (the LM iterations before the
  // solution need none).
  void keep_dwell_sums() { keep_dwell_sums_ = true; }
  // Per dwell (time order) and channel, at the last linearize after keep_dwell_sums(): residual sum, Jacobian-row
  // sum, n, mean time (the drift model's input; docs/calibration.md "Dwell drift").
  std::vector<DwellSums> dwell_sums(int c) const {
    std::vector<DwellSums> out;
    for (const auto& d : dwell_sums_)
      if (d[static_cast<size_t>(c)].n > 0) out.push_back(d[static_cast<size_t>(c)]);
    return out;
  }

 private:
  io::LogReader& log_;
  const model::ModelSpec& spec_;
  std::vector<Nuisance> nu_;
  Sigma6 sigma_;
  std::vector<model::ParamId> ids_all_;
  std::array<std::vector<model::ParamId>, 2> ids_;
  std::array<std::vector<int>, 2> pos_;
  physics::TableGeometry nominal_;
  Eigen::Vector3d g_ned_, wie_ned_;
  double lsb_[2];
  bool has_temp_rate_ = false;
  double dTdt_window_s_ = 10.0;
  double dwell_guard_s_ = kDefaultDwellGuard_s;
  mutable long long samples_ = 0;
  mutable Sigma6 rms_{};
  bool keep_dwell_sums_ = false;
  mutable std::vector<std::array<DwellSums, 6>> dwell_sums_;
};

// The gauge (fixture_errors.h). Works on the null space N (columns) of the unit-diagonal information at
// the start point, split into model rows N_m and nuisance rows N_u. Fixing a set F of nuisance
// parameters leaves the null directions with zero F-components: N·null(N_F).
//  1. A null direction with a model component means the data cannot tell that model combination from
//     fixture errors. The one legitimate case is the platform convention: with full misalignments of both
//     triads, a common rotation of their input axes (δM_a = δM_g = −[ε×]) is the same as rotating the
//     IMU on the platform. If the model part of the null space lies within those three rotation
//     generators, nuisance parameters (the mount first) are fixed until no model component is left; the
//     misalignments are then relative to the platform. Any other model component is a campaign
//     deficiency, reported by name: fixing a nuisance parameter there would silently move its true value
//     into the model estimates.
//  2. The remaining null directions are pure nuisance (a constant rotation passed from one gimbal to the
//     next): fixing any independent set of nuisance parameters spanning them changes no model estimate to
//     first order. Innermost axis first, the mount last, so the mount stays an output where it can.
struct GaugeDecision {
  std::vector<int> fixed;  // nuisance indices
};

// Columns spanning {c : a c = 0}, from the SVD of a.
Eigen::MatrixXd null_columns(const Eigen::MatrixXd& a, double tol) {
  const long k = a.cols();
  if (a.rows() == 0) return Eigen::MatrixXd::Identity(k, k);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  long r = 0;
  for (long i = 0; i < svd.singularValues().size(); ++i)
    if (svd.singularValues()[i] > tol) ++r;
  return svd.matrixV().rightCols(k - r);
}

// Number of singular values of a above tol.
long count_above(const Eigen::MatrixXd& a, double tol) { return a.cols() - null_columns(a, tol).cols(); }

GaugeDecision choose_gauge(const Eigen::MatrixXd& info, const std::vector<std::string>& names, int nm,
                           const std::vector<model::ParamId>& model_ids, const std::vector<Nuisance>& nu, double tol) {
  constexpr double kPart = 0.1;  // a unit null direction whose part in a subspace exceeds this lies in it
  const int n = static_cast<int>(info.rows()), nn = n - nm;
  GaugeDecision g;
  Eigen::VectorXd d(n), sqrt_h(n);
  for (int i = 0; i < n; ++i) {
    if (!(info(i, i) > 0) && i < nm)
      throw SolverError("fixture+errors: the campaign does not excite model parameter " + names[static_cast<size_t>(i)]);
    // A nuisance parameter without information (an axis that never moves) is a null direction by itself.
    sqrt_h[i] = info(i, i) > 0 ? std::sqrt(info(i, i)) : 0.0;
    d[i] = sqrt_h[i] > 0 ? 1.0 / sqrt_h[i] : 0.0;
  }
  Eigen::MatrixXd hs = d.asDiagonal() * info * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(hs);
  const double lmax = es.eigenvalues()[n - 1];
  int k = 0;
  while (k < n && es.eigenvalues()[k] <= tol * lmax) ++k;
  const Eigen::MatrixXd N = es.eigenvectors().leftCols(k);
  if (std::getenv("IMUFORGE_LM_DEBUG"))
    for (int j = 0; j < k; ++j) std::fprintf(stderr, "fixture+errors null: %s\n", format_combination(N.col(j), names).c_str());
  if (k == 0) return g;
  auto remaining = [&](const std::vector<int>& F) {
    Eigen::MatrixXd NF(static_cast<long>(F.size()), N.cols());
    for (size_t r = 0; r < F.size(); ++r) NF.row(static_cast<long>(r)) = N.row(nm + F[r]);
    return Eigen::MatrixXd(N * null_columns(NF, 0.05));
  };
  auto model_rank = [&](const Eigen::MatrixXd& basis) { return count_above(basis.topRows(nm), kPart); };
  bool platform = false;
  if (model_rank(N) > 0) {
    // The rotation generators, in scaled coordinates, where the model has every misalignment.
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(nm, 3);
    bool all = true;
    for (int s = 0; s < 2 && all; ++s)
      for (int j = 0; j < 3 && all; ++j)
        for (int kk = 0; kk < 3 && all; ++kk) {
          if (j == kk) continue;
          const std::string nmn = std::string(s ? "gyro" : "accel") + ".misalign." + "xyz"[j] + "xyz"[kk];
          const auto it = std::find(model_ids.begin(), model_ids.end(), model::find_param(nmn));
          if (it == model_ids.end()) {
            all = false;
            break;
          }
          const long row = static_cast<long>(it - model_ids.begin());
          // −[ε×](j,k) = ε_i with sign: (x,y) ↔ +ε_z, (y,x) ↔ −ε_z, ... (−[ε×] = [[0,ε_z,−ε_y],[−ε_z,0,ε_x],[ε_y,−ε_x,0]])
          const int i = 3 - j - kk;
          const double sign = ((j + 1) % 3 == kk) ? 1.0 : -1.0;
          G(row, i) = sign * sqrt_h[row];
        }
    Eigen::MatrixXd outside = N.topRows(nm);
    if (all) {
      const Eigen::HouseholderQR<Eigen::MatrixXd> qr(G);
      const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(nm, 3);
      outside -= Q * (Q.transpose() * outside);
    }
    if (count_above(outside, kPart) > 0) {
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(outside, Eigen::ComputeFullV);
      std::string msg;
      for (long j = 0; j < svd.singularValues().size(); ++j)
        if (svd.singularValues()[j] > kPart) msg += (msg.empty() ? "" : "; ") + format_combination(N * svd.matrixV().col(j), names);
      throw SolverError("fixture+errors: the campaign cannot separate fixture errors from the model: " + msg +
                        ". Add positions and rate runs that use every table axis at several angles of the others "
                        "(docs/calibration.md, 'Campaign design for fixture+errors'), or state measured fixture "
                        "properties with \"fixture_nuisance\": {\"assume_zero\": [...]} in the model");
    }
    platform = true;
  }
  // Fix nuisance parameters until no null direction is left: any independent set does (N_F nonsingular).
  // Order: innermost axis first and the mount last, so the mount stays an output where it can; the mount
  // first in the platform convention, whose misalignments are relative to the platform by definition.
  std::vector<int> order;
  for (int pass = 0; pass < 2; ++pass)
    for (int i = 0; i < nn; ++i)
      if ((nu[static_cast<size_t>(i)].axis < 0) == (platform ? pass == 0 : pass == 1)) order.push_back(i);
  long dim = N.cols();
  for (int i : order) {
    if (dim == 0) break;
    std::vector<int> F = g.fixed;
    F.push_back(i);
    const long dim2 = remaining(F).cols();
    if (dim2 < dim) {
      g.fixed = F;
      dim = dim2;
    }
  }
  if (dim > 0) throw SolverError("fixture+errors: internal: could not choose a gauge for the nuisance parameters");
  return g;
}

}  // namespace

FixtureErrorsResult solve_fixture_errors(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& c,
                                         const FixtureErrorsOptions& opt) {
  // Pass 0: the plain fixture solution (initial model values) and the within-dwell noise.
  FixtureAccumulator acc(spec, log.meta());
  io::LogRow row;
  log.rewind();
  while (log.next(row)) acc.add(row);
  acc.finish();
  const Sigma6 sigma = acc.static_noise_sigma();
  std::vector<Nuisance> nu = all_nuisance(static_cast<int>(c.axes.size()));
  if (!opt.mount) nu.resize(nu.size() - 3);
  const int nm = static_cast<int>(spec.parameters().size());
  Eigen::VectorXd theta0 = Eigen::VectorXd::Zero(nm);
  try {
    theta0 = solve_fixture(acc, sigma).estimate.value;
  } catch (const SolverError&) {
    // The plain fixture problem may be ill-posed on its own; start from zero.
  }
  FixtureErrorsResult res;
  // Nuisance parameters the user asserts are zero (a trusted, measured fixture property).
  for (const std::string& name : opt.assume_zero) {
    auto it = std::find_if(nu.begin(), nu.end(), [&](const Nuisance& n) { return n.name == name; });
    if (it == nu.end()) throw SolverError("fixture_nuisance.assume_zero: unknown nuisance parameter '" + name + "'");
    res.assumed_zero.push_back(name);
    nu.erase(it);
  }
  std::vector<std::string> names;
  for (model::ParamId id : spec.parameters()) names.push_back(model::param_info(id).name);
  for (const auto& n : nu) names.push_back(n.name);
  {
    FixtureErrorsProblem prob(log, spec, c, nu, sigma);
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(prob.num_params());
    x0.head(nm) = theta0;
    NormalEquations ne(prob.num_params());
    prob.linearize(x0, ne);
    const GaugeDecision g = choose_gauge(ne.info, names, nm, spec.parameters(), nu, opt.gauge_tolerance);
    for (int k : g.fixed) res.fixed.push_back(nu[static_cast<size_t>(k)].name);
    std::vector<Nuisance> keep;
    for (int k = 0; k < static_cast<int>(nu.size()); ++k)
      if (std::find(g.fixed.begin(), g.fixed.end(), k) == g.fixed.end()) keep.push_back(nu[static_cast<size_t>(k)]);
    nu = keep;
  }
  FixtureErrorsProblem prob(log, spec, c, nu, sigma);
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(prob.num_params());
  x0.head(nm) = theta0;
  LmOptions lo;
  lo.max_iterations = opt.max_iterations;
  // Central differences leave ~1e-5 σ of Jacobian noise: ask for steps below 1e-4 σ, not rounding level.
  lo.step_tolerance_sq = 1e-8;
  const LmResult lm = levenberg_marquardt(prob, x0, lo);
  if (!lm.converged) throw SolverError("fixture+errors: Levenberg-Marquardt did not converge in " +
                                       std::to_string(lm.iterations) + " iterations");
  res.mount_estimated = std::count_if(nu.begin(), nu.end(), [](const Nuisance& n) { return n.axis < 0; }) == 3;
  names.resize(static_cast<size_t>(nm));
  for (const auto& n : nu) {
    names.push_back(n.name);
    res.nuisance_names.push_back(n.name);
  }
  res.estimate.names = names;
  res.estimate.value = lm.theta;
  res.estimate.covariance = covariance_from_information(lm.normal.info, names, &res.observability);
  res.iterations = lm.iterations;
  res.noise_sigma = sigma;
  NormalEquations tmp(prob.num_params());
  prob.keep_dwell_sums();
  prob.linearize(lm.theta, tmp);  // residual RMS and the dwells' sums at the solution
  res.residual_rms = prob.residual_rms();
  res.samples = prob.samples();
  // As in fixture mode: the covariance carries the drift between dwells (docs/calibration.md, "Dwell drift"), on
  // the residuals at the solution and the joint Jacobian (model and nuisance parameters).
  if (dwell_scatter_of(spec)) {
    std::array<DwellDriftInput, kNumChannels> in;
    for (int c = 0; c < kNumChannels; ++c) {
      const std::vector<DwellSums> dw = prob.dwell_sums(c);
      if (!dw.empty()) in[static_cast<size_t>(c)] = dwell_drift_input(dw, sigma[static_cast<size_t>(c)]);
    }
    res.drifts = fit_drifts(in);
    res.estimate.covariance = drift_widened_covariance(in, res.estimate.covariance, res.drifts);
  }
  return res;
}

std::vector<std::string> fixture_nuisance_names(int n_axes) {
  std::vector<std::string> names;
  for (const Nuisance& n : all_nuisance(n_axes)) names.push_back(n.name);
  return names;
}

Eigen::MatrixXd fixture_joint_information(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& c,
                                          const std::vector<std::string>& nuisance, const Eigen::VectorXd& x,
                                          const Sigma6& sigma) {
  const std::vector<Nuisance> all = all_nuisance(static_cast<int>(c.axes.size()));
  std::vector<Nuisance> nu;
  for (const std::string& name : nuisance) {
    auto it = std::find_if(all.begin(), all.end(), [&](const Nuisance& n) { return n.name == name; });
    if (it == all.end()) throw SolverError("unknown fixture nuisance parameter '" + name + "'");
    nu.push_back(*it);
  }
  FixtureErrorsProblem prob(log, spec, c, nu, sigma);
  if (x.size() != prob.num_params()) throw SolverError("fixture_joint_information: x has the wrong size");
  NormalEquations ne(prob.num_params());
  prob.linearize(x, ne);
  return ne.info;
}

FixtureErrorsResult solve_fixture_errors(io::LogReader& log, const model::ModelSpec& spec, const std::string& campaign_path) {
  physics::Campaign c;
  try {
    c = io::load_campaign(campaign_path);
  } catch (const std::exception& e) {
    throw SolverError("campaign '" + campaign_path + "': " + e.what());
  }
  FixtureErrorsOptions o;
  if (auto it = spec.extra.find("fixture_nuisance"); it != spec.extra.end()) {
    if (!it->is_object()) throw SolverError("model: \"fixture_nuisance\" must be an object");
    for (auto kv = it->begin(); kv != it->end(); ++kv) {
      if (kv.key() == "mount") {
        if (!kv.value().is_boolean()) throw SolverError("model: fixture_nuisance.mount must be true or false");
        o.mount = kv.value().get<bool>();
      } else if (kv.key() == "assume_zero") {
        if (!kv.value().is_array()) throw SolverError("model: fixture_nuisance.assume_zero must be a list of names");
        for (const auto& v : kv.value()) {
          if (!v.is_string()) throw SolverError("model: fixture_nuisance.assume_zero must be a list of names");
          o.assume_zero.push_back(v.get<std::string>());
        }
      } else if (kv.key().empty() || kv.key()[0] != '_') {
        throw SolverError("model: fixture_nuisance: unknown key '" + kv.key() + "' (expected mount, assume_zero)");
      }
    }
  }
  return solve_fixture_errors(log, spec, c, o);
}

}  // namespace imuforge::solver
