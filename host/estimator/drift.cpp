#include "host/estimator/drift.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "host/estimator/estimator.h"

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

double reml(const std::vector<double>& t, const Eigen::VectorXd& y, const Eigen::MatrixXd& Q, const Eigen::VectorXd& w,
            double offset_var, double gm_var, double tau_s) {
  const Eigen::Index S = y.size(), r = Q.cols();
  const bool gm = gm_var > 0 && tau_s > 0;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(r + 1, r + 1);
  Eigen::VectorXd xhat = Eigen::VectorXd::Zero(r + 1), v(r + 1);
  double P = gm ? gm_var : 0.0, logdet = 0.0;
  for (Eigen::Index i = 0; i < S; ++i) {
    if (gm && i > 0) {
      const double phi = std::exp(-(t[static_cast<size_t>(i)] - t[static_cast<size_t>(i - 1)]) / tau_s);
      xhat *= phi;
      P = phi * phi * P + gm_var * (1.0 - phi * phi);
    }
    const double R = w[i] + offset_var;
    const double F = P + R;
    v[0] = y[i];
    v.tail(r) = Q.row(i).transpose();
    v -= xhat;
    logdet += std::log(F);
    M.selfadjointView<Eigen::Lower>().rankUpdate(v, 1.0 / F);
    if (gm) {
      xhat += (P / F) * v;
      P = P * R / F;
    }
  }
  if (r == 0) return logdet + M(0, 0);
  const Eigen::MatrixXd Mxx = M.bottomRightCorner(r, r).selfadjointView<Eigen::Lower>();
  const Eigen::VectorXd mxy = M.col(0).tail(r);
  const Eigen::LLT<Eigen::MatrixXd> llt(Mxx);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const Eigen::MatrixXd L = llt.matrixL();
  const double logdet_x = 2.0 * L.diagonal().array().log().sum();
  const double chi2 = M(0, 0) - mxy.dot(llt.solve(mxy));
  return logdet + logdet_x + chi2;
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

// Nelder-Mead minimum of f over R^3 from x0 with initial steps h: the likelihood's ridge (for τ past the log's
// span only gm_var/τ is determined) defeats a coordinate search. Stops after max_eval evaluations or when the
// simplex's values agree to 1e-4.
template <class F>
Eigen::Vector3d nelder_mead(F f, const Eigen::Vector3d& x0, double h, int max_eval, double& fbest) {
  std::array<Eigen::Vector3d, 4> x;
  std::array<double, 4> fx;
  for (int i = 0; i < 4; ++i) {
    x[static_cast<size_t>(i)] = x0;
    if (i > 0) x[static_cast<size_t>(i)][i - 1] += h;
    fx[static_cast<size_t>(i)] = f(x[static_cast<size_t>(i)]);
  }
  int evals = 4;
  while (evals < max_eval) {
    std::array<int, 4> o{0, 1, 2, 3};
    std::sort(o.begin(), o.end(), [&](int a, int b) { return fx[static_cast<size_t>(a)] < fx[static_cast<size_t>(b)]; });
    const size_t lo = static_cast<size_t>(o[0]), hi = static_cast<size_t>(o[3]), nh = static_cast<size_t>(o[2]);
    if (std::abs(fx[hi] - fx[lo]) < 1e-4) break;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < 4; ++i)
      if (i != hi) c += x[i] / 3.0;
    const Eigen::Vector3d xr = c + (c - x[hi]);
    const double fr = f(xr);
    ++evals;
    if (fr < fx[lo]) {
      const Eigen::Vector3d xe = c + 2.0 * (c - x[hi]);
      const double fe = f(xe);
      ++evals;
      if (fe < fr) { x[hi] = xe; fx[hi] = fe; } else { x[hi] = xr; fx[hi] = fr; }
    } else if (fr < fx[nh]) {
      x[hi] = xr; fx[hi] = fr;
    } else {
      const Eigen::Vector3d xc = c + 0.5 * (x[hi] - c);
      const double fc = f(xc);
      ++evals;
      if (fc < fx[hi]) {
        x[hi] = xc; fx[hi] = fc;
      } else {
        for (size_t i = 0; i < 4; ++i)
          if (i != lo) { x[i] = x[lo] + 0.5 * (x[i] - x[lo]); fx[i] = f(x[i]); ++evals; }
      }
    }
  }
  size_t b = 0;
  for (size_t i = 1; i < 4; ++i) if (fx[i] < fx[b]) b = i;
  fbest = fx[b];
  return x[b];
}

}  // namespace

double dwell_drift_reml(const DwellSeries& s, const DwellDrift& d) {
  check(s);
  return reml(s.t_s, s.y, column_basis(s.X), s.white_var, d.offset_var, d.gm_var, d.gm_tau_s);
}

DwellDrift fit_dwell_drift(const DwellSeries& s) {
  check(s);
  DwellDrift out;
  const Eigen::Index S = s.y.size();
  out.dwells = static_cast<int>(S);
  const Eigen::MatrixXd Q = column_basis(s.X);
  out.rank = static_cast<int>(Q.cols());
  if (S < Q.cols() + 4) return out;

  std::vector<double> w(s.white_var.data(), s.white_var.data() + S);
  std::nth_element(w.begin(), w.begin() + S / 2, w.end());
  const double s0 = w[static_cast<size_t>(S / 2)];
  std::vector<double> dt;
  for (size_t i = 1; i < s.t_s.size(); ++i)
    if (s.t_s[i] > s.t_s[i - 1]) dt.push_back(s.t_s[i] - s.t_s[i - 1]);
  const double span = s.t_s.back() - s.t_s.front();

  std::vector<std::pair<double, DwellDrift>> seen;  // every drift evaluated, for the plausible set
  auto L = [&](double la, double lb, double lt) {
    const double a = std::isfinite(la) ? s0 * std::exp(la) : 0.0;
    const double b = std::isfinite(lb) ? s0 * std::exp(lb) : 0.0;
    const double v = reml(s.t_s, s.y, Q, s.white_var, b, a, std::exp(lt));
    if (a > 0 || b > 0) {
      DwellDrift d;
      d.offset_var = b;
      d.gm_var = a;
      d.gm_tau_s = a > 0 ? std::exp(lt) : 0.0;
      seen.emplace_back(v, std::move(d));
    }
    return v;
  };
  const double none = -std::numeric_limits<double>::infinity();
  const double L0 = L(none, none, 0.0);
  double best = L0, ba = none, bb = none, bt = 0.0;
  // Offsets alone (the Gauss-Markov term off).
  for (double lb = -3.0; lb <= 18.0; lb += 3.0) {
    const double v = L(none, lb, 0.0);
    if (v < best) { best = v; ba = none; bb = lb; bt = 0.0; }
  }
  if (!dt.empty() && span > 0) {
    std::nth_element(dt.begin(), dt.begin() + static_cast<long>(dt.size() / 2), dt.end());
    const double dt_med = dt[dt.size() / 2];
    const double lt_hi = std::log(span), lt_lo = std::log(std::max(dt_med / 4.0, 1e-3));
    for (double lt = lt_hi; lt >= lt_lo; lt -= std::log(2.0))
      for (double la = -3.0; la <= 18.0; la += 1.5)
        for (double lb : {none, -3.0, 0.0, 3.0, 6.0, 9.0, 12.0}) {
          const double v = L(la, lb, lt);
          if (v < best) { best = v; ba = la; bb = lb; bt = lt; }
        }
    // Refine from the best grid point and the best with the other kind of τ (short: offsets between dwells;
    // long: a wander across the log), in (ln gm_var, ln offset_var, ln τ); ln offset_var below −15 is none.
    if (std::isfinite(ba)) {
      auto f = [&](const Eigen::Vector3d& x) {
        const double lt = std::clamp(x[2], lt_lo - 2.0, lt_hi + 1.0);
        const double v = L(std::min(x[0], 25.0), x[1] < -15.0 ? none : std::min(x[1], 25.0), lt);
        return v + (lt != x[2] ? 1e3 * std::abs(lt - x[2]) : 0.0);  // stay in the searched τ range
      };
      double fb;
      const Eigen::Vector3d xb = nelder_mead(f, Eigen::Vector3d(ba, std::isfinite(bb) ? bb : -16.0, bt), 1.0, 300, fb);
      if (fb < best) {
        best = fb;
        ba = std::min(xb[0], 25.0);
        bb = xb[1] < -15.0 ? none : std::min(xb[1], 25.0);
        bt = xb[2];
      }
    }
  }
  out.offset_var = std::isfinite(bb) ? s0 * std::exp(bb) : 0.0;
  out.gm_var = std::isfinite(ba) ? s0 * std::exp(ba) : 0.0;
  out.gm_tau_s = std::isfinite(ba) ? std::exp(bt) : 0.0;
  out.gain = std::max(0.0, L0 - best);
  out.adopted = out.gain > kDriftGainThreshold && out.any();
  if (out.adopted) {
    std::sort(seen.begin(), seen.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [v, d] : seen) {
      if (v > best + kDriftPlausible) break;
      // The Nelder-Mead path revisits near-copies of its best point; they add nothing to an envelope.
      bool dup = false;
      for (const DwellDrift& p : out.plausible)
        dup = dup || (std::abs(std::log((p.gm_var + 1e-300) / (d.gm_var + 1e-300))) < 0.05 &&
                      std::abs(std::log((p.offset_var + 1e-300) / (d.offset_var + 1e-300))) < 0.05 &&
                      std::abs(std::log((p.gm_tau_s + 1e-300) / (d.gm_tau_s + 1e-300))) < 0.05);
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
  if (!(d.gm_var > 0 && d.gm_tau_s > 0) || S == 0) return out;
  // Σ_j exp(−|t_i − t_j|/τ) G_j = forward part (j ≤ i) + backward part (j > i).
  Eigen::RowVectorXd acc = G.row(0);
  Eigen::MatrixXd fwd(S, G.cols());
  fwd.row(0) = acc;
  for (Eigen::Index i = 1; i < S; ++i) {
    const double e = std::exp(-(t_s[static_cast<size_t>(i)] - t_s[static_cast<size_t>(i - 1)]) / d.gm_tau_s);
    acc = G.row(i) + e * acc;
    fwd.row(i) = acc;
  }
  Eigen::RowVectorXd back = Eigen::RowVectorXd::Zero(G.cols());
  for (Eigen::Index i = S - 1; i >= 0; --i) {
    out.row(i) += d.gm_var * (fwd.row(i) + back);
    if (i > 0) {
      const double e = std::exp(-(t_s[static_cast<size_t>(i)] - t_s[static_cast<size_t>(i - 1)]) / d.gm_tau_s);
      back = e * (G.row(i) + back);
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
