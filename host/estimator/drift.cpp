#include "host/estimator/drift.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "host/estimator/estimator.h"
#include "host/estimator/stochastic.h"
#include "host/estimator/robust.h"

namespace imuforge::estimator {
namespace {

// An orthonormal basis of X's column space (REML depends on the columns only through that space: another
// basis shifts −2 log L_R by a constant). Columns are scaled to unit norm first so that units do not decide
// the rank.
Eigen::MatrixXd column_basis(const Eigen::MatrixXd& X) {
  if (X.cols() == 0 || X.rows() == 0) return Eigen::MatrixXd(X.rows(), 0);
  Eigen::MatrixXd Xs = X;
  for (Eigen::Index j = 0; j < Xs.cols(); ++j) {
    const double n = Xs.col(j).norm();
    if (n > 0) Xs.col(j) /= n;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Xs);
  qr.setThreshold(1e-10);
  const Eigen::Index r = qr.rank();
  Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(X.rows(), r);
  return Q;
}

// −2 log L_R on the rows [y | Q] through the shared whitening (stochastic.h): the Gauss-Markov wander and the
// flicker bank as its states, the per-dwell offset as a bias that is new in every dwell, the white variance of each
// mean added to the block's own.
double reml(const DwellSeries& s, const Eigen::MatrixXd& rows, const DwellDrift& d) {
  const Eigen::Index S = rows.rows(), r = rows.cols() - 1;
  StochasticModel m;
  if (d.gm_var > 0 && d.gm_tau_s > 0) {
    m.gm_sigma = std::sqrt(d.gm_var);
    m.gm_tau_s = d.gm_tau_s;
  }
  if (d.flicker_var > 0) {
    m.bank_sigma = std::sqrt(d.flicker_var);
    m.bank_tau_s = d.flicker_tau_s;
  }
  m.seg_bias_var = d.offset_var;
  // Zero durations: the wander is taken as constant over each dwell (drift.h says why).
  const std::vector<double> dur0(static_cast<size_t>(S), 0.0);
  double logS = 0.0;
  const NormalEquations ne =
      gls_normal_equations(m, s.t_s, dur0, rows, 0.0, nullptr, nullptr, &logS, nullptr, nullptr, &s.white_var);
  if (r == 0) return logS + ne.cost;
  // The columns' GLS fit on the estimator core, as the diagnosis's whole-log wander takes it: its kept columns'
  // information is cov⁻¹ (all of them: rows' columns are orthonormal).
  std::vector<int> cols(static_cast<size_t>(r));
  std::iota(cols.begin(), cols.end(), 0);
  const SubsetFit f = fit_subset(ne, cols);
  double logdet = 0.0;
  if (!f.kept.empty()) {
    const Eigen::LLT<Eigen::MatrixXd> llt(f.cov);
    for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) logdet -= 2.0 * std::log(llt.matrixL()(i, i));
  }
  return logS + f.rss + logdet;
}

Eigen::MatrixXd reml_rows(const DwellSeries& s, const Eigen::MatrixXd& Q) {
  Eigen::MatrixXd rows(s.y.size(), Q.cols() + 1);
  rows.col(0) = s.y;
  rows.rightCols(Q.cols()) = Q;
  return rows;
}

void check(const DwellSeries& s) {
  const size_t S = s.t_s.size();
  if (static_cast<size_t>(s.y.size()) != S || static_cast<size_t>(s.X.rows()) != S ||
      static_cast<size_t>(s.white_var.size()) != S)
    throw EstimatorError("dwell drift: the series' t, y, X and white variance differ in length");
  for (size_t i = 0; i < S; ++i) {
    if (!std::isfinite(s.t_s[i]) || (i > 0 && s.t_s[i] < s.t_s[i - 1]))
      throw EstimatorError("dwell drift: dwell times out of order at dwell " + std::to_string(i));
    if (!(s.white_var[static_cast<Eigen::Index>(i)] > 0) || !std::isfinite(s.white_var[static_cast<Eigen::Index>(i)]))
      throw EstimatorError("dwell drift: white variance of dwell " + std::to_string(i) + " is not positive");
  }
}

// Nelder-Mead minimum of f over R^n from x0 with initial steps h: the likelihood's ridges (for τ near the log's
// span only gm_var/τ is determined; a flicker bank and a Gauss-Markov term trade against each other) defeat a
// coordinate search. Stops after max_eval evaluations or when the simplex's values agree to 1e-4.
template <class F>
Eigen::VectorXd nelder_mead(F f, const Eigen::VectorXd& x0, double h, int max_eval, double& fbest) {
  const int n = static_cast<int>(x0.size());
  std::vector<Eigen::VectorXd> x(static_cast<size_t>(n + 1), x0);
  std::vector<double> fx(static_cast<size_t>(n + 1));
  for (int i = 0; i <= n; ++i) {
    if (i > 0) x[static_cast<size_t>(i)][i - 1] += h;
    fx[static_cast<size_t>(i)] = f(x[static_cast<size_t>(i)]);
  }
  int evals = n + 1;
  std::vector<size_t> o(static_cast<size_t>(n + 1));
  while (evals < max_eval) {
    for (size_t i = 0; i < o.size(); ++i) o[i] = i;
    std::sort(o.begin(), o.end(), [&](size_t a, size_t b) { return fx[a] < fx[b]; });
    const size_t lo = o.front(), hi = o.back(), nh = o[o.size() - 2];
    if (std::abs(fx[hi] - fx[lo]) < 1e-4) break;
    Eigen::VectorXd c = Eigen::VectorXd::Zero(n);
    for (size_t i = 0; i < x.size(); ++i)
      if (i != hi) c += x[i] / n;
    const Eigen::VectorXd xr = c + (c - x[hi]);
    const double fr = f(xr);
    ++evals;
    if (fr < fx[lo]) {
      const Eigen::VectorXd xe = c + 2.0 * (c - x[hi]);
      const double fe = f(xe);
      ++evals;
      if (fe < fr) { x[hi] = xe; fx[hi] = fe; } else { x[hi] = xr; fx[hi] = fr; }
    } else if (fr < fx[nh]) {
      x[hi] = xr; fx[hi] = fr;
    } else {
      const Eigen::VectorXd xc = c + 0.5 * (x[hi] - c);
      const double fc = f(xc);
      ++evals;
      if (fc < fx[hi]) {
        x[hi] = xc; fx[hi] = fc;
      } else {
        for (size_t i = 0; i < x.size(); ++i)
          if (i != lo) { x[i] = x[lo] + 0.5 * (x[i] - x[lo]); fx[i] = f(x[i]); ++evals; }
      }
    }
  }
  size_t bi = 0;
  for (size_t i = 1; i < fx.size(); ++i) if (fx[i] < fx[bi]) bi = i;
  fbest = fx[bi];
  return x[bi];
}

}  // namespace

double dwell_drift_reml(const DwellSeries& s, const DwellDrift& d) {
  check(s);
  return reml(s, reml_rows(s, column_basis(s.X)), d);
}

DwellDrift fit_dwell_drift(const DwellSeries& s) {
  check(s);
  DwellDrift out;
  const Eigen::Index S = s.y.size();
  out.dwells = static_cast<int>(S);
  const Eigen::MatrixXd Q = column_basis(s.X);
  const Eigen::MatrixXd rows = reml_rows(s, Q);
  out.rank = static_cast<int>(Q.cols());
  if (S < Q.cols() + 4) return out;

  std::vector<double> w(s.white_var.data(), s.white_var.data() + S);
  const double s0 = upper_median_in_place(w);
  std::vector<double> dt;
  for (size_t i = 1; i < s.t_s.size(); ++i)
    if (s.t_s[i] > s.t_s[i - 1]) dt.push_back(s.t_s[i] - s.t_s[i - 1]);
  const double span = s.t_s.back() - s.t_s.front();
  if (dt.empty() || !(span > 0)) return out;
  const double dt_med = upper_median_in_place(dt);
  const double lt_hi = std::log(span), lt_lo = std::log(std::max(dt_med / 4.0, 1e-3));
  // The flicker bank spans the scales the dwell means can show: from a quarter of their spacing to the span.
  const std::vector<double> bank = flicker_bank_taus(std::exp(lt_lo), span);

  // x = (ln gm_var, ln offset_var, ln τ, ln flicker_var), variances in units of s0 (a typical dwell mean's white
  // variance); a log variance below kNone is that term off.
  constexpr double kNone = -15.0;
  auto drift_of = [&](const Eigen::Vector4d& x) {
    DwellDrift d;
    if (x[0] > kNone) {
      d.gm_var = s0 * std::exp(std::min(x[0], 25.0));
      d.gm_tau_s = std::exp(x[2]);
    }
    if (x[1] > kNone) d.offset_var = s0 * std::exp(std::min(x[1], 25.0));
    if (x[3] > kNone && !bank.empty()) {
      d.flicker_var = s0 * std::exp(std::min(x[3], 25.0));
      d.flicker_tau_s = bank;
    }
    return d;
  };
  std::vector<std::pair<double, Eigen::Vector4d>> seen;  // every point evaluated, for the plausible set
  auto L = [&](const Eigen::Vector4d& x) {
    const DwellDrift d = drift_of(x);
    const double v = reml(s, rows, d);
    if (d.any()) seen.emplace_back(v, x);
    return v;
  };
  const double off = kNone - 1.0;
  const double L0 = L(Eigen::Vector4d(off, off, 0.0, off));
  double best = L0;
  Eigen::Vector4d xb(off, off, 0.0, off);
  auto consider = [&](const Eigen::Vector4d& x) {
    const double v = L(x);
    if (v < best) { best = v; xb = x; }
  };
  // Coarse grids: offsets alone; a Gauss-Markov wander (τ by factors of 2) with offsets; a flicker bank with offsets.
  for (double lb = -3.0; lb <= 18.0; lb += 3.0) consider(Eigen::Vector4d(off, lb, 0.0, off));
  for (double lt = lt_hi; lt >= lt_lo; lt -= std::log(2.0))
    for (double la = -3.0; la <= 18.0; la += 1.5)
      for (double lb : {off, -3.0, 0.0, 3.0, 6.0, 9.0, 12.0}) consider(Eigen::Vector4d(la, lb, lt, off));
  if (!bank.empty())
    for (double lf = -6.0; lf <= 15.0; lf += 1.5)
      for (double lb : {off, -3.0, 0.0, 3.0, 6.0, 9.0}) consider(Eigen::Vector4d(off, lb, 0.5 * (lt_lo + lt_hi), lf));
  // Refine jointly from the best grid point: a term that is off starts just below the level where it acts.
  if (best < L0) {
    Eigen::Vector4d x0 = xb;
    for (int k : {0, 1, 3})
      if (x0[k] <= kNone) x0[k] = -4.0;
    auto f = [&](const Eigen::VectorXd& x) {
      const double lt = std::clamp(x[2], lt_lo - 2.0, lt_hi);
      const double v = L(Eigen::Vector4d(x[0], x[1], lt, x[3]));
      return v + (lt != x[2] ? 1e3 * std::abs(lt - x[2]) : 0.0);  // stay in the searched τ range
    };
    double fb;
    const Eigen::VectorXd xn = nelder_mead(f, x0, 1.0, 400, fb);
    if (fb < best) {
      best = fb;
      xb = Eigen::Vector4d(xn[0], xn[1], std::clamp(xn[2], lt_lo - 2.0, lt_hi), xn[3]);
    }
  }
  const DwellDrift bd = drift_of(xb);
  out.offset_var = bd.offset_var;
  out.gm_var = bd.gm_var;
  out.gm_tau_s = bd.gm_tau_s;
  out.flicker_var = bd.flicker_var;
  out.flicker_tau_s = bd.flicker_tau_s;
  out.gain = std::max(0.0, L0 - best);
  out.adopted = out.gain > kDriftGainThreshold && out.any();
  if (out.adopted) {
    std::sort(seen.begin(), seen.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    auto near = [](double a, double b) { return std::abs(std::log((a + 1e-300) / (b + 1e-300))) < 0.05; };
    for (const auto& [v, x] : seen) {
      if (v > best + kDriftPlausible) break;
      const DwellDrift d = drift_of(x);
      // The Nelder-Mead path revisits near-copies of its best point; they add nothing to an envelope.
      bool dup = false;
      for (const DwellDrift& p : out.plausible)
        dup = dup || (near(p.gm_var, d.gm_var) && near(p.offset_var, d.offset_var) && near(p.gm_tau_s, d.gm_tau_s) &&
                      near(p.flicker_var, d.flicker_var));
      if (!dup) out.plausible.push_back(d);
      if (out.plausible.size() >= kDriftPlausibleMax) break;
    }
  }
  return out;
}

Eigen::MatrixXd drift_covariance_times(const DwellDrift& d, const std::vector<double>& t_s, const Eigen::MatrixXd& G) {
  const Eigen::Index S = G.rows();
  if (static_cast<Eigen::Index>(t_s.size()) != S) throw EstimatorError("dwell drift: times and rows differ in length");
  Eigen::MatrixXd out = d.offset_var * G;
  if (S == 0) return out;
  std::vector<std::pair<double, double>> states;  // {var, τ}: the wander, then the flicker bank's
  if (d.gm_var > 0 && d.gm_tau_s > 0) states.push_back({d.gm_var, d.gm_tau_s});
  if (d.flicker_var > 0)
    for (double T : d.flicker_tau_s) states.push_back({d.flicker_var, T});
  Eigen::MatrixXd fwd(S, G.cols());
  for (const auto& [var, tau] : states) {
    // Σ_j exp(−|t_i − t_j|/τ) G_j = forward part (j ≤ i) + backward part (j > i).
    Eigen::RowVectorXd acc = G.row(0);
    fwd.row(0) = acc;
    for (Eigen::Index i = 1; i < S; ++i) {
      const double e = std::exp(-(t_s[static_cast<size_t>(i)] - t_s[static_cast<size_t>(i - 1)]) / tau);
      acc = G.row(i) + e * acc;
      fwd.row(i) = acc;
    }
    Eigen::RowVectorXd back = Eigen::RowVectorXd::Zero(G.cols());
    for (Eigen::Index i = S - 1; i >= 0; --i) {
      out.row(i) += var * (fwd.row(i) + back);
      if (i > 0) {
        const double e = std::exp(-(t_s[static_cast<size_t>(i)] - t_s[static_cast<size_t>(i - 1)]) / tau);
        back = e * (G.row(i) + back);
      }
    }
  }
  return out;
}

Eigen::MatrixXd drift_covariance(const Eigen::MatrixXd& C0, const std::vector<ChannelDrift>& channels) {
  const Eigen::Index n = C0.rows();
  Eigen::MatrixXd out = C0;
  Eigen::VectorXd v_env = C0.diagonal();
  for (const ChannelDrift& ch : channels) {
    if (!ch.drift || !ch.t_s || !ch.drift->adopted) continue;
    const Eigen::Index p = static_cast<Eigen::Index>(ch.cols.size());
    if (ch.G.cols() != p) throw EstimatorError("dwell drift: G has " + std::to_string(ch.G.cols()) + " columns for " +
                                               std::to_string(p) + " parameters");
    if (p == 0) continue;
    Eigen::MatrixXd Cc(n, p);  // C0[:, cols]
    for (Eigen::Index j = 0; j < p; ++j) {
      const int k = ch.cols[static_cast<size_t>(j)];
      if (k < 0 || k >= n) throw EstimatorError("dwell drift: parameter index out of range");
      Cc.col(j) = C0.col(k);
    }
    const std::vector<DwellDrift> one{*ch.drift};
    const std::vector<DwellDrift>& set = ch.drift->plausible.empty() ? one : ch.drift->plausible;
    Eigen::VectorXd v_max = Eigen::VectorXd::Zero(n);
    Eigen::MatrixXd M_best;
    double widest = -1.0;
    for (const DwellDrift& d : set) {
      const Eigen::MatrixXd M = ch.G.transpose() * drift_covariance_times(d, *ch.t_s, ch.G);  // p × p
      const Eigen::MatrixXd CM = Cc * M;                                                     // n × p
      const Eigen::VectorXd v = (CM.array() * Cc.array()).rowwise().sum();                   // diag(Cc M Ccᵀ)
      v_max = v_max.cwiseMax(v);
      double w = 0.0;
      for (Eigen::Index k = 0; k < n; ++k)
        if (C0(k, k) > 0) w = std::max(w, v[k] / C0(k, k));
      if (w > widest) { widest = w; M_best = M; }
    }
    out += Cc * M_best * Cc.transpose();
    v_env += v_max;
  }
  out = 0.5 * (out + out.transpose());
  Eigen::VectorXd scale(n);
  for (Eigen::Index k = 0; k < n; ++k)
    scale[k] = out(k, k) > 0 ? std::sqrt(std::max(1.0, v_env[k] / out(k, k))) : 1.0;
  return scale.asDiagonal() * out * scale.asDiagonal();
}

}  // namespace imuforge::estimator
