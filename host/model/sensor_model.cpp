#include "host/model/sensor_model.h"

#include "host/io/input_error.h"

#include <cmath>
#include <fstream>
#include <set>
#include <stdexcept>

namespace imuforge::model {

using nlohmann::json;

namespace {

[[noreturn]] void bad(const std::string& where, const std::string& what) {
  throw std::invalid_argument(where + ": " + what);
}

double num(const json& j, const std::string& where) {
  if (!j.is_number()) bad(where, "expected a number, got " + std::string(j.type_name()));
  double v = j.get<double>();
  if (!std::isfinite(v)) bad(where, "not a finite number");
  return v;
}

bool is_comment_key(const std::string& k) { return !k.empty() && k[0] == '_'; }

// "accel.bias" -> (sensor, effect). Plain "bias" expands to every applicable sensor.
std::vector<std::pair<Sensor, Effect>> parse_effect_key(const std::string& key, const std::string& where) {
  std::string sn, en;
  auto dot = key.find('.');
  if (dot == std::string::npos) {
    en = key;
  } else {
    sn = key.substr(0, dot);
    en = key.substr(dot + 1);
  }
  Effect e;
  if (!find_effect(en, e)) {
    std::string names;
    for (const auto& info : effects()) names += std::string(" ") + info.name;
    bad(where, "unknown effect '" + en + "' (catalog:" + names + ")");
  }
  const auto& info = effect_info(e);
  std::vector<std::pair<Sensor, Effect>> out;
  if (sn.empty()) {
    for (int s = 0; s < kNumSensors; ++s)
      if (info.sensors & (1u << s)) out.emplace_back(static_cast<Sensor>(s), e);
    return out;
  }
  if (sn != "accel" && sn != "gyro") bad(where, "sensor must be 'accel' or 'gyro', got '" + sn + "'");
  Sensor s = sn == "accel" ? Sensor::kAccel : Sensor::kGyro;
  if (!(info.sensors & (1u << static_cast<int>(s))))
    bad(where, "effect '" + en + "' does not apply to the " + sn);
  out.emplace_back(s, e);
  return out;
}

TriadOutput parse_triad(const json& j, const std::string& where) {
  if (!j.is_object()) bad(where, "expected an object with lsb, bits, range");
  TriadOutput t;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (is_comment_key(k)) continue;
    if (k == "lsb") t.lsb = num(*it, where + ".lsb");
    else if (k == "bits") t.bits = static_cast<int>(num(*it, where + ".bits"));
    else if (k == "range") t.range = num(*it, where + ".range");
    else bad(where, "unknown key '" + k + "' (expected lsb, bits, range)");
  }
  if (!(t.lsb > 0)) bad(where + ".lsb", "must be > 0");
  if (t.bits < 2 || t.bits > 32) bad(where + ".bits", "must be in 2..32");
  if (t.range < 0) bad(where + ".range", "must be >= 0");
  return t;
}

}  // namespace

ParamSet SensorModel::effective_params() const {
  ParamSet p = params;
  for (const auto& info : model::params())
    if (!on(info.sensor, info.effect)) p[info.id] = 0.0;
  return p;
}

SensorModel sensor_model_from_json(const json& j) {
  if (!j.is_object()) bad("sensor model", "expected a JSON object");
  SensorModel m;
  bool have[2] = {false, false};
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (is_comment_key(k) || k == "format" || k == "version") continue;
    if (k == "name") m.name = it->get<std::string>();
    else if (k == "source") m.source = it->is_string() ? it->get<std::string>() : it->dump();
    else if (k == "T_ref_C") m.T_ref_C = num(*it, "T_ref_C");
    else if (k == "accel") { m.out[0] = parse_triad(*it, "accel"); have[0] = true; }
    else if (k == "gyro") { m.out[1] = parse_triad(*it, "gyro"); have[1] = true; }
    else if (k == "thermal") {
      if (!it->is_object()) bad("thermal", "expected an object");
      for (auto t = it->begin(); t != it->end(); ++t) {
        const std::string& tk = t.key();
        std::string w = "thermal." + tk;
        if (is_comment_key(tk)) continue;
        if (tk == "die_tau_s") m.thermal.die_tau_s = num(*t, w);
        else if (tk == "self_heating_C") m.thermal.self_heating_C = num(*t, w);
        else if (tk == "self_heating_tau_s") m.thermal.self_heating_tau_s = num(*t, w);
        else if (tk == "hysteresis_threshold_C") m.thermal.hysteresis_threshold_C = num(*t, w);
        else if (tk == "dTdt_window_s") m.thermal.dTdt_window_s = num(*t, w);
        else bad("thermal", "unknown key '" + tk + "'");
      }
      if (!(m.thermal.die_tau_s > 0) || !(m.thermal.self_heating_tau_s > 0) || !(m.thermal.dTdt_window_s > 0))
        bad("thermal", "time constants must be > 0");
      if (m.thermal.hysteresis_threshold_C < 0) bad("thermal.hysteresis_threshold_C", "must be >= 0");
    } else if (k == "effects") {
      if (!it->is_object()) bad("effects", "expected an object {\"<sensor>.<effect>\": {component: value}}");
      for (auto e = it->begin(); e != it->end(); ++e) {
        if (is_comment_key(e.key())) continue;
        std::string where = "effects." + e.key();
        auto targets = parse_effect_key(e.key(), where);
        if (!e->is_object()) bad(where, "expected an object of component values");
        bool enabled = true;
        if (auto en = e->find("enabled"); en != e->end()) {
          if (!en->is_boolean()) bad(where + ".enabled", "expected true or false");
          enabled = en->get<bool>();
        }
        for (auto [s, eff] : targets) {
          m.enabled[static_cast<int>(s)][static_cast<int>(eff)] = enabled;
          for (auto c = e->begin(); c != e->end(); ++c) {
            if (c.key() == "enabled" || is_comment_key(c.key())) continue;
            std::string pname = std::string(sensor_name(s)) + "." + effect_info(eff).name + "." + c.key();
            ParamId id;
            try {
              id = param_id_or_throw(pname);
            } catch (const std::invalid_argument& ex) {
              bad(where, ex.what());
            }
            m.params[id] = num(*c, where + "." + c.key());
          }
        }
      }
    } else {
      bad("sensor model", "unknown key '" + k +
                              "' (expected name, source, T_ref_C, accel, gyro, thermal, effects; '_' keys are comments)");
    }
  }
  if (!have[0] || !have[1]) bad("sensor model", "both 'accel' and 'gyro' output blocks (lsb, bits) are required");
  // Sanity of the stochastic parameters that would otherwise produce nonsense.
  for (int s = 0; s < kNumSensors; ++s) {
    Sensor sn = static_cast<Sensor>(s);
    for (Effect e : {Effect::kWhiteNoise, Effect::kBiasInstability, Effect::kRateRandomWalk, Effect::kQuantization,
                     Effect::kSaturation, Effect::kTurnOnBias})
      for (ParamId id : effect_params(sn, e))
        if (m.params[id] < 0) bad("effects." + param_info(id).name, "must be >= 0");
    if (m.on(sn, Effect::kBiasInstability)) {
      ParamId tau = find_param(std::string(sensor_name(sn)) + ".bias_instability.tau_s");
      if (!(m.params[tau] > 0)) bad(param_info(tau).name, "bias_instability needs tau_s > 0 (correlation time of the floor)");
    }
  }
  return m;
}

SensorModel load_sensor_model(const std::string& path) {
  const json j = io::read_json_file(path);
  try {
    return sensor_model_from_json(j);
  } catch (const json::exception& e) {
    throw std::invalid_argument(path + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
}

json sensor_model_to_json(const SensorModel& m) {
  json j;
  j["format"] = "imuforge-sensor";
  j["version"] = 1;
  j["name"] = m.name;
  if (!m.source.empty()) j["source"] = m.source;
  j["T_ref_C"] = m.T_ref_C;
  for (int s = 0; s < kNumSensors; ++s)
    j[sensor_name(static_cast<Sensor>(s))] = {{"lsb", m.out[s].lsb}, {"bits", m.out[s].bits}, {"range", m.out[s].range}};
  j["thermal"] = {{"die_tau_s", m.thermal.die_tau_s},
                  {"self_heating_C", m.thermal.self_heating_C},
                  {"self_heating_tau_s", m.thermal.self_heating_tau_s},
                  {"hysteresis_threshold_C", m.thermal.hysteresis_threshold_C},
                  {"dTdt_window_s", m.thermal.dTdt_window_s}};
  json eff = json::object();
  for (int s = 0; s < kNumSensors; ++s)
    for (int e = 0; e < kNumEffects; ++e) {
      Sensor sn = static_cast<Sensor>(s);
      auto ids = effect_params(sn, static_cast<Effect>(e));
      if (ids.empty()) continue;
      bool any = m.enabled[s][e];
      for (ParamId id : ids) any = any || m.params[id] != 0.0;
      if (!any) continue;
      json o = json::object();
      if (!m.enabled[s][e]) o["enabled"] = false;
      for (ParamId id : ids)
        if (m.params[id] != 0.0) o[param_info(id).component] = m.params[id];
      eff[std::string(sensor_name(sn)) + "." + effect_info(static_cast<Effect>(e)).name] = o;
    }
  j["effects"] = eff;
  return j;
}

// ---------------------------------------------------------------- model spec

std::vector<ParamId> ModelSpec::parameters() const {
  std::vector<ParamId> out;
  for (const auto& me : effects) {
    if (effect_info(me.effect).kind != EffectKind::kDeterministic) continue;
    for (ParamId id : effect_params(me.sensor, me.effect)) {
      const auto& p = param_info(id);
      bool temp = me.effect == Effect::kBiasTemp || me.effect == Effect::kScaleTemp || me.effect == Effect::kMisalignTemp;
      if (temp && p.power > me.order) continue;
      if (!me.components.empty()) {
        std::string head = p.component.substr(0, p.component.find('.'));
        bool keep = false;
        for (const auto& c : me.components) keep = keep || c == p.component || c == head;
        if (!keep) continue;
      }
      out.push_back(id);
    }
  }
  return out;
}

bool ModelSpec::has(Sensor s, Effect e) const {
  for (const auto& me : effects)
    if (me.sensor == s && me.effect == e) return true;
  return false;
}

ModelSpec model_spec_from_json(const json& j) {
  if (!j.is_object()) bad("model", "expected a JSON object");
  ModelSpec m;
  m.extra = json::object();
  std::set<std::pair<int, int>> seen;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (k == "format" || k == "version") continue;
    if (k == "name") {
      m.name = it->get<std::string>();
    } else if (k == "T_ref_C") {
      m.T_ref_C = num(*it, "T_ref_C");
    } else if (k == "hysteresis_threshold_C") {
      m.hysteresis_threshold_C = num(*it, "hysteresis_threshold_C");
      if (!(m.hysteresis_threshold_C > 0) || !std::isfinite(m.hysteresis_threshold_C))
        bad("hysteresis_threshold_C", "must be a positive number of degrees C");
    } else if (k == "effects") {
      // Either ["accel.bias", ...] or {"accel.bias": {options}, ...}.
      std::vector<std::pair<std::string, json>> items;
      if (it->is_array()) {
        for (const auto& e : *it) {
          if (!e.is_string()) bad("effects", "array entries must be effect names");
          items.emplace_back(e.get<std::string>(), json::object());
        }
      } else if (it->is_object()) {
        for (auto e = it->begin(); e != it->end(); ++e)
          if (!is_comment_key(e.key())) items.emplace_back(e.key(), e.value());
      } else {
        bad("effects", "expected an array of names or an object");
      }
      for (const auto& [key, opt] : items) {
        std::string where = "effects." + key;
        if (!opt.is_object()) bad(where, "options must be an object");
        for (auto [s, e] : parse_effect_key(key, where)) {
          if (!seen.insert({static_cast<int>(s), static_cast<int>(e)}).second)
            bad(where, "effect listed twice for the " + std::string(sensor_name(s)));
          ModelEffect me{s, e, 0, false, {}};
          bool temp = e == Effect::kBiasTemp || e == Effect::kScaleTemp || e == Effect::kMisalignTemp;
          bool basic = e == Effect::kBias || e == Effect::kScale || e == Effect::kMisalign;
          if (temp) me.order = 1;
          for (auto o = opt.begin(); o != opt.end(); ++o) {
            const std::string& ok = o.key();
            if (is_comment_key(ok)) continue;
            if (ok == "order") {
              if (!temp) bad(where + ".order", "only *_temp effects have a polynomial order");
              double v = num(*o, where + ".order");
              if (v != std::floor(v) || v < 0 || v > 3) bad(where + ".order", "must be an integer 0..3");
              me.order = static_cast<int>(v);
            } else if (ok == "per_plateau") {
              if (!basic) bad(where + ".per_plateau", "only bias, scale, misalign can be fitted per plateau");
              if (!o->is_boolean()) bad(where + ".per_plateau", "expected true or false");
              me.per_plateau = o->get<bool>();
            } else if (ok == "components") {
              if (!o->is_array()) bad(where + ".components", "expected an array of component names");
              for (const auto& c : *o) {
                if (!c.is_string()) bad(where + ".components", "expected strings");
                std::string cs = c.get<std::string>();
                bool ok2 = false;
                for (const auto& cc : effect_info(e).components)
                  ok2 = ok2 || cc == cs || cc.substr(0, cc.find('.')) == cs;
                if (!ok2) bad(where + ".components", "no component '" + cs + "' in effect " + effect_info(e).name);
                me.components.push_back(cs);
              }
            } else {
              bad(where, "unknown option '" + ok + "' (expected order, per_plateau, components)");
            }
          }
          m.effects.push_back(me);
        }
      }
    } else {
      m.extra[k] = *it;  // solver options: kept verbatim
    }
  }
  if (m.effects.empty()) bad("model", "no 'effects' listed");
  return m;
}

ModelSpec load_model_spec(const std::string& path) {
  const json j = io::read_json_file(path);
  try {
    return model_spec_from_json(j);
  } catch (const json::exception& e) {
    throw std::invalid_argument(path + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
}

json model_spec_to_json(const ModelSpec& m) {
  json j = m.extra.is_object() ? m.extra : json::object();
  j["format"] = "imuforge-model";
  j["version"] = 1;
  j["name"] = m.name;
  j["T_ref_C"] = m.T_ref_C;
  if (std::isfinite(m.hysteresis_threshold_C)) j["hysteresis_threshold_C"] = m.hysteresis_threshold_C;
  json eff = json::object();
  for (const auto& me : m.effects) {
    json o = json::object();
    if (me.effect == Effect::kBiasTemp || me.effect == Effect::kScaleTemp || me.effect == Effect::kMisalignTemp)
      o["order"] = me.order;
    if (me.per_plateau) o["per_plateau"] = true;
    if (!me.components.empty()) o["components"] = me.components;
    eff[std::string(sensor_name(me.sensor)) + "." + effect_info(me.effect).name] = o;
  }
  j["effects"] = eff;
  return j;
}

}  // namespace imuforge::model
