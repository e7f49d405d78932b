#include "host/physics/table.h"

#include <cmath>
#include <stdexcept>

namespace imuforge::physics {

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

namespace {
// Plain 3×3 helpers: this function runs several times per sample, and Eigen's generic assignment
// loops for fixed 3×3 products were not inlined at -O2 (60 % of the simulator's time).
struct M3 {
  double m[3][3];
};
struct V3 {
  double v[3];
};
inline V3 mul(const M3& A, const V3& x) {
  V3 y;
  for (int i = 0; i < 3; ++i) y.v[i] = A.m[i][0] * x.v[0] + A.m[i][1] * x.v[1] + A.m[i][2] * x.v[2];
  return y;
}
inline M3 mul(const M3& A, const M3& B) {
  M3 C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C.m[i][j] = A.m[i][0] * B.m[0][j] + A.m[i][1] * B.m[1][j] + A.m[i][2] * B.m[2][j];
  return C;
}
inline V3 cross(const V3& a, const V3& b) {
  return V3{{a.v[1] * b.v[2] - a.v[2] * b.v[1], a.v[2] * b.v[0] - a.v[0] * b.v[2], a.v[0] * b.v[1] - a.v[1] * b.v[0]}};
}
inline V3 from(const Eigen::Vector3d& e) { return V3{{e.x(), e.y(), e.z()}}; }
inline M3 from(const Eigen::Matrix3d& e) {
  M3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = e(i, j);
  return r;
}
inline Eigen::Vector3d to(const V3& v) { return Eigen::Vector3d(v.v[0], v.v[1], v.v[2]); }
}  // namespace

ImuKinematics table_kinematics(const PreparedTable& P, const TableState& st, const Eigen::Vector3d& g_ned,
                               const Eigen::Vector3d& wie_ned) {
  // Walk from the base (outermost axis) in to the platform, carrying the attitude C_child←base, the
  // table-relative rate w (child frame) and its child-frame derivative wd.
  M3 C = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};  // C_frame←ned
  V3 w = {{0, 0, 0}}, wd = {{0, 0, 0}};
  for (int i = P.n_axes - 1; i >= 0; --i) {
    const std::size_t u = static_cast<std::size_t>(i);
    const V3 a = from(P.a[u]);
    const double th = st.angle_rad[u] + P.zero_rad[u];
    const double thd = st.rate_rad_s[u];
    const double thdd = st.accel_rad_s2[u];
    // Rodrigues, transposed (child←parent): Rᵀ = I − s[a×] + (1 − c)[a×]².
    const double c = std::cos(th), s = std::sin(th);
    M3 Rt;
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) Rt.m[r][q] = (r == q ? 1.0 : 0.0) - s * P.S[u](r, q) + (1.0 - c) * P.S2[u](r, q);
    const V3 wp = mul(Rt, w);
    // d/dt(Rᵀ) = −θ̇ [a×] Rᵀ (R leaves a invariant).
    const V3 awp = cross(a, wp);
    const V3 Rwd = mul(Rt, wd);
    for (int k = 0; k < 3; ++k) {
      wd.v[k] = -thd * awp.v[k] + Rwd.v[k] + thdd * a.v[k];
      w.v[k] = wp.v[k] + thd * a.v[k];
    }
    C = mul(Rt, C);
  }
  const M3 Cip = from(P.C_imu_plat);
  // Inertial rate of the platform: Earth rate (constant in the Earth-fixed base) plus the table rate.
  const V3 wie_p = mul(C, from(wie_ned));
  V3 w_ib, wd_ib;
  const V3 wxe = cross(w, wie_p);
  for (int k = 0; k < 3; ++k) {
    w_ib.v[k] = wie_p.v[k] + w.v[k];
    // Body-frame derivative of C·ω_ie: −ω_table × (C ω_ie). Same as the inertial derivative of ω_ib.
    wd_ib.v[k] = -wxe.v[k] + wd.v[k];
  }
  const V3 r = from(P.lever_arm_m);
  // f = −g (plumb-bob: Earth's centripetal term already inside g) + rigid-body lever-arm acceleration.
  const V3 Cg = mul(C, from(g_ned));
  const V3 t1 = cross(wd_ib, r), t2 = cross(w_ib, cross(w_ib, r));
  V3 f_p;
  for (int k = 0; k < 3; ++k) f_p.v[k] = -Cg.v[k] + t1.v[k] + t2.v[k];
  ImuKinematics k;
  k.f_mps2 = to(mul(Cip, f_p));
  k.w_rad_s = to(mul(Cip, w_ib));
  k.wdot_rad_s2 = to(mul(Cip, wd_ib));
  const M3 Cin = mul(Cip, C);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) k.C_imu_ned(i, j) = Cin.m[i][j];
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

std::string axis_error_name(int axis, int part) {
  static const char* kPart[3] = {"tilt_a", "tilt_b", "zero"};
  return "fixture.axis" + std::to_string(axis) + "." + kPart[part < 0 || part > 2 ? 2 : part];
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

}  // namespace imuforge::physics
