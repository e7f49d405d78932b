#include "host/physics/vehicle.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace imuforge::physics {

namespace {

constexpr double kTwoPi = 2.0 * M_PI;

[[noreturn]] void bad(std::size_t i, const std::string& what) {
  throw std::invalid_argument("segments[" + std::to_string(i) + "]: " + what);
}

// Raised-cosine step of total `delta` over T: value and rate at τ (rate (δ/T)(1 − cos 2πτ/T), zero at
// both ends, so the derivative of what it drives is continuous).
void raised_step(double delta, double T, double tau, double& val, double& rate) {
  const double x = tau / T;
  val = delta * (x - std::sin(kTwoPi * x) / kTwoPi);
  rate = delta / T * (1.0 - std::cos(kTwoPi * x));
}

// Turn-rate profile: ramp up over Tr (raised half-cosine), hold r over Tm, ramp down over Tr.
// Returns the heading change since the start of the turn and the rate at τ.
void turn_profile(double r, double Tr, double Tm, double tau, double& dpsi, double& rate) {
  auto ramp_int = [&](double u) { return Tr > 0 ? u / 2 - Tr / (2 * M_PI) * std::sin(M_PI * u / Tr) : 0.0; };
  if (tau < Tr) {
    rate = r * 0.5 * (1 - std::cos(M_PI * tau / Tr));
    dpsi = r * ramp_int(tau);
  } else if (tau < Tr + Tm) {
    rate = r;
    dpsi = r * (Tr / 2 + (tau - Tr));
  } else {
    const double u = std::min(tau - Tr - Tm, Tr);  // ramp down: rate r(1 + cos πu/Tr)/2
    rate = Tr > 0 ? r * 0.5 * (1 + std::cos(M_PI * u / Tr)) : 0.0;
    dpsi = r * (Tr / 2 + Tm + (Tr > 0 ? u / 2 + Tr / (2 * M_PI) * std::sin(M_PI * u / Tr) : 0.0));
  }
}

}  // namespace

VehicleTrajectory::VehicleTrajectory(const VehicleStart& start, std::vector<VehicleSegment> segments)
    : start_(start), seg_(std::move(segments)) {
  if (!(std::abs(start_.latitude_deg) < 89.0)) throw std::invalid_argument("start.latitude_deg: must be within ±89°");
  if (seg_.empty()) throw std::invalid_argument("segments: at least one segment");
  double t = 0, s = 0, psi = start_.heading_deg * M_PI / 180.0;
  for (std::size_t i = 0; i < seg_.size(); ++i) {
    VehicleSegment& g = seg_[i];
    s0_.push_back(s);
    psi0_.push_back(psi);
    switch (g.kind) {
      case VehicleSegment::Kind::kStand:
        if (s != 0) bad(i, "stand at non-zero speed " + std::to_string(s) + " m/s (decelerate to 0 first)");
        break;
      case VehicleSegment::Kind::kAccelerate:
        if (!(g.speed_to_mps >= 0)) bad(i, "accelerate: speed_to_mps must be >= 0");
        s = g.speed_to_mps;
        break;
      case VehicleSegment::Kind::kCruise:
        break;
      case VehicleSegment::Kind::kTurn: {
        if (!(s > 0)) bad(i, "turn at zero speed (accelerate first)");
        if (!(g.radius_m > 0)) bad(i, "turn: radius_m must be > 0");
        if (!(g.transition_s >= 0)) bad(i, "turn: transition_s must be >= 0");
        if (!(g.angle_rad != 0) || !std::isfinite(g.angle_rad)) bad(i, "turn: angle_deg must be non-zero");
        const double Tm = std::abs(g.angle_rad) * g.radius_m / s - g.transition_s;
        if (Tm < 0) bad(i, "turn: angle too small for the transitions at this radius and speed");
        g.duration_s = Tm + 2 * g.transition_s;
        psi += g.angle_rad;
        break;
      }
      case VehicleSegment::Kind::kClimb:
        if (!(s > 0)) bad(i, "climb at zero speed (accelerate first)");
        if (!(g.duration_s > 0)) bad(i, "climb: duration_s must be > 0");
        if (2 * std::abs(g.height_change_m) / g.duration_s >= 0.9 * s)
          bad(i, "climb: too steep for the speed (peak vertical speed 2·height/duration must stay below 0.9·speed)");
        break;
    }
    if (!(g.duration_s > 0) || !std::isfinite(g.duration_s)) bad(i, "duration_s must be > 0");
    t += g.duration_s;
    t_end_.push_back(t);
  }
}

PathState VehicleTrajectory::path(double t_s) const {
  t_s = std::clamp(t_s, 0.0, duration_s());
  const std::size_t i = std::min<std::size_t>(
      static_cast<std::size_t>(std::upper_bound(t_end_.begin(), t_end_.end(), t_s) - t_end_.begin()), seg_.size() - 1);
  const VehicleSegment& g = seg_[i];
  const double tau = t_s - segment_start_s(i);
  PathState p;
  p.segment = static_cast<int>(i);
  p.speed_mps = s0_[i];
  p.heading_rad = psi0_[i];
  switch (g.kind) {
    case VehicleSegment::Kind::kStand:
    case VehicleSegment::Kind::kCruise:
      break;
    case VehicleSegment::Kind::kAccelerate: {
      double ds, rate;
      raised_step(g.speed_to_mps - s0_[i], g.duration_s, tau, ds, rate);
      p.speed_mps = s0_[i] + ds;
      p.speed_dot = rate;
      break;
    }
    case VehicleSegment::Kind::kTurn: {
      const double r = (g.angle_rad > 0 ? 1.0 : -1.0) * s0_[i] / g.radius_m;
      double dpsi, rate;
      turn_profile(r, g.transition_s, g.duration_s - 2 * g.transition_s, tau, dpsi, rate);
      p.heading_rad += dpsi;
      p.heading_rate = rate;
      break;
    }
    case VehicleSegment::Kind::kClimb: {
      // v_up = (Δh/T)(1 − cos 2πτ/T): a raised-cosine bump whose integral is Δh.
      const double T = g.duration_s, x = tau / T;
      p.vup_mps = g.height_change_m / T * (1 - std::cos(kTwoPi * x));
      p.vup_dot = g.height_change_m / T * kTwoPi / T * std::sin(kTwoPi * x);
      break;
    }
  }
  return p;
}

namespace {

struct Motion {
  Eigen::Vector3d v, vdot, w_nb;  // NED velocity, its rate; ω_nb in body
  Eigen::Matrix3d C_nb;
};

Motion motion(const PathState& p) {
  Motion m;
  const double s = p.speed_mps, vu = p.vup_mps;
  const double sh = std::sqrt(std::max(0.0, s * s - vu * vu));
  const double sh_dot = sh > 0 ? (s * p.speed_dot - vu * p.vup_dot) / sh : p.speed_dot;
  const double cp = std::cos(p.heading_rad), sp = std::sin(p.heading_rad);
  m.v = Eigen::Vector3d(sh * cp, sh * sp, -vu);
  m.vdot = Eigen::Vector3d(sh_dot * cp - sh * sp * p.heading_rate, sh_dot * sp + sh * cp * p.heading_rate, -p.vup_dot);
  const double th = s > 0 ? std::asin(std::clamp(vu / s, -1.0, 1.0)) : 0.0;
  const double th_dot = s > 0 && std::cos(th) > 0 ? (p.vup_dot * s - vu * p.speed_dot) / (s * s * std::cos(th)) : 0.0;
  m.C_nb = (Eigen::AngleAxisd(p.heading_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(th, Eigen::Vector3d::UnitY()))
               .toRotationMatrix();
  m.w_nb = Eigen::Vector3d(-p.heading_rate * std::sin(th), th_dot, p.heading_rate * std::cos(th));
  return m;
}

void sense(const Motion& m, const Geodetic& pos, Eigen::Vector3d& f_b, Eigen::Vector3d& w_b) {
  const Site site{pos.lat_rad * 180.0 / M_PI, pos.h_m};
  const Eigen::Vector3d wie = earth_rate_ned(site);
  const Eigen::Vector3d wen = transport_rate_ned(pos.lat_rad, pos.h_m, m.v);
  const Eigen::Vector3d f_n = m.vdot - gravity_ned(site) + (2.0 * wie + wen).cross(m.v);
  const Eigen::Matrix3d C_bn = m.C_nb.transpose();
  f_b = C_bn * f_n;
  w_b = C_bn * (wie + wen) + m.w_nb;
}

}  // namespace

Eigen::Vector3d geodetic_rate(const Geodetic& pos, const Eigen::Vector3d& v_ned) {
  const EarthRadii r = radii_of_curvature(pos.lat_rad);
  return Eigen::Vector3d(v_ned.x() / (r.meridian_m + pos.h_m),
                         v_ned.y() / ((r.normal_m + pos.h_m) * std::cos(pos.lat_rad)), -v_ned.z());
}

VehicleState vehicle_kinematics(const VehicleTrajectory& tr, double t_s, const Geodetic& pos) {
  const PathState p = tr.path(t_s);
  const Motion m = motion(p);
  VehicleState st;
  st.t_s = t_s;
  st.pos = pos;
  st.v_ned = m.v;
  st.q_nb = Eigen::Quaterniond(m.C_nb);
  st.segment = p.segment;
  sense(m, pos, st.f_b, st.w_b);
  // Central difference of the analytic profiles (position held: its change over 1 ms is immaterial here).
  constexpr double h = 5e-4;
  Eigen::Vector3d fp, wp, fm, wm;
  sense(motion(tr.path(t_s + h)), pos, fp, wp);
  sense(motion(tr.path(t_s - h)), pos, fm, wm);
  const double span = std::min(t_s + h, tr.duration_s()) - std::max(t_s - h, 0.0);
  if (span > 0) {
    st.wdot_b = (wp - wm) / span;
    st.fdot_b = (fp - fm) / span;
  }
  return st;
}

std::vector<VehicleState> sample_vehicle(const VehicleTrajectory& tr, double rate_hz) {
  if (!(rate_hz > 0) || rate_hz > 1e5) throw std::invalid_argument("trajectory sample rate must be in (0, 1e5] Hz");
  const double dt = 1.0 / rate_hz;
  const std::size_t n = static_cast<std::size_t>(std::floor(tr.duration_s() * rate_hz + 1e-9)) + 1;
  std::vector<VehicleState> out;
  out.reserve(n);
  Geodetic pos{tr.start().latitude_deg * M_PI / 180.0, tr.start().longitude_deg * M_PI / 180.0, tr.start().height_m};
  auto vel = [&](double t) { return motion(tr.path(t)).v; };
  auto step = [](const Geodetic& p, const Eigen::Vector3d& d, double k) {
    return Geodetic{p.lat_rad + k * d.x(), p.lon_rad + k * d.y(), p.h_m + k * d.z()};
  };
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    out.push_back(vehicle_kinematics(tr, t, pos));
    // RK4 from t to t + dt.
    const Eigen::Vector3d vm = vel(t + 0.5 * dt);
    const Eigen::Vector3d k1 = geodetic_rate(pos, out.back().v_ned);
    const Eigen::Vector3d k2 = geodetic_rate(step(pos, k1, 0.5 * dt), vm);
    const Eigen::Vector3d k3 = geodetic_rate(step(pos, k2, 0.5 * dt), vm);
    const Eigen::Vector3d k4 = geodetic_rate(step(pos, k3, dt), vel(t + dt));
    pos = step(pos, k1 + 2 * k2 + 2 * k3 + k4, dt / 6.0);
  }
  return out;
}

}  // namespace imuforge::physics
