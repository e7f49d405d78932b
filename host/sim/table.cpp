#include "host/sim/table.h"

#include <cmath>
#include <stdexcept>

namespace imuforge::sim {

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// Rodrigues: rotation by angle about unit axis a (v_parent = R v_child).
Eigen::Matrix3d rot(const Eigen::Vector3d& a, double ang) {
  const double c = std::cos(ang), s = std::sin(ang);
  Eigen::Matrix3d S = skew(a);
  return Eigen::Matrix3d::Identity() + s * S + (1.0 - c) * S * S;
}

// The two nominal directions perpendicular to the nominal axis (x: y, z; y: z, x; z: x, y).
void perp(const Eigen::Vector3d& a, Eigen::Vector3d& ea, Eigen::Vector3d& eb) {
  Eigen::Index i;
  a.cwiseAbs().maxCoeff(&i);
  ea = Eigen::Vector3d::Unit((i + 1) % 3);
  eb = Eigen::Vector3d::Unit((i + 2) % 3);
}

}  // namespace

TableGeometry TableGeometry::nominal() const {
  TableGeometry g = *this;
  for (auto& ax : g.axes) ax.error = AxisError{};
  g.mount.rot_error_rad.setZero();
  return g;
}

PreparedTable::PreparedTable(const TableGeometry& g) : n_axes(g.n_axes) {
  if (n_axes < 0 || n_axes > kMaxTableAxes) throw std::invalid_argument("table: 0..3 axes");
  for (int i = 0; i < kMaxTableAxes; ++i) {
    const TableAxis& ax = g.axes[static_cast<std::size_t>(i)];
    Eigen::Vector3d ea, eb;
    perp(ax.axis_nominal, ea, eb);
    a[static_cast<std::size_t>(i)] = (ax.axis_nominal + ax.error.tilt_a_rad * ea + ax.error.tilt_b_rad * eb).normalized();
    S[static_cast<std::size_t>(i)] = skew(a[static_cast<std::size_t>(i)]);
    S2[static_cast<std::size_t>(i)] = S[static_cast<std::size_t>(i)] * S[static_cast<std::size_t>(i)];
    zero_rad[static_cast<std::size_t>(i)] = ax.error.zero_rad;
  }
  // Platform -> IMU: nominal mount times the small error rotation Exp([e×]).
  const Eigen::Vector3d& e = g.mount.rot_error_rad;
  const double en = e.norm();
  const Eigen::Matrix3d Cerr = en > 0 ? rot(e / en, en) : Eigen::Matrix3d::Identity();
  C_imu_plat = g.mount.C_imu_plat * Cerr;
  lever_arm_m = g.mount.lever_arm_m;
}

ImuKinematics table_kinematics(const TableGeometry& geom, const TableState& st, const Eigen::Vector3d& g_ned,
                               const Eigen::Vector3d& wie_ned) {
  return table_kinematics(PreparedTable(geom), st, g_ned, wie_ned);
}

ImuKinematics table_kinematics(const PreparedTable& P, const TableState& st, const Eigen::Vector3d& g_ned,
                               const Eigen::Vector3d& wie_ned) {
  // Walk from the base (outermost axis) in to the platform, carrying the attitude C_child←base, the
  // table-relative rate w (child frame) and its child-frame derivative wd.
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();  // C_frame←ned
  Eigen::Vector3d w = Eigen::Vector3d::Zero(), wd = Eigen::Vector3d::Zero();
  for (int i = P.n_axes - 1; i >= 0; --i) {
    const std::size_t u = static_cast<std::size_t>(i);
    const Eigen::Vector3d& a = P.a[u];
    const double th = st.angle_rad[u] + P.zero_rad[u];
    const double thd = st.rate_rad_s[u];
    const double thdd = st.accel_rad_s2[u];
    // Rodrigues, transposed (child←parent): Rᵀ = I − s[a×] + (1 − c)[a×]².
    const double c = std::cos(th), s = std::sin(th);
    const Eigen::Matrix3d Rt = Eigen::Matrix3d::Identity() - s * P.S[u] + (1.0 - c) * P.S2[u];
    const Eigen::Vector3d wp = Rt * w;
    // d/dt(Rᵀ) = −θ̇ [a×] Rᵀ (R leaves a invariant).
    wd = -thd * a.cross(wp) + Rt * wd + thdd * a;
    w = wp + thd * a;
    C = Rt * C;
  }
  const Eigen::Matrix3d& Cip = P.C_imu_plat;
  // Inertial rate of the platform: Earth rate (constant in the Earth-fixed base) plus the table rate.
  const Eigen::Vector3d wie_p = C * wie_ned;
  const Eigen::Vector3d w_ib = wie_p + w;
  // Body-frame derivative of C·ω_ie: −ω_table × (C ω_ie). Same as the inertial derivative of ω_ib.
  const Eigen::Vector3d wd_ib = -w.cross(wie_p) + wd;
  const Eigen::Vector3d& r = P.lever_arm_m;
  // f = −g (plumb-bob: Earth's centripetal term already inside g) + rigid-body lever-arm acceleration.
  const Eigen::Vector3d f_p = -(C * g_ned) + wd_ib.cross(r) + w_ib.cross(w_ib.cross(r));
  ImuKinematics k;
  k.f_mps2 = Cip * f_p;
  k.w_rad_s = Cip * w_ib;
  k.wdot_rad_s2 = Cip * wd_ib;
  k.C_imu_ned = Cip * C;
  return k;
}

ImuKinematics free_kinematics(const Eigen::Matrix3d& C_imu_ned, const Eigen::Vector3d& w_nb_imu,
                              const Eigen::Vector3d& wdot_nb_imu, const Eigen::Vector3d& g_ned,
                              const Eigen::Vector3d& wie_ned) {
  ImuKinematics k;
  const Eigen::Vector3d wie_b = C_imu_ned * wie_ned;
  k.C_imu_ned = C_imu_ned;
  k.f_mps2 = -(C_imu_ned * g_ned);
  k.w_rad_s = wie_b + w_nb_imu;
  k.wdot_rad_s2 = -w_nb_imu.cross(wie_b) + wdot_nb_imu;
  return k;
}

Eigen::Vector3d axis_from_name(const std::string& name) {
  double sgn = 1.0;
  std::string n = name;
  if (!n.empty() && (n[0] == '-' || n[0] == '+')) {
    sgn = n[0] == '-' ? -1.0 : 1.0;
    n = n.substr(1);
  }
  if (n == "x") return sgn * Eigen::Vector3d::UnitX();
  if (n == "y") return sgn * Eigen::Vector3d::UnitY();
  if (n == "z") return sgn * Eigen::Vector3d::UnitZ();
  throw std::invalid_argument("axis '" + name + "': expected x, y, z, -x, -y or -z");
}

Eigen::Matrix3d rotation_zyx_deg(double yaw_deg, double pitch_deg, double roll_deg) {
  const double d = M_PI / 180.0;
  return (Eigen::AngleAxisd(yaw_deg * d, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_deg * d, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * d, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace imuforge::sim
