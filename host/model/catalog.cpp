#include "host/model/catalog.h"

#include <stdexcept>
#include <unordered_map>

namespace imuforge::model {

namespace {

std::vector<std::string> axes3() { return {"x", "y", "z"}; }
std::vector<std::string> offdiag() { return {"xy", "xz", "yx", "yz", "zx", "zy"}; }
std::vector<std::string> with_powers(const std::vector<std::string>& base, const char* prefix, int from, int to) {
  std::vector<std::string> out;
  for (const auto& b : base)
    for (int p = from; p <= to; ++p) out.push_back(b + "." + prefix + std::to_string(p));
  return out;
}

std::vector<EffectInfo> build_effects() {
  using K = EffectKind;
  std::vector<EffectInfo> v;
  auto add = [&](Effect e, const char* n, const char* g, std::uint8_t s, K k, std::vector<std::string> c,
                 const char* u, const char* d) { v.push_back(EffectInfo{e, n, g, s, k, std::move(c), u, d}); };
  add(Effect::kBias, "bias", "basic", kMaskBoth, K::kDeterministic, axes3(), "m/s^2 | rad/s", "constant offset b_j");
  add(Effect::kScale, "scale", "basic", kMaskBoth, K::kDeterministic, axes3(), "1",
      "scale-factor error, diagonal of M (1e-3 = 1000 ppm)");
  add(Effect::kMisalign, "misalign", "basic", kMaskBoth, K::kDeterministic, offdiag(), "rad",
      "off-diagonal of M, component jk = row j column k");
  add(Effect::kBiasTemp, "bias_temp", "temperature", kMaskBoth, K::kDeterministic, with_powers(axes3(), "t", 1, 3),
      "unit/degC^p", "bias polynomial in tau = T - T_ref");
  add(Effect::kScaleTemp, "scale_temp", "temperature", kMaskBoth, K::kDeterministic,
      with_powers(axes3(), "t", 1, 3), "1/degC^p", "scale-factor polynomial in tau");
  add(Effect::kMisalignTemp, "misalign_temp", "temperature", kMaskBoth, K::kDeterministic,
      with_powers(offdiag(), "t", 1, 3), "rad/degC^p", "misalignment polynomial in tau");
  add(Effect::kScaleNonlinearity, "scale_nonlinearity", "input dependence", kMaskBoth, K::kDeterministic,
      with_powers(axes3(), "k", 2, 3), "1/unit, 1/unit^2", "k2 u_j^2 + k3 u_j^3");
  add(Effect::kScaleAsymmetry, "scale_asymmetry", "input dependence", kMaskBoth, K::kDeterministic, axes3(), "1",
      "a_j min(u_j, 0): extra scale for negative input");
  add(Effect::kCrossCoupling, "cross_coupling", "input dependence", kMaskBoth, K::kDeterministic, offdiag(),
      "1/unit", "c_jk u_j u_k (on-axis times cross-axis input)");
  add(Effect::kCrossAxisNonlinearity, "cross_axis_nonlinearity", "input dependence", kMaskAccel, K::kDeterministic,
      {"x.yy", "x.zz", "x.yz", "y.xx", "y.zz", "y.zx", "z.xx", "z.yy", "z.xy"}, "1/(m/s^2)",
      "K_j,kl f_k f_l over the cross axes k, l != j: squares K_pp, K_oo and product K_po (IEEE 1293)");
  add(Effect::kGSensitivity, "g_sensitivity", "gyro g-dependence", kMaskGyro, K::kDeterministic,
      {"xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"}, "(rad/s)/(m/s^2)", "G_jk f_k");
  add(Effect::kG2Sensitivity, "g2_sensitivity", "gyro g-dependence", kMaskGyro, K::kDeterministic,
      {"x.xy", "x.yz", "x.zx", "y.xy", "y.yz", "y.zx", "z.xy", "z.yz", "z.zx",
       "x.xx", "x.yy", "x.zz", "y.xx", "y.yy", "y.zz", "z.xx", "z.yy", "z.zz"},
      "(rad/s)/(m/s^2)^2", "g^2 sensitivity G2_j,kl f_k f_l: products (anisoelastic) and squares (IEEE 1431)");
  add(Effect::kSizeEffect, "size_effect", "accelerometer geometry", kMaskAccel, K::kDeterministic,
      {"x.rx", "x.ry", "x.rz", "y.rx", "y.ry", "y.rz", "z.rx", "z.ry", "z.rz"}, "m",
      "lever arm r_j of sensing axis j: [w x (w x r_j) + wdot x r_j]_j");
  add(Effect::kTempHysteresis, "temp_hysteresis", "thermal history", kMaskBoth, K::kDeterministic, axes3(),
      "m/s^2 | rad/s", "h_j d(t), d = direction of last temperature change");
  add(Effect::kTempRate, "temp_rate", "thermal history", kMaskBoth, K::kDeterministic, axes3(),
      "unit/(degC/s)", "r_j dT/dt");
  add(Effect::kTiming, "timing", "timing", kMaskBoth, K::kDeterministic, {"latency_s", "ppm"}, "s, ppm",
      "sample at t reads the input at t - latency - ppm*1e-6*t");
  add(Effect::kWhiteNoise, "white_noise", "noise", kMaskBoth, K::kStochastic, axes3(), "unit/sqrt(Hz)",
      "white noise density N; sigma = N sqrt(fs)");
  add(Effect::kBiasInstability, "bias_instability", "noise", kMaskBoth, K::kStochastic,
      {"x", "y", "z", "tau_s"}, "unit; s", "flicker floor B (Allan minimum / 0.664) as sum of Gauss-Markov");
  add(Effect::kRateRandomWalk, "rate_random_walk", "noise", kMaskBoth, K::kStochastic, axes3(), "unit*sqrt(Hz)",
      "random walk of the bias, K");
  add(Effect::kQuantization, "quantization", "noise", kMaskBoth, K::kStochastic, axes3(), "unit",
      "output rounded to step q (before the LSB rounding)");
  add(Effect::kSaturation, "saturation", "output", kMaskBoth, K::kStochastic, axes3(), "unit",
      "output clipped to +-limit");
  add(Effect::kTurnOnBias, "turn_on_bias", "output", kMaskBoth, K::kStochastic, axes3(), "unit",
      "1-sigma of a constant drawn once per power-up");
  return v;
}

int axis_index(char c) { return c == 'x' ? 0 : c == 'y' ? 1 : c == 'z' ? 2 : -1; }

ParamInfo make_param(ParamId id, Sensor s, const EffectInfo& e, const std::string& comp) {
  ParamInfo p{id, std::string(sensor_name(s)) + "." + e.name + "." + comp, s, e.effect, comp, -1, -1, -1, 0,
              e.kind == EffectKind::kDeterministic};
  // Component grammar: "<j>", "<j><k>", "<j>.t<p>", "<j><k>.t<p>", "<j>.k<p>", "<j>.<k><l>", "<j>.r<k>".
  const std::string& c = comp;
  auto dot = c.find('.');
  std::string head = c.substr(0, dot);
  std::string tail = dot == std::string::npos ? "" : c.substr(dot + 1);
  if (head.size() >= 1 && axis_index(head[0]) >= 0) p.j = axis_index(head[0]);
  if (head.size() == 2 && axis_index(head[1]) >= 0) p.k = axis_index(head[1]);
  if (!tail.empty()) {
    if (tail[0] == 't' || tail[0] == 'k') {
      p.power = tail[1] - '0';
    } else if (tail[0] == 'r') {
      p.k = axis_index(tail[1]);
    } else if (tail.size() == 2) {
      p.k = axis_index(tail[0]);
      p.l = axis_index(tail[1]);
    }
  }
  if (head == "latency_s" || head == "ppm" || head == "tau_s") p.j = -1;
  return p;
}

struct Tables {
  std::vector<EffectInfo> effects;
  std::vector<ParamInfo> params;
  std::unordered_map<std::string, ParamId> by_name;
  std::vector<ParamId> by_effect[kNumSensors][kNumEffects];
};

const Tables& tables() {
  static const Tables t = [] {
    Tables t;
    t.effects = build_effects();
    for (int si = 0; si < kNumSensors; ++si) {
      Sensor s = static_cast<Sensor>(si);
      for (const auto& e : t.effects) {
        if (!(e.sensors & (1u << si))) continue;
        for (const auto& c : e.components) {
          ParamId id = static_cast<ParamId>(t.params.size());
          t.params.push_back(make_param(id, s, e, c));
          t.by_name.emplace(t.params.back().name, id);
          t.by_effect[si][static_cast<int>(e.effect)].push_back(id);
        }
      }
    }
    return t;
  }();
  return t;
}

}  // namespace

const char* sensor_name(Sensor s) { return s == Sensor::kAccel ? "accel" : "gyro"; }

const std::vector<EffectInfo>& effects() { return tables().effects; }
const EffectInfo& effect_info(Effect e) { return tables().effects.at(static_cast<std::size_t>(e)); }

bool find_effect(std::string_view name, Effect& out) {
  for (const auto& e : effects())
    if (name == e.name) {
      out = e.effect;
      return true;
    }
  return false;
}

const std::vector<ParamInfo>& params() { return tables().params; }
int num_params() { return static_cast<int>(tables().params.size()); }
const ParamInfo& param_info(ParamId id) { return tables().params.at(static_cast<std::size_t>(id)); }

ParamId find_param(std::string_view name) {
  const auto& m = tables().by_name;
  auto it = m.find(std::string(name));
  return it == m.end() ? -1 : it->second;
}

ParamId param_id_or_throw(std::string_view name) {
  ParamId id = find_param(name);
  if (id >= 0) return id;
  std::string n(name);
  std::string msg = "unknown parameter '" + n + "'";
  auto d1 = n.find('.');
  auto d2 = d1 == std::string::npos ? std::string::npos : n.find('.', d1 + 1);
  if (d1 == std::string::npos || d2 == std::string::npos) {
    msg += " (expected <sensor>.<effect>.<component>, sensor = accel or gyro)";
  } else {
    std::string sn = n.substr(0, d1), en = n.substr(d1 + 1, d2 - d1 - 1);
    Effect e;
    if (sn != "accel" && sn != "gyro") {
      msg += ": sensor must be 'accel' or 'gyro'";
    } else if (!find_effect(en, e)) {
      msg += ": no effect '" + en + "' in the catalog";
    } else {
      Sensor s = sn == "accel" ? Sensor::kAccel : Sensor::kGyro;
      if (!(effect_info(e).sensors & (1u << static_cast<int>(s)))) {
        msg += ": effect '" + en + "' does not apply to the " + sn;
      } else {
        msg += ": valid components of " + sn + "." + en + " are";
        for (const auto& c : effect_info(e).components) msg += " " + c;
      }
    }
  }
  throw std::invalid_argument(msg);
}

std::vector<ParamId> effect_params(Sensor s, Effect e) {
  return tables().by_effect[static_cast<int>(s)][static_cast<int>(e)];
}

ParamSet::ParamSet() : v_(static_cast<std::size_t>(num_params()), 0.0) {}
double ParamSet::get(std::string_view name) const { return (*this)[param_id_or_throw(name)]; }
void ParamSet::set(std::string_view name, double value) { (*this)[param_id_or_throw(name)] = value; }

}  // namespace imuforge::model
