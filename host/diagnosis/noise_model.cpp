#include "host/diagnosis/noise_model.h"
#include "host/diagnosis/concurrency.h"
#include "host/diagnosis/stats.h"
#include "host/estimator/estimator.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>

namespace imuforge::diagnosis {

namespace {
// Allan χ² of the model with the flicker bank's variance fixed at cb and the other terms of `m` (N always,
// Q, GM, K when the chosen model has them) refitted non-negatively: the profile over the nuisance terms.
double profile_chi2(const std::vector<AllanAccumulator::Point>& pts, const StochasticModel& m, const std::vector<double>& bank,
                    double cb) {
  std::vector<std::function<double(double)>> basis;
  basis.push_back([](double tau) { return 1.0 / tau; });
  if (m.Q > 0) basis.push_back([](double tau) { return 3.0 / (tau * tau); });
  if (m.gm_sigma > 0) {
    const double T = m.gm_tau_s;
    basis.push_back([T](double tau) { return gauss_markov_avar(tau, T); });
  }
  if (m.K > 0) basis.push_back([](double tau) { return tau / 3.0; });
  const int p = static_cast<int>(basis.size());
  std::vector<double> fl(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) fl[i] = cb * flicker_bank_avar(pts[i].tau_s, bank);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(p);
  auto model_at = [&](std::size_t i) {
    double f = fl[i];
    for (int j = 0; j < p; ++j) f += c[j] * basis[static_cast<std::size_t>(j)](pts[i].tau_s);
    return f;
  };
  for (int pass = 0; pass < 3; ++pass) {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double f = pass > 0 ? model_at(i) : pts[i].avar;
      const double w = pts[i].edf / (2.0 * f * f);
      Eigen::VectorXd a(p);
      for (int j = 0; j < p; ++j) a[j] = basis[static_cast<std::size_t>(j)](pts[i].tau_s);
      H += w * a * a.transpose();
      g += w * a * (pts[i].avar - fl[i]);
    }
    const Eigen::VectorXd s = H.diagonal().cwiseSqrt().cwiseInverse();
    if (!s.allFinite()) return std::numeric_limits<double>::infinity();
    c = s.asDiagonal() * Eigen::MatrixXd(s.asDiagonal() * H * s.asDiagonal()).ldlt().solve(s.asDiagonal() * g);
    for (int j = 0; j < p; ++j) c[j] = std::max(c[j], 0.0);  // a term pushed to zero stays there (non-negative)
  }
  double chi2 = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double f = std::max(model_at(i), 1e-300);
    chi2 += pts[i].edf / 2.0 * (pts[i].avar - f) * (pts[i].avar - f) / (f * f);
  }
  return chi2;
}
}  // namespace

void flicker_upper_limit(const std::vector<AllanAccumulator::Point>& pts, double tmin, double T_hi, StochasticModel& m) {
  if (pts.size() < 3) return;
  // The bank of the chosen model, or (no flicker chosen) the widest one: from the shortest cluster time.
  const std::vector<double> bank = m.bank_tau_s.empty() ? flicker_bank_taus(tmin, T_hi) : m.bank_tau_s;
  if (bank.empty()) return;
  const double floor1 = flicker_bank_avar(std::sqrt(bank.front() * bank.back()), bank);
  if (!(floor1 > 0)) return;
  const double c0 = m.bank_sigma * m.bank_sigma;
  const double chi2_0 = profile_chi2(pts, m, bank, c0);
  if (!std::isfinite(chi2_0)) return;
  // Start at the fit, or (none fitted) where the flicker floor is 1e-4 of the lowest Allan variance.
  double avar_min = pts.front().avar;
  for (const auto& p : pts) avar_min = std::min(avar_min, p.avar);
  double cb = c0 > 0 ? c0 : 1e-4 * avar_min / floor1;
  double last_ok = c0;
  for (int i = 0; i < 400; ++i, cb *= 1.05) {
    if (profile_chi2(pts, m, bank, cb) - chi2_0 > 2.71) break;  // one-sided 95 % (χ²₁ = 2.71)
    last_ok = cb;
  }
  if (!(last_ok > c0)) return;
  m.bank_sigma_lik = std::sqrt(last_ok);
  m.flicker_B_upper = flicker_B_of_sigma(m.bank_sigma_lik, bank);
  if (m.bank_tau_s.empty()) m.bank_tau_s = bank;
}

StochasticModel fit_stochastic_model(const std::vector<AllanAccumulator::Point>& pts, double horizon_s) {
  StochasticModel best;
  best.n_points = static_cast<int>(pts.size());
  if (pts.empty()) return best;
  double tmin = pts.front().tau_s, tmax = pts.front().tau_s;
  for (const auto& p : pts) {
    tmin = std::min(tmin, p.tau_s);
    tmax = std::max(tmax, p.tau_s);
  }
  // Basis: 0 Q (3/τ²), 1 N (1/τ), 2 GM (unit-variance GM Allan curve at T), 3 K (τ/3), 4 flicker bank
  // (unit-variance states from a lower corner to the horizon: 1/f has no upper corner a static record could
  // show, so the floor is assumed to continue over the whole log, as IEEE 952's B does). The grid value T is
  // the GM's correlation time and, for flicker, its lower corner (T = 0: the shortest cluster time): a
  // flicker that only starts at seconds looks like a GM bump over a short record, and must not lose to one.
  const double T_hi = std::max(horizon_s, 4.0 * tmax);
  std::vector<double> grid{0.0};
  const int kGrid = 18;
  for (int i = 0; i < kGrid; ++i) grid.push_back(tmin * std::pow(4.0 * tmax / tmin, static_cast<double>(i) / (kGrid - 1)));
  double best_chi2 = std::numeric_limits<double>::infinity();
  for (double T : grid) {
    const std::vector<double> bank = flicker_bank_taus(T > 0 ? T : tmin, T_hi);
    std::vector<double> bank_avar(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) bank_avar[i] = flicker_bank_avar(pts[i].tau_s, bank);
    auto basis = [&, T](int t, double tau) {
      switch (t) {
        case 0: return 3.0 / (tau * tau);
        case 1: return 1.0 / tau;
        case 2: return gauss_markov_avar(tau, T);
        case 3: return tau / 3.0;
        default: {
          // the points' own τ come back here: look their bank value up (the bank sum is the costly part)
          for (std::size_t i = 0; i < pts.size(); ++i)
            if (pts[i].tau_s == tau) return bank_avar[i];
          return flicker_bank_avar(tau, bank);
        }
      }
    };
    for (unsigned subset = 1; subset < 32; ++subset) {
      if ((subset & 0x4) && T == 0.0) continue;
      if (!(subset & 0x14) && T != 0.0) continue;  // subsets without a slow term once only
      if ((subset & 0x10) && bank.empty()) continue;
      std::vector<int> terms;
      for (int t = 0; t < 5; ++t)
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
      // Flicker is the exception: every inertial sensor has a bias instability, and its floor usually sits
      // below the white noise over the τ a static dwell reaches, so it is rarely "significant" there. It is
      // kept at whatever positive level the curve supports: a small flicker term costs little power, a
      // missing one lets the hour-scale wander it implies read as a thermal effect.
      const int extra_terms = p - ((subset & 0x2) ? 1 : 0) - ((subset & 0x10) ? 1 : 0);
      const double crit = chi2 + 10.0 * extra_terms + (T > 0 ? 5.0 : 0.0);  // T > 0: a GM or flicker corner
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
            case 3: m.K = std::sqrt(c[i]); break;
            default: {
              m.bank_sigma = std::sqrt(c[i]);
              m.bank_tau_s = bank;
              // B from the bank's Allan floor inside its span (flat to a few % there).
              m.flicker_B = flicker_B_of_sigma(m.bank_sigma, bank);
              break;
            }
          }
        }
        best = m;
      }
    }
  }
  flicker_upper_limit(pts, tmin, T_hi, best);
  return best;
}

double output_step(std::vector<double> abs_diffs, double tiny) {
  const std::size_t n_all = abs_diffs.size();
  std::vector<double>& nz = abs_diffs;  // the non-zero differences, in place
  nz.erase(std::remove_if(nz.begin(), nz.end(), [tiny](double d) { return !(std::isfinite(d) && d > tiny); }), nz.end());
  if (nz.size() < 100) return 0.0;
  std::sort(nz.begin(), nz.end());
  // The smallest cluster (differences of one step, each off by at most a finer LSB): its median.
  std::size_t k = 0;
  while (k < nz.size() && nz[k] < 1.5 * nz.front()) ++k;
  const double step = nz[k / 2];
  if (!(step > tiny)) return 0.0;
  std::size_t on = n_all - nz.size();  // zero differences sit on the lattice
  for (double d : nz) {
    const double r = d / step;
    on += std::fabs(r - std::round(r)) <= 0.15 ? 1 : 0;
  }
  return static_cast<double>(on) >= 0.95 * static_cast<double>(n_all) ? step : 0.0;
}

double quantization_mean_bias_var(double step, double sigma) {
  if (!(step > 0)) return 0.0;
  const double r2 = (sigma / step) * (sigma / step);
  double v = 0, e = 1;
  const int kMax = 64;
  for (int k = 1; k <= kMax; ++k) {
    e = std::exp(-4.0 * M_PI * M_PI * k * k * r2);
    v += step * step / (2.0 * M_PI * M_PI * k * k) * e;
    if (e < 1e-18) return v;
  }
  // The tail Σ_{k>K} 1/k² ≈ 1/(K + ½) (exact to O(K⁻³) at σ = 0; the factor e bounds it otherwise).
  return v + step * step / (2.0 * M_PI * M_PI) * e / (kMax + 0.5);
}

double quantizer_input_sigma(double step, double out_var) {
  if (!(step > 0) || !(out_var > 0)) return 0.0;
  // Within a static stretch the output's variance is σ² + Δ²/12 − b(x)²; over poses (x uniform in a step) it is
  // σ² + Δ²/12 − quantization_mean_bias_var(Δ, σ), which rises from 0 at σ = 0. Bisection on σ.
  auto f = [&](double sg) { return sg * sg + step * step / 12.0 - quantization_mean_bias_var(step, sg); };
  double lo = 0, hi = std::sqrt(out_var) + step;
  if (f(hi) < out_var) return hi;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < out_var ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

StochasticModel with_wander(const StochasticModel& m, const WholeLogWander* w, double duration_s, double rw_prior_var,
                            double& rw_prior_var_out) {
  StochasticModel out = m;
  out.bank_sigma = std::max(m.bank_sigma, m.bank_sigma_lik);  // the likelihood's own level
  rw_prior_var_out = rw_prior_var;
  if (w && w->kind == WholeLogWander::kFlicker) {
    // Below the likelihood's level the raise is the verdict's floor only; the likelihood keeps its own level.
    if (w->below_likelihood)
      out.bank_sigma = w->bank_sigma;
    else
      out.bank_sigma = out.bank_sigma_lik = w->bank_sigma;
  }
  if (w && w->kind == WholeLogWander::kRandomWalk) {
    // A walk raised jointly with the flicker that goes with it (whole_log_wander).
    out.bank_sigma = out.bank_sigma_lik = w->bank_sigma;
    out.K = w->K;
    rw_prior_var_out = w->K * w->K * duration_s / 6.0;
  }
  return out;
}

std::array<WholeLogWander, 3> whole_log_wander(const StochasticModel& m, const std::vector<double>& t_s,
                                               const std::vector<double>& dur_s, const Eigen::Ref<const Eigen::MatrixXd>& rows,
                                               double rw_prior_var, double duration_s, double ratio_max,
                                               const std::vector<int>* seg_of, const Eigen::MatrixXd* covariates) {
  std::array<WholeLogWander, 3> out;
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols()), P = c - 1;
  if (n <= P + 2 || !(duration_s > 0)) return out;
  // One line's evaluation state: the last evaluation's innovations, its standardised residual e and checks, and its
  // GLS fit's χ². Each line owns one, so the lines can be searched at once (below).
  struct Eval {
    Eigen::MatrixXd innov;
    Eigen::VectorXd S, e;
    double max_abs_z = 0, whiteness_p = 1, autocorr_sq = 0, rss_last = 0;
    Eval(int n, int c) : innov(n, c), S(n), e(n) {}
  };
  // −2 log L_REML: Σ log S + χ² of the GLS fit + log det of the columns' information.
  auto m2ll = [&](Eval& ev, const StochasticModel& mm, double rw0) {
    Eigen::MatrixXd& innov = ev.innov;
    Eigen::VectorXd &S = ev.S, &e = ev.e;
    double &max_abs_z = ev.max_abs_z, &whiteness_p = ev.whiteness_p, &autocorr_sq = ev.autocorr_sq, &rss_last = ev.rss_last;
    double logS = 0;
    const estimator::NormalEquations ne = gls_normal_equations(mm, t_s, dur_s, rows, rw0, seg_of, nullptr, &logS, &innov, &S);
    // The columns' GLS fit on the shared estimator core; its kept columns' information is cov⁻¹.
    std::vector<int> cols(static_cast<std::size_t>(P));
    std::iota(cols.begin(), cols.end(), 0);
    const estimator::SubsetFit f = estimator::fit_subset(ne, cols);
    double logdet = 0;
    if (!f.kept.empty()) {
      const Eigen::LLT<Eigen::MatrixXd> llt(f.cov);
      for (int i = 0; i < static_cast<int>(f.kept.size()); ++i) logdet -= 2.0 * std::log(llt.matrixL()(i, i));
    }
    rss_last = f.rss;
    max_abs_z = 0;
    for (int i = 0; i < n; ++i) {
      double fit_i = 0;
      for (int k = 0; k < static_cast<int>(f.kept.size()); ++k) fit_i += innov(i, 1 + f.kept[static_cast<std::size_t>(k)]) * f.theta[k];
      e[i] = (innov(i, 0) - fit_i) / std::sqrt(S[i]);
      max_abs_z = std::max(max_abs_z, std::fabs(e[i]));
    }
    const int L = std::min(10, n / 5);
    whiteness_p = 1;
    autocorr_sq = 0;
    if (L >= 1) {
      const double mean = e.mean();
      const Eigen::VectorXd ec = e.array() - mean;
      const double c0 = ec.squaredNorm();
      double Q = 0;
      for (int k = 1; k <= L && c0 > 0; ++k) {
        const double rk = ec.head(n - k).dot(ec.tail(n - k)) / c0;
        Q += rk * rk / static_cast<double>(n - k);
        autocorr_sq += rk * rk;
      }
      Q *= static_cast<double>(n) * static_cast<double>(n + 2);
      whiteness_p = chi2_sf(Q, L);
    }
    return logS + f.rss + logdet;
  };
  double rw_unused = 0;
  StochasticModel m0 = with_wander(m, nullptr, duration_s, rw_prior_var, rw_unused);
  // Where the dwells' Allan curve shows no flicker at all (point estimate 0), the likelihood carries the flicker's
  // upper limit while the held-out verdict carries none. Both lines then start from the dwells' own model, no
  // flicker, so that a flicker the whole log shows below that limit is found at all: a bias instability whose
  // floor begins past the dwells' length is exactly what they cannot show (`varied` single-accel.cross_coupling:
  // a tactical gyro's 300 s bias instability read B = 0 on 70 s soaks, its segment means stood at held-out
  // χ²/dof 3.2 against white noise alone, and the whole log's flicker B 3.3e-6 was never looked for).
  const double flicker_from = m0.bank_sigma;
  const bool no_flicker_seen = !(m.bank_sigma > 0) && flicker_from > 0;
  const double tau_long = 0.25 * duration_s;
  // The ratio stays against the likelihood's level (the limits keep a deterministic residual visible whatever
  // level the search starts from).
  const double avar0 = m0.avar(tau_long);
  if (no_flicker_seen) m0.bank_sigma = m0.bank_sigma_lik = 0;
  // ... while what the line is reported and judged material against is the level the held-out verdict carries.
  const double avar_seen = m0.avar(tau_long);  // ≤ avar0: m0 has lost at most its flicker
  if (!(avar_seen > 0)) return out;
  Eval ev_flicker(n, c), ev_walk(n, c);
  const double base = m2ll(ev_flicker, m0, rw_prior_var);
  if (!std::isfinite(base)) return out;
  const double step = std::pow(2.0, 0.25);
  // Each line's maximiser, then its residual checks (jump, whiteness) under it.
  auto finish = [&](Eval& ev, WholeLogWander& w, double line_best) {
    w.gain = base - line_best;
    double rw0 = 0;
    const StochasticModel mm = with_wander(m, &w, duration_s, rw_prior_var, rw0);
    m2ll(ev, mm, rw0);
    const Eigen::VectorXd& e = ev.e;
    const double max_abs_z = ev.max_abs_z, whiteness_p = ev.whiteness_p, autocorr_sq = ev.autocorr_sq, rss_last = ev.rss_last;
    w.max_abs_z = max_abs_z;
    w.whiteness_p = whiteness_p;
    w.autocorr_sq = autocorr_sq;
    const SpectralLine line = line_power_spectrum(t_s, e);
    w.line_p = line.false_alarm_p;
    w.line_period_s = line.period_s;
    // A bias step or one outlying block? Both give one large innovation (the outlier's may be the swing back after
    // it). The residual is fitted, under the same noise model and with the same columns, once with an indicator of
    // one block and once with a level step, each placed at the largest innovation or a block either side; the
    // better step against the better single block, as a signed √Δχ².
    int im = 0;
    for (int i = 1; i < n; ++i)
      if (std::fabs(e[i]) > std::fabs(e[im])) im = i;
    std::vector<int> cols_all(static_cast<std::size_t>(P + 1));
    std::iota(cols_all.begin(), cols_all.end(), 0);
    Eigen::MatrixXd rr(n, c + 1);
    rr.leftCols(c) = rows;
    auto rss_with = [&](const Eigen::VectorXd& extra) {
      rr.col(c) = extra;
      return estimator::fit_subset(gls_normal_equations(mm, t_s, dur_s, rr, rw0, seg_of), cols_all).rss;
    };
    const double rss0 = rss_last;  // m2ll(mm, rw0) above: the same fit without an extra column
    double best_spike = 0, best_step = 0;
    for (int k = std::max(0, im - 1); k <= std::min(n - 1, im + 1); ++k) {
      Eigen::VectorXd spike = Eigen::VectorXd::Zero(n), step = Eigen::VectorXd::Zero(n);
      spike[k] = 1.0;
      step.tail(n - k).setOnes();
      best_spike = std::max(best_spike, rss0 - rss_with(spike));
      if (k > 0) best_step = std::max(best_step, rss0 - rss_with(step));
    }
    const double d = best_step - best_spike;
    w.jump_persist_z = (d >= 0 ? 1.0 : -1.0) * std::sqrt(std::fabs(d));
    // Koenker–Breusch–Pagan on e² (WholeLogWander::hetero_*): OLS of e² on [1, covariates], LM = n R².
    if (covariates && covariates->rows() == n && covariates->cols() > 0) {
      const int k = static_cast<int>(covariates->cols());
      Eigen::MatrixXd Z(n, k + 1);
      Z.col(0).setOnes();
      Z.rightCols(k) = *covariates;
      const Eigen::VectorXd e2 = e.array().square().matrix();
      const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Z);
      const Eigen::VectorXd fit = Z * qr.solve(e2);
      const double mean = e2.mean();
      const double tss = (e2.array() - mean).square().sum(), rss = (e2 - fit).squaredNorm();
      const int rank = static_cast<int>(qr.rank());
      if (tss > 0 && rank > 1) {
        w.hetero_lm = static_cast<double>(n) * std::max(0.0, 1.0 - rss / tss);
        w.hetero_p = chi2_sf(w.hetero_lm, rank - 1);
        std::vector<int> order(static_cast<std::size_t>(n));
        std::iota(order.begin(), order.end(), 0);
        std::sort(order.begin(), order.end(), [&](int a, int b) { return fit[a] < fit[b]; });
        const int q = std::max(1, n / 4);
        double lo = 0, hi = 0;
        for (int i = 0; i < q; ++i) {
          lo += e2[order[static_cast<std::size_t>(i)]];
          hi += e2[order[static_cast<std::size_t>(n - 1 - i)]];
        }
        w.hetero_ratio = lo > 0 ? hi / lo : std::numeric_limits<double>::infinity();
      }
    }
  };
  // The flicker line and the verdict's floor (out[0], out[2]) on one thread, the random walk (out[1]) on another
  // where the machine has two: the lines share nothing but their inputs, so the answer is the same to the last bit.
  // The search is most of a diagnosis's work after the log's passes (a few whole-log searches per axis and per
  // selected effect), and the walk's line, the longest, is about half of it.
  auto flicker_lines = [&](Eval& ev) {
    // Flicker: the bank's σ raised (a bank exists whenever the Allan fit had points).
    if (!m.bank_tau_s.empty() && flicker_from > 0) {
      StochasticModel mf = m0;
      WholeLogWander& w = out[0];
      double line_best = base;
      for (double s = (no_flicker_seen ? 0.25 : 1.0) * flicker_from * step;; s *= step) {
        mf.bank_sigma = mf.bank_sigma_lik = s;
        const double ratio = std::sqrt(mf.avar(tau_long) / avar0);
        if (ratio > ratio_max) break;
        const double v = m2ll(ev, mf, rw_prior_var);
        if (!std::isfinite(v)) break;
        if (v < line_best) {
          line_best = v;
          w.kind = WholeLogWander::kFlicker;
          w.bank_sigma = s;
          w.B = flicker_B_of_sigma(s, m.bank_tau_s);
          w.limit_ratio = ratio;
          w.ratio = std::sqrt(mf.avar(tau_long) / avar_seen);
        } else if (v > line_best + 10.0) {
          break;  // far past this line's maximum (the likelihood is unimodal along one level)
        }
      }
      if (w.kind != WholeLogWander::kNone) finish(ev, w, line_best);
    }
    // The verdict's floor: where the dwells' point estimate of the flicker is below the likelihood's level, the
    // flicker's maximiser between the two, and its gain over the point estimate (WholeLogWander::below_likelihood).
    if (m.bank_sigma > 0 && m.bank_sigma < flicker_from && !no_flicker_seen) {
      StochasticModel mf = m0;
      mf.bank_sigma = mf.bank_sigma_lik = m.bank_sigma;
      const double avar_point = mf.avar(tau_long);
      const double base_seen = m2ll(ev, mf, rw_prior_var);
      WholeLogWander& w = out[2];
      double line_best = base_seen, s_best = 0;
      for (double s = m.bank_sigma * step;; s *= step) {
        const bool last = !(s * step < flicker_from);
        if (last) s = flicker_from;  // the likelihood's own level closes the range (its −2 log L is `base`)
        mf.bank_sigma = mf.bank_sigma_lik = s;
        const double v = last ? base : m2ll(ev, mf, rw_prior_var);
        if (std::isfinite(v) && v < line_best) line_best = v, s_best = s;
        if (last) break;
      }
      if (s_best > 0) {
        w.kind = WholeLogWander::kFlicker;
        w.below_likelihood = true;
        w.bank_sigma = s_best;
        w.B = flicker_B_of_sigma(s_best, m.bank_tau_s);
        mf.bank_sigma = mf.bank_sigma_lik = s_best;
        w.limit_ratio = std::sqrt(mf.avar(tau_long) / avar0);
        w.ratio = std::sqrt(mf.avar(tau_long) / avar_point);  // against the point estimate the verdict carries
        finish(ev, w, line_best);
        w.gain_seen = base_seen - line_best;
      }
    }
  };
  auto walk_line = [&](Eval& ev) {
    // Random walk: K raised from its fit, or from where it adds 1 % to the Allan variance at D/4, jointly with the
    // flicker: short dwells read the start of a random walk as flicker, and a walk raised beside that flicker held
    // fits the whole log short of its size.
    {
      WholeLogWander& w = out[1];
      double line_best = base;
      const double k_start = std::max(m.K, 0.1 * std::sqrt(3.0 * avar0 / tau_long));
      for (int j = 0; j <= (m0.bank_sigma > 0 ? 5 : 0); ++j) {
        StochasticModel mk = m0;
        mk.bank_sigma = mk.bank_sigma_lik = j == 5 ? 0.0 : m0.bank_sigma / static_cast<double>(1 << j);
        double fl_best = std::numeric_limits<double>::infinity();
        for (double k = k_start * step;; k *= step) {
          mk.K = k;
          const double ratio = std::sqrt(mk.avar(tau_long) / avar0);
          if (ratio > ratio_max) break;
          const double v = m2ll(ev, mk, k * k * duration_s / 6.0);
          if (!std::isfinite(v)) break;
          fl_best = std::min(fl_best, v);
          if (v < line_best) {
            line_best = v;
            w.kind = WholeLogWander::kRandomWalk;
            w.K = k;
            w.bank_sigma = mk.bank_sigma;
            w.B = mk.bank_sigma > 0 ? flicker_B_of_sigma(mk.bank_sigma, m.bank_tau_s) : 0.0;
            w.flicker_lowered = j > 0;
            w.limit_ratio = ratio;
            w.ratio = std::sqrt(mk.avar(tau_long) / avar_seen);
          } else if (v > (j == 0 ? line_best : fl_best) + 10.0) {  // j = 0: past this line's maximum, as above
            break;
          }
        }
        if (fl_best > line_best + 10.0) break;  // past the flicker's maximum along the profile
      }
      if (w.kind != WholeLogWander::kNone) finish(ev, w, line_best);
    }
  };
  run_concurrently([&] { flicker_lines(ev_flicker); }, [&] { walk_line(ev_walk); });
  return out;
}

Eigen::MatrixXd modulated_sinusoid(const std::vector<double>& t_s, const std::vector<double>& dur_s, double period_s,
                                   int windows) {
  const int n = static_cast<int>(t_s.size());
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(n, 2 * std::max(windows, 1));
  if (n == 0 || !(period_s > 0) || windows < 1) return out;
  const double t0 = t_s.front(), span = t_s.back() - t0, w = 2.0 * M_PI / period_s;
  for (int i = 0; i < n; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    const double ph = w * (t_s[ui] - t0), x = 0.5 * w * dur_s[ui];
    const double sinc = x > 1e-9 ? std::sin(x) / x : 1.0;
    const int wi = span > 0 ? std::min(windows - 1, static_cast<int>((t_s[ui] - t0) / span * windows)) : 0;
    out(i, 2 * wi) = sinc * std::sin(ph);
    out(i, 2 * wi + 1) = sinc * std::cos(ph);
  }
  return out;
}

PeriodicBias periodic_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                           const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                           const std::vector<int>* seg_of) {
  PeriodicBias out;
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols()), P = c - 1;
  if (n <= P + 4 || !(duration_s > 0) || static_cast<int>(t_s.size()) != n) return out;
  const double f_lo = 1.5 / duration_s, f_hi = 25.0 / duration_s, df = 1.0 / (3.0 * duration_s);
  std::vector<double> freqs;
  for (double f = f_lo; f <= f_hi * (1 + 1e-12); f += df) freqs.push_back(f);
  const int F = static_cast<int>(freqs.size());
  const double t0 = t_s.front();
  // The pair of columns of frequency f into columns j, j + 1 of dst: a block's mean of the sinusoid, its value at
  // the mid time times sinc(π f · dur).
  auto fill = [&](Eigen::MatrixXd& dst, int j, double f) { dst.middleCols(j, 2) = modulated_sinusoid(t_s, dur_s, 1.0 / f, 1); };
  Eigen::MatrixXd aug(n, c + 2 * F);
  aug.leftCols(c) = rows;
  for (int k = 0; k < F; ++k) fill(aug, c + 2 * k, freqs[static_cast<std::size_t>(k)]);
  const estimator::NormalEquations ne = gls_normal_equations(m, t_s, dur_s, aug, rw_prior_var, seg_of);
  std::vector<int> cols(static_cast<std::size_t>(P));
  std::iota(cols.begin(), cols.end(), 0);
  const double rss0 = estimator::fit_subset(ne, cols).rss;
  cols.resize(static_cast<std::size_t>(P) + 2);
  int best = -1;
  std::vector<double> gk(static_cast<std::size_t>(F));
  for (int k = 0; k < F; ++k) {
    cols[static_cast<std::size_t>(P)] = P + 2 * k;
    cols[static_cast<std::size_t>(P) + 1] = P + 2 * k + 1;
    const double g = gk[static_cast<std::size_t>(k)] = rss0 - estimator::fit_subset(ne, cols).rss;
    if (g > out.gain) out.gain = g, best = k;
  }
  out.n_periods = F;
  if (best < 0) return out;
  // The modulated line (header): windows by a block's mid time, each holding three cycles at least.
  {
    std::vector<std::pair<double, int>> peaks;
    const double span = t_s.back() - t0;
    for (int k = 0; k < F; ++k) {
      if (span * freqs[static_cast<std::size_t>(k)] < 6.0) continue;  // two stretches of three cycles at least
      const double g = gk[static_cast<std::size_t>(k)];
      if ((k == 0 || g >= gk[static_cast<std::size_t>(k) - 1]) && (k == F - 1 || g >= gk[static_cast<std::size_t>(k) + 1]))
        peaks.push_back({g, k});
    }
    std::sort(peaks.begin(), peaks.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
    if (peaks.size() > 3) peaks.resize(3);
    for (const auto& peak : peaks) {
      const double f = freqs[static_cast<std::size_t>(peak.second)];
      const int W = std::min(8, static_cast<int>(std::floor(span * f / 3.0)));
      if (W < 2) continue;
      Eigen::MatrixXd wm(n, c + 2 * W);
      wm.leftCols(c) = rows;
      wm.rightCols(2 * W) = modulated_sinusoid(t_s, dur_s, 1.0 / f, W);
      const estimator::NormalEquations nw = gls_normal_equations(m, t_s, dur_s, wm, rw_prior_var, seg_of);
      std::vector<int> base(static_cast<std::size_t>(P)), full(static_cast<std::size_t>(P + 2 * W));
      std::iota(base.begin(), base.end(), 0);
      std::iota(full.begin(), full.end(), 0);
      const double g = estimator::fit_subset(nw, base).rss - estimator::fit_subset(nw, full).rss;
      if (g > out.mod_gain) out.mod_gain = g, out.mod_period_s = 1.0 / f, out.mod_windows = W;
    }
  }
  // The grid's best frequency refined between its neighbours (golden section): a strong sinusoid loses much of
  // its gain a third of a grid step off its frequency, and the random walk takes up what the misfit leaves.
  Eigen::MatrixXd two(n, c + 2);
  two.leftCols(c) = rows;
  std::vector<int> all(static_cast<std::size_t>(P) + 2);
  std::iota(all.begin(), all.end(), 0);
  auto gain_at = [&](double f) {
    fill(two, c, f);
    return rss0 - estimator::fit_subset(gls_normal_equations(m, t_s, dur_s, two, rw_prior_var, seg_of), all).rss;
  };
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  // Within the band searched: at its ends the neighbour outside is not a period the check asks about.
  double a = std::max(freqs[static_cast<std::size_t>(best)] - df, f_lo);
  double b = std::min(freqs[static_cast<std::size_t>(best)] + df, freqs.back());
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a), g1 = gain_at(x1), g2 = gain_at(x2);
  for (int it = 0; it < 16; ++it) {
    if (g1 > g2) {
      b = x2, x2 = x1, g2 = g1, x1 = b - phi * (b - a), g1 = gain_at(x1);
    } else {
      a = x1, x1 = x2, g1 = g2, x2 = a + phi * (b - a), g2 = gain_at(x2);
    }
  }
  const double f_best = g1 > g2 ? x1 : x2, g_best = std::max(g1, g2);
  out.period_s = 1.0 / freqs[static_cast<std::size_t>(best)];
  if (g_best > out.gain) out.gain = g_best, out.period_s = 1.0 / f_best;
  return out;
}

namespace {

// −2 log L (ML) of rows = aug's first c columns under w (nullptr: m's own level), returned, and beside each shape
// column in turn (with_shape; coef: each shape's coefficient, when asked).
double shape_ml(const StochasticModel& m, const WholeLogWander* w, const std::vector<double>& t_s,
                const std::vector<double>& dur_s, const Eigen::MatrixXd& aug, int c, double rw_prior_var,
                double duration_s, const std::vector<int>* seg_of, std::vector<double>& with_shape,
                std::vector<double>* coef) {
  const int S = static_cast<int>(aug.cols()) - c, P = c - 1;
  std::vector<int> cols(static_cast<std::size_t>(P));
  std::iota(cols.begin(), cols.end(), 0);
  double rw = 0, logS = 0;
  const StochasticModel mm = with_wander(m, w, duration_s, rw_prior_var, rw);
  const estimator::NormalEquations ne = gls_normal_equations(mm, t_s, dur_s, aug, rw, seg_of, nullptr, &logS);
  const double base = logS + estimator::fit_subset(ne, cols).rss;
  with_shape.assign(static_cast<std::size_t>(S), base);
  cols.push_back(P);
  for (int k = 0; k < S; ++k) {
    cols.back() = P + k;
    const auto f = estimator::fit_subset(ne, cols);
    with_shape[static_cast<std::size_t>(k)] = logS + f.rss;
    if (coef)
      for (std::size_t i = 0; i < f.kept.size(); ++i)
        if (f.kept[i] == P + k) (*coef)[static_cast<std::size_t>(k)] = f.theta[static_cast<Eigen::Index>(i)];
  }
  return base;
}

// −2 log L (ML: Σ log S + χ², not REML: see trend_bias in the header) of rows = aug's first c columns, and of
// rows beside each of aug's remaining S shape columns in turn, under the model's own level (own, own_shape, coef:
// each shape's coefficient there) and, when raise is not kNone, profiled over the raise's own level from 1/16 to
// 2× the raise and the model's own (best, best_shape). The one profile trend_bias and input_bias ask. The 41 levels
// are independent fits: half of them run beside the rest and the model's own level (concurrency.h), and the minima
// are taken in the levels' order afterwards, so the answer is the one-thread answer to the bit.
// O(42 · n · (c + S)² + 42 · S · c³).
struct ShapeProfile {
  double own = 0, best = 0;
  std::vector<double> own_shape, best_shape, coef;
};
ShapeProfile profile_shapes(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                            const Eigen::MatrixXd& aug, int c, double rw_prior_var, double duration_s,
                            const WholeLogWander& raise, const std::vector<int>* seg_of) {
  const int S = static_cast<int>(aug.cols()) - c;
  ShapeProfile out;
  out.coef.assign(static_cast<std::size_t>(S), 0.0);
  auto own = [&] { out.own = shape_ml(m, nullptr, t_s, dur_s, aug, c, rw_prior_var, duration_s, seg_of, out.own_shape, &out.coef); };
  if (raise.kind == WholeLogWander::kNone) {
    own();
    out.best = out.own;
    out.best_shape = out.own_shape;
    return out;
  }
  // The raise's level times 2^(k/8), k = −32 … 8.
  constexpr int kLo = -32, kLevels = 41;
  std::vector<double> v(kLevels);
  std::vector<std::vector<double>> v_shape(kLevels);
  auto levels = [&](int i0, int i1) {
    for (int i = i0; i < i1; ++i) {
      WholeLogWander w = raise;
      const double f = std::pow(2.0, (kLo + i) / 8.0);
      if (w.kind == WholeLogWander::kRandomWalk) w.K *= f;
      else w.bank_sigma *= f;
      v[static_cast<std::size_t>(i)] =
          shape_ml(m, &w, t_s, dur_s, aug, c, rw_prior_var, duration_s, seg_of, v_shape[static_cast<std::size_t>(i)], nullptr);
    }
  };
  run_concurrently([&] { levels(0, kLevels / 2); }, [&] {
    own();
    levels(kLevels / 2, kLevels);
  });
  out.best = out.own;
  out.best_shape = out.own_shape;
  for (int i = 0; i < kLevels; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    if (std::isfinite(v[ui])) out.best = std::min(out.best, v[ui]);
    for (int s = 0; s < S; ++s)
      if (std::isfinite(v_shape[ui][static_cast<std::size_t>(s)]))
        out.best_shape[static_cast<std::size_t>(s)] = std::min(out.best_shape[static_cast<std::size_t>(s)], v_shape[ui][static_cast<std::size_t>(s)]);
  }
  return out;
}

}  // namespace

TrendBias trend_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                     const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                     const WholeLogWander& raise, const std::vector<int>* seg_of) {
  TrendBias out;
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols()), P = c - 1;
  if (n <= P + 3 || !(duration_s > 0) || static_cast<int>(t_s.size()) != n) return out;
  // The shapes, one column each: the line (a block's mean of it is its value at the block's mid time; centred and
  // scaled to O(1) for the solve), then the settling transients e^{−(t − t_first)/τ} (a block's mean: the value
  // at its mid time times sinh(x)/x, x = dur/2τ).
  std::vector<double> taus;
  for (double d = 20.0; d >= 1.5 - 1e-9; d /= std::sqrt(2.0)) taus.push_back(duration_s / d);
  const int S = 1 + static_cast<int>(taus.size());
  out.n_shapes = S;
  const double t_mid = 0.5 * (t_s.front() + t_s.back()), t_first = t_s.front();
  Eigen::MatrixXd aug(n, c + S);
  aug.leftCols(c) = rows;
  for (int i = 0; i < n; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    aug(i, c) = (t_s[ui] - t_mid) / duration_s;
    for (int k = 1; k < S; ++k) {
      const double tau = taus[static_cast<std::size_t>(k - 1)], x = 0.5 * dur_s[ui] / tau;
      aug(i, c + k) = std::exp(-(t_s[ui] - t_first) / tau) * (x > 1e-9 ? std::sinh(x) / x : 1.0);
    }
  }
  const ShapeProfile p = profile_shapes(m, t_s, dur_s, aug, c, rw_prior_var, duration_s, raise, seg_of);
  out.line_gain = std::max(p.own - p.own_shape[0], 0.0);
  out.slope_per_s = p.coef[0] / duration_s;
  if (raise.kind == WholeLogWander::kNone) return out;
  out.gain = p.best - p.best_shape[0];
  for (int s = 1; s < S; ++s) {
    const double g = p.best - p.best_shape[static_cast<std::size_t>(s)];
    if (g > out.settle_gain) {
      out.settle_gain = g;
      out.settle_own_gain = std::max(p.own - p.own_shape[static_cast<std::size_t>(s)], 0.0);
      out.settle_tau_s = taus[static_cast<std::size_t>(s - 1)];
      out.settle_amplitude = p.coef[static_cast<std::size_t>(s)];
    }
  }
  return out;
}

constexpr int kInputBiasProfiled = 6;

namespace {
// A function column scaled to unit spread about its mean (the solve's conditioning; a likelihood ratio does not
// see it); a constant column is returned as zeros.
Eigen::VectorXd unit_spread(const Eigen::Ref<const Eigen::VectorXd>& col) {
  const double sd = std::sqrt((col.array() - col.mean()).square().mean());
  return sd > 0 ? Eigen::VectorXd(col / sd) : Eigen::VectorXd::Zero(col.size());
}
}  // namespace

InputBias input_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                     const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                     const WholeLogWander& raise, const Eigen::Ref<const Eigen::MatrixXd>& functions,
                     const std::vector<int>* seg_of) {
  InputBias out;
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols()), P = c - 1;
  const int S = static_cast<int>(functions.cols());
  if (n <= P + 3 || S == 0 || functions.rows() != n || !(duration_s > 0) || static_cast<int>(t_s.size()) != n ||
      raise.kind == WholeLogWander::kNone)
    return out;
  std::vector<int> live;
  Eigen::MatrixXd aug(n, c + S);
  aug.leftCols(c) = rows;
  for (int k = 0; k < S; ++k) {
    aug.col(c + k) = unit_spread(functions.col(k));
    if (functions.col(k).cwiseAbs().maxCoeff() > 0.0) live.push_back(k);
  }
  out.n_functions = static_cast<int>(live.size());
  if (live.empty()) return out;
  // Screened at the raise's own level (one pass with every function), profiled for the kInputBiasProfiled likeliest:
  // the profile is 42 passes, and with ~80 columns on a 1 h log of 3273 blocks it cost 3 s of 28.
  std::vector<double> at_raise;
  shape_ml(m, &raise, t_s, dur_s, aug, c, rw_prior_var, duration_s, seg_of, at_raise, nullptr);
  std::sort(live.begin(), live.end(), [&](int a, int b) {
    return at_raise[static_cast<std::size_t>(a)] < at_raise[static_cast<std::size_t>(b)];
  });
  if (live.size() > static_cast<std::size_t>(kInputBiasProfiled)) live.resize(static_cast<std::size_t>(kInputBiasProfiled));
  Eigen::MatrixXd aug2(n, c + static_cast<int>(live.size()));
  aug2.leftCols(c) = rows;
  for (std::size_t i = 0; i < live.size(); ++i) aug2.col(c + static_cast<Eigen::Index>(i)) = aug.col(c + live[i]);
  const ShapeProfile p = profile_shapes(m, t_s, dur_s, aug2, c, rw_prior_var, duration_s, raise, seg_of);
  for (std::size_t i = 0; i < live.size(); ++i) {
    const double g = p.best - p.best_shape[i];
    if (g > out.gain) {
      out.gain = g;
      out.own_gain = std::max(p.own - p.own_shape[i], 0.0);
      out.best = live[i];
    }
  }
  return out;
}

InputBias input_group_bias(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                           const Eigen::Ref<const Eigen::MatrixXd>& rows, double rw_prior_var, double duration_s,
                           const WholeLogWander& raise, const Eigen::Ref<const Eigen::MatrixXd>& group,
                           const std::vector<int>* seg_of) {
  InputBias out;
  const int n = static_cast<int>(rows.rows()), c = static_cast<int>(rows.cols()), P = c - 1;
  if (n <= P + 3 || group.cols() == 0 || group.rows() != n || !(duration_s > 0) || static_cast<int>(t_s.size()) != n ||
      raise.kind == WholeLogWander::kNone)
    return out;
  // rows = [z | columns]: the group joins the columns. Each model's −2 log L, profiled over the raise's level as
  // trend_bias does, is the "best" of a profile with no shape of its own.
  std::vector<int> live;
  for (int k = 0; k < static_cast<int>(group.cols()); ++k)
    if (group.col(k).cwiseAbs().maxCoeff() > 0.0) live.push_back(k);
  out.n_functions = static_cast<int>(live.size());
  if (live.empty() || n <= P + out.n_functions + 3) return out;
  Eigen::MatrixXd with(n, c + out.n_functions);
  with.leftCols(c) = rows;
  for (std::size_t i = 0; i < live.size(); ++i) with.col(c + static_cast<Eigen::Index>(i)) = unit_spread(group.col(live[i]));
  const Eigen::MatrixXd without = rows;
  const ShapeProfile p0 = profile_shapes(m, t_s, dur_s, without, c, rw_prior_var, duration_s, raise, seg_of);
  const ShapeProfile p1 = profile_shapes(m, t_s, dur_s, with, static_cast<int>(with.cols()), rw_prior_var, duration_s, raise, seg_of);
  out.gain = std::max(p0.best - p1.best, 0.0);
  out.own_gain = std::max(p0.own - p1.own, 0.0);
  return out;
}

double weighted_sum_variance(const StochasticModel& m, const std::vector<double>& t_s, const std::vector<double>& dur_s,
                             const std::vector<int>& seg, const std::vector<double>& u, const std::vector<double>& diag,
                             double t_start, double rw_prior_var) {
  const std::size_t n = t_s.size();
  double total = 0;
  // Each correlated state: Σ_i Σ_j u_i α_i u_j α_j e^{−|t_j − t_i|/T}, the sum over i < j carried forward in time.
  // cross[i] collects the i = j term of the same formula, which diag[i] replaces.
  std::vector<double> cross(n, 0.0);
  for (const auto& [s2, T] : m.gm_states(false)) {
    double acc = 0, sum = 0;  // acc = Σ_{i<j} u_i α_i e^{−(t_j − t_i)/T}
    for (std::size_t j = 0; j < n; ++j) {
      double a = 1, v = 1;
      gm_block(std::max(dur_s[j], 1e-9), T, a, v);
      const double x = u[j] * a;
      if (j > 0) acc *= std::exp(-std::max(t_s[j] - t_s[j - 1], 0.0) / T);
      sum += 2.0 * x * acc + x * x;
      acc += x;
      cross[j] += s2 * a * a;
    }
    total += s2 * sum;
  }
  // Random walk: prior·(Σu)² + K² Σ_{i,j} u_i u_j (min(t_i, t_j) − t_start)⁺ = K² ∫ (Σ_{t_i > s} u_i)² ds.
  double U = 0;
  for (double x : u) U += x;
  total += rw_prior_var * U * U;
  if (m.K > 0) {
    double tail = U, prev = t_start;
    for (std::size_t k = 0; k < n; ++k) {
      total += m.K * m.K * tail * tail * std::max(t_s[k] - prev, 0.0);
      prev = std::max(prev, t_s[k]);
      tail -= u[k];
    }
  }
  // The per-segment bias, within a segment.
  if (m.seg_bias_var > 0) {
    double in_seg = 0;
    for (std::size_t k = 0; k < n; ++k) {
      in_seg += u[k];
      if (k + 1 == n || seg[k + 1] != seg[k]) {
        total += m.seg_bias_var * in_seg * in_seg;
        in_seg = 0;
      }
    }
  }
  for (std::size_t k = 0; k < n; ++k) {
    const double c = cross[k] + rw_prior_var + m.K * m.K * std::max(t_s[k] - t_start, 0.0) + m.seg_bias_var;
    total += u[k] * u[k] * (diag[k] - c);
  }
  return total;
}

double block_covariance(const StochasticModel& m, double ti, double di, double tj, double dj, bool same, double t_start,
                        double rw_prior_var) {
  double c = 0;
  // The point estimate: what the noise floor and the held-out variances are judged against (the upper limit
  // is the likelihood's guard against drift, not a claim about the floor).
  for (const auto& [s2, T] : m.gm_states(false)) {
    double ai = 1, vi = 1, aj = 1, vj = 1;
    gm_block(std::max(di, 1e-9), T, ai, vi);
    gm_block(std::max(dj, 1e-9), T, aj, vj);
    c += s2 * (same ? vi : ai * aj * std::exp(-std::fabs(ti - tj) / T));
  }
  c += rw_prior_var + m.K * m.K * std::max(0.0, std::min(ti, tj) - t_start) + m.seg_bias_var;
  if (same) c += m.white_var(std::max(std::min(di, dj), 1e-9));
  return c;
}

}  // namespace imuforge::diagnosis
