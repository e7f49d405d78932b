#include "host/io/campaign_file.h"

#include "host/io/input_error.h"

#include <cmath>
#include <fstream>
#include <stdexcept>

namespace imuforge::io {

using physics::Campaign;
using physics::CampaignAxis;
using physics::CampaignPhase;
using physics::CampaignStep;

using nlohmann::json;

namespace {

[[noreturn]] void bad(const std::string& where, const std::string& what) {
  throw std::invalid_argument(where + ": " + what);
}

bool comment(const std::string& k) { return !k.empty() && k[0] == '_'; }

double num(const json& j, const std::string& where) {
  if (!j.is_number()) bad(where, std::string("expected a number, got ") + j.type_name());
  double v = j.get<double>();
  if (!std::isfinite(v)) bad(where, "not finite");
  return v;
}

std::string str(const json& j, const std::string& where) {
  if (!j.is_string()) bad(where, "expected a string");
  return j.get<std::string>();
}

std::array<double, 3> vec(const json& j, std::size_t n, const std::string& where) {
  if (!j.is_array() || j.size() != n)
    bad(where, "expected an array of " + std::to_string(n) + " numbers (one per " +
                   (n == 3 ? std::string("component/axis") : std::string("table axis")) + ")");
  std::array<double, 3> v{};
  for (std::size_t i = 0; i < n; ++i) v[i] = num(j[i], where + "[" + std::to_string(i) + "]");
  return v;
}

void check_axis_name(const std::string& a, const std::string& where) {
  static const char* ok[] = {"x", "y", "z", "-x", "-y", "-z", "+x", "+y", "+z"};
  for (const char* o : ok)
    if (a == o) return;
  bad(where, "axis must be x, y, z, -x, -y or -z, got '" + a + "'");
}

CampaignStep parse_step(const json& s, const Campaign& c, const std::string& where) {
  if (!s.is_object()) bad(where, "expected an object");
  const std::size_t n = c.axes.size();
  CampaignStep st;
  auto t = s.find("type");
  if (t == s.end()) bad(where, "missing 'type' (position, rate, ramp_rate, sine, soak, pose, or use)");
  std::string type = str(*t, where + ".type");
  if (type == "position") st.kind = CampaignStep::Kind::kPosition;
  else if (type == "rate") st.kind = CampaignStep::Kind::kRate;
  else if (type == "ramp_rate") st.kind = CampaignStep::Kind::kRampRate;
  else if (type == "sine") st.kind = CampaignStep::Kind::kSine;
  else if (type == "soak") st.kind = CampaignStep::Kind::kSoak;
  else if (type == "pose") st.kind = CampaignStep::Kind::kPose;
  else bad(where + ".type", "unknown step type '" + type + "'");
  bool need[8] = {};  // position, rate, from, amp, freq, attitude
  for (auto it = s.begin(); it != s.end(); ++it) {
    const std::string& k = it.key();
    std::string w = where + "." + k;
    if (comment(k) || k == "type") continue;
    if (k == "label") st.label = str(*it, w);
    else if (k == "dwell_s") st.dwell_s = num(*it, w);
    else if (k == "settle_s") st.settle_s = num(*it, w);
    else if (k == "move_s") st.move_s = num(*it, w);
    else if (k == "position_deg") { st.position_deg = vec(*it, n, w); need[0] = true; }
    else if (k == "rate_dps") { st.rate_dps = vec(*it, n, w); need[1] = true; }
    else if (k == "rate_from_dps") { st.rate_from_dps = vec(*it, n, w); need[2] = true; }
    else if (k == "amplitude_deg") { st.amplitude_deg = vec(*it, n, w); need[3] = true; }
    else if (k == "frequency_hz") { st.frequency_hz = vec(*it, n, w); need[4] = true; }
    else if (k == "attitude_deg") { st.attitude_deg = vec(*it, 3, w); need[5] = true; }
    else bad(where, "unknown key '" + k + "'");
  }
  using K = CampaignStep::Kind;
  if (!(st.dwell_s > 0)) bad(where + ".dwell_s", "must be > 0");
  if (st.kind == K::kPosition && !need[0]) bad(where, "position step needs position_deg");
  if (st.kind == K::kRate && !need[1]) bad(where, "rate step needs rate_dps");
  if (st.kind == K::kRampRate && (!need[1] || !need[2])) bad(where, "ramp_rate step needs rate_from_dps and rate_dps");
  if (st.kind == K::kSine && (!need[3] || !need[4])) bad(where, "sine step needs amplitude_deg and frequency_hz");
  if (st.kind == K::kPose && !need[5]) bad(where, "pose step needs attitude_deg [roll, pitch, yaw]");
  if (st.kind == K::kPose && !(st.move_s > 0)) bad(where + ".move_s", "must be > 0");
  if (st.kind != K::kPose && n == 0) bad(where, "table steps need table.axes");
  for (std::size_t i = 0; i < n; ++i) {
    const auto& ax = c.axes[i];
    auto lim = [&](double r, const char* what) {
      if (std::fabs(r) > ax.max_rate_dps * (1 + 1e-12))
        bad(where, std::string(what) + " on axis '" + ax.name + "' exceeds its max_rate_dps");
    };
    if (st.kind == K::kRate || st.kind == K::kRampRate) lim(st.rate_dps[i], "rate_dps");
    if (st.kind == K::kRampRate) lim(st.rate_from_dps[i], "rate_from_dps");
    if (st.kind == K::kSine) {
      if (st.frequency_hz[i] < 0 || st.amplitude_deg[i] < 0) bad(where, "sine amplitude/frequency must be >= 0");
      lim(st.amplitude_deg[i] * 2 * M_PI * st.frequency_hz[i], "sine peak rate");
      if (st.amplitude_deg[i] * std::pow(2 * M_PI * st.frequency_hz[i], 2) > ax.max_accel_dps2 * (1 + 1e-12))
        bad(where, "sine peak acceleration on axis '" + ax.name + "' exceeds its max_accel_dps2");
    }
  }
  return st;
}

void parse_steps(const json& arr, const Campaign& c, const json& seqs, const std::string& where,
                 std::vector<CampaignStep>& out, int depth) {
  if (!arr.is_array()) bad(where, "expected an array of steps");
  if (depth > 8) bad(where, "sequences nest too deeply (recursive 'use'?)");
  for (std::size_t i = 0; i < arr.size(); ++i) {
    std::string w = where + "[" + std::to_string(i) + "]";
    const json& s = arr[i];
    if (s.is_object() && s.contains("use")) {
      std::string name = str(s["use"], w + ".use");
      if (!seqs.is_object() || !seqs.contains(name)) bad(w + ".use", "no sequence named '" + name + "'");
      parse_steps(seqs[name], c, seqs, "sequences." + name, out, depth + 1);
      continue;
    }
    out.push_back(parse_step(s, c, w));
  }
}

}  // namespace

Campaign campaign_from_json(const json& j) {
  if (!j.is_object()) bad("campaign", "expected a JSON object");
  Campaign c;
  json seqs = json::object();
  const json* phases = nullptr;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (comment(k) || k == "format" || k == "version") continue;
    if (k == "name") c.name = str(*it, k);
    else if (k == "description") c.description = str(*it, k);
    else if (k == "sample_rate_hz") c.sample_rate_hz = num(*it, k);
    else if (k == "site") {
      for (auto s = it->begin(); s != it->end(); ++s) {
        if (comment(s.key())) continue;
        if (s.key() == "latitude_deg") c.latitude_deg = num(*s, "site.latitude_deg");
        else if (s.key() == "height_m") c.height_m = num(*s, "site.height_m");
        else bad("site", "unknown key '" + s.key() + "'");
      }
    } else if (k == "table") {
      if (!it->is_object()) bad("table", "expected an object");
      for (auto s = it->begin(); s != it->end(); ++s) {
        const std::string& tk = s.key();
        if (comment(tk)) continue;
        if (tk == "settle_s") c.settle_s = num(*s, "table.settle_s");
        else if (tk == "axes") {
          if (!s->is_array() || s->size() > 3) bad("table.axes", "expected an array of 1..3 axes (innermost first)");
          for (std::size_t i = 0; i < s->size(); ++i) {
            std::string w = "table.axes[" + std::to_string(i) + "]";
            const json& a = (*s)[i];
            if (!a.is_object()) bad(w, "expected an object");
            CampaignAxis ax;
            ax.name = "axis" + std::to_string(i);
            for (auto f = a.begin(); f != a.end(); ++f) {
              if (comment(f.key())) continue;
              if (f.key() == "name") ax.name = str(*f, w + ".name");
              else if (f.key() == "axis") ax.axis = str(*f, w + ".axis");
              else if (f.key() == "max_rate_dps") ax.max_rate_dps = num(*f, w + ".max_rate_dps");
              else if (f.key() == "max_accel_dps2") ax.max_accel_dps2 = num(*f, w + ".max_accel_dps2");
              else bad(w, "unknown key '" + f.key() + "'");
            }
            check_axis_name(ax.axis, w + ".axis");
            if (!(ax.max_rate_dps > 0) || !(ax.max_accel_dps2 > 0)) bad(w, "max_rate_dps and max_accel_dps2 must be > 0");
            c.axes.push_back(ax);
          }
        } else if (tk == "mount") {
          for (auto f = s->begin(); f != s->end(); ++f) {
            if (comment(f.key())) continue;
            if (f.key() == "rotation_deg") c.mount_rotation_deg = vec(*f, 3, "table.mount.rotation_deg");
            else if (f.key() == "lever_arm_m") c.lever_arm_m = vec(*f, 3, "table.mount.lever_arm_m");
            else bad("table.mount", "unknown key '" + f.key() + "'");
          }
        } else {
          bad("table", "unknown key '" + tk + "'");
        }
      }
    } else if (k == "chamber") {
      for (auto s = it->begin(); s != it->end(); ++s) {
        if (comment(s.key())) continue;
        if (s.key() == "initial_C") c.initial_C = num(*s, "chamber.initial_C");
        else if (s.key() == "ramp_limit_C_per_min") c.ramp_limit_C_per_min = num(*s, "chamber.ramp_limit_C_per_min");
        else if (s.key() == "tau_s") c.chamber_tau_s = num(*s, "chamber.tau_s");
        else bad("chamber", "unknown key '" + s.key() + "'");
      }
      if (!(c.ramp_limit_C_per_min > 0) || !(c.chamber_tau_s > 0)) bad("chamber", "ramp limit and tau_s must be > 0");
    } else if (k == "sequences") {
      if (!it->is_object()) bad("sequences", "expected an object of named step lists");
      seqs = *it;
    } else if (k == "phases") {
      phases = &*it;
    } else if (k == "simulation") {
      c.simulation_json = it->dump();
    } else {
      bad("campaign", "unknown key '" + k + "'");
    }
  }
  if (!(c.sample_rate_hz > 0)) bad("sample_rate_hz", "must be > 0");
  if (c.latitude_deg < -90 || c.latitude_deg > 90) bad("site.latitude_deg", "must be within [-90, 90]");
  if (!(c.settle_s >= 0)) bad("table.settle_s", "must be >= 0");
  if (!phases || !phases->is_array() || phases->empty()) bad("phases", "expected a non-empty array");
  for (std::size_t p = 0; p < phases->size(); ++p) {
    std::string w = "phases[" + std::to_string(p) + "]";
    const json& ph = (*phases)[p];
    if (!ph.is_object()) bad(w, "expected an object");
    CampaignPhase cp;
    bool have_set = false;
    const json* steps = nullptr;
    for (auto it = ph.begin(); it != ph.end(); ++it) {
      const std::string& k = it.key();
      if (comment(k)) continue;
      if (k == "type") {
        std::string t = str(*it, w + ".type");
        if (t == "plateau") cp.kind = CampaignPhase::Kind::kPlateau;
        else if (t == "ramp") cp.kind = CampaignPhase::Kind::kRamp;
        else bad(w + ".type", "expected plateau or ramp, got '" + t + "'");
      } else if (k == "label") cp.label = str(*it, w + ".label");
      else if (k == "setpoint_C") { cp.setpoint_C = num(*it, w + ".setpoint_C"); have_set = true; }
      else if (k == "soak_s") cp.soak_s = num(*it, w + ".soak_s");
      else if (k == "rate_C_per_min") cp.rate_C_per_min = num(*it, w + ".rate_C_per_min");
      else if (k == "steps") steps = &*it;
      else bad(w, "unknown key '" + k + "'");
    }
    if (!ph.contains("type")) bad(w, "missing 'type' (plateau or ramp)");
    if (!have_set) bad(w, "missing setpoint_C");
    if (cp.setpoint_C < -100 || cp.setpoint_C > 200) bad(w + ".setpoint_C", "outside -100..200 degC");
    if (cp.soak_s < 0) bad(w + ".soak_s", "must be >= 0");
    if (cp.kind == CampaignPhase::Kind::kRamp) {
      if (steps) bad(w, "a ramp phase holds the table still: no steps allowed");
      if (!(cp.rate_C_per_min > 0)) bad(w + ".rate_C_per_min", "must be > 0");
      if (cp.rate_C_per_min > c.ramp_limit_C_per_min * (1 + 1e-12))
        bad(w + ".rate_C_per_min", "exceeds chamber.ramp_limit_C_per_min");
    }
    if (steps) parse_steps(*steps, c, seqs, w + ".steps", cp.steps, 0);
    c.phases.push_back(std::move(cp));
  }
  return c;
}

Campaign load_campaign(const std::string& path) {
  const json j = io::read_json_file(path);
  try {
    return campaign_from_json(j);
  } catch (const json::exception& e) {
    throw std::invalid_argument(path + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
}

json campaign_to_json(const Campaign& c) {
  json j;
  j["format"] = "imuforge-campaign";
  j["version"] = 1;
  j["name"] = c.name;
  if (!c.description.empty()) j["description"] = c.description;
  j["site"] = {{"latitude_deg", c.latitude_deg}, {"height_m", c.height_m}};
  j["sample_rate_hz"] = c.sample_rate_hz;
  json axes = json::array();
  const std::size_t n = c.axes.size();
  auto part = [n](const std::array<double, 3>& a) { return std::vector<double>(a.begin(), a.begin() + static_cast<long>(n)); };
  for (const auto& a : c.axes)
    axes.push_back({{"name", a.name}, {"axis", a.axis}, {"max_rate_dps", a.max_rate_dps}, {"max_accel_dps2", a.max_accel_dps2}});
  j["table"] = {{"axes", axes},
                {"settle_s", c.settle_s},
                {"mount", {{"rotation_deg", c.mount_rotation_deg}, {"lever_arm_m", c.lever_arm_m}}}};
  j["chamber"] = {{"initial_C", c.initial_C}, {"ramp_limit_C_per_min", c.ramp_limit_C_per_min}, {"tau_s", c.chamber_tau_s}};
  json ph = json::array();
  for (const auto& p : c.phases) {
    json o;
    o["type"] = p.kind == CampaignPhase::Kind::kPlateau ? "plateau" : "ramp";
    if (!p.label.empty()) o["label"] = p.label;
    o["setpoint_C"] = p.setpoint_C;
    if (p.kind == CampaignPhase::Kind::kPlateau) {
      o["soak_s"] = p.soak_s;
      json st = json::array();
      for (const auto& s : p.steps) {
        json x;
        using K = CampaignStep::Kind;
        static const char* names[] = {"position", "rate", "ramp_rate", "sine", "soak", "pose"};
        x["type"] = names[static_cast<int>(s.kind)];
        if (!s.label.empty()) x["label"] = s.label;
        x["dwell_s"] = s.dwell_s;
        if (s.kind == K::kPosition) {
          x["position_deg"] = part(s.position_deg);
          if (s.settle_s >= 0) x["settle_s"] = s.settle_s;
        }
        if (s.kind == K::kRate || s.kind == K::kRampRate) x["rate_dps"] = part(s.rate_dps);
        if (s.kind == K::kRampRate) x["rate_from_dps"] = part(s.rate_from_dps);
        if (s.kind == K::kSine) {
          x["amplitude_deg"] = part(s.amplitude_deg);
          x["frequency_hz"] = part(s.frequency_hz);
        }
        if (s.kind == K::kPose) {
          x["attitude_deg"] = s.attitude_deg;
          x["move_s"] = s.move_s;
        }
        st.push_back(x);
      }
      o["steps"] = st;
    } else {
      o["rate_C_per_min"] = p.rate_C_per_min;
    }
    ph.push_back(o);
  }
  j["phases"] = ph;
  if (!c.simulation_json.empty()) j["simulation"] = json::parse(c.simulation_json);
  return j;
}

}  // namespace imuforge::io
