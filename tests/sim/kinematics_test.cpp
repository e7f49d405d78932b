// Frame-chain tests against closed forms and an independent (Coriolis-form) computation.
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "host/physics/earth.h"
#include "host/physics/table.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace sim_kinematics_test {

using namespace imuforge::physics;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kDeg = M_PI / 180.0;

Matrix3d skew(const Vector3d& v) {
  Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}
Vector3d vee(const Matrix3d& S) { return Vector3d(S(2, 1), S(0, 2), S(1, 0)); }

TableGeometry one_axis_z(const Vector3d& lever) {
  TableGeometry g;
  g.n_axes = 1;
  g.axes[0].axis_nominal = Vector3d::UnitZ();
  g.mount.lever_arm_m = lever;
  return g;
}

}  // namespace

TEST(Earth, NormalGravityMatchesPublishedValues) {
  // WGS-84 normal gravity on the ellipsoid: 9.7803253359 (equator), 9.8321849378 (pole); at 45° the
  // Somigliana form with TR8350.2's published k = 0.00193185265241, e² = 0.00669437999013 gives
  // 9.80619776937 m/s².
  EXPECT_NEAR(normal_gravity_mps2(Site{0, 0}), 9.7803253359, 1e-9);
  EXPECT_NEAR(normal_gravity_mps2(Site{90, 0}), 9.8321849378, 1e-9);
  EXPECT_NEAR(normal_gravity_mps2(Site{45, 0}), 9.80619776937, 1e-9);
  // Free-air gradient ≈ −3.086e-6 s⁻² near the surface.
  const double dg = normal_gravity_mps2(Site{45, 1000}) - normal_gravity_mps2(Site{45, 0});
  EXPECT_NEAR(dg, -3.086e-3, 2e-5);
}

TEST(Kinematics, StaticSpecificForceIsLocalGravityPointingUp) {
  for (double lat : {0.0, 35.0, 48.14, -60.0}) {
    const Site site{lat, 250.0};
    const Vector3d g = gravity_ned(site), wie = earth_rate_ned(site);
    TableGeometry geom = one_axis_z(Vector3d::Zero());
    TableState st;
    ImuKinematics k = table_kinematics(geom, st, g, wie);
    const double gmag = normal_gravity_mps2(site);
    // |f| equals local normal gravity: NOT 2.3 mg low (the double-counted centripetal term of RTSim).
    EXPECT_NEAR(k.f_mps2.norm(), gmag, 1e-12 * gmag) << "lat " << lat;
    // Points up (−z in NED) within 1e-9 rad.
    const double ang = std::acos(std::clamp(-k.f_mps2.z() / k.f_mps2.norm(), -1.0, 1.0));
    EXPECT_LT(ang, 1e-9);
    // The gyro reads the Earth rate only.
    EXPECT_NEAR((k.w_rad_s - wie).norm(), 0.0, 1e-18);
  }
  // The RTSim error would be ω²R cos²φ ≈ 2.3 mg at 35°: make sure our check would have caught it.
  const double R = wgs84::kA_m, om = wgs84::kOmegaE_rad_s, phi = 35 * kDeg;
  EXPECT_GT(om * om * R * std::cos(phi) * std::cos(phi) / 9.80665, 2.0e-3);
}

TEST(Kinematics, ConstantRateAboutVertical) {
  const Site site{35.0, 0.0};
  const Vector3d g = gravity_ned(site), wie = earth_rate_ned(site);
  const Vector3d r(0.1, 0.0, 0.0);
  TableGeometry geom = one_axis_z(r);
  const double rate = 60 * kDeg;
  for (double ang : {0.0, 0.7, 2.0}) {
    TableState st;
    st.angle_rad[0] = ang;
    st.rate_rad_s[0] = rate;
    ImuKinematics k = table_kinematics(geom, st, g, wie);
    // Gyro: table rate + Earth rate projected on the rotated platform.
    const Matrix3d C = Eigen::AngleAxisd(ang, Vector3d::UnitZ()).toRotationMatrix().transpose();
    const Vector3d expect_w = C * wie + Vector3d(0, 0, rate);
    EXPECT_NEAR((k.w_rad_s - expect_w).norm(), 0.0, 1e-15);
    // Accelerometer: gravity up plus the centripetal ω²r towards the axis. Closed form with the full
    // inertial rate ω (table + Earth) and ω̇ = −ω_table × (C ω_ie) (the Earth rate turns in the platform).
    const Vector3d wd = -Vector3d(0, 0, rate).cross(C * wie);
    const Vector3d f_exp = -(C * g) + wd.cross(r) + expect_w.cross(expect_w.cross(r));
    EXPECT_LT((k.f_mps2 - f_exp).norm(), 1e-12);
    // and the textbook value −ω²r (table rate only) to within the Earth-rate correction (~1e-4 relative).
    EXPECT_NEAR(k.f_mps2.x(), -rate * rate * r.x(), 2e-4 * rate * rate * r.x());
    EXPECT_NEAR(k.f_mps2.y(), 0.0, 1e-5);
    EXPECT_NEAR(k.f_mps2.z(), -normal_gravity_mps2(site), 2e-5);  // Coriolis-like Ω·ω·r terms ~1e-5
  }
}

// Independent computation for a two-axis table: attitude as a product of rotations, body rate from
// Cᵀ Ċ, and specific force in the Earth-fixed (rotating) frame with explicit Coriolis and centripetal
// terms: a_i = r̈ + 2Ω×ṙ + Ω×(Ω×r), f = a_i − G = −g + r̈ + 2Ω×ṙ (the Ω×(Ω×r) of the centre is in g;
// the lever's own Ω×(Ω×r) is kept).
TEST(Kinematics, TwoAxisAgreesWithIndependentComputation) {
  const Site site{48.14, 520.0};
  const Vector3d g = gravity_ned(site), W = earth_rate_ned(site);
  TableGeometry geom;
  geom.n_axes = 2;
  geom.axes[0].axis_nominal = Vector3d::UnitZ();  // inner
  geom.axes[1].axis_nominal = Vector3d::UnitX();  // outer
  geom.mount.C_imu_plat = rotation_zyx_deg(30, -10, 5).transpose();
  geom.mount.lever_arm_m = Vector3d(0.05, -0.03, 0.12);
  TableState st;
  st.angle_rad = {0.4, -1.1, 0};
  st.rate_rad_s = {2.0, -0.7, 0};
  st.accel_rad_s2 = {1.5, 0.8, 0};
  ImuKinematics k = table_kinematics(geom, st, g, W);

  const Vector3d ai = Vector3d::UnitZ(), ao = Vector3d::UnitX();
  const double ti = st.angle_rad[0], to = st.angle_rad[1];
  const double di = st.rate_rad_s[0], d_o = st.rate_rad_s[1];
  const double ddi = st.accel_rad_s2[0], ddo = st.accel_rad_s2[1];
  const Matrix3d Ro = Eigen::AngleAxisd(to, ao).toRotationMatrix(), Ri = Eigen::AngleAxisd(ti, ai).toRotationMatrix();
  const Matrix3d Ai = skew(ai), Ao = skew(ao);
  const Matrix3d C = Ro * Ri;  // C_ned←plat
  const Matrix3d Cd = d_o * Ao * Ro * Ri + di * Ro * Ai * Ri;
  const Matrix3d Cdd = ddo * Ao * Ro * Ri + d_o * d_o * Ao * Ao * Ro * Ri + 2 * d_o * di * Ao * Ro * Ai * Ri +
                       ddi * Ro * Ai * Ri + di * di * Ro * Ai * Ai * Ri;
  const Vector3d r = geom.mount.lever_arm_m;
  const Matrix3d Cip = geom.mount.C_imu_plat;
  const Vector3d w_plat = vee(C.transpose() * Cd) + C.transpose() * W;
  const Vector3d f_ned = -g + Cdd * r + 2 * W.cross(Cd * r) + W.cross(W.cross(C * r));
  const Vector3d f_plat = C.transpose() * f_ned;
  const Vector3d w_exp = Cip * w_plat, f_exp = Cip * f_plat;
  EXPECT_LT((k.w_rad_s - w_exp).norm(), 1e-9 * w_exp.norm());
  EXPECT_LT((k.f_mps2 - f_exp).norm(), 1e-9 * f_exp.norm());
  EXPECT_LT((k.C_imu_ned - Cip * C.transpose()).norm(), 1e-12);
}

TEST(Kinematics, AxisErrorsAndMountErrorMoveTheReadings) {
  const Site site{45, 0};
  const Vector3d g = gravity_ned(site), wie = earth_rate_ned(site);
  TableGeometry geom = one_axis_z(Vector3d::Zero());
  TableState st;
  st.rate_rad_s[0] = 1.0;
  ImuKinematics k0 = table_kinematics(geom, st, g, wie);
  geom.axes[0].error.tilt_a_rad = 1e-3;  // axis z tilted towards x
  ImuKinematics k1 = table_kinematics(geom, st, g, wie);
  EXPECT_NEAR(k1.w_rad_s.x() - k0.w_rad_s.x(), 1e-3, 1e-6);
  geom.axes[0].error = AxisError{};
  geom.axes[0].error.zero_rad = 0.01;
  st.rate_rad_s[0] = 0;
  ImuKinematics k2 = table_kinematics(geom, st, g, wie);
  const Vector3d wie_rot = Eigen::AngleAxisd(0.01, Vector3d::UnitZ()).toRotationMatrix().transpose() * wie;
  EXPECT_LT((k2.w_rad_s - wie_rot).norm(), 1e-15);
  EXPECT_EQ(geom.nominal().axes[0].error.zero_rad, 0.0);
}
}  // namespace sim_kinematics_test
