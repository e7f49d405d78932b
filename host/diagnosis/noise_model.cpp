#include "host/diagnosis/noise_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace imuforge::diagnosis {

double gauss_markov_avar(double tau_s, double T_s) {
  if (!(T_s > 0) || !(tau_s > 0)) return 0.0;
  const double x = tau_s / T_s;
  // AVAR = (2σ²T/τ)[1 − (T/2τ)(3 − 4e^{−τ/T} + e^{−2τ/T})]; its small-x series avoids the cancellation.
  if (x < 1e-3) return 2.0 * x / 3.0 - x * x / 2.0;
  return 2.0 / x * (1.0 - (3.0 - 4.0 * std::exp(-x) + std::exp(-2.0 * x)) / (2.0 * x));
}

double StochasticModel::avar(double tau_s) const {
  return 3.0 * Q * Q / (tau_s * tau_s) + N * N / tau_s + gm_sigma * gm_sigma * gauss_markov_avar(tau_s, gm_tau_s) +
         K * K * tau_s / 3.0;
}

double StochasticModel::white_var(double tau_s) const {
  // Mean of white noise over τ: N²/τ; quantization (uniform, rounding per sample) shrinks like white at
  // the sample level and is reported by its Allan term 3Q²/τ², which is the variance of a mean over τ too.
  return N * N / tau_s + 3.0 * Q * Q / (tau_s * tau_s);
}

StochasticModel fit_stochastic_model(const std::vector<AllanAccumulator::Point>& pts) {
  StochasticModel best;
  best.n_points = static_cast<int>(pts.size());
  if (pts.empty()) return best;
  double tmin = pts.front().tau_s, tmax = pts.front().tau_s;
  for (const auto& p : pts) {
    tmin = std::min(tmin, p.tau_s);
    tmax = std::max(tmax, p.tau_s);
  }
  // Basis: 0 Q (3/τ²), 1 N (1/τ), 2 GM (unit-variance GM Allan curve at T), 3 K (τ/3).
  std::vector<double> grid{0.0};
  const int kGrid = 18;
  for (int i = 0; i < kGrid; ++i) grid.push_back(tmin * std::pow(4.0 * tmax / tmin, static_cast<double>(i) / (kGrid - 1)));
  double best_chi2 = std::numeric_limits<double>::infinity();
  for (double T : grid) {
    auto basis = [T](int t, double tau) {
      switch (t) {
        case 0: return 3.0 / (tau * tau);
        case 1: return 1.0 / tau;
        case 2: return gauss_markov_avar(tau, T);
        default: return tau / 3.0;
      }
    };
    for (unsigned subset = 1; subset < 16; ++subset) {
      if ((subset & 0x4) && T == 0.0) continue;
      if (!(subset & 0x4) && T != 0.0) continue;  // non-GM subsets once only
      std::vector<int> terms;
      for (int t = 0; t < 4; ++t)
        if (subset & (1u << t)) terms.push_back(t);
      const int p = static_cast<int>(terms.size());
      if (p > static_cast<int>(pts.size())) continue;
      Eigen::VectorXd c;
      Eigen::MatrixXd H;
      double chi2 = 0;
      if (!fit_allan_terms(pts, [&](int i, double tau) { return basis(terms[static_cast<std::size_t>(i)], tau); }, p, c, H, chi2))
        continue;
      // Each term beyond white noise must pay for itself clearly (Δχ² > 10 each, p ≈ 0.002; the GM's
      // correlation time counts as a further parameter), so a short white record gets no phantom drift
      // that would then swallow real effects as "noise".
      const int extra_terms = p - ((subset & 0x2) ? 1 : 0);
      const double crit = chi2 + 10.0 * extra_terms + (T > 0 ? 5.0 : 0.0);
      if (crit < best_chi2) {
        best_chi2 = crit;
        StochasticModel m;
        m.n_points = best.n_points;
        m.chi2 = chi2;
        for (int i = 0; i < p; ++i) {
          switch (terms[static_cast<std::size_t>(i)]) {
            case 0: m.Q = std::sqrt(c[i]); break;
            case 1: m.N = std::sqrt(c[i]); break;
            case 2: m.gm_sigma = std::sqrt(c[i]); m.gm_tau_s = T; break;
            default: m.K = std::sqrt(c[i]); break;
          }
        }
        best = m;
      }
    }
  }
  return best;
}

namespace {
// A block mean over d of a Gauss-Markov process of correlation time T, against its value g at mid-block:
// mean = alpha·g + e, Var(mean) = vm·σ² (both → 1 for d ≪ T), so the part not carried by the state is
// (vm − alpha²)·σ². Without it a GM of T ≪ d would count as a full random bias per block.
void gm_block(double d, double T, double& alpha, double& vm) {
  const double x = d / T;
  if (x < 1e-6) {
    alpha = vm = 1.0;
    return;
  }
  alpha = 2.0 / x * (1.0 - std::exp(-x / 2.0));
  vm = 2.0 / (x * x) * (x - 1.0 + std::exp(-x));
}
}  // namespace

void whiten_segment(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                    const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, Eigen::Ref<Eigen::MatrixXd> innov,
                    Eigen::Ref<Eigen::VectorXd> S) {
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols());
  const double s2 = m.gm_tau_s > 0 ? m.gm_sigma * m.gm_sigma : 0.0;
  // State [GM bias, RW bias]; one mean column per data column (the filter is linear in the data).
  Eigen::Matrix2d P = Eigen::Matrix2d::Zero();
  P(0, 0) = s2;
  P(1, 1) = std::max(rw_prior_var, 0.0);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(2, c);
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      const double dt = std::max(t_s[static_cast<std::size_t>(i)] - t_s[static_cast<std::size_t>(i - 1)], 0.0);
      const double phi = s2 > 0 ? std::exp(-dt / m.gm_tau_s) : 0.0;
      M.row(0) *= phi;
      P(0, 0) *= phi * phi;
      P(0, 1) *= phi;
      P(1, 0) *= phi;
      P(0, 0) += s2 * (1.0 - phi * phi);
      P(1, 1) += m.K * m.K * dt;
    }
    const double d = std::max(dur_s[static_cast<std::size_t>(i)], 1e-9);
    double alpha = 1.0, vm = 1.0;
    if (s2 > 0) gm_block(d, m.gm_tau_s, alpha, vm);
    const double R = std::max(m.white_var(d) + s2 * std::max(vm - alpha * alpha, 0.0), 1e-300);
    const Eigen::Vector2d h(alpha, 1.0);
    const double hPh = h.dot(P * h);
    const double Si = hPh + R;
    Eigen::RowVectorXd nu = rows.row(i) - (alpha * M.row(0) + M.row(1));
    innov.row(i) = nu;
    S[i] = Si;
    Eigen::Vector2d Kg = P * h / Si;
    M += Kg * nu;
    P -= Kg * Kg.transpose() * Si;
    P = 0.5 * (P + P.transpose());
  }
}

double block_covariance(const StochasticModel& m, double ti, double di, double tj, double dj, bool same, double t_start,
                        double rw_prior_var) {
  double c = 0;
  if (m.gm_tau_s > 0) {
    double ai = 1, vi = 1, aj = 1, vj = 1;
    gm_block(std::max(di, 1e-9), m.gm_tau_s, ai, vi);
    gm_block(std::max(dj, 1e-9), m.gm_tau_s, aj, vj);
    c += m.gm_sigma * m.gm_sigma * (same ? vi : ai * aj * std::exp(-std::fabs(ti - tj) / m.gm_tau_s));
  }
  c += rw_prior_var + m.K * m.K * std::max(0.0, std::min(ti, tj) - t_start);
  if (same) c += m.white_var(std::max(std::min(di, dj), 1e-9));
  return c;
}

}  // namespace imuforge::diagnosis
