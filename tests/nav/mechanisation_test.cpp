// The strapdown mechanisation against closed forms (docs/navigation.md § checks). The inputs are direct
// synthetic increments, not the vehicle simulator, so the checks do not lean on the code they test.
#include <cmath>
#include <functional>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "host/nav/strapdown.h"
#include "host/physics/earth.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace nav_mechanisation_test {

using namespace imuforge;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using nav::Geodetic;

namespace {

constexpr double kDeg = M_PI / 180.0;

Vector3d earth_rate(double lat_rad) { return physics::earth_rate_ned(physics::Site{lat_rad / kDeg, 0.0}); }

// Stationary, level, body = NED, at latitude lat: true f_b = −g, ω_b = ω_ie; plus the given sensor
// errors. Runs `seconds` at dt with the height held (the vertical channel is unstable by nature) and calls
// `probe(t, state)` after every step.
void run_stationary(double lat_rad, const Vector3d& accel_bias, const Vector3d& gyro_bias, double seconds, double dt,
                    const std::function<void(double, const nav::NavState&)>& probe) {
  nav::NavState s0;
  s0.pos = Geodetic{lat_rad, 0.0, 0.0};
  nav::Strapdown nav(s0);
  const double g = physics::normal_gravity_mps2(physics::Site{lat_rad / kDeg, 0.0});
  nav::Increment in;
  in.dt_s = dt;
  in.dtheta_rad = (earth_rate(lat_rad) + gyro_bias) * dt;
  in.dv_mps = (Vector3d(0, 0, -g) + accel_bias) * dt;
  const long n = std::lround(seconds / dt);
  for (long k = 1; k <= n; ++k) {
    nav.update(in);
    nav.hold_height(0.0, 0.0);
    probe(static_cast<double>(k) * dt, nav.state());
  }
}

double schuler_rad_s(double lat_rad) {
  const physics::EarthRadii r = physics::radii_of_curvature(lat_rad);
  return std::sqrt(physics::normal_gravity_mps2(physics::Site{lat_rad / kDeg, 0.0}) / r.meridian_m);
}

}  // namespace

TEST(Earth, RadiiOfCurvatureMatchPublishedValues) {
  // WGS-84 at 45°: meridian radius 6 367 381.816 m, prime vertical 6 388 838.290 m (a/√(1−e² sin²φ)).
  const physics::EarthRadii r45 = physics::radii_of_curvature(45 * kDeg);
  EXPECT_NEAR(r45.meridian_m, 6367381.816, 1e-2);
  EXPECT_NEAR(r45.normal_m, 6388838.290, 1e-2);
  const physics::EarthRadii r0 = physics::radii_of_curvature(0.0);
  EXPECT_NEAR(r0.normal_m, 6378137.0, 1e-6);
  EXPECT_NEAR(r0.meridian_m, 6335439.327, 1e-2);  // a(1 − e²)
}

TEST(Mechanisation, StationaryWithoutErrorsStaysPut) {
  double worst_m = 0, worst_v = 0, worst_att = 0;
  run_stationary(45 * kDeg, Vector3d::Zero(), Vector3d::Zero(), 3600, 0.05, [&](double, const nav::NavState& s) {
    worst_m = std::max(worst_m, nav::horizontal_offset_m(s.pos, Geodetic{45 * kDeg, 0, 0}).norm());
    worst_v = std::max(worst_v, s.v_ned.norm());
    worst_att = std::max(worst_att, nav::attitude_error_ned(s.q_nb, Quaterniond::Identity()).norm());
  });
  EXPECT_LT(worst_m, 1e-4);
  EXPECT_LT(worst_v, 1e-7);
  EXPECT_LT(worst_att, 1e-10);
}

// δp_N(t) = b/ω_s² (1 − cos ω_s t), δv_N = (b/ω_s) sin ω_s t: the Schuler loop. At the equator the
// Earth-rate coupling of the north channel vanishes to first order (Foucault term Ω sin φ = 0), so the
// closed form holds to O(Ω²/ω_s²) ≈ 0.4 %.
TEST(Mechanisation, AccelBiasGivesTheSchulerOscillation) {
  const double b = 1e-3;  // m/s², north accelerometer (≈ 0.1 mg)
  const double ws = schuler_rad_s(0.0);
  const double period_min = 2 * M_PI / ws / 60.0;
  EXPECT_NEAR(period_min, 84.4, 0.2);  // the textbook figure (2π√(R/g))
  double prev_v = 0, first_zero_s = -1, peak_n = 0, peak_t = 0, worst_dev = 0;
  const double amp = b / (ws * ws);
  run_stationary(0.0, Vector3d(b, 0, 0), Vector3d::Zero(), 1.2 * 2 * M_PI / ws, 0.1, [&](double t, const nav::NavState& s) {
    const double n = nav::horizontal_offset_m(s.pos, Geodetic{0, 0, 0}).x();
    const double v = s.v_ned.x();
    if (n > peak_n) {
      peak_n = n;
      peak_t = t;
    }
    if (first_zero_s < 0 && prev_v > 0 && v <= 0) first_zero_s = t;  // δv_N = 0 at half a period
    prev_v = v;
    worst_dev = std::max(worst_dev, std::abs(n - amp * (1 - std::cos(ws * t))));
  });
  const double T = 2 * M_PI / ws;
  EXPECT_NEAR(first_zero_s, T / 2, 0.005 * T);
  EXPECT_NEAR(peak_t, T / 2, 0.005 * T);
  EXPECT_NEAR(peak_n, 2 * amp, 0.01 * 2 * amp) << "amplitude b/ω_s² = " << amp << " m";
  EXPECT_LT(worst_dev, 0.01 * 2 * amp);
  EXPECT_GT(amp, 600.0);  // the test is not vacuous: ~640 m
}

// East gyro bias ε: tilt φ_E = −(ε/ω_s) sin ω_s t (bounded), δv_N = −R ε (1 − cos ω_s t),
// δp_N = −R ε (t − sin(ω_s t)/ω_s) (unbounded). Down gyro bias: heading error ε t.
TEST(Mechanisation, GyroBiasGivesTheExpectedAttitudeAndPositionGrowth) {
  const double eps = 1e-6;  // rad/s ≈ 0.2 °/h
  const double ws = schuler_rad_s(0.0);
  const double R = physics::radii_of_curvature(0.0).meridian_m;
  double worst_pos = 0, worst_att = 0, n_end = 0, att_peak = 0;
  const double T = 1.0 * 3600;
  run_stationary(0.0, Vector3d::Zero(), Vector3d(0, eps, 0), T, 0.1, [&](double t, const nav::NavState& s) {
    const double n = nav::horizontal_offset_m(s.pos, Geodetic{0, 0, 0}).x();
    const double n_cf = -R * eps * (t - std::sin(ws * t) / ws);
    const double att = nav::attitude_error_ned(s.q_nb, Quaterniond::Identity()).y();
    const double att_cf = -(eps / ws) * std::sin(ws * t);  // computed frame tilted about east
    worst_pos = std::max(worst_pos, std::abs(n - n_cf));
    worst_att = std::max(worst_att, std::abs(att + att_cf));
    att_peak = std::max(att_peak, std::abs(att));
    n_end = n;
  });
  const double n_end_cf = -R * eps * (T - std::sin(ws * T) / ws);
  EXPECT_NEAR(n_end, n_end_cf, 0.01 * std::abs(n_end_cf)) << "closed form " << n_end_cf << " m";
  EXPECT_LT(worst_pos, 0.01 * std::abs(n_end_cf));
  EXPECT_NEAR(att_peak, eps / ws, 0.02 * eps / ws);
  EXPECT_LT(worst_att, 0.02 * eps / ws);

  // Heading: a down-axis gyro bias turns the computed frame about the vertical at ε.
  double heading_end = 0;
  run_stationary(0.0, Vector3d::Zero(), Vector3d(0, 0, eps * 10), 600, 0.1,
                 [&](double, const nav::NavState& s) { heading_end = nav::heading_rad(s.q_nb); });
  EXPECT_NEAR(heading_end, eps * 10 * 600, 0.01 * eps * 10 * 600);
}

namespace {

// Constant velocity v_ned at constant height with the body level and heading along the track. Truth
// rate ω_ib = C_bn (ω_ie + ω_en), specific force f = C_bn ((2ω_ie + ω_en) × v − g), evaluated along the
// truth path `lat_of_t`. Increments by the trapezoid over sub-steps. Returns the final navigator state.
nav::NavState fly(double lat0, double h, const Vector3d& v, double heading, double seconds, double dt,
                  const std::function<double(double)>& lat_of_t) {
  const Quaterniond q(Eigen::AngleAxisd(heading, Vector3d::UnitZ()));
  const Eigen::Matrix3d C_bn = q.toRotationMatrix().transpose();
  auto rates = [&](double t, Vector3d& f, Vector3d& w) {
    const double lat = lat_of_t(t);
    const physics::Site site{lat / kDeg, h};
    const Vector3d wie = physics::earth_rate_ned(site);
    const Vector3d wen = physics::transport_rate_ned(lat, h, v);
    f = C_bn * ((2 * wie + wen).cross(v) - physics::gravity_ned(site));
    w = C_bn * (wie + wen);
  };
  nav::NavState s0;
  s0.q_nb = q;
  s0.v_ned = v;
  s0.pos = Geodetic{lat0, 0.0, h};
  nav::Strapdown nav(s0);
  const long n = std::lround(seconds / dt);
  Vector3d f0, w0, f1, w1;
  rates(0, f0, w0);
  for (long k = 1; k <= n; ++k) {
    const double t = static_cast<double>(k) * dt;
    rates(t, f1, w1);
    nav::Increment in;
    in.dt_s = dt;
    in.dtheta_rad = 0.5 * (w0 + w1) * dt;
    in.dv_mps = 0.5 * (f0 + f1) * dt;
    nav.update(in);
    f0 = f1;
    w0 = w1;
  }
  return nav.state();
}

}  // namespace

// Along a parallel the latitude stays put and the longitude grows at v_E / ((N + h) cos φ): a closed
// form. Without the transport rate (ω_en) the attitude would turn away at v/R ≈ 3e-5 rad/s and the
// position would be kilometres off.
TEST(Mechanisation, ConstantVelocityAlongAParallelIsExact) {
  const double lat = 45 * kDeg, h = 1000, ve = 200, T = 600;
  const nav::NavState s = fly(lat, h, Vector3d(0, ve, 0), M_PI / 2, T, 0.01, [&](double) { return lat; });
  const double N = physics::radii_of_curvature(lat).normal_m;
  const Geodetic truth{lat, ve * T / ((N + h) * std::cos(lat)), h};
  const Eigen::Vector2d err = nav::horizontal_offset_m(s.pos, truth);
  EXPECT_LT(err.norm(), 1e-5) << "north " << err.x() << " east " << err.y() << " m after " << ve * T / 1000 << " km";
  EXPECT_LT(std::abs(s.pos.h_m - h), 1e-4);
  EXPECT_LT((s.v_ned - Vector3d(0, ve, 0)).norm(), 1e-5);
  EXPECT_LT(nav::attitude_error_ned(s.q_nb, Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()))).norm(), 1e-9);
}

// Along a meridian: ∫(M(φ) + h) dφ = v t, solved here by Newton on a Simpson quadrature of M.
TEST(Mechanisation, ConstantVelocityAlongAMeridianIsExact) {
  const double lat0 = 30 * kDeg, h = 500, vn = 250, T = 600;
  auto arc = [&](double lat) {  // ∫_{lat0}^{lat} (M + h) dφ, Simpson with 64 panels
    const int n = 64;
    const double step = (lat - lat0) / n;
    double s = 0;
    for (int i = 0; i <= n; ++i) {
      const double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
      s += w * (physics::radii_of_curvature(lat0 + i * step).meridian_m + h);
    }
    return s * step / 3;
  };
  auto lat_of_t = [&](double t) {
    double lat = lat0 + vn * t / (physics::radii_of_curvature(lat0).meridian_m + h);
    for (int it = 0; it < 3; ++it) lat -= (arc(lat) - vn * t) / (physics::radii_of_curvature(lat).meridian_m + h);
    return lat;
  };
  // The truth path is needed at every sub-step: tabulate it once (latitude is smooth; cubic error tiny).
  const double dt = 0.01;
  std::vector<double> tab;
  for (double t = 0; t <= T + 1; t += 1.0) tab.push_back(lat_of_t(t));
  auto lat_interp = [&](double t) {
    const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(t), tab.size() - 4);
    const double u = t - static_cast<double>(i);
    // Cubic through i, i+1, i+2, i+3 at u ∈ [0, 1] (Lagrange).
    const double p0 = tab[i], p1 = tab[i + 1], p2 = tab[i + 2], p3 = tab[i + 3];
    return p0 * (u - 1) * (u - 2) * (u - 3) / -6 + p1 * u * (u - 2) * (u - 3) / 2 + p2 * u * (u - 1) * (u - 3) / -2 +
           p3 * u * (u - 1) * (u - 2) / 6;
  };
  const nav::NavState s = fly(lat0, h, Vector3d(vn, 0, 0), 0.0, T, dt, lat_interp);
  const Geodetic truth{lat_of_t(T), 0.0, h};
  const Eigen::Vector2d err = nav::horizontal_offset_m(s.pos, truth);
  EXPECT_LT(err.norm(), 1e-5) << "north " << err.x() << " east " << err.y() << " m after " << vn * T / 1000 << " km";
  EXPECT_LT(std::abs(s.pos.h_m - h), 1e-4);
  EXPECT_LT((s.v_ned - Vector3d(vn, 0, 0)).norm(), 1e-5);
  EXPECT_LT(nav::attitude_error_ned(s.q_nb, Quaterniond::Identity()).norm(), 1e-9);
}
}  // namespace nav_mechanisation_test
