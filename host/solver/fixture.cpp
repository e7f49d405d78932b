// Fixture mode, one piece (past 600 lines): a row's path through the Ṫ delay line (CenteredTempRate), the dwell
// guard (DwellGuard), the block, segment and plateau moments and the solve with its dwell-scatter widening. They
// share the block tolerances and the per-segment statistics; apart, each would reach into the others' state.
#include "host/solver/fixture.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

namespace imuforge::solver {

using model::Effect;
using model::Sensor;

namespace {
// Plateaus are clusters of segment temperatures; chamber plateaus sit tens of °C apart while the die
// drifts by well under this within one.
constexpr double kPlateauTolerance_C = 3.0;
// A block continues while the reference stays within these of its first sample: Earth rate turning with
// the table (±5e-5 rad/s) and encoder noise on f_ref must not split a dwell into single samples.
// The regressors are taken at the block mean; the error this leaves is O(Δu²/u²) < 1e-7 relative.
constexpr double kBlockTolF_mps2 = 2e-3;
constexpr double kBlockTolW_rad_s = 2e-4;
// Blocks whose die temperature spans more than this feed the static noise estimate only as a fallback.
constexpr double kNoiseBlockSpan_C = 1.0;
// Degrees of freedom the dwell-only pool needs before it is preferred.
constexpr long long kNoiseMinDof = 100;

// The streaming stages (CenteredTempRate, DwellGuard) need rows in time order with finite stamps.
void check_time_order(double t_s, double last_t_s, const char* stage) {
  if (!std::isfinite(t_s))
    throw SolverError("log row after t=" + std::to_string(last_t_s) + " s has a non-finite time stamp");
  if (t_s < last_t_s)
    throw SolverError("log time goes backwards (" + std::to_string(t_s) + " s after " + std::to_string(last_t_s) +
                      " s): " + stage + " needs rows in time order");
}

bool is_temperature_effect(Effect e) {
  return e == Effect::kBiasTemp || e == Effect::kScaleTemp || e == Effect::kMisalignTemp;
}
}  // namespace

// ---------------------------------------------------------------------------------------------------
// Streaming centred difference for Ṫ (same definition as model::temp_rate_centered; test
// FixtureMode.StreamingTempRateEqualsBatchDefinition checks they agree bit for bit).

CenteredTempRate::CenteredTempRate(double window_s) : window_s_(window_s) {
  if (!(window_s > 0) || !std::isfinite(window_s))
    throw SolverError("dTdt_window_s must be a positive number of seconds");
}

void CenteredTempRate::release(std::size_t i, double t_hi, double T_hi) {
  const double t_i = rows_[i].t_s;
  // hist_ holds (t, T) from the oldest pending row's lower window edge on; rows after i need nothing
  // older than t_i − window, so trimming here keeps memory within one ±window span.
  while (hist_.size() > 1 && hist_.front().first < t_i - window_s_) hist_.pop_front();
  const double t_lo = hist_.front().first, T_lo = hist_.front().second;
  const double dt = t_hi - t_lo;
  tdot_.push_back(dt > 0 && !std::isnan(T_hi) && !std::isnan(T_lo) ? (T_hi - T_lo) / dt : 0.0);
}

void CenteredTempRate::push(const io::LogRow& row) {
  if (closed_) throw SolverError("CenteredTempRate::push after close()");
  check_time_order(row.t_s, last_t_, "dT/dt");
  // Rows whose upper window edge this row passes are final: their last row at ≤ t_i + window is the
  // previous row (it did not release them when it arrived, so its t ≤ t_i + window).
  while (n_ready_ < rows_.size() && rows_[n_ready_].t_s + window_s_ < row.t_s) {
    release(n_ready_, hist_.back().first, hist_.back().second);
    ++n_ready_;
  }
  if (rows_.size() >= kMaxRows)
    throw SolverError("dT/dt window of +-" + std::to_string(window_s_) + " s holds more than " +
                      std::to_string(kMaxRows) + " rows (time stamps stuck at " + std::to_string(row.t_s) +
                      " s?); reduce \"dTdt_window_s\" in the model file");
  hist_.emplace_back(row.t_s, row.temp_C);
  rows_.push_back(row);
  last_t_ = row.t_s;
}

void CenteredTempRate::close() {
  closed_ = true;
  while (n_ready_ < rows_.size()) {
    release(n_ready_, hist_.back().first, hist_.back().second);
    ++n_ready_;
  }
}

bool CenteredTempRate::pop(io::LogRow& row, double& Tdot_C_s) {
  if (n_ready_ == 0) return false;
  row = rows_.front();
  Tdot_C_s = tdot_.front();
  rows_.pop_front();
  tdot_.pop_front();
  --n_ready_;
  if (rows_.empty() && closed_) hist_.clear();
  return true;
}

// ---------------------------------------------------------------------------------------------------

DwellGuard::DwellGuard(double guard_s) : guard_s_(guard_s) {
  if (!(guard_s >= 0) || !std::isfinite(guard_s))
    throw SolverError("dwell_guard_s must be a finite number of seconds >= 0");
}

DwellGuard::Ref DwellGuard::ref_of(const io::LogRow& row) {
  Ref r;
  r.has = row.has_ref;
  for (int k = 0; k < 3; ++k) {
    r.u[k] = row.f_ref[k];
    r.u[3 + k] = row.w_ref[k];
  }
  return r;
}

bool DwellGuard::differs(const Ref& a, const Ref& b) {
  if (!a.has || !b.has) return true;  // an unknown reference may be anything
  for (int k = 0; k < 3; ++k)
    if (!(std::abs(a.u[k] - b.u[k]) <= kBlockTolF_mps2) || !(std::abs(a.u[3 + k] - b.u[3 + k]) <= kBlockTolW_rad_s))
      return true;
  return false;
}

void DwellGuard::push(const io::LogRow& row, double Tdot_C_s) {
  if (closed_) throw SolverError("DwellGuard::push after close()");
  check_time_order(row.t_s, last_t_, "the dwell guard");
  last_t_ = row.t_s;
  if (guard_s_ == 0) {
    pending_.push_back({row, Tdot_C_s, -1});
    return;
  }
  if (pending_.size() >= kMaxRows)
    throw SolverError("dwell guard of " + std::to_string(guard_s_) + " s holds more than " + std::to_string(kMaxRows) +
                      " rows (time stamps stuck at " + std::to_string(row.t_s) +
                      " s?); reduce \"dwell_guard_s\" in the model file");
  const bool in_dwell = row.has_ref && row.segment >= 0;
  const Ref key = ref_of(row);
  if (!runs_.empty() && runs_.back().open && !(in_dwell && row.segment == runs_.back().segment))
    runs_.back().open = false;
  // Look ahead for runs that ended: the first outside row within guard_s that differs settles t_la.
  for (Run& r : runs_) {
    if (r.open || r.resolved) continue;
    if (row.t_s - r.t_last > guard_s_) {
      r.resolved = true;
    } else if (differs(key, r.last)) {
      r.t_la = row.t_s;
      r.resolved = true;
    }
  }
  long long run = -1;
  if (in_dwell) {
    if (runs_.empty() || !runs_.back().open) {
      Run r;
      r.id = next_run_++;
      r.segment = row.segment;
      for (const auto& h : hist_)
        if (h.first >= row.t_s - guard_s_ && differs(key, h.second)) r.t_lb = std::max(r.t_lb, h.first);
      runs_.push_back(r);
    }
    runs_.back().t_last = row.t_s;
    runs_.back().last = key;
    run = runs_.back().id;
  }
  while (!hist_.empty() && hist_.front().first < row.t_s - guard_s_) hist_.pop_front();
  hist_.emplace_back(row.t_s, key);
  pending_.push_back({row, Tdot_C_s, run});
}

void DwellGuard::close() { closed_ = true; }

bool DwellGuard::pop(io::LogRow& row, double& Tdot_C_s, bool& keep) {
  if (pending_.empty()) return false;
  const Pending& p = pending_.front();
  // Final once a row past t + guard_s has arrived: a differing row later than that cannot reach it.
  if (!(closed_ || guard_s_ == 0 || p.row.t_s + guard_s_ < last_t_)) return false;
  keep = true;
  const long long run = p.run;
  if (run >= 0) {
    const Run& r = runs_[static_cast<std::size_t>(run - runs_.front().id)];
    keep = !(p.row.t_s - r.t_lb <= guard_s_ || r.t_la - p.row.t_s <= guard_s_);
    if (!keep) ++dropped_;
  }
  row = p.row;
  Tdot_C_s = p.q;
  pending_.pop_front();
  if (run >= 0 && !runs_.front().open && (pending_.empty() || pending_.front().run != run)) runs_.pop_front();
  if (pending_.empty() && closed_) hist_.clear();
  return true;
}

double dwell_guard_of(const model::ModelSpec& spec) {
  double g_s = kDefaultDwellGuard_s;
  if (spec.extra.is_object()) {
    const auto g = spec.extra.find("dwell_guard_s");
    if (g != spec.extra.end()) {
      if (!g->is_number() || !(g->get<double>() >= 0) || !std::isfinite(g->get<double>()))
        throw SolverError("model \"dwell_guard_s\" must be a number of seconds >= 0");
      g_s = g->get<double>();
    }
  }
  return g_s;
}

// ---------------------------------------------------------------------------------------------------

const char* channel_name(int c) {
  static const char* n[kNumChannels] = {"accel.x", "accel.y", "accel.z", "gyro.x", "gyro.y", "gyro.z"};
  return (c >= 0 && c < kNumChannels) ? n[c] : "?";
}

void ChannelStats::reset(int n_local) {
  a = Eigen::MatrixXd::Zero(n_local, n_local);
  b = Eigen::VectorXd::Zero(n_local);
  zz = 0.0;
  n = 0;
}

ChannelStats& ChannelStats::operator+=(const ChannelStats& o) {
  a += o.a;
  b += o.b;
  zz += o.zz;
  n += o.n;
  return *this;
}

FixtureAccumulator::FixtureAccumulator(const model::ModelSpec& spec, const io::LogMeta& meta)
    : spec_(spec), guard_(dwell_guard_of(spec)) {
  if (!(meta.accel_lsb_mps2 > 0) || !(meta.gyro_lsb_rad_s > 0))
    throw SolverError("log metadata lacks a positive accel_lsb/gyro_lsb: cannot convert counts to SI");
  lsb_[0] = meta.accel_lsb_mps2;
  lsb_[1] = meta.gyro_lsb_rad_s;
  const std::vector<model::ParamId> ids = spec.parameters();
  if (ids.empty()) throw SolverError("the model estimates no deterministic parameter");
  dTdt_window_s_ = dTdt_window_of(spec);
  hyst_ = logged_hysteresis_tracker(spec);
  bool has_rate = false;
  for (size_t i = 0; i < ids.size(); ++i) {
    const auto& pi = model::param_info(ids[i]);
    const int s = static_cast<int>(pi.sensor);
    bool pp = false;
    for (const auto& e : spec.effects)
      if (e.sensor == pi.sensor && e.effect == pi.effect) pp = e.per_plateau;
    has_rate = has_rate || pi.effect == Effect::kTempRate;
    ids_[static_cast<size_t>(s)].push_back(ids[i]);
    per_plateau_[static_cast<size_t>(s)].push_back(pp);
    spec_pos_[static_cast<size_t>(s)].push_back(static_cast<int>(i));
    any_per_plateau_ = any_per_plateau_ || pp;
    needs_temp_ = needs_temp_ || pp || is_temperature_effect(pi.effect) || pi.effect == Effect::kTempRate;
  }
  for (int s = 0; s < 2; ++s)
    for (size_t i = 0; i < ids_[static_cast<size_t>(s)].size(); ++i) {
      const auto& pi = model::param_info(ids_[static_cast<size_t>(s)][i]);
      if (pi.effect == Effect::kBias && pi.j >= 0 && pi.j < 3 && !per_plateau_[static_cast<size_t>(s)][i])
        bias_local_[static_cast<size_t>(s)][static_cast<size_t>(pi.j)] = static_cast<int>(i);
    }
  if (has_rate) tdot_.emplace(dTdt_window_s_);
  for (int c = 0; c < kNumChannels; ++c) seg_stats_[static_cast<size_t>(c)].reset(static_cast<int>(ids_[static_cast<size_t>(c / 3)].size()));
}

double dTdt_window_of(const model::ModelSpec& spec) {
  double w_s = model::ThermalConstants{}.dTdt_window_s;
  if (spec.extra.is_object()) {
    const auto w = spec.extra.find("dTdt_window_s");
    if (w != spec.extra.end()) {
      if (!w->is_number() || !(w->get<double>() > 0) || !std::isfinite(w->get<double>()))
        throw SolverError("model \"dTdt_window_s\" must be a positive number of seconds");
      w_s = w->get<double>();
    }
  }
  return w_s;
}

model::HysteresisTracker logged_hysteresis_tracker(const model::ModelSpec& spec) {
  const double thr_C = std::isfinite(spec.hysteresis_threshold_C) ? spec.hysteresis_threshold_C
                                                                 : model::ThermalConstants{}.hysteresis_threshold_C;
  return model::HysteresisTracker(thr_C, model::kLoggedTempSmoothing_s);
}

void FixtureAccumulator::add(const io::LogRow& row) {
  if (finished_) throw SolverError("FixtureAccumulator::add after finish()");
  auto use = [this](const io::LogRow& r, double q, bool keep) { process(r, q, keep); };
  if (!tdot_) {
    guard_.feed(row, 0.0, use);
    return;
  }
  tdot_->feed(row, [this, &use](const io::LogRow& r, double q) { guard_.feed(r, q, use); });
}

void FixtureAccumulator::process(const io::LogRow& row, double Tdot_C_s, bool keep) {
  const double d = hyst_.update(row.temp_C, row.t_s);
  if (!row.has_ref || row.segment < 0) {
    flush_block();
    flush_segment();
    return;
  }
  if (!keep) return;  // guarded (DwellGuard): the segment goes on after it, so nothing is flushed
  double T = row.temp_C;
  if (std::isnan(T)) {
    if (needs_temp_)
      throw SolverError("log row at t=" + std::to_string(row.t_s) +
                        " s has no temperature, but the model has temperature terms");
    T = spec_.T_ref_C;
  }
  if (!std::isfinite(T)) throw SolverError("log row at t=" + std::to_string(row.t_s) + " s: temperature is not finite");
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(row.f_ref[k]) || !std::isfinite(row.w_ref[k]))
      throw SolverError("log row at t=" + std::to_string(row.t_s) + " s: reference is not finite");
  if (!in_segment_ || row.segment != seg_id_) {
    flush_block();
    flush_segment();
    in_segment_ = true;
    seg_id_ = row.segment;
    seg_sum_ = SegmentSummary{};
    seg_sum_.segment = row.segment;
    seg_y_sum_.setZero();
    seg_y_sq_.setZero();
    seg_t_sum_s_ = 0.0;
    seg_T_min_C_ = std::numeric_limits<double>::infinity();
    seg_T_max_C_ = -std::numeric_limits<double>::infinity();
    for (int c = 0; c < kNumChannels; ++c) seg_stats_[static_cast<size_t>(c)].reset(static_cast<int>(ids_[static_cast<size_t>(c / 3)].size()));
  }
  const double key[7] = {row.f_ref[0], row.f_ref[1], row.f_ref[2], row.w_ref[0], row.w_ref[1], row.w_ref[2], d};
  bool same = in_block_ && key[6] == key_[6];
  for (int k = 0; same && k < 3; ++k)
    same = std::abs(key[k] - key_[k]) <= kBlockTolF_mps2 && std::abs(key[3 + k] - key_[3 + k]) <= kBlockTolW_rad_s;
  if (!same) {
    flush_block();
    std::copy(key, key + 7, key_);
    in_block_ = true;
    block_.reset(T);
    block_u_.setZero();
    block_q_ = RateMoments{};
    block_T_min_ = block_T_max_ = T;
  }
  block_T_min_ = std::min(block_T_min_, T);
  block_T_max_ = std::max(block_T_max_, T);
  for (int k = 0; k < 3; ++k) {
    block_u_[k] += row.f_ref[k];
    block_u_[3 + k] += row.w_ref[k];
  }
  double z[kNumChannels];
  const double u[kNumChannels] = {row.f_ref[0], row.f_ref[1], row.f_ref[2], row.w_ref[0], row.w_ref[1], row.w_ref[2]};
  for (int c = 0; c < kNumChannels; ++c) {
    const double y = row.raw[c] * lsb_[c / 3];
    z[c] = y - u[c];
    seg_y_sum_[c] += y;
    seg_y_sq_[c] += y * y;
  }
  block_.add(T, z);
  if (tdot_) {
    // Same s as BlockMoments::add, so the Ṫ cross moments pair with its Σ s^k.
    const double sb = (T - block_.T0_C) / kBlockTempScale;
    const double q = Tdot_C_s;
    block_q_.qs[0] += q;
    block_q_.qs[1] += q * sb;
    block_q_.qs[2] += q * sb * sb;
    block_q_.qs[3] += q * sb * sb * sb;
    block_q_.qq += q * q;
    for (int c = 0; c < kNumChannels; ++c) block_q_.qz[c] += q * z[c];
  }
  seg_sum_.n += 1;
  seg_sum_.T_C += T;
  seg_t_sum_s_ += row.t_s;
  seg_T_min_C_ = std::min(seg_T_min_C_, T);
  seg_T_max_C_ = std::max(seg_T_max_C_, T);
  for (int k = 0; k < 3; ++k) {
    seg_sum_.f_ref[k] += row.f_ref[k];
    seg_sum_.w_ref[k] += row.w_ref[k];
  }
  ++samples_used_;
}

void FixtureAccumulator::flush_block() {
  if (!in_block_) return;
  in_block_ = false;
  if (block_.n == 0) return;
  const bool narrow = block_T_max_ - block_T_min_ <= kNoiseBlockSpan_C;
  const Eigen::Matrix4d S = block_.S();
  const Eigen::Matrix4d& v2c = node_to_coeff();
  model::MeasureInput in;
  // Regressors at the block's mean input: they are linear in u for the basic and temperature terms, so
  // Σ φ and Σ φ z are exact and Σ φφᵀ is off only by the input's within-block variance (second order).
  const Eigen::Matrix<double, 6, 1> um = block_u_ / static_cast<double>(block_.n);
  in.f = um.head<3>();
  in.w = um.tail<3>();
  in.d = key_[6];
  for (int s = 0; s < 2; ++s) {
    const auto& ids = ids_[static_cast<size_t>(s)];
    const int nl = static_cast<int>(ids.size());
    // node values of the Jacobian rows: jn[node] is 3 × nl, at Ṫ = 0
    std::array<Eigen::Matrix<double, 3, Eigen::Dynamic>, kNumNodes + 1> jn;
    in.Tdot_C_s = 0.0;
    for (int k = 0; k <= kNumNodes; ++k) {
      const double node = k < kNumNodes ? kNodes[static_cast<size_t>(k)] : kCheckNode;
      in.T_C = block_.T0_C + node * kBlockTempScale;
      jn[static_cast<size_t>(k)].resize(3, nl);
      if (nl) model::regressors(static_cast<Sensor>(s), ids, in, spec_.T_ref_C, jn[static_cast<size_t>(k)]);
    }
    // The Ṫ part of the regressors, e = J(Ṫ = 1) − J(Ṫ = 0). Exact compression needs it independent of T
    // (true for temp_rate, whose regressor is Ṫ itself): checked at every node.
    Eigen::Matrix<double, 3, Eigen::Dynamic> jq = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, nl);
    if (tdot_ && nl) {
      Eigen::Matrix<double, 3, Eigen::Dynamic> j1(3, nl);
      for (int k = 0; k <= kNumNodes; ++k) {
        const double node = k < kNumNodes ? kNodes[static_cast<size_t>(k)] : kCheckNode;
        in.T_C = block_.T0_C + node * kBlockTempScale;
        in.Tdot_C_s = 1.0;
        model::regressors(static_cast<Sensor>(s), ids, in, spec_.T_ref_C, j1);
        const Eigen::Matrix<double, 3, Eigen::Dynamic> e = j1 - jn[static_cast<size_t>(k)];
        if (k == 0) jq = e;
        else if ((e - jq).cwiseAbs().maxCoeff() > 1e-12 * std::max(1.0, jq.cwiseAbs().maxCoeff()))
          throw SolverError("model regressors couple dT/dt with temperature; the block compression would be inexact");
      }
      in.Tdot_C_s = 0.0;
    }
    for (int j = 0; j < 3; ++j) {
      const int c = 3 * s + j;
      ChannelStats& cs = seg_stats_[static_cast<size_t>(c)];
      Eigen::MatrixXd bn(nl, 4);
      for (int k = 0; k < kNumNodes; ++k) bn.col(k) = jn[static_cast<size_t>(k)].row(j).transpose();
      const Eigen::MatrixXd bc = bn * v2c.transpose();  // rows: monomial coefficients of each regressor
      // The block compression is exact only if every regressor is a cubic in T: check at a 5th node.
      if (nl) {
        const Eigen::Vector4d m(1, kCheckNode, kCheckNode * kCheckNode, kCheckNode * kCheckNode * kCheckNode);
        const Eigen::VectorXd pred = bc * m;
        const Eigen::VectorXd act = jn[kNumNodes].row(j).transpose();
        const double scale = std::max(1.0, act.cwiseAbs().maxCoeff());
        if ((pred - act).cwiseAbs().maxCoeff() > 1e-8 * scale)
          throw SolverError("model regressors are not polynomial of degree <= 3 in temperature; "
                            "the block compression would be inexact");
      }
      const auto& zsa = block_.zs[static_cast<size_t>(c)];
      const Eigen::Vector4d zs(zsa[0], zsa[1], zsa[2], zsa[3]);
      if (nl) {
        cs.a.noalias() += bc * S * bc.transpose();
        cs.b.noalias() += bc * zs;
        if (tdot_) {
          // φ = B m(s) + e q:  Σφφᵀ += B Qs eᵀ + e Qsᵀ Bᵀ + Σq² e eᵀ,  Σφz += e Σqz  (exact).
          const Eigen::VectorXd e = jq.row(j).transpose();
          const Eigen::Vector4d qs(block_q_.qs[0], block_q_.qs[1], block_q_.qs[2], block_q_.qs[3]);
          const Eigen::VectorXd bq = bc * qs;
          cs.a.noalias() += bq * e.transpose() + e * bq.transpose() + block_q_.qq * e * e.transpose();
          cs.b.noalias() += block_q_.qz[c] * e;
        }
      }
      cs.zz += block_.zz[static_cast<size_t>(c)];
      cs.n += block_.n;
      if (block_.n >= 3) {
        const double v = block_.within_variance(c) * static_cast<double>(block_.n - 2);
        var_num_[1][c] += v;
        if (narrow) var_num_[0][c] += v;
      }
    }
  }
  if (block_.n >= 3) {
    var_den_[1] += block_.n - 2;
    if (narrow) var_den_[0] += block_.n - 2;
  }
}

int FixtureAccumulator::plateau_of(double T_C) {
  int best = -1;
  double bd = kPlateauTolerance_C;
  for (size_t p = 0; p < plateau_n_.size(); ++p) {
    const double d = std::abs(plateau_T_sum_[p] / static_cast<double>(plateau_n_[p]) - T_C);
    if (d < bd) {
      bd = d;
      best = static_cast<int>(p);
    }
  }
  if (best >= 0) return best;
  ChannelSet cs;
  for (int c = 0; c < kNumChannels; ++c) cs[static_cast<size_t>(c)].reset(static_cast<int>(ids_[static_cast<size_t>(c / 3)].size()));
  plateau_stats_.push_back(cs);
  plateau_T_sum_.push_back(0.0);
  plateau_n_.push_back(0);
  return static_cast<int>(plateau_n_.size() - 1);
}

void FixtureAccumulator::flush_segment() {
  if (!in_segment_) return;
  in_segment_ = false;
  if (seg_sum_.n == 0) return;
  const double n = static_cast<double>(seg_sum_.n);
  seg_sum_.T_C /= n;
  seg_sum_.f_ref /= n;
  seg_sum_.w_ref /= n;
  for (int c = 0; c < kNumChannels; ++c) {
    seg_sum_.y[static_cast<size_t>(c)] = seg_y_sum_[c] / n;
    seg_sum_.var[static_cast<size_t>(c)] =
        n > 1 ? std::max(0.0, (seg_y_sq_[c] - seg_y_sum_[c] * seg_y_sum_[c] / n) / (n - 1)) : 0.0;
  }
  if (any_per_plateau_ && seg_T_max_C_ - seg_T_min_C_ > kPlateauTolerance_C) {
    // In transit (a soak after a chamber step, a ramp): a per-plateau value assumes one temperature, and
    // this segment has none. It would otherwise open a plateau of its own that only it informs.
    seg_sum_.plateau = -1;
    transit_samples_ += seg_sum_.n;
    segments_[seg_sum_.segment] = seg_sum_;
    return;
  }
  const int p = plateau_of(seg_sum_.T_C);
  seg_sum_.plateau = p;
  for (int c = 0; c < kNumChannels; ++c) plateau_stats_[static_cast<size_t>(p)][static_cast<size_t>(c)] += seg_stats_[static_cast<size_t>(c)];
  plateau_T_sum_[static_cast<size_t>(p)] += seg_sum_.T_C * n;
  plateau_n_[static_cast<size_t>(p)] += seg_sum_.n;
  segments_[seg_sum_.segment] = seg_sum_;
  {
    SegmentMeans m;
    m.plateau = p;
    m.n = seg_sum_.n;
    m.t_mid_s = seg_t_sum_s_ / n;
    for (int c = 0; c < kNumChannels; ++c) {
      const int ib = bias_local_[static_cast<size_t>(c / 3)][static_cast<size_t>(c % 3)];
      if (ib < 0) continue;
      const ChannelStats& st = seg_stats_[static_cast<size_t>(c)];
      m.sphi[static_cast<size_t>(c)] = st.a.col(ib);
      m.sz[static_cast<size_t>(c)] = st.b[ib];
    }
    seg_means_.push_back(std::move(m));
  }
  if (on_segment) on_segment(seg_sum_, seg_stats_);
}

void FixtureAccumulator::finish() {
  if (finished_) return;
  auto use = [this](const io::LogRow& r, double q, bool keep) { process(r, q, keep); };
  if (tdot_) tdot_->finish([this, &use](const io::LogRow& r, double q) { guard_.feed(r, q, use); });
  guard_.finish(use);
  flush_block();
  flush_segment();
  finished_ = true;
  discovery_to_sorted_ = plateau_ranks();
  plateaus_sorted_.assign(plateau_n_.size(), PlateauInfo{});
  for (size_t p = 0; p < plateau_n_.size(); ++p)
    plateaus_sorted_[static_cast<size_t>(discovery_to_sorted_[p])] = {plateau_T_sum_[p] / static_cast<double>(plateau_n_[p]),
                                                                      plateau_n_[p]};
  for (auto& kv : segments_)
    if (kv.second.plateau >= 0) kv.second.plateau = discovery_to_sorted_[static_cast<size_t>(kv.second.plateau)];
  for (auto& m : seg_means_)
    if (m.plateau >= 0) m.plateau = discovery_to_sorted_[static_cast<size_t>(m.plateau)];
  if (samples_used_ == 0 && guard_.dropped() > 0)
    throw SolverError("every dwell sample (" + std::to_string(guard_.dropped()) + ") lies within the dwell guard of " +
                      std::to_string(guard_.guard_s()) +
                      " s of a reference change: the dwells are too short for it; set \"dwell_guard_s\" lower in the model "
                      "(0 turns it off) if the sensor's time stamps are known to match the fixture's");
  if (samples_used_ == 0) throw SolverError("the log has no sample with a fixture reference inside a dwell");
  if (plateau_n_.empty())
    throw SolverError("per-plateau model: every segment is in transit (its temperature moves by more than 3 °C); "
                      "plateaus need dwells at a settled temperature");
}

std::vector<int> FixtureAccumulator::plateau_ranks() const {
  const size_t np = plateau_n_.size();
  std::vector<int> order(np);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return plateau_T_sum_[static_cast<size_t>(a)] / static_cast<double>(plateau_n_[static_cast<size_t>(a)]) <
           plateau_T_sum_[static_cast<size_t>(b)] / static_cast<double>(plateau_n_[static_cast<size_t>(b)]);
  });
  std::vector<int> rank(np);
  for (size_t r = 0; r < np; ++r) rank[static_cast<size_t>(order[r])] = static_cast<int>(r);
  return rank;
}

int FixtureAccumulator::slot(int sensor, int local, int plateau_rank, int np) const {
  // Slots follow spec order; a per-plateau parameter takes one slot per plateau.
  const int target = spec_pos_[static_cast<size_t>(sensor)][static_cast<size_t>(local)];
  int base = 0;
  // Walk spec positions in order; counts are small (≤ a few hundred), and this runs per segment or
  // solve, not per sample.
  std::vector<std::pair<int, bool>> order;  // (spec position, per_plateau)
  for (int s = 0; s < 2; ++s)
    for (size_t i = 0; i < spec_pos_[static_cast<size_t>(s)].size(); ++i)
      order.emplace_back(spec_pos_[static_cast<size_t>(s)][i], per_plateau_[static_cast<size_t>(s)][i]);
  std::sort(order.begin(), order.end());
  for (const auto& o : order) {
    if (o.first == target) {
      if (o.second && (plateau_rank < 0 || plateau_rank >= np)) throw SolverError("internal: plateau rank out of range");
      return o.second ? base + plateau_rank : base;
    }
    base += o.second ? np : 1;
  }
  throw SolverError("internal: parameter slot not found");
}

std::vector<int> FixtureAccumulator::plateau_slots(int plateau_rank, int np) const {
  std::vector<int> out;
  for (int s = 0; s < 2; ++s)
    for (size_t i = 0; i < per_plateau_[static_cast<size_t>(s)].size(); ++i)
      if (per_plateau_[static_cast<size_t>(s)][i]) out.push_back(slot(s, static_cast<int>(i), plateau_rank, np));
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> FixtureAccumulator::names() const { return slot_names(num_plateaus()); }

std::vector<std::string> FixtureAccumulator::slot_names(int np) const {
  std::vector<std::tuple<int, model::ParamId, bool>> order;
  for (int s = 0; s < 2; ++s)
    for (size_t i = 0; i < ids_[static_cast<size_t>(s)].size(); ++i)
      order.emplace_back(spec_pos_[static_cast<size_t>(s)][i], ids_[static_cast<size_t>(s)][i], per_plateau_[static_cast<size_t>(s)][i]);
  std::sort(order.begin(), order.end());
  std::vector<std::string> out;
  for (const auto& [pos, id, pp] : order) {
    (void)pos;
    const std::string& nm = model::param_info(id).name;
    if (!pp) {
      out.push_back(nm);
    } else {
      for (int p = 0; p < np; ++p) out.push_back(nm + "@plateau" + std::to_string(p));
    }
  }
  return out;
}

NormalEquations FixtureAccumulator::normal_equations(const Sigma6& sigma) const {
  if (!finished_) throw SolverError("FixtureAccumulator: call finish() first");
  const int n = static_cast<int>(names().size());
  const int np = num_plateaus();
  NormalEquations ne(n);
  for (size_t p = 0; p < plateau_stats_.size(); ++p) add_weighted(plateau_stats_[p], sigma, discovery_to_sorted_[p], np, ne);
  return ne;
}

void FixtureAccumulator::add_weighted(const ChannelSet& set, const Sigma6& sigma, int plateau_rank, int np,
                                      NormalEquations& ne) const {
  for (int c = 0; c < kNumChannels; ++c) {
    const int s = c / 3;
    const ChannelStats& cs = set[static_cast<size_t>(c)];
    const double w = 1.0 / (sigma[static_cast<size_t>(c)] * sigma[static_cast<size_t>(c)]);
    const int nl = static_cast<int>(cs.b.size());
    std::vector<int> sl(static_cast<size_t>(nl));
    for (int i = 0; i < nl; ++i) sl[static_cast<size_t>(i)] = slot(s, i, plateau_rank, np);
    for (int i = 0; i < nl; ++i) {
      ne.rhs[sl[static_cast<size_t>(i)]] += w * cs.b[i];
      for (int k = 0; k < nl; ++k) ne.info(sl[static_cast<size_t>(i)], sl[static_cast<size_t>(k)]) += w * cs.a(i, k);
    }
    ne.cost += w * cs.zz;
    ne.n_obs += cs.n;
  }
}

NormalEquations FixtureAccumulator::segment_normal_equations(const ChannelSet& seg, const Sigma6& sigma) const {
  if (any_per_plateau_)
    throw SolverError("per-plateau model: give the segment's plateau (segment_normal_equations(seg, sigma, plateau))");
  return segment_normal_equations(seg, sigma, -1);
}

NormalEquations FixtureAccumulator::segment_normal_equations(const ChannelSet& seg, const Sigma6& sigma,
                                                             int plateau) const {
  const int np = plateaus_discovered();
  int rank = -1;
  if (any_per_plateau_) {
    if (plateau < 0 || plateau >= np) throw SolverError("segment_normal_equations: unknown plateau index");
    rank = plateau_ranks()[static_cast<size_t>(plateau)];
  }
  const int n = static_cast<int>(slot_names(np).size());
  NormalEquations ne(n);
  add_weighted(seg, sigma, rank, np, ne);
  return ne;
}

Sigma6 FixtureAccumulator::static_noise_sigma() const {
  const int pool = var_den_[0] >= kNoiseMinDof ? 0 : 1;
  if (var_den_[pool] < 2) throw SolverError("not enough samples in dwells to estimate the noise");
  Sigma6 s{};
  for (int c = 0; c < kNumChannels; ++c) {
    s[static_cast<size_t>(c)] = std::sqrt(var_num_[pool][c] / static_cast<double>(var_den_[pool]));
    if (!(s[static_cast<size_t>(c)] > 0))
      throw SolverError(std::string("channel ") + channel_name(c) + " shows no noise at all within dwells; "
                        "give the noise σ in the model file (\"noise_sigma\")");
  }
  return s;
}

Sigma6 FixtureAccumulator::residual_rms(const Eigen::VectorXd& theta) const {
  Sigma6 out{};
  std::array<long long, kNumChannels> n{};
  for (size_t p = 0; p < plateau_stats_.size(); ++p) {
    const int ps = discovery_to_sorted_[p];
    for (int c = 0; c < kNumChannels; ++c) {
      const ChannelStats& cs = plateau_stats_[p][static_cast<size_t>(c)];
      const int nl = static_cast<int>(cs.b.size());
      Eigen::VectorXd th(nl);
      for (int i = 0; i < nl; ++i) th[i] = theta[slot(c / 3, i, ps, num_plateaus())];
      out[static_cast<size_t>(c)] += cs.zz - 2 * th.dot(cs.b) + th.dot(cs.a * th);
      n[static_cast<size_t>(c)] += cs.n;
    }
  }
  for (int c = 0; c < kNumChannels; ++c)
    out[static_cast<size_t>(c)] = n[static_cast<size_t>(c)] ? std::sqrt(std::max(0.0, out[static_cast<size_t>(c)]) / static_cast<double>(n[static_cast<size_t>(c)])) : 0.0;
  return out;
}

SegmentScatter segment_scatter(const FixtureAccumulator& acc, const Eigen::VectorXd& theta, const Sigma6& sigma) {
  SegmentScatter out;
  const int np = static_cast<int>(acc.plateaus().size());  // finished: the sorted plateaus
  for (int c = 0; c < kNumChannels; ++c) {
    const int s = c / 3;
    const int nl = static_cast<int>(acc.sensor_ids(static_cast<Sensor>(s)).size());
    double q = 0.0;
    int dwells = 0;
    std::vector<bool> acts(static_cast<size_t>(nl), false);
    for (const auto& m : acc.segment_means()) {
      if (m.sphi[static_cast<size_t>(c)].size() == 0 || m.n == 0) continue;  // no bias term on this channel
      const Eigen::VectorXd& sp = m.sphi[static_cast<size_t>(c)];
      double pred = 0.0;
      for (int i = 0; i < nl; ++i) {
        if (sp[i] == 0.0) continue;
        acts[static_cast<size_t>(i)] = true;
        pred += sp[i] * theta[acc.slot(s, i, m.plateau < 0 ? 0 : m.plateau, std::max(np, 1))];
      }
      const double rbar = (m.sz[static_cast<size_t>(c)] - pred) / static_cast<double>(m.n);
      q += static_cast<double>(m.n) * rbar * rbar;
      ++dwells;
    }
    const int p = static_cast<int>(std::count(acts.begin(), acts.end(), true));
    out.dof[static_cast<size_t>(c)] = dwells - p;
    const double s2 = sigma[static_cast<size_t>(c)] * sigma[static_cast<size_t>(c)];
    out.ratio[static_cast<size_t>(c)] =
        dwells - p > 0 ? q / s2 / static_cast<double>(dwells - p) : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

bool scatter_significant(double ratio, int dof) {
  return dof > 0 && std::isfinite(ratio) && ratio > 1.0 + 3.0 * std::sqrt(2.0 / dof);
}

DwellDriftInput dwell_drift_input(const std::vector<DwellSums>& dwells, double sigma) {
  DwellDriftInput out;
  std::vector<int> col_of;  // parameter index → column, −1: not acting on the channel
  for (const DwellSums& d : dwells) {
    if (col_of.size() < static_cast<size_t>(d.sphi.size())) col_of.resize(static_cast<size_t>(d.sphi.size()), -1);
    for (Eigen::Index i = 0; i < d.sphi.size(); ++i)
      if (d.sphi[i] != 0.0) col_of[static_cast<size_t>(i)] = 0;
  }
  for (size_t i = 0; i < col_of.size(); ++i)
    if (col_of[i] == 0) {
      col_of[i] = static_cast<int>(out.cols.size());
      out.cols.push_back(static_cast<int>(i));
    }
  const Eigen::Index S = static_cast<Eigen::Index>(dwells.size()), p = static_cast<Eigen::Index>(out.cols.size());
  out.series.t_s.resize(static_cast<size_t>(S));
  out.series.y.resize(S);
  out.series.X = Eigen::MatrixXd::Zero(S, p);
  out.series.white_var.resize(S);
  out.G = Eigen::MatrixXd::Zero(S, p);
  const double s2 = sigma * sigma;
  for (Eigen::Index k = 0; k < S; ++k) {
    const DwellSums& d = dwells[static_cast<size_t>(k)];
    if (d.n <= 0) throw SolverError("dwell drift: a dwell without samples");
    const double n = static_cast<double>(d.n);
    out.series.t_s[static_cast<size_t>(k)] = d.t_mid_s;
    out.series.y[k] = d.sz / n;
    out.series.white_var[k] = s2 / n;
    for (Eigen::Index i = 0; i < d.sphi.size(); ++i) {
      if (d.sphi[i] == 0.0) continue;
      const int col = col_of[static_cast<size_t>(i)];
      out.series.X(k, col) = d.sphi[i] / n;
      out.G(k, col) = d.sphi[i] / s2;
    }
  }
  return out;
}

ChannelDrifts fit_drifts(const std::array<DwellDriftInput, kNumChannels>& in) {
  ChannelDrifts out;
  for (int c = 0; c < kNumChannels; ++c)
    if (!in[static_cast<size_t>(c)].series.t_s.empty())
      out[static_cast<size_t>(c)] = estimator::fit_dwell_drift(in[static_cast<size_t>(c)].series);
  return out;
}

Eigen::MatrixXd drift_widened_covariance(const std::array<DwellDriftInput, kNumChannels>& in, const Eigen::MatrixXd& C0,
                                         const ChannelDrifts& drifts) {
  std::vector<estimator::ChannelDrift> chans;
  for (int c = 0; c < kNumChannels; ++c) {
    const DwellDriftInput& d = in[static_cast<size_t>(c)];
    if (drifts[static_cast<size_t>(c)].adopted)
      chans.push_back({&drifts[static_cast<size_t>(c)], &d.series.t_s, d.G, d.cols});
  }
  return estimator::drift_covariance(C0, chans);
}

namespace {

// The accumulator's dwells of each channel in slot space (SegmentMeans mapped through the plateau slots).
std::array<DwellDriftInput, kNumChannels> fixture_drift_inputs(const FixtureAccumulator& acc, const Sigma6& sigma) {
  std::array<DwellDriftInput, kNumChannels> out;
  const int np = std::max(static_cast<int>(acc.plateaus().size()), 1);
  const int n_slots = static_cast<int>(acc.slot_names(static_cast<int>(acc.plateaus().size())).size());
  for (int c = 0; c < kNumChannels; ++c) {
    const int s = c / 3;
    const int nl = static_cast<int>(acc.sensor_ids(static_cast<Sensor>(s)).size());
    std::vector<DwellSums> dw;
    for (const auto& m : acc.segment_means()) {
      if (m.sphi[static_cast<size_t>(c)].size() == 0 || m.n == 0) continue;  // no bias term on this channel
      DwellSums d;
      d.t_mid_s = m.t_mid_s;
      d.n = m.n;
      d.sz = m.sz[static_cast<size_t>(c)];
      d.sphi = Eigen::VectorXd::Zero(n_slots);
      for (int i = 0; i < nl; ++i)
        d.sphi[acc.slot(s, i, m.plateau < 0 ? 0 : m.plateau, np)] += m.sphi[static_cast<size_t>(c)][i];
      dw.push_back(std::move(d));
    }
    if (!dw.empty()) out[static_cast<size_t>(c)] = dwell_drift_input(dw, sigma[static_cast<size_t>(c)]);
  }
  return out;
}

}  // namespace

bool dwell_scatter_of(const model::ModelSpec& spec) {
  if (!spec.extra.is_object()) return true;
  const auto d = spec.extra.find("dwell_scatter");
  if (d == spec.extra.end()) return true;
  if (!d->is_boolean()) throw SolverError("model \"dwell_scatter\" must be true or false");
  return d->get<bool>();
}

FixtureSolution solve_fixture_widened(const FixtureAccumulator& acc, const Sigma6& sigma, SegmentScatter* scatter,
                                      ChannelDrifts* drifts) {
  FixtureSolution sol = solve_fixture(acc, sigma);
  if (scatter) *scatter = segment_scatter(acc, sol.estimate.value, sigma);
  if (!dwell_scatter_of(acc.spec())) {
    if (drifts) *drifts = ChannelDrifts{};
    return sol;
  }
  const auto in = fixture_drift_inputs(acc, sigma);
  const ChannelDrifts dr = fit_drifts(in);
  if (drifts) *drifts = dr;
  sol.estimate.covariance = drift_widened_covariance(in, sol.estimate.covariance, dr);
  return sol;
}

nlohmann::json dwell_scatter_json(const SegmentScatter* sc, bool widen, const ChannelDrifts& drifts) {
  nlohmann::json j = {{"widened", widen}};
  for (int c = 0; c < kNumChannels; ++c) {
    nlohmann::json e = nlohmann::json::object();
    if (sc && std::isfinite(sc->ratio[static_cast<size_t>(c)])) {
      const double r = sc->ratio[static_cast<size_t>(c)];
      e = {{"ratio", r}, {"dof", sc->dof[static_cast<size_t>(c)]},
           {"significant", scatter_significant(r, sc->dof[static_cast<size_t>(c)])}};
    }
    const estimator::DwellDrift& d = drifts[static_cast<size_t>(c)];
    if (d.dwells > 0)
      e["drift"] = {{"adopted", d.adopted},        {"gain", d.gain},
                    {"offset_sigma", std::sqrt(d.offset_var)}, {"gm_sigma", std::sqrt(d.gm_var)},
                    {"gm_tau_s", d.gm_tau_s},      {"flicker_sigma", std::sqrt(d.flicker_var)},
                    {"plausible", d.plausible.size()}};
    if (!e.empty()) j[channel_name(c)] = e;
  }
  return j;
}

FixtureSolution solve_fixture(const FixtureAccumulator& acc, const Sigma6& sigma) {
  for (int c = 0; c < kNumChannels; ++c)
    if (!(sigma[static_cast<size_t>(c)] > 0) || !std::isfinite(sigma[static_cast<size_t>(c)]))
      throw SolverError(std::string("noise sigma of ") + channel_name(c) + " must be positive and finite");
  FixtureSolution sol;
  const NormalEquations ne = acc.normal_equations(sigma);
  sol.estimate = solve_normal_equations(ne, acc.names(), &sol.observability);
  sol.noise_sigma = sigma;
  sol.residual_rms = acc.residual_rms(sol.estimate.value);
  // cost at θ̂ of a linear problem: c − gᵀθ̂
  sol.chi2 = ne.cost - ne.rhs.dot(sol.estimate.value);
  sol.samples = acc.samples_used();
  return sol;
}

}  // namespace imuforge::solver
