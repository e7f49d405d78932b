#include "host/nav/strapdown.h"

#include <cmath>

namespace imuforge::nav {

namespace {

// Quaternion of a rotation vector (exact; series near zero).
Eigen::Quaterniond rotvec_quat(const Eigen::Vector3d& v) {
  const double a2 = v.squaredNorm();
  double c, s;  // cos(a/2), sin(a/2)/a
  if (a2 < 1e-12) {
    c = 1.0 - a2 / 8.0;
    s = 0.5 - a2 / 48.0;
  } else {
    const double a = std::sqrt(a2);
    c = std::cos(0.5 * a);
    s = std::sin(0.5 * a) / a;
  }
  return Eigen::Quaterniond(c, s * v.x(), s * v.y(), s * v.z());
}

}  // namespace

void Strapdown::reset(const NavState& s) {
  s_ = s;
  s_.q_nb.normalize();
  have_prev_in_ = false;
  have_prev_state_ = false;
}

void Strapdown::reset_position_velocity(const Geodetic& pos, const Eigen::Vector3d& v_ned) {
  // Keep the previous-state difference (the extrapolation slope), move both to the new values.
  if (have_prev_state_) {
    prev_pos_ = Geodetic{pos.lat_rad - (s_.pos.lat_rad - prev_pos_.lat_rad), pos.lon_rad - (s_.pos.lon_rad - prev_pos_.lon_rad),
                         pos.h_m - (s_.pos.h_m - prev_pos_.h_m)};
    prev_v_ = v_ned - (s_.v_ned - prev_v_);
  }
  s_.pos = pos;
  s_.v_ned = v_ned;
}

void Strapdown::hold_height(double h_m, double v_down_mps) {
  if (have_prev_state_) {
    prev_pos_.h_m = h_m - (s_.pos.h_m - prev_pos_.h_m);
    prev_v_.z() = v_down_mps - (s_.v_ned.z() - prev_v_.z());
  }
  s_.pos.h_m = h_m;
  s_.v_ned.z() = v_down_mps;
}

void Strapdown::update(const Increment& in) {
  const double dt = in.dt_s;
  // Mid-interval position and velocity, extrapolated from the last two states.
  Geodetic pm = s_.pos;
  Eigen::Vector3d vm = s_.v_ned;
  if (have_prev_state_) {
    pm.lat_rad += 0.5 * (s_.pos.lat_rad - prev_pos_.lat_rad);
    pm.lon_rad += 0.5 * (s_.pos.lon_rad - prev_pos_.lon_rad);
    pm.h_m += 0.5 * (s_.pos.h_m - prev_pos_.h_m);
    vm += 0.5 * (s_.v_ned - prev_v_);
  }
  const physics::Site site{pm.lat_rad * (180.0 / M_PI), pm.h_m};
  const Eigen::Vector3d wie = physics::earth_rate_ned(site);
  const Eigen::Vector3d wen = physics::transport_rate_ned(pm.lat_rad, pm.h_m, vm);
  const Eigen::Vector3d zeta = (wie + wen) * dt;

  // Body-frame corrections: coning (attitude), rotation and sculling (velocity).
  Eigen::Vector3d phi = in.dtheta_rad;
  Eigen::Vector3d dvb = in.dv_mps + 0.5 * in.dtheta_rad.cross(in.dv_mps);
  if (have_prev_in_) {
    phi += prev_in_.dtheta_rad.cross(in.dtheta_rad) / 12.0;
    dvb += (prev_in_.dtheta_rad.cross(in.dv_mps) + prev_in_.dv_mps.cross(in.dtheta_rad)) / 12.0;
  }

  // Velocity: specific-force increment in the mid-interval navigation frame, gravity and Coriolis.
  const Eigen::Vector3d dvn0 = s_.q_nb * dvb;
  const Eigen::Vector3d dvn = dvn0 - 0.5 * zeta.cross(dvn0);
  const Eigen::Vector3d g = physics::gravity_ned(site);
  const Eigen::Vector3d v_new = s_.v_ned + dvn + (g - (2.0 * wie + wen).cross(vm)) * dt;

  // Position: trapezoid of the velocity over the mid-interval radii.
  const Eigen::Vector3d vavg = 0.5 * (s_.v_ned + v_new);
  const physics::EarthRadii r = physics::radii_of_curvature(pm.lat_rad);
  Geodetic p_new;
  p_new.lat_rad = s_.pos.lat_rad + vavg.x() / (r.meridian_m + pm.h_m) * dt;
  p_new.lon_rad = s_.pos.lon_rad + vavg.y() / ((r.normal_m + pm.h_m) * std::cos(pm.lat_rad)) * dt;
  p_new.h_m = s_.pos.h_m - vavg.z() * dt;

  // Attitude: body rotation on the right, navigation-frame rotation on the left.
  Eigen::Quaterniond q = rotvec_quat(-zeta) * s_.q_nb * rotvec_quat(phi);
  q.normalize();

  prev_pos_ = s_.pos;
  prev_v_ = s_.v_ned;
  have_prev_state_ = true;
  prev_in_ = in;
  have_prev_in_ = true;
  s_.q_nb = q;
  s_.v_ned = v_new;
  s_.pos = p_new;
}

double heading_rad(const Eigen::Quaterniond& q_nb) {
  const Eigen::Matrix3d C = q_nb.toRotationMatrix();
  return std::atan2(C(1, 0), C(0, 0));
}

Eigen::Vector3d attitude_error_ned(const Eigen::Quaterniond& est, const Eigen::Quaterniond& truth) {
  const Eigen::AngleAxisd aa(est * truth.conjugate());
  double ang = aa.angle();
  if (ang > M_PI) ang -= 2 * M_PI;
  return ang * aa.axis();
}

Eigen::Vector2d horizontal_offset_m(const Geodetic& a, const Geodetic& b) {
  const physics::EarthRadii r = physics::radii_of_curvature(b.lat_rad);
  double dlon = a.lon_rad - b.lon_rad;
  if (dlon > M_PI) dlon -= 2 * M_PI;
  if (dlon < -M_PI) dlon += 2 * M_PI;
  return Eigen::Vector2d((a.lat_rad - b.lat_rad) * (r.meridian_m + b.h_m), dlon * (r.normal_m + b.h_m) * std::cos(b.lat_rad));
}

}  // namespace imuforge::nav
