#include "host/solver/fixture.h"

#include <algorithm>
#include <cmath>
#include <numeric>

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

bool is_temperature_effect(Effect e) {
  return e == Effect::kBiasTemp || e == Effect::kScaleTemp || e == Effect::kMisalignTemp;
}
}  // namespace

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

FixtureAccumulator::FixtureAccumulator(const model::ModelSpec& spec, const io::LogMeta& meta) : spec_(spec) {
  if (!(meta.accel_lsb_mps2 > 0) || !(meta.gyro_lsb_rad_s > 0))
    throw SolverError("log metadata lacks a positive accel_lsb/gyro_lsb: cannot convert counts to SI");
  lsb_[0] = meta.accel_lsb_mps2;
  lsb_[1] = meta.gyro_lsb_rad_s;
  const std::vector<model::ParamId> ids = spec.parameters();
  if (ids.empty()) throw SolverError("the model estimates no deterministic parameter");
  for (size_t i = 0; i < ids.size(); ++i) {
    const auto& pi = model::param_info(ids[i]);
    const int s = static_cast<int>(pi.sensor);
    bool pp = false;
    for (const auto& e : spec.effects)
      if (e.sensor == pi.sensor && e.effect == pi.effect) pp = e.per_plateau;
    if (pi.effect == Effect::kTempRate)
      throw SolverError(std::string("effect ") + pi.name +
                        ": temp_rate needs dT/dt, which the streaming fixture solver does not derive yet; "
                        "remove it from the model");
    ids_[static_cast<size_t>(s)].push_back(ids[i]);
    per_plateau_[static_cast<size_t>(s)].push_back(pp);
    spec_pos_[static_cast<size_t>(s)].push_back(static_cast<int>(i));
    any_per_plateau_ = any_per_plateau_ || pp;
    needs_temp_ = needs_temp_ || pp || is_temperature_effect(pi.effect);
  }
  for (int c = 0; c < kNumChannels; ++c) seg_stats_[static_cast<size_t>(c)].reset(static_cast<int>(ids_[static_cast<size_t>(c / 3)].size()));
}

void FixtureAccumulator::add(const io::LogRow& row) {
  if (finished_) throw SolverError("FixtureAccumulator::add after finish()");
  const double d = hyst_.update(row.temp_C);
  if (!row.has_ref || row.segment < 0) {
    flush_block();
    flush_segment();
    return;
  }
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
  }
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
  seg_sum_.n += 1;
  seg_sum_.T_C += T;
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
    // node values of the Jacobian rows: jn[node] is 3 × nl
    std::array<Eigen::Matrix<double, 3, Eigen::Dynamic>, kNumNodes + 1> jn;
    for (int k = 0; k <= kNumNodes; ++k) {
      const double node = k < kNumNodes ? kNodes[static_cast<size_t>(k)] : kCheckNode;
      in.T_C = block_.T0_C + node * kBlockTempScale;
      jn[static_cast<size_t>(k)].resize(3, nl);
      if (nl) model::regressors(static_cast<Sensor>(s), ids, in, spec_.T_ref_C, jn[static_cast<size_t>(k)]);
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
      }
      cs.zz += block_.zz[static_cast<size_t>(c)];
      cs.n += block_.n;
      if (block_.n >= 3) var_num_[c] += block_.within_variance(c) * static_cast<double>(block_.n - 2);
    }
  }
  if (block_.n >= 3) var_den_ += block_.n - 2;
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
  const int p = plateau_of(seg_sum_.T_C);
  seg_sum_.plateau = p;
  for (int c = 0; c < kNumChannels; ++c) plateau_stats_[static_cast<size_t>(p)][static_cast<size_t>(c)] += seg_stats_[static_cast<size_t>(c)];
  plateau_T_sum_[static_cast<size_t>(p)] += seg_sum_.T_C * n;
  plateau_n_[static_cast<size_t>(p)] += seg_sum_.n;
  segments_[seg_sum_.segment] = seg_sum_;
  if (on_segment) on_segment(seg_sum_, seg_stats_);
}

void FixtureAccumulator::finish() {
  if (finished_) return;
  flush_block();
  flush_segment();
  finished_ = true;
  const size_t np = plateau_n_.size();
  std::vector<int> order(np);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return plateau_T_sum_[static_cast<size_t>(a)] / static_cast<double>(plateau_n_[static_cast<size_t>(a)]) <
           plateau_T_sum_[static_cast<size_t>(b)] / static_cast<double>(plateau_n_[static_cast<size_t>(b)]);
  });
  discovery_to_sorted_.assign(np, 0);
  plateaus_sorted_.clear();
  for (size_t r = 0; r < np; ++r) {
    const size_t p = static_cast<size_t>(order[r]);
    discovery_to_sorted_[p] = static_cast<int>(r);
    plateaus_sorted_.push_back({plateau_T_sum_[p] / static_cast<double>(plateau_n_[p]), plateau_n_[p]});
  }
  for (auto& kv : segments_) kv.second.plateau = discovery_to_sorted_[static_cast<size_t>(kv.second.plateau)];
  if (samples_used_ == 0) throw SolverError("the log has no sample with a fixture reference inside a dwell");
}

int FixtureAccumulator::slot(int sensor, int local, int plateau_sorted) const {
  // Slots follow spec order; a per-plateau parameter takes one slot per plateau.
  const int target = spec_pos_[static_cast<size_t>(sensor)][static_cast<size_t>(local)];
  const int np = static_cast<int>(plateaus_sorted_.size());
  int base = 0;
  // Walk spec positions in order; counts are small (≤ a few hundred), and this runs per solve, not per sample.
  std::vector<std::pair<int, bool>> order;  // (spec position, per_plateau)
  for (int s = 0; s < 2; ++s)
    for (size_t i = 0; i < spec_pos_[static_cast<size_t>(s)].size(); ++i)
      order.emplace_back(spec_pos_[static_cast<size_t>(s)][i], per_plateau_[static_cast<size_t>(s)][i]);
  std::sort(order.begin(), order.end());
  for (const auto& o : order) {
    if (o.first == target) return o.second ? base + plateau_sorted : base;
    base += o.second ? np : 1;
  }
  throw SolverError("internal: parameter slot not found");
}

std::vector<std::string> FixtureAccumulator::names() const {
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
      for (size_t p = 0; p < plateaus_sorted_.size(); ++p) out.push_back(nm + "@plateau" + std::to_string(p));
    }
  }
  return out;
}

NormalEquations FixtureAccumulator::normal_equations(const Sigma6& sigma) const {
  if (!finished_) throw SolverError("FixtureAccumulator: call finish() first");
  const int n = static_cast<int>(names().size());
  NormalEquations ne(n);
  for (size_t p = 0; p < plateau_stats_.size(); ++p) {
    const int ps = discovery_to_sorted_[p];
    for (int c = 0; c < kNumChannels; ++c) {
      const int s = c / 3;
      const ChannelStats& cs = plateau_stats_[p][static_cast<size_t>(c)];
      const double w = 1.0 / (sigma[static_cast<size_t>(c)] * sigma[static_cast<size_t>(c)]);
      const int nl = static_cast<int>(cs.b.size());
      std::vector<int> sl(static_cast<size_t>(nl));
      for (int i = 0; i < nl; ++i) sl[static_cast<size_t>(i)] = slot(s, i, ps);
      for (int i = 0; i < nl; ++i) {
        ne.rhs[sl[static_cast<size_t>(i)]] += w * cs.b[i];
        for (int k = 0; k < nl; ++k) ne.info(sl[static_cast<size_t>(i)], sl[static_cast<size_t>(k)]) += w * cs.a(i, k);
      }
      ne.cost += w * cs.zz;
      ne.n_obs += cs.n;
    }
  }
  return ne;
}

NormalEquations FixtureAccumulator::segment_normal_equations(const ChannelSet& seg, const Sigma6& sigma) const {
  if (any_per_plateau_) throw SolverError("per-plateau parameters cannot be estimated recursively (plateaus are only known at the end)");
  int n = 0;
  for (int s = 0; s < 2; ++s) n += static_cast<int>(ids_[static_cast<size_t>(s)].size());
  NormalEquations ne(n);
  for (int c = 0; c < kNumChannels; ++c) {
    const int s = c / 3;
    const ChannelStats& cs = seg[static_cast<size_t>(c)];
    const double w = 1.0 / (sigma[static_cast<size_t>(c)] * sigma[static_cast<size_t>(c)]);
    const int nl = static_cast<int>(cs.b.size());
    for (int i = 0; i < nl; ++i) {
      const int si = spec_pos_[static_cast<size_t>(s)][static_cast<size_t>(i)];
      ne.rhs[si] += w * cs.b[i];
      for (int k = 0; k < nl; ++k) ne.info(si, spec_pos_[static_cast<size_t>(s)][static_cast<size_t>(k)]) += w * cs.a(i, k);
    }
    ne.cost += w * cs.zz;
    ne.n_obs += cs.n;
  }
  return ne;
}

Sigma6 FixtureAccumulator::static_noise_sigma() const {
  if (var_den_ < 2) throw SolverError("not enough samples in dwells to estimate the noise");
  Sigma6 s{};
  for (int c = 0; c < kNumChannels; ++c) {
    s[static_cast<size_t>(c)] = std::sqrt(var_num_[c] / static_cast<double>(var_den_));
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
      for (int i = 0; i < nl; ++i) th[i] = theta[slot(c / 3, i, ps)];
      out[static_cast<size_t>(c)] += cs.zz - 2 * th.dot(cs.b) + th.dot(cs.a * th);
      n[static_cast<size_t>(c)] += cs.n;
    }
  }
  for (int c = 0; c < kNumChannels; ++c)
    out[static_cast<size_t>(c)] = n[static_cast<size_t>(c)] ? std::sqrt(std::max(0.0, out[static_cast<size_t>(c)]) / static_cast<double>(n[static_cast<size_t>(c)])) : 0.0;
  return out;
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
