// Lag probe on the motion (step_lag.h says what; docs/diagnosis.md § timing says why).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "host/diagnosis/concurrency.h"
#include "host/diagnosis/step_lag.h"
#include "host/estimator/robust.h"

namespace imuforge::diagnosis {

namespace {

constexpr double kWindow_s = 4.0;     // a table move (accelerate, coast, brake) with still time on each side
constexpr double kMaxShift_s = 2.5;   // beyond the 1 s, short of the 5 s dwells that would alias
constexpr double kBinTarget_hz = 100.0;

struct Binned {
  std::vector<double> t;  // bin centre, s from the first sample
  std::vector<float> u[2][3], y[2][3];
  std::vector<char> ok;   // every sample of the bin has a reference, no gap inside
};

Binned bin_log(SampleSource& src, double fs, double duration_s, int m, long max_missing) {
  Binned b;
  const std::size_t n_est = static_cast<std::size_t>(std::max(0.0, duration_s * fs / m)) + 2;
  b.t.reserve(n_est);
  b.ok.reserve(n_est);
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 3; ++k) {
      b.u[s][k].reserve(n_est);
      b.y[s][k].reserve(n_est);
    }
  double su[2][3] = {}, sy[2][3] = {}, st = 0, t_prev = 0, t_first = 0;
  int cnt = 0;
  bool good = true, first = true;
  auto flush = [&]() {
    if (cnt == 0) return;
    b.t.push_back(st / cnt);
    for (int s = 0; s < 2; ++s)
      for (int k = 0; k < 3; ++k) {
        b.u[s][k].push_back(static_cast<float>(su[s][k] / cnt));
        b.y[s][k].push_back(static_cast<float>(sy[s][k] / cnt));
        su[s][k] = sy[s][k] = 0;
      }
    b.ok.push_back(good && cnt == m ? 1 : 0);
    st = 0;
    cnt = 0;
    good = true;
  };
  src.rewind();
  Sample x;
  while (src.next(x)) {
    if (first) { t_first = t_prev = x.t_s; first = false; }
    // A gap in time ends the bin (and marks it): the bins' spacing stays one bin where they are used.
    if (x.t_s - t_prev > 5.0 / fs) {
      good = false;
      flush();
      // Bins for the missing time, marked, keep the bin index proportional to time where a window could reach
      // across (a window never holds a marked bin, so a longer gap needs only that many).
      const double gap = x.t_s - t_prev;
      const long missing = std::min(std::lround(gap * fs / m) - 1, max_missing);
      for (long i = 0; i < missing; ++i) {
        cnt = 1;
        st = t_prev - t_first + (static_cast<double>(i) + 1.0) * m / fs;
        good = false;
        flush();
      }
    }
    t_prev = x.t_s;
    st += x.t_s - t_first;
    for (int k = 0; k < 3; ++k) {
      su[0][k] += x.f[k];
      su[1][k] += x.w[k];
      sy[0][k] += x.y[k];
      sy[1][k] += x.y[3 + k];
    }
    good = good && x.has_ref;
    if (++cnt == m) flush();
  }
  flush();
  return b;
}

struct LocalLag {
  double t_s, lag_s;
};

}  // namespace

std::array<StepLag, 2> probe_motion_lag(SampleSource& src, double fs, double duration_s) {
  std::array<StepLag, 2> out;
  if (!(fs > 0) || !(duration_s > 0)) return out;
  int m = std::max(1, static_cast<int>(std::lround(fs / kBinTarget_hz)));
  const double n_samples = duration_s * fs;
  if (n_samples / m > 2e6) m = static_cast<int>(std::ceil(n_samples / 2e6));
  const double hb = m / fs;  // bin interval, s
  const long L = static_cast<long>(std::ceil(kMaxShift_s / hb));
  const long W = std::max<long>(8, std::lround(kWindow_s / hb));
  const Binned b = bin_log(src, fs, duration_s, m, W + 2 * L + 2);
  const long N = static_cast<long>(b.t.size());
  if (N < W + 2 * L + 2) return out;
  // Prefix count of bad bins: a window and its shifted reference must lie in one stretch with a reference.
  std::vector<long> bad(static_cast<std::size_t>(N) + 1, 0);
  for (long i = 0; i < N; ++i) bad[static_cast<std::size_t>(i) + 1] = bad[static_cast<std::size_t>(i)] + (b.ok[static_cast<std::size_t>(i)] ? 0 : 1);
  const double* thr = kLagProbeMinChange;  // a window's output range, at least
  const bool trace = std::getenv("IMUFORGE_DIAG_TRACE") != nullptr;
  // The two triads are searched at once (concurrency.h): each owns its scratch, its result and its trace, and the
  // traces print in triad order after both.
  std::string trace_text[2];
  auto tracef = [&](int s, const char* fmt, auto... args) {
    char buf[200];
    std::snprintf(buf, sizeof buf, fmt, args...);
    trace_text[s] += buf;
  };
  auto per_sensor = [&](int s) {
    std::vector<double> E(static_cast<std::size_t>(2 * L + 1)), sorted(E.size());
    std::vector<LocalLag> lags;
    for (long i0 = L; i0 + W + L <= N; i0 += W / 2) {
      if (bad[static_cast<std::size_t>(i0 + W + L)] - bad[static_cast<std::size_t>(i0 - L)] != 0) continue;
      double range = 0;
      for (int k = 0; k < 3; ++k) {
        const auto& yk = b.y[s][k];
        const auto mm = std::minmax_element(yk.begin() + i0, yk.begin() + i0 + W);
        range = std::max(range, static_cast<double>(*mm.second - *mm.first));
      }
      if (range < thr[s]) continue;
      // E(l): squared difference of output and reference read l bins earlier (l > 0: the output is late),
      // each axis's mean difference removed.
      for (long l = -L; l <= L; ++l) {
        double e = 0;
        for (int k = 0; k < 3; ++k) {
          const float* yk = b.y[s][k].data() + i0;
          const float* uk = b.u[s][k].data() + i0 - l;
          double sd = 0, sdd = 0;
          for (long i = 0; i < W; ++i) {
            const double d = static_cast<double>(yk[i]) - uk[i];
            sd += d;
            sdd += d * d;
          }
          e += sdd - sd * sd / static_cast<double>(W);
        }
        E[static_cast<std::size_t>(l + L)] = e;
      }
      const auto it = std::min_element(E.begin(), E.end());
      const long j = it - E.begin();
      if (j == 0 || j == 2 * L) continue;  // the best shift is at the edge of the search: beyond it
      const double e0 = *it;
      // Unique: no other local minimum within 5× of the best (a sine's later periods, a similar move).
      bool unique = true;
      for (long q = 1; q < 2 * L && unique; ++q)
        if (q != j && E[static_cast<std::size_t>(q)] <= E[static_cast<std::size_t>(q - 1)] &&
            E[static_cast<std::size_t>(q)] <= E[static_cast<std::size_t>(q + 1)] && std::labs(q - j) > 2 &&
            E[static_cast<std::size_t>(q)] < 5.0 * e0)
          unique = false;
      sorted = E;
      std::nth_element(sorted.begin(), sorted.begin() + L, sorted.end());
      const double med = sorted[static_cast<std::size_t>(L)];
      if (!unique || !(e0 < 0.05 * med)) continue;
      const double em = E[static_cast<std::size_t>(j - 1)], ep = E[static_cast<std::size_t>(j + 1)];
      const double den = em - 2.0 * e0 + ep;
      const double frac = den > 0 ? std::clamp(0.5 * (em - ep) / den, -0.5, 0.5) : 0.0;
      const double t_mid = b.t[static_cast<std::size_t>(i0 + W / 2)];
      lags.push_back({t_mid, (static_cast<double>(j - L) + frac) * hb});
    }
    StepLag& r = out[static_cast<std::size_t>(s)];
    const std::size_t n = lags.size();
    r.n_steps = static_cast<int>(n);
    if (trace) {
      tracef(s, "motion lag %d: %zu local lags\n", s, n);
      for (std::size_t i = 0; i < n; i += std::max<std::size_t>(1, n / 40)) tracef(s, "  t %.1f lag %.4f\n", lags[i].t_s, lags[i].lag_s);
    }
    if (n < 8) return;
    // The line most lags agree with: candidates through pairs of a spread subset (and level lines through each),
    // scored by the count within tol. Aliases (a lag a period of the motion off) scatter; the clock is a line.
    const double tol = std::max(1.5 * hb, 0.01);
    const std::size_t stride = std::max<std::size_t>(1, n / 120);
    std::vector<std::size_t> sub;
    for (std::size_t i = 0; i < n; i += stride) sub.push_back(i);
    auto count = [&](double a, double c) {
      int k = 0;
      for (const auto& g : lags) k += std::fabs(g.lag_s - (a + c * g.t_s)) <= tol ? 1 : 0;
      return k;
    };
    int best = -1;
    double ba = 0, bc = 0;
    for (std::size_t p = 0; p < sub.size(); ++p) {
      const auto& g1 = lags[sub[p]];
      const int k0 = count(g1.lag_s, 0.0);
      if (k0 > best) { best = k0; ba = g1.lag_s; bc = 0; }
      for (std::size_t q = p + 1; q < sub.size(); ++q) {
        const auto& g2 = lags[sub[q]];
        if (!(g2.t_s - g1.t_s > 60.0)) continue;
        const double c = (g2.lag_s - g1.lag_s) / (g2.t_s - g1.t_s);
        if (std::fabs(c) > 2e-3) continue;  // beyond ±2000 ppm: not a crystal
        const double a = g1.lag_s - c * g1.t_s;
        const int k = count(a, c);
        if (k > best) { best = k; ba = a; bc = c; }
      }
    }
    std::vector<char> in(n);
    double cut = tol, S = 0, St = 0, Stt = 0, det = 0, ss = 0;
    int n_in = 0;
    for (int iter = 0; iter < 8; ++iter) {
      S = St = Stt = 0;
      double Sy = 0, Sty = 0;
      n_in = 0;
      for (std::size_t i = 0; i < n; ++i) {
        in[i] = std::fabs(lags[i].lag_s - (ba + bc * lags[i].t_s)) <= cut ? 1 : 0;
        if (!in[i]) continue;
        const double t = lags[i].t_s, y = lags[i].lag_s;
        S += 1; St += t; Stt += t * t; Sy += y; Sty += t * y;
        ++n_in;
      }
      det = S * Stt - St * St;
      if (n_in < 3 || !(det > 0)) break;
      bc = (S * Sty - St * Sy) / det;
      ba = (Sy - bc * St) / S;
      std::vector<double> a;
      ss = 0;
      for (std::size_t i = 0; i < n; ++i)
        if (in[i]) {
          const double e = lags[i].lag_s - (ba + bc * lags[i].t_s);
          a.push_back(std::fabs(e));
          ss += e * e;
        }
      const double next_cut = std::max(tol, 3.0 * estimator::robust_sigma_of_magnitudes(a));
      if (next_cut == cut && iter > 0) break;
      cut = next_cut;
    }
    if (n_in < 3 || !(det > 0)) return;
    r.n_outliers = static_cast<int>(n) - n_in;
    r.latency_s = ba;
    r.ppm = bc * 1e6;
    r.rms_s = std::sqrt(ss / n_in);
    // σ from the scatter about the line (at least a bin's uniform h²/12: the parabola's own error).
    const double s2 = std::max(n_in > 2 ? ss / (n_in - 2.0) : hb * hb, hb * hb / 12.0);
    r.sigma_latency_s = std::sqrt(s2 * Stt / det);
    r.sigma_ppm = 1e6 * std::sqrt(s2 * S / det);
    r.max_abs_s = std::max(std::fabs(ba), std::fabs(ba + bc * duration_s));
    r.valid = n_in >= 8 && 10 * n_in >= 6 * static_cast<int>(n);
    if (trace)
      tracef(s, "motion lag %d: line %d of %zu: latency %.5g s ppm %.5g rms %.3g s valid %d\n", s, n_in, n, ba, bc * 1e6,
             r.rms_s, r.valid);
  };
  run_concurrently([&] { per_sensor(0); }, [&] { per_sensor(1); });
  if (trace)
    for (const std::string& t : trace_text) std::fputs(t.c_str(), stderr);
  return out;
}

}  // namespace imuforge::diagnosis
