#include "host/physics/timeline.h"
#include "host/physics/units.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

namespace imuforge::physics {

namespace {

using physics::kDeg;  // host/physics/units.h

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& n, double ang) {
  return Eigen::AngleAxisd(ang, n).toRotationMatrix();
}

// Smoothstep s(x) = 3x² − 2x³ and its time derivatives for x = τ/T.
void smooth(double tau, double T, double& s, double& sd, double& sdd) {
  double x = std::clamp(tau / T, 0.0, 1.0);
  s = x * x * (3 - 2 * x);
  sd = (tau >= T || tau <= 0) ? 0.0 : 6 * x * (1 - x) / T;
  sdd = (tau >= T || tau < 0) ? 0.0 : (6 - 12 * x) / (T * T);
}

struct Builder {
  const Campaign& c;
  Timeline tl;
  double t = 0;
  std::array<double, 3> ang{}, rate{};
  bool free = false;
  Eigen::Matrix3d C_ned_imu = Eigen::Matrix3d::Identity();
  int seg = 0;
  int phase = 0;
  TableGeometry geom;
  std::size_t n;

  explicit Builder(const Campaign& cc) : c(cc), geom(geometry_from_campaign(cc)), n(cc.axes.size()) {}

  TimelineEntry& push(double dur, bool is_seg, const std::string& kind, const std::string& label) {
    TimelineEntry e;
    e.t0 = t;
    e.t1 = t + dur;
    e.phase = phase;
    e.label = label;
    e.free = free;
    e.has_ref = !free;
    e.C0_ned_imu = C_ned_imu;
    e.phi = 0;
    e.move_s = 1;
    for (std::size_t i = 0; i < kMaxTableAxes; ++i) e.axis[i].a0 = ang[i];
    if (is_seg) {
      e.segment = seg++;
      tl.segments.push_back(SegmentInfo{e.segment, e.t0, e.t1, phase, kind, label, e.has_ref});
    }
    tl.entries.push_back(e);
    t += dur;
    return tl.entries.back();
  }
  // Updates ang/rate from the end of the last entry.
  void finish() {
    const auto& e = tl.entries.back();
    for (std::size_t i = 0; i < n; ++i) {
      double a, r, ac;
      e.axis[i].eval(e.t1 - e.t0, a, r, ac);
      ang[i] = a;
      rate[i] = r;
    }
  }
  // Rate change (accel limited per axis), segment −1. No-op if already there.
  void rate_to(const std::array<double, 3>& r1, const std::string& label) {
    if (free) return;
    double dur = 0;
    for (std::size_t i = 0; i < n; ++i)
      dur = std::max(dur, std::fabs(r1[i] - rate[i]) / (c.axes[i].max_accel_dps2 * kDeg));
    if (dur <= 0) return;
    auto& e = push(dur, false, "", label);
    for (std::size_t i = 0; i < n; ++i) {
      auto& p = e.axis[i];
      p.kind = AxisProfile::Kind::kRateChange;
      p.r0 = rate[i];
      p.r1 = r1[i];
      double a = c.axes[i].max_accel_dps2 * kDeg;
      p.acc = r1[i] >= rate[i] ? a : -a;
      p.t_acc = std::fabs(r1[i] - rate[i]) / a;
    }
    finish();
  }
  void stop(const std::string& label) { rate_to({0, 0, 0}, label); }
  void leave_free() {
    // Back on the table: the operator re-mounts the IMU (attitude jumps to the table's).
    free = false;
  }
  void move_to(const std::array<double, 3>& target_rad, bool nearest, const std::string& label) {
    stop(label);
    std::array<double, 3> d{};
    double dur = 0;
    for (std::size_t i = 0; i < n; ++i) {
      double tgt = target_rad[i];
      if (nearest) tgt += 2 * M_PI * std::round((ang[i] - tgt) / (2 * M_PI));
      d[i] = tgt - ang[i];
      double v = c.axes[i].max_rate_dps * kDeg, a = c.axes[i].max_accel_dps2 * kDeg;
      double ad = std::fabs(d[i]);
      double T = ad >= v * v / a ? 2 * v / a + (ad - v * v / a) / v : 2 * std::sqrt(ad / a);
      dur = std::max(dur, T);
    }
    if (dur <= 0) return;
    auto& e = push(dur, false, "", label);
    for (std::size_t i = 0; i < n; ++i) {
      auto& p = e.axis[i];
      p.kind = AxisProfile::Kind::kMove;
      double v = c.axes[i].max_rate_dps * kDeg, a = c.axes[i].max_accel_dps2 * kDeg;
      double ad = std::fabs(d[i]);
      p.acc = d[i] >= 0 ? a : -a;
      if (ad >= v * v / a) {
        p.t_acc = v / a;
        p.t_const = (ad - v * v / a) / v;
      } else {
        p.t_acc = std::sqrt(ad / a);
        p.t_const = 0;
      }
    }
    finish();
  }
  void hold(double dur, bool is_seg, const std::string& kind, const std::string& label) {
    if (dur <= 0) return;
    push(dur, is_seg, kind, label);
    finish();
  }
};

}  // namespace

TableGeometry geometry_from_campaign(const Campaign& c) {
  TableGeometry g;
  g.n_axes = static_cast<int>(c.axes.size());
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    g.axes[i].name = c.axes[i].name;
    g.axes[i].axis_nominal = axis_from_name(c.axes[i].axis);
  }
  g.mount.C_imu_plat =
      rotation_zyx_deg(c.mount_rotation_deg[0], c.mount_rotation_deg[1], c.mount_rotation_deg[2]).transpose();
  g.mount.lever_arm_m = Eigen::Vector3d(c.lever_arm_m[0], c.lever_arm_m[1], c.lever_arm_m[2]);
  return g;
}

void AxisProfile::eval(double tau, double& ang, double& rate, double& accel) const {
  switch (kind) {
    case Kind::kHold:
      ang = a0, rate = 0, accel = 0;
      return;
    case Kind::kMove: {
      const double vs = acc * t_acc;
      if (tau < t_acc) {
        ang = a0 + 0.5 * acc * tau * tau, rate = acc * tau, accel = acc;
      } else if (tau < t_acc + t_const) {
        ang = a0 + 0.5 * acc * t_acc * t_acc + vs * (tau - t_acc), rate = vs, accel = 0;
      } else if (tau < 2 * t_acc + t_const) {
        const double t3 = tau - t_acc - t_const;
        ang = a0 + 0.5 * acc * t_acc * t_acc + vs * t_const + vs * t3 - 0.5 * acc * t3 * t3;
        rate = vs - acc * t3, accel = -acc;
      } else {
        ang = a0 + acc * t_acc * t_acc + vs * t_const, rate = 0, accel = 0;
      }
      return;
    }
    case Kind::kRateChange:
      if (tau < t_acc) {
        ang = a0 + r0 * tau + 0.5 * acc * tau * tau, rate = r0 + acc * tau, accel = acc;
      } else {
        ang = a0 + r0 * t_acc + 0.5 * acc * t_acc * t_acc + r1 * (tau - t_acc), rate = r1, accel = 0;
      }
      return;
    case Kind::kConstRate:
      ang = a0 + r0 * tau, rate = r0, accel = 0;
      return;
    case Kind::kRateRamp:
      ang = a0 + r0 * tau + 0.5 * acc * tau * tau, rate = r0 + acc * tau, accel = acc;
      return;
    case Kind::kSine: {
      const double c = std::cos(omega * tau), s = std::sin(omega * tau);
      ang = a0 - amp * c, rate = amp * omega * s, accel = amp * omega * omega * c;
      return;
    }
  }
}

Timeline build_timeline(const Campaign& c) {
  Builder b(c);
  double sp = c.initial_C;
  using SK = CampaignStep::Kind;
  for (std::size_t p = 0; p < c.phases.size(); ++p) {
    const CampaignPhase& ph = c.phases[p];
    b.phase = static_cast<int>(p);
    const std::string plabel = ph.label.empty() ? ("phase " + std::to_string(p)) : ph.label;
    if (ph.kind == CampaignPhase::Kind::kRamp) {
      b.stop(plabel);
      const double slew = ph.rate_C_per_min / 60.0;
      b.tl.setpoints.push_back(SetpointEvent{b.t, ph.setpoint_C, slew});
      b.hold(std::fabs(ph.setpoint_C - sp) / slew, true, "ramp", plabel + " ramp");
      sp = ph.setpoint_C;
      continue;
    }
    b.stop(plabel);
    const double slew = c.ramp_limit_C_per_min / 60.0;
    b.tl.setpoints.push_back(SetpointEvent{b.t, ph.setpoint_C, slew});
    b.hold(std::fabs(ph.setpoint_C - sp) / slew + ph.soak_s, true, "plateau_soak", plabel + " soak");
    sp = ph.setpoint_C;
    for (const CampaignStep& s : ph.steps) {
      std::array<double, 3> rr{};
      for (int i = 0; i < 3; ++i) rr[i] = s.rate_dps[i] * kDeg;
      switch (s.kind) {
        case SK::kPosition: {
          b.leave_free();
          std::array<double, 3> tgt{};
          for (int i = 0; i < 3; ++i) tgt[i] = s.position_deg[i] * kDeg;
          b.move_to(tgt, true, s.label);
          b.hold(s.settle_s >= 0 ? s.settle_s : c.settle_s, false, "", s.label);
          b.hold(s.dwell_s, true, "position", s.label);
          break;
        }
        case SK::kRate: {
          b.leave_free();
          b.rate_to(rr, s.label);
          auto& e = b.push(s.dwell_s, true, "rate", s.label);
          for (std::size_t i = 0; i < b.n; ++i) {
            e.axis[i].kind = AxisProfile::Kind::kConstRate;
            e.axis[i].r0 = b.rate[i];
          }
          b.finish();
          break;
        }
        case SK::kRampRate: {
          b.leave_free();
          std::array<double, 3> r0{};
          for (int i = 0; i < 3; ++i) r0[i] = s.rate_from_dps[i] * kDeg;
          b.rate_to(r0, s.label);
          auto& e = b.push(s.dwell_s, true, "ramp_rate", s.label);
          for (std::size_t i = 0; i < b.n; ++i) {
            e.axis[i].kind = AxisProfile::Kind::kRateRamp;
            e.axis[i].r0 = b.rate[i];
            e.axis[i].r1 = rr[i];
            e.axis[i].acc = (rr[i] - b.rate[i]) / s.dwell_s;
          }
          b.finish();
          break;
        }
        case SK::kSine: {
          b.leave_free();
          // Oscillate about the current angle: first move to centre − A so the motion starts at rest.
          std::array<double, 3> centre = b.ang, start{};
          for (std::size_t i = 0; i < b.n; ++i) start[i] = centre[i] - s.amplitude_deg[i] * kDeg;
          b.move_to(start, false, s.label);
          auto& e = b.push(s.dwell_s, true, "sine", s.label);
          for (std::size_t i = 0; i < b.n; ++i) {
            e.axis[i].kind = AxisProfile::Kind::kSine;
            e.axis[i].a0 = centre[i];
            e.axis[i].amp = s.amplitude_deg[i] * kDeg;
            e.axis[i].omega = 2 * M_PI * s.frequency_hz[i];
          }
          b.finish();
          break;
        }
        case SK::kSoak:
          b.stop(s.label);
          b.hold(s.dwell_s, true, "soak", s.label);
          break;
        case SK::kPose: {
          if (!b.free) {
            b.stop(s.label);
            // Leave the table from its current nominal attitude.
            TableState st;
            for (std::size_t i = 0; i < b.n; ++i) st.angle_rad[i] = b.ang[i];
            ImuKinematics k = table_kinematics(b.geom, st, Eigen::Vector3d(0, 0, 9.8), Eigen::Vector3d::Zero());
            b.C_ned_imu = k.C_imu_ned.transpose();
            b.free = true;
          }
          Eigen::Matrix3d C1 = rotation_zyx_deg(s.attitude_deg[2], s.attitude_deg[1], s.attitude_deg[0]);
          Eigen::AngleAxisd aa(b.C_ned_imu.transpose() * C1);
          auto& e = b.push(s.move_s, false, "", s.label);
          e.free = true;
          e.has_ref = false;
          e.C0_ned_imu = b.C_ned_imu;
          e.n = aa.axis();
          e.phi = aa.angle();
          e.move_s = s.move_s;
          b.C_ned_imu = C1;
          auto& h = b.push(s.dwell_s, true, "pose", s.label);
          h.free = true;
          h.has_ref = false;
          h.C0_ned_imu = C1;
          b.tl.segments.back().has_ref = false;
          break;
        }
      }
    }
  }
  b.tl.duration_s = b.t;
  if (b.tl.entries.empty()) throw std::invalid_argument("campaign has zero duration");
  return std::move(b.tl);
}

MotionSample sample_motion(const Timeline& tl, double t, std::size_t& cursor) {
  const auto& E = tl.entries;
  t = std::clamp(t, 0.0, tl.duration_s);
  if (cursor >= E.size()) cursor = E.size() - 1;
  while (cursor + 1 < E.size() && t >= E[cursor].t1) ++cursor;
  while (cursor > 0 && t < E[cursor].t0) --cursor;
  const TimelineEntry& e = E[cursor];
  MotionSample m;
  m.entry = &e;
  m.free = e.free;
  const double tau = t - e.t0;
  if (e.free) {
    double s, sd, sdd;
    smooth(tau, e.move_s, s, sd, sdd);
    Eigen::Matrix3d C = e.phi != 0 ? Eigen::Matrix3d(e.C0_ned_imu * exp_so3(e.n, e.phi * s)) : e.C0_ned_imu;
    m.C_imu_ned = C.transpose();
    m.w_nb_imu = e.n * (e.phi * sd);
    m.wdot_nb_imu = e.n * (e.phi * sdd);
  } else {
    for (std::size_t i = 0; i < kMaxTableAxes; ++i)
      e.axis[i].eval(tau, m.table.angle_rad[i], m.table.rate_rad_s[i], m.table.accel_rad_s2[i]);
    m.C_imu_ned.setIdentity();
    m.w_nb_imu.setZero();
    m.wdot_nb_imu.setZero();
  }
  return m;
}

}  // namespace imuforge::physics
