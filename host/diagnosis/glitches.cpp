#include "host/diagnosis/glitches.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace imuforge::diagnosis {

namespace {

struct Row {
  long long row = 0;
  bool has_ref = false;
  double t_s = 0;
  double y[kNumAxes] = {};
};

// One centre row of the stretch: its residual (residual()) and its direct neighbours', and the value that replaces it.
struct Entry {
  long long row;
  double t_s, d, e_prev, e_next, fix;
  double r1;  // the centre against its direct neighbours alone: what the scale is measured on (a plain second
              // difference, √1.5 σ under white noise; d is never larger)
};

// The centre of five evenly spaced rows against four lines: through its direct neighbours, through the outer two,
// and each side's two extrapolated to it; the nearest, and 0 unless the centre lies on the same side of all four.
// A line cancels from each, so a turning table's ramp leaves nothing; a kink (a rate starting or stopping, where
// the second difference alone is as isolated as a glitch) lies on one side's extrapolation, a step on one side's
// line, and a row caught halfway through a step (a pose changing within a sample period) between the two sides'.
double second_difference(const double* v) { return v[2] - 0.5 * (v[1] + v[3]); }
double residual(const double* v) {
  const double r[4] = {second_difference(v), v[2] - 0.5 * (v[0] + v[4]), v[2] - (2.0 * v[1] - v[0]), v[2] - (2.0 * v[3] - v[4])};
  double best = r[0];
  for (int k = 1; k < 4; ++k) {
    if (r[k] * r[0] <= 0) return 0.0;
    if (std::fabs(r[k]) < std::fabs(best)) best = r[k];
  }
  return best;
}

double median_of(std::vector<double>& v) {
  const std::size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  return v[m];
}

}  // namespace

GlitchFilterSource::GlitchFilterSource(SampleSource& inner, double z_threshold) : inner_(inner) {
  if (!(z_threshold > 0)) return;
  std::array<std::vector<Entry>, kNumAxes> stretch;
  std::array<double, kNumAxes> quantum;  // smallest non-zero step between neighbouring rows in the stretch
  quantum.fill(0.0);
  std::array<double, kNumAxes> last_sigma;  // the previous stretch's σ, for a last stretch too short for its own
  last_sigma.fill(0.0);
  std::array<std::vector<double>, kNumAxes> sizes;  // every glitch's size in σ (for the median)
  std::vector<double> scratch;
  scratch.reserve(kStretchRows);
  const bool trace = std::getenv("IMUFORGE_DIAG_TRACE") != nullptr;

  // Judged per stretch; the last half-window of rows waits for the next stretch, whose first half-window is then
  // their context (a row's local σ sees rows on both sides wherever the stretch boundary falls).
  constexpr long long kHalf = kLocalRows / 2;
  std::array<long long, kNumAxes> first_new{};  // entries of the stretch before this one were judged already
  auto judge = [&](int a, bool last) {
    auto& E = stretch[static_cast<std::size_t>(a)];
    const long long n_e = static_cast<long long>(E.size());
    const long long k0 = first_new[static_cast<std::size_t>(a)], k1 = last ? n_e : n_e - kHalf;
    if (k1 <= k0) return;
    scratch.clear();
    for (const auto& e : E) scratch.push_back(std::fabs(e.r1));
    double sigma = 1.4826 * median_of(scratch);
    const bool short_tail = static_cast<int>(E.size()) < kStretchRows / 4 && last_sigma[static_cast<std::size_t>(a)] > 0;
    if (short_tail) sigma = last_sigma[static_cast<std::size_t>(a)];
    if (!(sigma > 0)) {  // more than half the residuals exactly zero: a noiseless or coarsely quantised stretch
      double ss = 0;
      for (const auto& e : E) ss += e.r1 * e.r1;
      sigma = std::sqrt(ss / static_cast<double>(E.size()));
    }
    auto& S = summary_[static_cast<std::size_t>(a)];
    for (long long k = k0; k < k1; ++k) {
      const Entry& e = E[static_cast<std::size_t>(k)];
      const double floor = std::max(8.0 * quantum[static_cast<std::size_t>(a)], 1e-12 * (1.0 + std::fabs(e.fix)));
      if (!(std::fabs(e.d) > std::max(z_threshold * sigma, floor))) continue;
      // The stretch's σ is the quiet rows'; a turning or vibrating part of it has its own: the candidate is judged
      // against each half of the kLocalRows rows about it as well (the largest σ: a row where the table starts to
      // vibrate has quiet rows on one side only).
      double local = 0.0;
      for (int side = 0; side < 2; ++side) {
        const long long lo = side == 0 ? std::max(0LL, k - kLocalRows / 2) : k + 1;
        const long long hi = side == 0 ? k : std::min(n_e, k + 1 + kLocalRows / 2);
        if (hi - lo < kLocalRows / 4) continue;
        scratch.clear();
        for (long long m = lo; m < hi; ++m) scratch.push_back(std::fabs(E[static_cast<std::size_t>(m)].r1));
        local = std::max(local, 1.4826 * median_of(scratch));
      }
      const double s_used = std::max(sigma, local);
      const double bar = std::max(z_threshold * s_used, floor);
      if (!(std::fabs(e.d) > bar && std::fabs(e.e_prev) < 0.5 * bar && std::fabs(e.e_next) < 0.5 * bar)) continue;
      fixes_.push_back({e.row, a, e.fix});
      if (trace)
        std::fprintf(stderr, "glitch %s t %.3f d %.4g prev %.3g next %.3g sigma %.3g quantum %.3g n %zu\n", axis_name(a), e.t_s, e.d, e.e_prev,
                     e.e_next, s_used, quantum[static_cast<std::size_t>(a)], E.size());
      const double z = std::fabs(e.d) / s_used;
      if (S.count == 0) S.first_t_s = e.t_s;
      S.last_t_s = e.t_s;
      ++S.count;
      S.max_sigma = std::max(S.max_sigma, z);
      S.max_abs = std::max(S.max_abs, std::fabs(e.d));
      if (S.t_s.size() < GlitchSummary::kListed) S.t_s.push_back(e.t_s);
      sizes[static_cast<std::size_t>(a)].push_back(z);
    }
    S.rows_checked += k1 - k0;
    last_sigma[static_cast<std::size_t>(a)] = sigma;
    E.erase(E.begin(), E.begin() + static_cast<std::ptrdiff_t>(std::max(0LL, n_e - 2 * kHalf)));
    first_new[static_cast<std::size_t>(a)] = std::min<long long>(kHalf, static_cast<long long>(E.size()));
    quantum[static_cast<std::size_t>(a)] = 0.0;
  };

  // Seven rows: the centre's residual and both neighbours' (each from its own four neighbours).
  constexpr int kRing = 7;
  Row ring[kRing];
  int filled = 0;
  long long row = 0;
  Sample s;
  inner_.rewind();
  while (inner_.next(s)) {
    Row r;
    r.row = row++;
    r.t_s = s.t_s;
    r.has_ref = s.has_ref;
    for (int a = 0; a < kNumAxes; ++a) r.y[a] = s.y[a];
    for (int k = 0; k + 1 < kRing; ++k) ring[k] = ring[k + 1];
    ring[kRing - 1] = r;
    if (filled < kRing) ++filled;
    if (filled < kRing) continue;
    // Evenly spaced (no gap, no repeated time stamp): the neighbourhood is the signal's own.
    double dt_min = 1e300, dt_max = 0;
    for (int k = 0; k + 1 < kRing; ++k) {
      const double dt = ring[k + 1].t_s - ring[k].t_s;
      dt_min = std::min(dt_min, dt);
      dt_max = std::max(dt_max, dt);
    }
    if (!(dt_min > 0 && dt_max <= 1.5 * dt_min)) continue;
    // Rows with a reference only: the fit reads nothing else (a hand-held log's moving rows, where a knock on the
    // desk is as sharp as a glitch, carry none).
    bool ref = true;
    for (int k = 0; k < kRing; ++k) ref = ref && ring[k].has_ref;
    if (!ref) continue;
    for (int a = 0; a < kNumAxes; ++a) {
      double v[kRing];
      bool finite = true;
      for (int k = 0; k < kRing; ++k) {
        v[k] = ring[k].y[a];
        finite = finite && std::isfinite(v[k]);
      }
      if (!finite) continue;
      const double step = std::fabs(v[kRing - 1] - v[kRing - 2]);
      auto& q = quantum[static_cast<std::size_t>(a)];
      if (step > 0 && (q == 0 || step < q)) q = step;
      const double d = residual(v + 1), d_prev = residual(v), d_next = residual(v + 2);
      auto& E = stretch[static_cast<std::size_t>(a)];
      E.push_back({ring[3].row, ring[3].t_s, d, d_prev, d_next, v[3] - d, second_difference(v + 1)});
      if (static_cast<int>(E.size()) >= kStretchRows) judge(a, false);
    }
  }
  for (int a = 0; a < kNumAxes; ++a) judge(a, true);  // the last, shorter stretch
  std::sort(fixes_.begin(), fixes_.end(), [](const Fix& x, const Fix& y) { return x.row != y.row ? x.row < y.row : x.axis < y.axis; });
  for (std::size_t i = 0; i < fixes_.size();) {
    std::size_t j = i;
    while (j < fixes_.size() && fixes_[j].row == fixes_[i].row) ++j;
    if (j - i > 1)
      for (std::size_t k = i; k < j; ++k) ++summary_[static_cast<std::size_t>(fixes_[k].axis)].shared;
    i = j;
  }
  for (int a = 0; a < kNumAxes; ++a)
    if (!sizes[static_cast<std::size_t>(a)].empty()) summary_[static_cast<std::size_t>(a)].median_sigma = median_of(sizes[static_cast<std::size_t>(a)]);
  inner_.rewind();
}

void GlitchFilterSource::rewind() {
  inner_.rewind();
  row_ = 0;
  next_fix_ = 0;
}

bool GlitchFilterSource::next(Sample& s) {
  if (!inner_.next(s)) return false;
  while (next_fix_ < fixes_.size() && fixes_[next_fix_].row == row_) {
    s.y[fixes_[next_fix_].axis] = fixes_[next_fix_].value;
    ++next_fix_;
  }
  ++row_;
  return true;
}

long long GlitchFilterSource::total() const {
  long long n = 0;
  for (const auto& S : summary_) n += S.count;
  return n;
}

}  // namespace imuforge::diagnosis
