// Strapdown inertial navigator: NED mechanisation on the WGS-84 ellipsoid (host/physics/earth.h is the
// Earth model: normal gravity with height, Earth rate, transport rate, radii of curvature).
// Library only: no I/O, no allocation per step. docs/navigation.md has the equations.
//
// State: attitude quaternion q_nb (body → NED), velocity v_n (NED, m/s), geodetic position (lat, lon, h).
// Input: incremental angle Δθ (rad) and velocity Δv (m/s) in the body frame over dt. One update k−1 → k:
//   attitude   φ = Δθ + Δθ_{k−1}×Δθ / 12                                          (coning, two-sample)
//              q_k = q(−ζ) ⊗ q_{k−1} ⊗ q(φ),   ζ = (ω_ie + ω_en)·dt at the mid-interval position/velocity
//   velocity   Δv_b = Δv + Δθ×Δv / 2 + (Δθ_{k−1}×Δv + Δv_{k−1}×Δθ) / 12          (rotation + sculling)
//              v_k = v_{k−1} + (I − [ζ×]/2) C_nb,{k−1} Δv_b + (g − (2ω_ie + ω_en)×v)·dt   (mid-interval terms)
//   position   lat, lon, h by the trapezoid of v_{k−1}, v_k over the mid-interval radii.
// Mid-interval position and velocity are extrapolated from the two previous states (second order).
// The vertical channel is unstable (time constant √(R/2g) ≈ 570 s); hold_height() aids it when needed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "host/physics/earth.h"

namespace imuforge::nav {

using physics::Geodetic;

struct NavState {
  Eigen::Quaterniond q_nb = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_ned = Eigen::Vector3d::Zero();
  Geodetic pos;
};

struct Increment {
  Eigen::Vector3d dtheta_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d dv_mps = Eigen::Vector3d::Zero();
  double dt_s = 0.0;
};

class Strapdown {
 public:
  explicit Strapdown(const NavState& initial) { reset(initial); }

  // Full reset: state and history (the next update has no previous increment for coning/sculling).
  void reset(const NavState& s);
  // One mechanisation step. O(1), no allocation.
  void update(const Increment& in);
  // Aiding by reset: position and velocity set to the given values (attitude untouched). The history
  // used for mid-interval extrapolation is set to the same values, so the next step does not see a jump.
  void reset_position_velocity(const Geodetic& pos, const Eigen::Vector3d& v_ned);
  void reset_attitude(const Eigen::Quaterniond& q_nb) { s_.q_nb = q_nb.normalized(); }
  // Vertical-channel aiding: height and vertical velocity set (e.g. from a baro or a known height).
  void hold_height(double h_m, double v_down_mps);

  const NavState& state() const { return s_; }

 private:
  NavState s_;
  Geodetic prev_pos_;                // position at the start of the last update
  Eigen::Vector3d prev_v_;           // velocity at the start of the last update
  Increment prev_in_;
  bool have_prev_in_ = false, have_prev_state_ = false;
};

// A rate-output IMU gives samples f(t_k), ω(t_k). The increment over [t_{k−1}, t_k] is the trapezoid of
// two samples (second order). The first sample only primes the integrator.
class SampleIntegrator {
 public:
  // Returns false for the first sample (no increment yet).
  bool push(const Eigen::Vector3d& f_mps2, const Eigen::Vector3d& w_rad_s, double dt_s, Increment& out) {
    const bool ok = have_;
    if (ok) {
      out.dtheta_rad = 0.5 * (w_prev_ + w_rad_s) * dt_s;
      out.dv_mps = 0.5 * (f_prev_ + f_mps2) * dt_s;
      out.dt_s = dt_s;
    }
    f_prev_ = f_mps2;
    w_prev_ = w_rad_s;
    have_ = true;
    return ok;
  }
  void reset() { have_ = false; }

 private:
  Eigen::Vector3d f_prev_ = Eigen::Vector3d::Zero(), w_prev_ = Eigen::Vector3d::Zero();
  bool have_ = false;
};

// Heading (yaw of the ZYX Euler angles) of an attitude, rad in (−π, π].
double heading_rad(const Eigen::Quaterniond& q_nb);
// Small-angle attitude error of `est` against `truth`: rotation vector of C_est C_truthᵀ in NED (rad).
Eigen::Vector3d attitude_error_ned(const Eigen::Quaterniond& est, const Eigen::Quaterniond& truth);
// North and east distance (m) from `b` to `a`, using the radii of curvature at b.
Eigen::Vector2d horizontal_offset_m(const Geodetic& a, const Geodetic& b);

}  // namespace imuforge::nav
