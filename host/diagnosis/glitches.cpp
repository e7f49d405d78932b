#include "host/diagnosis/glitches.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "host/estimator/robust.h"

namespace imuforge::diagnosis {

namespace {

// The centre of five evenly spaced rows against four lines: through its direct neighbours, through the outer two,
// and each side's two extrapolated to it; the nearest, and 0 unless the centre lies on the same side of all four.
// A line cancels from each, so a turning table's ramp leaves nothing; a kink (a rate starting or stopping, where
// the second difference alone is as isolated as a glitch) lies on one side's extrapolation, a step on one side's
// line, and a row caught halfway through a step (a pose changing within a sample period) between the two sides'.
double second_difference(const double* v) { return v[2] - 0.5 * (v[1] + v[3]); }
// Without branches on the signs: under noise they fall either way at random, and a mispredicted branch per line
// was a sixth of the filter's time on the 1 h / 1 kHz bench.
double residual(const double* v) {
  const double r0 = second_difference(v), r1 = v[2] - 0.5 * (v[0] + v[4]), r2 = v[2] - (2.0 * v[1] - v[0]), r3 = v[2] - (2.0 * v[3] - v[4]);
  const double m = std::min(std::min(std::fabs(r0), std::fabs(r1)), std::min(std::fabs(r2), std::fabs(r3)));
  const bool same_side = (r0 * r1 > 0) & (r0 * r2 > 0) & (r0 * r3 > 0);
  return same_side ? std::copysign(m, r0) : 0.0;
}

}  // namespace

GlitchFilterSource::GlitchFilterSource(SampleSource& inner, double z_threshold, std::size_t max_buffered_rows)
    : inner_(inner), z_(z_threshold), max_buffered_(std::max<std::size_t>(max_buffered_rows, 2 * kStretchRows)) {
  searched_ = !(z_threshold > 0);  // off: nothing to search, every pass replays the log as it is
  trace_ = std::getenv("IMUFORGE_DIAG_TRACE") != nullptr;
  scratch_.reserve(kStretchRows);
}

void GlitchFilterSource::reset_search() {
  filled_ = 0;
  ring_head_ = 0;
  rows_read_ = 0;
  for (auto& E : stretch_) E.clear();
  first_new_.fill(0);
  quantum_.fill(0.0);
  last_sigma_.fill(0.0);
  for (auto& z : sizes_) z.clear();
  ahead_head_ = ahead_n_ = 0;
  res_row_.fill(-1);
  emitted_ = 0;
  inner_done_ = false;
  fixes_.clear();
  summary_ = {};
}

// Judged per stretch; the last half-window of rows waits for the next stretch, whose first half-window is then
// their context (a row's local σ sees rows on both sides wherever the stretch boundary falls).
void GlitchFilterSource::judge(int a, bool all) {
  constexpr long long kHalf = kLocalRows / 2;
  const auto ua = static_cast<std::size_t>(a);
  auto& E = stretch_[ua];
  const long long n_e = static_cast<long long>(E.size());
  const long long k0 = first_new_[ua], k1 = all ? n_e : n_e - kHalf;
  if (k1 <= k0) return;
  scratch_.clear();
  for (const auto& e : E) scratch_.push_back(std::fabs(e.r1));
  double sigma = estimator::robust_sigma_of_magnitudes(scratch_);
  const bool short_tail = static_cast<int>(E.size()) < kStretchRows / 4 && last_sigma_[ua] > 0;
  if (short_tail) sigma = last_sigma_[ua];
  if (!(sigma > 0)) {  // more than half the residuals exactly zero: a noiseless or coarsely quantised stretch
    double ss = 0;
    for (const auto& e : E) ss += e.r1 * e.r1;
    sigma = std::sqrt(ss / static_cast<double>(E.size()));
  }
  auto& S = summary_[ua];
  for (long long k = k0; k < k1; ++k) {
    const Entry& e = E[static_cast<std::size_t>(k)];
    const double floor = std::max(8.0 * quantum_[ua], 1e-12 * (1.0 + std::fabs(e.fix)));
    if (!(std::fabs(e.d) > std::max(z_ * sigma, floor))) continue;
    // The stretch's σ is the quiet rows'; a turning or vibrating part of it has its own: the candidate is judged
    // against each half of the kLocalRows rows about it as well (the largest σ: a row where the table starts to
    // vibrate has quiet rows on one side only).
    double local = 0.0;
    for (int side = 0; side < 2; ++side) {
      const long long lo = side == 0 ? std::max(0LL, k - kLocalRows / 2) : k + 1;
      const long long hi = side == 0 ? k : std::min(n_e, k + 1 + kLocalRows / 2);
      if (hi - lo < kLocalRows / 4) continue;
      scratch_.clear();
      for (long long m = lo; m < hi; ++m) scratch_.push_back(std::fabs(E[static_cast<std::size_t>(m)].r1));
      local = std::max(local, estimator::robust_sigma_of_magnitudes(scratch_));
    }
    const double s_used = std::max(sigma, local);
    const double bar = std::max(z_ * s_used, floor);
    if (!(std::fabs(e.d) > bar && std::fabs(e.e_prev) < 0.5 * bar && std::fabs(e.e_next) < 0.5 * bar)) continue;
    fixes_.push(e.row, a, e.fix);
    // Not handed on yet (ready_before() stops at this axis' first unjudged row): fixed where it waits.
    ahead_at(static_cast<std::size_t>(e.row - emitted_)).y[a] = e.fix;
    if (trace_)
      std::fprintf(stderr, "glitch %s t %.3f d %.4g prev %.3g next %.3g sigma %.3g quantum %.3g n %zu\n", axis_name(a), e.t_s, e.d, e.e_prev,
                   e.e_next, s_used, quantum_[ua], E.size());
    const double z = std::fabs(e.d) / s_used;
    if (S.count == 0) S.first_t_s = e.t_s;
    S.last_t_s = e.t_s;
    ++S.count;
    S.max_sigma = std::max(S.max_sigma, z);
    S.max_abs = std::max(S.max_abs, std::fabs(e.d));
    if (S.t_s.size() < GlitchSummary::kListed) S.t_s.push_back(e.t_s);
    sizes_[ua].push_back(z);
  }
  S.rows_checked += k1 - k0;
  last_sigma_[ua] = sigma;
  // Keep the last 2·kHalf entries: the unjudged ones and the context before them.
  const long long drop = std::max(0LL, n_e - 2 * kHalf);
  E.erase(E.begin(), E.begin() + static_cast<std::ptrdiff_t>(drop));
  first_new_[ua] = k1 - drop;
  quantum_[ua] = 0.0;
}

// Seven rows: the centre's residual and both neighbours' (each from its own four neighbours).
void GlitchFilterSource::scan(const Sample& s) {
  Row& r = ring_[ring_head_];
  r.row = rows_read_++;
  r.t_s = s.t_s;
  r.has_ref = s.has_ref;
  for (int a = 0; a < kNumAxes; ++a) r.y[a] = s.y[a];
  ring_head_ = (ring_head_ + 1) % kRing;
  if (filled_ < kRing) ++filled_;
  if (filled_ < kRing) return;
  const Row* w[kRing];  // oldest first
  for (int k = 0; k < kRing; ++k) w[k] = &ring_[(ring_head_ + k) % kRing];
  // Evenly spaced (no gap, no repeated time stamp): the neighbourhood is the signal's own.
  double dt_min = 1e300, dt_max = 0;
  for (int k = 0; k + 1 < kRing; ++k) {
    const double dt = w[k + 1]->t_s - w[k]->t_s;
    dt_min = std::min(dt_min, dt);
    dt_max = std::max(dt_max, dt);
  }
  if (!(dt_min > 0 && dt_max <= 1.5 * dt_min)) return;
  // Rows with a reference only: the fit reads nothing else (a hand-held log's moving rows, where a knock on the
  // desk is as sharp as a glitch, carry none).
  for (int k = 0; k < kRing; ++k)
    if (!w[k]->has_ref) return;
  for (int a = 0; a < kNumAxes; ++a) {
    double v[kRing];
    bool finite = true;
    for (int k = 0; k < kRing; ++k) {
      v[k] = w[k]->y[a];
      finite = finite && std::isfinite(v[k]);
    }
    if (!finite) continue;
    const double step = std::fabs(v[kRing - 1] - v[kRing - 2]);
    auto& q = quantum_[static_cast<std::size_t>(a)];
    if (step > 0 && (q == 0 || step < q)) q = step;
    // The three residuals about the centre: the two older from the windows before where those were whole.
    const auto ua = static_cast<std::size_t>(a);
    const long long c = w[3]->row;
    auto& rr = res_[ua];
    if (res_row_[ua] == c) {  // the previous window's: centres c − 2, c − 1, c
      rr = {rr[1], rr[2], residual(v + 2)};
    } else {
      rr = {residual(v), residual(v + 1), residual(v + 2)};
    }
    res_row_[ua] = c + 1;
    const double d_prev = rr[0], d = rr[1], d_next = rr[2];
    auto& E = stretch_[static_cast<std::size_t>(a)];
    E.push_back({w[3]->row, w[3]->t_s, d, d_prev, d_next, v[3] - d, second_difference(v + 1)});
    if (static_cast<int>(E.size()) >= kStretchRows) judge(a, false);
  }
}

long long GlitchFilterSource::ready_before() const {
  long long lim = rows_read_ - kRing / 2;  // the next centre: no row below it can join a stretch any more
  for (int a = 0; a < kNumAxes; ++a) {
    const auto& E = stretch_[static_cast<std::size_t>(a)];
    const auto k = static_cast<std::size_t>(first_new_[static_cast<std::size_t>(a)]);
    if (k < E.size()) lim = std::min(lim, E[k].row);
  }
  return lim;
}

void GlitchFilterSource::finish_search() {
  for (int a = 0; a < kNumAxes; ++a) judge(a, true);  // the last, shorter stretch
  fixes_.sort();
  const std::vector<RowFixes::Fix>& fixes = fixes_.all();
  for (std::size_t i = 0; i < fixes.size();) {
    std::size_t j = i;
    while (j < fixes.size() && fixes[j].row == fixes[i].row) ++j;
    if (j - i > 1)
      for (std::size_t k = i; k < j; ++k) ++summary_[static_cast<std::size_t>(fixes[k].axis)].shared;
    i = j;
  }
  for (int a = 0; a < kNumAxes; ++a)
    if (!sizes_[static_cast<std::size_t>(a)].empty())
      summary_[static_cast<std::size_t>(a)].median_sigma = estimator::upper_median_in_place(sizes_[static_cast<std::size_t>(a)]);
  for (auto& E : stretch_) std::vector<Entry>().swap(E);
}

void GlitchFilterSource::rewind() {
  inner_.rewind();
  fixes_.rewind();
  if (!searched_) reset_search();  // a pass left before the end: search again from the start
}

bool GlitchFilterSource::next(Sample& s) {
  if (searched_) {  // replay
    if (!inner_.next(s)) return false;
    fixes_.apply(s);
    return true;
  }
  // Search: read ahead until the oldest waiting row is judged on every axis.
  while (ahead_n_ == 0 || (!inner_done_ && emitted_ >= ready_before())) {
    if (inner_done_) {  // the end, and every row handed on
      searched_ = true;
      return false;
    }
    Sample in;
    if (!inner_.next(in)) {
      inner_done_ = true;
      finish_search();
      continue;
    }
    ahead_push(in);
    scan(ahead_at(ahead_n_ - 1));
    if (ahead_n_ > max_buffered_)  // rows with a reference sparse on some axis: judge what each holds now
      for (int a = 0; a < kNumAxes; ++a) judge(a, true);
  }
  s = ahead_at(0);
  ahead_head_ = (ahead_head_ + 1) % ahead_.size();
  --ahead_n_;
  ++emitted_;
  return true;
}

void GlitchFilterSource::ahead_push(const Sample& s) {
  if (ahead_n_ == ahead_.size()) {  // full: grow, unwrapped
    std::vector<Sample> grown;
    grown.reserve(std::max<std::size_t>(2 * ahead_.size(), 2048));
    for (std::size_t i = 0; i < ahead_n_; ++i) grown.push_back(ahead_at(i));
    grown.resize(grown.capacity());
    ahead_.swap(grown);
    ahead_head_ = 0;
  }
  ahead_at(ahead_n_) = s;
  ++ahead_n_;
}

const std::array<GlitchSummary, kNumAxes>& GlitchFilterSource::summary() {
  if (!searched_) {
    if (emitted_ == 0 && ahead_n_ == 0) rewind();
    Sample s;
    while (next(s)) {
    }
  }
  return summary_;
}

long long GlitchFilterSource::total() {
  long long n = 0;
  for (const auto& S : summary()) n += S.count;
  return n;
}

}  // namespace imuforge::diagnosis
