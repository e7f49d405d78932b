#include "host/estimator/stochastic.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace imuforge::estimator {

double gauss_markov_avar(double tau_s, double T_s) {
  if (!(T_s > 0) || !(tau_s > 0)) return 0.0;
  const double x = tau_s / T_s;
  // AVAR = (2σ²T/τ)[1 − (T/2τ)(3 − 4e^{−τ/T} + e^{−2τ/T})]; its small-x series avoids the cancellation.
  if (x < 1e-3) return 2.0 * x / 3.0 - x * x / 2.0;
  return 2.0 / x * (1.0 - (3.0 - 4.0 * std::exp(-x) + std::exp(-2.0 * x)) / (2.0 * x));
}

std::vector<double> flicker_bank_taus(double T_lo_s, double T_hi_s) {
  std::vector<double> out;
  if (!(T_lo_s > 0) || !(T_hi_s > T_lo_s)) return out;
  for (double T = T_lo_s; out.empty() || out.back() < T_hi_s; T *= 4.0) out.push_back(T);
  return out;
}

double flicker_bank_avar(double tau_s, const std::vector<double>& bank_tau_s) {
  double s = 0;
  for (double T : bank_tau_s) s += gauss_markov_avar(tau_s, T);
  return s;
}

double flicker_B_of_sigma(double bank_sigma, const std::vector<double>& bank_tau_s) {
  if (bank_tau_s.empty() || !(bank_sigma > 0)) return 0.0;
  // IEEE 952: the flicker floor of the Allan variance is (2 ln 2 / π) B²; the bank is flat to a few % there.
  const double floor = flicker_bank_avar(std::sqrt(bank_tau_s.front() * bank_tau_s.back()), bank_tau_s);
  return std::sqrt(bank_sigma * bank_sigma * floor * M_PI / (2.0 * std::log(2.0)));
}

double StochasticModel::avar(double tau_s) const {
  return 3.0 * Q * Q / (tau_s * tau_s) + N * N / tau_s + gm_sigma * gm_sigma * gauss_markov_avar(tau_s, gm_tau_s) +
         bank_sigma * bank_sigma * flicker_bank_avar(tau_s, bank_tau_s) + K * K * tau_s / 3.0;
}

std::vector<std::pair<double, double>> StochasticModel::gm_states(bool upper_limit) const {
  std::vector<std::pair<double, double>> out;
  if (gm_tau_s > 0 && gm_sigma > 0) out.push_back({gm_sigma * gm_sigma, gm_tau_s});
  const double bs = upper_limit ? std::max(bank_sigma, bank_sigma_lik) : bank_sigma;
  if (bs > 0)
    for (double T : bank_tau_s) out.push_back({bs * bs, T});
  return out;
}

double StochasticModel::white_var(double tau_s) const {
  // Mean of white noise over τ: N²/τ; quantization (uniform, rounding per sample) shrinks like white at
  // the sample level and is reported by its Allan term 3Q²/τ², which is the variance of a mean over τ too.
  return N * N / tau_s + 3.0 * Q * Q / (tau_s * tau_s);
}

// Without the (vm − alpha²)·σ² part a GM of T ≪ d would count as a full random bias per block.
void gm_block(double d, double T, double& alpha, double& vm) {
  const double x = d / T;
  if (x < 1e-6) {
    alpha = vm = 1.0;
    return;
  }
  alpha = 2.0 / x * (1.0 - std::exp(-x / 2.0));
  vm = 2.0 / (x * x) * (x - 1.0 + std::exp(-x));
}

void whiten_segment(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                    const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, Eigen::Ref<Eigen::MatrixXd> innov,
                    Eigen::Ref<Eigen::VectorXd> S, const std::vector<char>* missing, const std::vector<int>* seg_of,
                    const Eigen::VectorXd* extra_var) {
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols());
  // State [GM biases (single GM, flicker bank)..., RW bias, segment bias (when m.seg_bias_var > 0)]; one mean
  // column per data column (the filter is linear in the data).
  const std::vector<std::pair<double, double>> gm = m.gm_states();
  const bool seg_bias = m.seg_bias_var > 0;
  const int G = static_cast<int>(gm.size()), NS = G + 1 + (seg_bias ? 1 : 0), Qs = G + 1;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(NS, NS);
  for (int g = 0; g < G; ++g) P(g, g) = gm[static_cast<std::size_t>(g)].first;
  P(G, G) = std::max(rw_prior_var, 0.0);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(NS, c);
  Eigen::VectorXd phi(NS), h(NS), Ph(NS), Kg(NS);
  Eigen::RowVectorXd hM(c), nu(c);
  // Every GLS fit of the diagnosis runs this filter over a whole log's blocks (a 1 h, 1 kHz log: thousands of calls
  // of 3000+ blocks), so the per-block work is kept to the arithmetic: the GM states' transition and block-mean
  // factors are recomputed only where the spacing or the duration changes (both repeat from block to block), and
  // the per-block vectors are allocated once.
  double dt_last = -1.0, d_last = -1.0;
  Eigen::VectorXd h_gm(G), R_gm(G);
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      const double dt = std::max(t_s[static_cast<std::size_t>(i)] - t_s[static_cast<std::size_t>(i - 1)], 0.0);
      if (dt != dt_last) {
        for (int g = 0; g < G; ++g) phi[g] = std::exp(-dt / gm[static_cast<std::size_t>(g)].second);
        phi[G] = 1.0;
        if (seg_bias) phi[Qs] = 1.0;
        dt_last = dt;
      }
      // M ← diag(φ) M and P ← diag(φ) P diag(φ), in place. φ is 1 on the walk and the segment bias (rows G and
      // up), and x·1 is x to the bit, so only the GM rows and columns are multiplied: with no GM state (the
      // white-and-walk models the wander search tries) the transition costs nothing.
      if (G > 0) {
        for (int col = 0; col < c; ++col)
          for (int r = 0; r < G; ++r) M(r, col) = phi[r] * M(r, col);
        for (int col = 0; col < G; ++col)
          for (int r = 0; r < NS; ++r) P(r, col) = (r < G ? phi[r] * P(r, col) : P(r, col)) * phi[col];
        for (int col = G; col < NS; ++col)
          for (int r = 0; r < G; ++r) P(r, col) = phi[r] * P(r, col);
      }
      for (int g = 0; g < G; ++g) P(g, g) += gm[static_cast<std::size_t>(g)].first * (1.0 - phi[g] * phi[g]);
      // The random-walk state is the bias at the END of the last block (below): it walks over the gap only.
      const double gap = std::max((t_s[static_cast<std::size_t>(i)] - 0.5 * dur_s[static_cast<std::size_t>(i)]) -
                                      (t_s[static_cast<std::size_t>(i - 1)] + 0.5 * dur_s[static_cast<std::size_t>(i - 1)]),
                                  0.0);
      P(G, G) += m.K * m.K * gap;
    }
    // A new segment draws a new, independent segment bias (forgets the last one).
    if (seg_bias && (i == 0 || !seg_of || (*seg_of)[static_cast<std::size_t>(i)] != (*seg_of)[static_cast<std::size_t>(i - 1)])) {
      M.row(Qs).setZero();
      P.row(Qs).setZero();
      P.col(Qs).setZero();
      P(Qs, Qs) = m.seg_bias_var;
    }
    const double d = std::max(dur_s[static_cast<std::size_t>(i)], 1e-9);
    // The random walk within the block: its increment u over the block (variance q) carries the bias to the block's
    // end, and the block mean sees u/2 of it plus an independent part of variance q/12 (the mean of a Brownian path
    // over [0, d] is u/2 + e, Var e = d/12). Treating the walk as constant within a block (its value at mid-block)
    // drops that part and ignores that the mean shares the next transition's increment: with a strong walk over
    // 30 s blocks the innovations then stayed correlated (Σ r_k² 0.06-0.1) and a true random walk read as periodic.
    const double q = m.K * m.K * d;
    if (missing && (*missing)[static_cast<std::size_t>(i)]) {
      P(G, G) += q;
      innov.row(i).setZero();
      S[i] = 1.0;
      continue;
    }
    double R = m.white_var(d) + (extra_var ? (*extra_var)[i] : 0.0);
    if (d != d_last) {
      for (int g = 0; g < G; ++g) {
        double alpha = 1.0, vm = 1.0;
        gm_block(d, gm[static_cast<std::size_t>(g)].second, alpha, vm);
        h_gm[g] = alpha;
        R_gm[g] = gm[static_cast<std::size_t>(g)].first * std::max(vm - alpha * alpha, 0.0);
      }
      d_last = d;
    }
    for (int g = 0; g < G; ++g) {
      h[g] = h_gm[g];
      R += R_gm[g];
    }
    h[G] = 1.0;
    if (seg_bias) h[Qs] = 1.0;
    R = std::max(R, 1e-300);
    Ph.noalias() = P * h;
    const double Si = h.dot(Ph) + R + q / 3.0;  // Var(u/2 + e) = q/4 + q/12
    hM.noalias() = h.transpose() * M;
    nu = rows.row(i) - hM;
    innov.row(i) = nu;
    S[i] = Si;
    Kg = Ph / Si;
    // The two rank-one updates as loops: the same products in the same order as Eigen's outer products, with
    // (K K^T) S as (K_r K_c) S (bit for bit; checked over 2e5 random cases), without the NS x NS temporary that
    // the expression allocated per block (3 % of a diagnosis in malloc and free).
    for (int col = 0; col < c; ++col)
      for (int r = 0; r < NS; ++r) M(r, col) += Kg[r] * nu[col];
    for (int col = 0; col < NS; ++col)
      for (int r = 0; r < NS; ++r) P(r, col) -= (Kg[r] * Kg[col]) * Si;
    if (q > 0) {
      // Update u with the block (gain q/2 / S) and fold it into the walk: bias at the end = at the start + u.
      M.row(G) += (0.5 * q / Si) * nu;
      const double gu = -(0.5 * q / Si);
      for (int r = 0; r < NS; ++r) P(r, G) += gu * Ph[r];
      for (int col = 0; col < NS; ++col) P(G, col) += gu * Ph[col];
      P(G, G) += q - 0.25 * q * q / Si;
    }
    // P ← (P + Pᵀ)/2, in place. (Written as P = 0.5 (P + Pᵀ) this read its own half-overwritten transpose, Eigen
    // assuming no aliasing, so the upper triangle was not the mean; the difference was in the last bits.)
    for (int col = 0; col < NS; ++col)
      for (int r = col + 1; r < NS; ++r) P(r, col) = P(col, r) = 0.5 * (P(r, col) + P(col, r));
  }
}

estimator::NormalEquations gls_normal_equations(const StochasticModel& m, const std::vector<double>& t_s,
                                                const std::vector<double>& dur_s, const Eigen::Ref<const Eigen::MatrixXd>& rows,
                                                double rw_prior_var, const std::vector<int>* seg_of,
                                                const std::vector<char>* missing, double* sum_log_S,
                                                Eigen::MatrixXd* innov_out, Eigen::VectorXd* S_out,
                                                const Eigen::VectorXd* extra_var) {
  const int n = static_cast<int>(rows.rows()), P = static_cast<int>(rows.cols()) - 1;
  Eigen::MatrixXd innov_local;
  Eigen::VectorXd S_local;
  Eigen::MatrixXd& innov = innov_out ? *innov_out : innov_local;
  Eigen::VectorXd& S = S_out ? *S_out : S_local;
  innov.resize(n, P + 1);
  S.resize(n);
  whiten_segment(m, t_s, dur_s, rows, rw_prior_var, innov, S, missing, seg_of, extra_var);
  estimator::NormalEquations ne(P);
  double logS = 0;
  for (int i = 0; i < n; ++i) {
    if (missing && (*missing)[static_cast<std::size_t>(i)]) continue;
    ne.add_row_lower(innov.row(i).tail(P).transpose(), innov(i, 0), 1.0 / S[i]);
    logS += std::log(S[i]);
  }
  ne.symmetrize();
  if (sum_log_S) *sum_log_S = logS;
  return ne;
}

}  // namespace imuforge::estimator
