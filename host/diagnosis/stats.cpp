#include "host/diagnosis/stats.h"

#include "host/diagnosis/noise_model.h"
#include "host/estimator/robust.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <math.h>  // lgamma_r
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace imuforge::diagnosis {

namespace {
// ln Γ(a), a > 0, without std::lgamma's write of the global signgam (POSIX): the χ² tails are evaluated on two
// threads at once (concurrency.h: the whole-log wander's lines), and ThreadSanitizer reports that write as a race.
// glibc's lgamma is this function with the sign stored, so the values are the same.
double log_gamma_pos(double a) {
  int sign = 0;
  return lgamma_r(a, &sign);
}

constexpr double kEps = 1e-16;
constexpr int kMaxIter = 100000;

// log P(a,x) via the series  P = e^{-x} x^a / Γ(a+1) Σ_n x^n / ((a+1)…(a+n)).
double log_gamma_p_series(double a, double x) {
  double term = 1.0 / a, sum = term, ap = a;
  for (int n = 0; n < kMaxIter; ++n) {
    ap += 1.0;
    term *= x / ap;
    sum += term;
    if (std::fabs(term) < std::fabs(sum) * kEps) break;
  }
  return -x + a * std::log(x) - log_gamma_pos(a) + std::log(sum);
}

// log Q(a,x) via the continued fraction Γ(a,x) = e^{-x} x^a (1/(x+1−a−) 1·(1−a)/(x+3−a−) …), modified Lentz.
double log_gamma_q_cf(double a, double x) {
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kMaxIter; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < kEps) break;
  }
  return -x + a * std::log(x) - log_gamma_pos(a) + std::log(h);
}
}  // namespace

double log_gamma_q(double a, double x) {
  if (!(a > 0.0) || !(x >= 0.0)) throw std::invalid_argument("log_gamma_q: need a > 0 and x >= 0");
  if (x == 0.0) return 0.0;
  if (std::isinf(x)) return -std::numeric_limits<double>::infinity();
  if (x < a + 1.0) {
    const double lp = log_gamma_p_series(a, x);
    const double p = std::exp(lp);
    return p >= 1.0 ? -std::numeric_limits<double>::infinity() : std::log1p(-p);
  }
  return log_gamma_q_cf(a, x);
}

double gamma_q(double a, double x) { return std::exp(log_gamma_q(a, x)); }

double chi2_sf(double x, double k) { return x <= 0.0 ? 1.0 : gamma_q(0.5 * k, 0.5 * x); }

double chi2_log10_sf(double x, double k) { return x <= 0.0 ? 0.0 : log_gamma_q(0.5 * k, 0.5 * x) / std::log(10.0); }

void AllanAccumulator::add_series(const std::vector<double>& x) {
  const std::size_t L = x.size();
  if (L < 3) return;
  // Cumulative sums make every cluster average O(1).
  std::vector<double> cs(L + 1, 0.0);
  // Remove the series mean first: it cancels in the differences and keeps the sums well conditioned.
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(L);
  for (std::size_t i = 0; i < L; ++i) cs[i + 1] = cs[i] + (x[i] - mean);
  std::size_t level = 0;
  for (std::size_t m = 1; 2 * m + 1 <= L; m *= 2, ++level) {
    if (num_.size() <= level) {
      num_.push_back(0.0);
      cnt_.push_back(0);
      edf_.push_back(0.0);
    }
    double s = 0.0;
    const std::size_t n_terms = L - 2 * m + 1;
    for (std::size_t i = 0; i < n_terms; ++i) {
      const double a0 = cs[i + m] - cs[i];
      const double a1 = cs[i + 2 * m] - cs[i + m];
      const double d = (a1 - a0) / static_cast<double>(m);
      s += d * d;
    }
    num_[level] += s;
    cnt_[level] += static_cast<long long>(n_terms);
    // Howe's edf for the overlapping estimator under white FM noise, summed over series.
    const double M = static_cast<double>(L), md = static_cast<double>(m);
    double edf = (3.0 * (M - 1.0) / (2.0 * md) - 2.0 * (M - 2.0) / M) * 4.0 * md * md / (4.0 * md * md + 5.0);
    edf_[level] += std::max(edf, 1.0);
  }
}

std::vector<AllanAccumulator::Point> AllanAccumulator::points(long long min_terms) const {
  std::vector<Point> out;
  for (std::size_t l = 0; l < num_.size(); ++l) {
    // Points resting on too few independent differences are too noisy to score (their χ² weight lies).
    if (cnt_[l] < min_terms || edf_[l] < 10.0) continue;
    Point p;
    p.tau_s = tau0_s_ * static_cast<double>(1ULL << l);
    p.avar = num_[l] / (2.0 * static_cast<double>(cnt_[l]));
    p.edf = edf_[l];
    p.terms = cnt_[l];
    out.push_back(p);
  }
  return out;
}

double NoiseTerms::avar(double tau_s) const {
  return 3.0 * Q * Q / (tau_s * tau_s) + N * N / tau_s + 2.0 * std::log(2.0) / M_PI * B * B + K * K * tau_s / 3.0;
}

bool fit_allan_terms(const std::vector<AllanAccumulator::Point>& pts, const std::function<double(int, double)>& basis, int p,
                     Eigen::VectorXd& c, Eigen::MatrixXd& H, double& chi2) {
  c = Eigen::VectorXd::Zero(p);
  // Weights from the measured values (σ(AVAR) ≈ AVAR·√(2/edf)); reweighting passes with the fitted
  // curve reduce the bias toward low points.
  for (int pass = 0; pass < 3; ++pass) {
    H = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
    for (const auto& pt : pts) {
      double ref = pt.avar;
      if (pass > 0) {
        double f = 0;
        for (int i = 0; i < p; ++i) f += c[i] * basis(i, pt.tau_s);
        if (f > 0) ref = f;
      }
      const double w = pt.edf / (2.0 * ref * ref);
      Eigen::VectorXd a(p);
      for (int i = 0; i < p; ++i) a[i] = basis(i, pt.tau_s);
      H += w * a * a.transpose();
      g += w * a * pt.avar;
    }
    // Scale to unit diagonal: the basis spans many decades.
    Eigen::VectorXd s = H.diagonal().cwiseSqrt().cwiseInverse();
    if (!s.allFinite()) return false;
    Eigen::MatrixXd Hs = s.asDiagonal() * H * s.asDiagonal();
    Eigen::LDLT<Eigen::MatrixXd> ldlt(Hs);
    if (ldlt.info() != Eigen::Success) return false;
    c = s.asDiagonal() * ldlt.solve(s.asDiagonal() * g);
    for (int i = 0; i < p; ++i)
      if (!(c[i] > 0)) return false;
  }
  chi2 = 0;
  for (const auto& pt : pts) {
    double f = 0;
    for (int i = 0; i < p; ++i) f += c[i] * basis(i, pt.tau_s);
    chi2 += pt.edf / 2.0 * (pt.avar - f) * (pt.avar - f) / (f * f);
  }
  return true;
}

NoiseFit fit_noise_terms(const std::vector<AllanAccumulator::Point>& pts, unsigned enabled_mask, double gm_T_s) {
  NoiseFit best;
  best.n_points = static_cast<int>(pts.size());
  best.chi2 = std::numeric_limits<double>::infinity();
  if (pts.empty()) {
    best.chi2 = 0.0;
    return best;
  }
  const double kFl = 2.0 * std::log(2.0) / M_PI;
  auto basis = [&](int t, double tau) {
    switch (t) {
      case 0: return 1.0 / (tau * tau);
      case 1: return 1.0 / tau;
      case 2: return 1.0;
      case 3: return tau;
      default: return gauss_markov_avar(tau, gm_T_s);
    }
  };
  for (unsigned subset = 1; subset < 16; ++subset) {
    if ((subset & enabled_mask) != subset) continue;
    std::vector<int> terms;
    for (int t = 0; t < 4; ++t)
      if (subset & (1u << t)) terms.push_back(t);
    if (gm_T_s > 0) terms.push_back(4);  // the correlated (Gauss-Markov) term is in every subset
    const int p = static_cast<int>(terms.size());
    if (p > static_cast<int>(pts.size())) continue;
    Eigen::VectorXd c;
    Eigen::MatrixXd H;
    double chi2 = 0;
    if (!fit_allan_terms(pts, [&](int i, double tau) { return basis(terms[static_cast<std::size_t>(i)], tau); }, p, c, H, chi2))
      continue;
    if (chi2 < best.chi2) {
      NoiseFit nf;
      nf.n_points = best.n_points;
      nf.chi2 = chi2;
      Eigen::MatrixXd cov = H.inverse();
      for (int i = 0; i < p; ++i) {
        const int t = terms[static_cast<std::size_t>(i)];
        const double ci = c[i], si = std::sqrt(std::max(cov(i, i), 0.0));
        // σ of a square-root parameter: d√c = dc / (2√c).
        switch (t) {
          case 4: break;  // the Gauss-Markov amplitude is not an IEEE 952 power-law term
          case 0: nf.terms.Q = std::sqrt(ci / 3.0); nf.sigma[0] = si / 3.0 / (2.0 * nf.terms.Q); break;
          case 1: nf.terms.N = std::sqrt(ci); nf.sigma[1] = si / (2.0 * nf.terms.N); break;
          case 2: nf.terms.B = std::sqrt(ci / kFl); nf.sigma[2] = si / kFl / (2.0 * nf.terms.B); break;
          default: nf.terms.K = std::sqrt(3.0 * ci); nf.sigma[3] = 3.0 * si / (2.0 * nf.terms.K); break;
        }
      }
      best = nf;
    }
  }
  if (!std::isfinite(best.chi2) && !(gm_T_s > 0)) best.chi2 = 0.0;
  return best;
}

SpectralLine line_power_spectrum(const std::vector<double>& t_s, const Eigen::Ref<const Eigen::VectorXd>& e) {
  SpectralLine out;
  const int n = static_cast<int>(e.size());
  if (n < 20 || static_cast<int>(t_s.size()) != n) return out;
  std::vector<double> dt;
  dt.reserve(static_cast<std::size_t>(n));
  for (int i = 1; i < n; ++i) dt.push_back(t_s[static_cast<std::size_t>(i)] - t_s[static_cast<std::size_t>(i - 1)]);
  const double med_dt = estimator::upper_median_in_place(dt);
  const double t0 = t_s.front(), span = t_s.back() - t_s.front();
  if (!(med_dt > 0) || !(span > 0)) return out;
  const double f_lo = 2.0 / span;
  double f_hi = 0.5 / med_dt;
  if (!(f_hi > f_lo)) return out;
  // The work is n × frequencies, and the frequencies grow with n (span / spacing): bounded at kMaxWork by
  // oversampling less (4× down to 1×), then, for logs of tens of thousands of blocks, by searching up to a lower
  // frequency (the slowest lines, those a whole-log wander is mistaken for, are kept; a 1 h log of 3273 blocks
  // needs neither).
  const double kMaxWork = 4e7;
  int over = 4;
  while (over > 1 && static_cast<double>(n) * (f_hi - f_lo) * over * span > kMaxWork) over /= 2;
  f_hi = std::min(f_hi, f_lo + kMaxWork / (static_cast<double>(n) * over * span));
  const double df = 1.0 / (over * span);
  const int F = static_cast<int>((f_hi - f_lo) / df) + 1;
  const Eigen::VectorXd ec = e.array() - e.mean();
  const double var = ec.squaredNorm() / std::max(1, n - 1);
  if (!(var > 0)) return out;
  // cos/sin of 2π f t_i for every i, advanced by one grid step per frequency (a rotation by 2π df t_i).
  std::vector<double> c(static_cast<std::size_t>(n)), s(static_cast<std::size_t>(n)), cd(static_cast<std::size_t>(n)),
      sd(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double t = t_s[static_cast<std::size_t>(i)] - t0;
    c[static_cast<std::size_t>(i)] = std::cos(2.0 * M_PI * f_lo * t);
    s[static_cast<std::size_t>(i)] = std::sin(2.0 * M_PI * f_lo * t);
    cd[static_cast<std::size_t>(i)] = std::cos(2.0 * M_PI * df * t);
    sd[static_cast<std::size_t>(i)] = std::sin(2.0 * M_PI * df * t);
  }
  // The least-squares sinusoid a·cos + b·sin at grid frequency k (Scargle's power without his τ):
  // [C S] M⁻¹ [C S]ᵀ / (2 var).
  auto judge = [&](int k, double C, double S, double CC, double SS, double CS) {
    const double det = CC * SS - CS * CS;
    if (!(det > 1e-12 * CC * SS)) return;
    const double pw = (SS * C * C - 2.0 * CS * C * S + CC * S * S) / det / (2.0 * var);
    if (pw > out.power) {
      out.power = pw;
      out.period_s = 1.0 / (f_lo + k * df);
    }
  };
  // The sums of c², s² and cs at each frequency depend on the times alone, and the diagnosis asks the spectrum of
  // many residuals over the same blocks (each whole-log wander line's innovations, several per axis and per selected
  // effect), so they are kept per thread for the last few time grids (a key of the times' bits; F × 3 doubles each).
  // A second call over the same times then runs only the C, S sums and the rotations, and its powers are the first
  // call's to the last bit (the same recurrence, the same order of addition).
  struct GridSums {
    std::uint64_t key = 0;
    int n = 0, F = 0;
    std::vector<double> cc, ss, cs;
  };
  thread_local std::array<GridSums, 4> cache;
  thread_local std::size_t cache_next = 0;
  std::uint64_t key = 1469598103934665603ull;  // FNV-1a over the times' bits, the grid's step and width
  auto mix = [&key](double v) {
    std::uint64_t b = 0;
    std::memcpy(&b, &v, sizeof b);
    for (int i = 0; i < 8; ++i) key = (key ^ ((b >> (8 * i)) & 0xffu)) * 1099511628211ull;
  };
  for (double t : t_s) mix(t);
  mix(df);
  mix(f_lo);
  mix(static_cast<double>(F));
  GridSums* hit = nullptr;
  for (auto& g : cache)
    if (g.F == F && g.n == n && g.key == key) hit = &g;
  GridSums* fill = nullptr;
  if (!hit) {
    fill = &cache[cache_next];
    cache_next = (cache_next + 1) % cache.size();
    fill->key = 0;  // not valid until filled below
    fill->n = n;
    fill->F = F;
    fill->cc.assign(static_cast<std::size_t>(F), 0.0);
    fill->ss.assign(static_cast<std::size_t>(F), 0.0);
    fill->cs.assign(static_cast<std::size_t>(F), 0.0);
  }
  // Two frequencies per pass over the blocks (four once the grid's sums are cached): each sum is still added in
  // block order, and each frequency's cos/sin is still one rotation of the last one's, so the powers are those of one
  // frequency per pass to the last bit, but the sets of sums are independent chains the processor overlaps (one set
  // alone waits on its adds; this loop took 13 % of the bench's 1 h table case in perf).
  int k = 0;
  while (hit && k + 3 < F) {
    double C0 = 0, S0 = 0, C1 = 0, S1 = 0, C2 = 0, S2 = 0, C3 = 0, S3 = 0;
    for (int i = 0; i < n; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const double ei = ec[i], c0 = c[ui], s0 = s[ui], cdi = cd[ui], sdi = sd[ui];
      C0 += ei * c0;
      S0 += ei * s0;
      const double c1 = c0 * cdi - s0 * sdi, s1 = s0 * cdi + c0 * sdi;
      C1 += ei * c1;
      S1 += ei * s1;
      const double c2 = c1 * cdi - s1 * sdi, s2 = s1 * cdi + c1 * sdi;
      C2 += ei * c2;
      S2 += ei * s2;
      const double c3 = c2 * cdi - s2 * sdi, s3 = s2 * cdi + c2 * sdi;
      C3 += ei * c3;
      S3 += ei * s3;
      c[ui] = c3 * cdi - s3 * sdi;
      s[ui] = s3 * cdi + c3 * sdi;
    }
    const double Cs[4] = {C0, C1, C2, C3}, Ss[4] = {S0, S1, S2, S3};
    for (int q = 0; q < 4; ++q) {
      const auto uq = static_cast<std::size_t>(k + q);
      judge(k + q, Cs[q], Ss[q], hit->cc[uq], hit->ss[uq], hit->cs[uq]);
    }
    k += 4;
  }
  // The rest (all of it on a first call, at most three frequencies after the loop above) with the grid's sums too:
  // a first call stores them; after the cached loop they are recomputed, the same values.
  for (; k + 1 < F; k += 2) {
    double C0 = 0, S0 = 0, CC0 = 0, SS0 = 0, CS0 = 0, C1 = 0, S1 = 0, CC1 = 0, SS1 = 0, CS1 = 0;
    for (int i = 0; i < n; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const double ei = ec[i], c0 = c[ui], s0 = s[ui], cdi = cd[ui], sdi = sd[ui];
      C0 += ei * c0;
      S0 += ei * s0;
      CC0 += c0 * c0;
      SS0 += s0 * s0;
      CS0 += c0 * s0;
      const double c1 = c0 * cdi - s0 * sdi, s1 = s0 * cdi + c0 * sdi;
      C1 += ei * c1;
      S1 += ei * s1;
      CC1 += c1 * c1;
      SS1 += s1 * s1;
      CS1 += c1 * s1;
      c[ui] = c1 * cdi - s1 * sdi;
      s[ui] = s1 * cdi + c1 * sdi;
    }
    if (fill) {
      const auto uk = static_cast<std::size_t>(k);
      fill->cc[uk] = CC0, fill->ss[uk] = SS0, fill->cs[uk] = CS0;
      fill->cc[uk + 1] = CC1, fill->ss[uk + 1] = SS1, fill->cs[uk + 1] = CS1;
    }
    judge(k, C0, S0, CC0, SS0, CS0);
    judge(k + 1, C1, S1, CC1, SS1, CS1);
  }
  if (k < F) {
    double C = 0, S = 0, CC = 0, SS = 0, CS = 0;
    for (int i = 0; i < n; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const double ci = c[ui], si = s[ui];
      C += ec[i] * ci;
      S += ec[i] * si;
      CC += ci * ci;
      SS += si * si;
      CS += ci * si;
    }
    judge(k, C, S, CC, SS, CS);
  }
  if (fill) fill->key = key;
  // Baluev (2008, MNRAS 385, 1279) for a power of known noise level: FAP ≤ e^{−P} + W e^{−P} √P with
  // W = bandwidth · √(4π Var t), tight at small FAP for any sampling. (1 − (1 − e^{−P})^M with M = bandwidth × span,
  // the regular-sampling count, fired 2.5× too often at 10 % on white noise: the oversampled grid finds peaks
  // between the independent frequencies.)
  double mt = 0, mt2 = 0;
  for (double ti : t_s) {
    mt += ti - t0;
    mt2 += (ti - t0) * (ti - t0);
  }
  mt /= n;
  const double var_t = std::max(mt2 / n - mt * mt, 0.0);
  const double W = (f_hi - f_lo) * std::sqrt(4.0 * M_PI * var_t);
  out.false_alarm_p = std::min(1.0, std::exp(-out.power) * (1.0 + W * std::sqrt(out.power)));
  return out;
}

}  // namespace imuforge::diagnosis
