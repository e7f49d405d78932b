#include "host/sim/trajectory_file.h"

#include <cmath>
#include <fstream>
#include <set>
#include <stdexcept>

namespace imuforge::sim {

using nlohmann::json;
using physics::VehicleSegment;

namespace {

[[noreturn]] void bad(const std::string& where, const std::string& what) { throw std::invalid_argument(where + ": " + what); }

double num(const json& o, const std::string& key, const std::string& where, bool required, double dflt = 0.0) {
  auto it = o.find(key);
  if (it == o.end()) {
    if (required) bad(where, "missing key '" + key + "'");
    return dflt;
  }
  if (!it->is_number()) bad(where + "." + key, "expected a number");
  const double v = it->get<double>();
  if (!std::isfinite(v)) bad(where + "." + key, "not a finite number");
  return v;
}

void only_keys(const json& o, const std::set<std::string>& allowed, const std::string& where) {
  for (auto it = o.begin(); it != o.end(); ++it) {
    const std::string& k = it.key();
    if (!k.empty() && k[0] == '_') continue;
    if (!allowed.count(k)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      bad(where, "unknown key '" + k + "' (expected " + list + ")");
    }
  }
}

VehicleSegment parse_segment(const json& s, const std::string& where) {
  if (!s.is_object()) bad(where, "expected an object with a \"type\"");
  auto ty = s.find("type");
  if (ty == s.end() || !ty->is_string()) bad(where, "missing string \"type\" (stand, accelerate, cruise, turn, climb)");
  const std::string t = ty->get<std::string>();
  VehicleSegment g;
  if (auto l = s.find("label"); l != s.end()) {
    if (!l->is_string()) bad(where + ".label", "expected a string");
    g.label = l->get<std::string>();
  }
  if (t == "stand") {
    only_keys(s, {"type", "label", "duration_s"}, where);
    g.kind = VehicleSegment::Kind::kStand;
    g.duration_s = num(s, "duration_s", where, true);
  } else if (t == "accelerate") {
    only_keys(s, {"type", "label", "duration_s", "speed_mps"}, where);
    g.kind = VehicleSegment::Kind::kAccelerate;
    g.duration_s = num(s, "duration_s", where, true);
    g.speed_to_mps = num(s, "speed_mps", where, true);
  } else if (t == "cruise") {
    only_keys(s, {"type", "label", "duration_s"}, where);
    g.kind = VehicleSegment::Kind::kCruise;
    g.duration_s = num(s, "duration_s", where, true);
  } else if (t == "turn") {
    only_keys(s, {"type", "label", "radius_m", "angle_deg", "transition_s"}, where);
    g.kind = VehicleSegment::Kind::kTurn;
    g.radius_m = num(s, "radius_m", where, true);
    g.angle_rad = num(s, "angle_deg", where, true) * M_PI / 180.0;
    g.transition_s = num(s, "transition_s", where, false, 1.0);
  } else if (t == "climb") {
    only_keys(s, {"type", "label", "duration_s", "height_m"}, where);
    g.kind = VehicleSegment::Kind::kClimb;
    g.duration_s = num(s, "duration_s", where, true);
    g.height_change_m = num(s, "height_m", where, true);
  } else {
    bad(where + ".type", "unknown segment type '" + t + "' (expected stand, accelerate, cruise, turn, climb)");
  }
  return g;
}

}  // namespace

TrajectoryFile trajectory_from_json(const json& j) {
  if (!j.is_object()) bad("trajectory", "expected a JSON object");
  only_keys(j, {"format", "version", "name", "sample_rate_hz", "ambient_C", "start", "segments"}, "trajectory");
  if (j.contains("format") && j["format"] != "imuforge-trajectory") bad("format", "expected \"imuforge-trajectory\"");
  if (j.contains("version") && j["version"] != 1) bad("version", "only version 1 is known");
  auto st = j.find("start");
  if (st == j.end() || !st->is_object()) bad("trajectory", "missing object \"start\"");
  only_keys(*st, {"latitude_deg", "longitude_deg", "height_m", "heading_deg"}, "start");
  physics::VehicleStart start;
  start.latitude_deg = num(*st, "latitude_deg", "start", true);
  start.longitude_deg = num(*st, "longitude_deg", "start", true);
  start.height_m = num(*st, "height_m", "start", false, 0.0);
  start.heading_deg = num(*st, "heading_deg", "start", false, 0.0);
  if (std::abs(start.latitude_deg) >= 89.0) bad("start.latitude_deg", "must be within ±89° (NED mechanisation)");
  auto segs = j.find("segments");
  if (segs == j.end() || !segs->is_array() || segs->empty()) bad("trajectory", "missing non-empty array \"segments\"");
  std::vector<VehicleSegment> v;
  for (std::size_t i = 0; i < segs->size(); ++i) v.push_back(parse_segment((*segs)[i], "segments[" + std::to_string(i) + "]"));
  const double fs = num(j, "sample_rate_hz", "trajectory", false, 200.0);
  if (!(fs >= 10.0 && fs <= 10000.0)) bad("sample_rate_hz", "must be in [10, 10000] Hz");
  const double amb = num(j, "ambient_C", "trajectory", false, 25.0);
  if (!(amb > -60 && amb < 125)) bad("ambient_C", "must be in (−60, 125) °C");
  std::string name = j.value("name", std::string("trajectory"));
  return TrajectoryFile{name, fs, amb, physics::VehicleTrajectory(start, std::move(v))};
}

TrajectoryFile load_trajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open trajectory file");
  try {
    return trajectory_from_json(json::parse(in));
  } catch (const json::exception& e) {
    throw std::invalid_argument(path + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
}

void labelled_span(const physics::VehicleTrajectory& tr, const std::string& label, double& start_s, double& duration_s) {
  const auto& segs = tr.segments();
  for (std::size_t i = 0; i < segs.size(); ++i)
    if (segs[i].label == label) {
      std::size_t k = i;
      while (k + 1 < segs.size() && segs[k + 1].label == label) ++k;
      start_s = tr.segment_start_s(i);
      duration_s = tr.segment_end_s(k) - start_s;
      return;
    }
  throw std::invalid_argument("no segment labelled '" + label + "' in the trajectory");
}

}  // namespace imuforge::sim
