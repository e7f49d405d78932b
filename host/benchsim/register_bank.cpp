#include "host/benchsim/register_bank.h"
#include "host/physics/units.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace imuforge::benchsim {

using fixture::FixtureKind;
using fixture::Point;
using fixture::RegisterMap;

namespace {
using physics::kDeg;  // host/physics/units.h

double wrap_deg(double a) {
  double w = std::fmod(a + 180.0, 360.0);
  if (w < 0) w += 360.0;
  return w - 180.0;
}
}  // namespace

RegisterBank::RegisterBank(RegisterMap table, RegisterMap chamber) : table_(std::move(table)), chamber_(std::move(chamber)) {
  if (table_.kind() != FixtureKind::kRateTable) throw std::runtime_error("bench-sim: " + table_.origin() + " is not a rate-table map");
  if (chamber_.kind() != FixtureKind::kChamber) throw std::runtime_error("bench-sim: " + chamber_.origin() + " is not a chamber map");
  int top = 0;
  for (const RegisterMap* m : {&table_, &chamber_})
    for (const auto& s : m->slots()) top = std::max(top, static_cast<int>(s.address) + 1);
  regs_.assign(static_cast<size_t>(top), 0);
  owner_.assign(static_cast<size_t>(top), Owner{});
  for (int mi = 0; mi < 2; ++mi) {
    const RegisterMap* m = mi == 0 ? &table_ : &chamber_;
    for (const auto& s : m->slots()) {
      Owner& o = owner_[s.address];
      if (o.map >= 0) {
        // Shared points (the clock) are fine when both maps describe them identically.
        const Point& op = point_of(o);
        const bool same = op.name == s.point->name && op.type == s.point->type && op.scale == s.point->scale &&
                          !op.writable && !s.point->writable;
        if (!same)
          throw std::runtime_error("bench-sim: register " + std::to_string(s.address) + " is " +
                                   map_of(o).label(op, o.axis) + " in " + map_of(o).origin() + " but " +
                                   m->label(*s.point, s.axis) + " in " + m->origin());
        continue;
      }
      o = Owner{mi, static_cast<int>(s.point - m->points().data()), s.axis};
    }
  }
  seq_applied_.assign(static_cast<size_t>(table_.axes()), 0);
}

void RegisterBank::put(const RegisterMap& m, const char* name, double value, int axis) {
  const Point* p = m.find(name);
  if (!p) return;
  std::vector<uint16_t> w;
  try {
    w = m.encode(*p, value);
  } catch (const std::runtime_error&) {
    // Out of range for this register (a runaway value): saturate at the point's range rather than
    // stop serving; if even that does not fit, keep the previous content.
    const double lo = p->min > -1e299 ? p->min : -1e9, hi = p->max < 1e299 ? p->max : 1e9;
    try {
      w = m.encode(*p, std::isfinite(value) ? std::clamp(value, lo, hi) : 0.0);
    } catch (const std::runtime_error&) {
      return;
    }
  }
  const uint16_t a = m.address(*p, axis);
  std::copy(w.begin(), w.end(), regs_.begin() + a);
}

double RegisterBank::get(const RegisterMap& m, const char* name, int axis, double dflt) const {
  const Point* p = m.find(name);
  if (!p) return dflt;
  return m.decode(*p, regs_.data() + m.address(*p, axis));
}

void RegisterBank::init_from(const World& w) {
  for (int a = 0; a < table_.axes(); ++a) {
    const AxisReport r = a < w.axes() ? w.axis(a) : AxisReport{};
    put(table_, "mode", static_cast<int>(r.mode), a);
    put(table_, "command", r.mode == AxisMode::kIdle ? 0.0 : r.command / kDeg, a);
    put(table_, "cmd_seq", 0, a);
    seq_applied_[static_cast<size_t>(a)] = 0;
  }
  const ChamberReport c = w.chamber();
  put(chamber_, "setpoint", c.setpoint_C);
  put(chamber_, "ramp", c.ramp_C_per_min);
  put(chamber_, "run", c.running ? 1 : 0);
  publish(w);
}

void RegisterBank::publish(const World& w) {
  const double t = w.time_s();
  put(table_, "clock", t);
  put(chamber_, "clock", t);
  put(table_, "axes", table_.axes());
  for (int a = 0; a < table_.axes(); ++a) {
    if (a >= w.axes()) {
      put(table_, "status", 8, a);  // fault: this axis does not exist in the simulated table
      put(table_, "fault_code", 3, a);
      continue;
    }
    const AxisReport r = w.axis(a);
    put(table_, "seq_ack", seq_applied_[static_cast<size_t>(a)], a);
    put(table_, "angle", wrap_deg(r.angle_rad / kDeg), a);
    put(table_, "rate", r.rate_rad_s / kDeg, a);
    const Point* ps = table_.find("status");
    if (ps) {
      unsigned bits = 0;
      auto set = [&](const char* n, bool v) {
        auto it = ps->bits.find(n);
        if (v && it != ps->bits.end()) bits |= 1u << it->second;
      };
      set("in_position", r.in_position);
      set("settled", r.settled);
      set("moving", r.moving);
      set("fault", r.fault);
      put(table_, "status", bits, a);
    }
    put(table_, "fault_code", r.fault_code, a);
  }
  const ChamberReport c = w.chamber();
  put(chamber_, "air_temp", c.air_C);
  if (const Point* ps = chamber_.find("status")) {
    unsigned bits = 0;
    auto set = [&](const char* n, bool v) {
      auto it = ps->bits.find(n);
      if (v && it != ps->bits.end()) bits |= 1u << it->second;
    };
    set("running", c.running);
    set("at_setpoint", c.at_setpoint);
    set("fault", c.fault);
    put(chamber_, "status", bits);
  }
  put(chamber_, "fault_code", c.fault_code);
}

int RegisterBank::check_write(uint16_t address, const uint16_t* words, int n, std::string* why) const {
  if (n < 1 || static_cast<int>(address) + n > size()) {
    *why = "write beyond the register space";
    return 2;
  }
  for (int i = 0; i < n; ++i) {
    const Owner& o = owner_[address + static_cast<size_t>(i)];
    if (o.map < 0 || !point_of(o).writable) {
      *why = "register " + std::to_string(address + i) +
             (o.map >= 0 ? " (" + map_of(o).label(point_of(o), o.axis) + ") is read-only" : " is not mapped");
      return 2;
    }
  }
  // Decode every touched point as it would read after the write, and check its range.
  std::vector<uint16_t> after(regs_);
  std::copy(words, words + n, after.begin() + address);
  for (int i = 0; i < n; ++i) {
    const Owner& o = owner_[address + static_cast<size_t>(i)];
    const RegisterMap& m = map_of(o);
    const Point& p = point_of(o);
    const double v = m.decode(p, after.data() + m.address(p, o.axis));
    bool ok = std::isfinite(v) && v >= p.min && v <= p.max;
    if (ok && !p.values.empty()) {
      ok = false;
      for (const auto& kv : p.values) ok = ok || kv.second == static_cast<int>(v);
    }
    if (!ok) {
      std::ostringstream os;
      os << m.label(p, o.axis) << ": value " << v << " not accepted";
      *why = os.str();
      return 3;
    }
  }
  return 0;
}

void RegisterBank::apply_write(uint16_t address, const uint16_t* words, int n, World& w) {
  std::copy(words, words + n, regs_.begin() + address);
  std::vector<int> axes_touched;
  bool setpoint = false, ramp = false, run = false;
  for (int i = 0; i < n; ++i) {
    const Owner& o = owner_[address + static_cast<size_t>(i)];
    if (o.map == 0) {
      if (std::find(axes_touched.begin(), axes_touched.end(), o.axis) == axes_touched.end()) axes_touched.push_back(o.axis);
    } else {
      const std::string& n = point_of(o).name;
      setpoint |= n == "setpoint";
      ramp |= n == "ramp";
      run |= n == "run";
    }
  }
  for (int a : axes_touched) {
    if (a >= w.axes()) continue;
    const bool has_seq = table_.find("cmd_seq") != nullptr;
    if (has_seq) {
      const auto seq = static_cast<uint16_t>(get(table_, "cmd_seq", a, 0));
      if (seq == seq_applied_[static_cast<size_t>(a)]) continue;  // staged only, or a repeat of the last command
      seq_applied_[static_cast<size_t>(a)] = seq;
    }
    const auto mode = static_cast<AxisMode>(static_cast<int>(get(table_, "mode", a, 0)));
    const double cmd_deg = get(table_, "command", a, 0);
    w.command_axis(a, mode, cmd_deg * kDeg);
    ++commands_applied_;
  }
  if (ramp) w.set_ramp(get(chamber_, "ramp", 0, 3.0));
  if (setpoint) w.set_setpoint(get(chamber_, "setpoint", 0, 25.0));
  if (run) w.set_running(get(chamber_, "run", 0, 1) != 0);
  publish(w);
}

}  // namespace imuforge::benchsim
