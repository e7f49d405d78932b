// Rate-table geometry and kinematics: from table angles/rates (and their errors) to the specific
// force and angular rate the IMU senses. Used by the simulator (true geometry) AND by the solver's
// fixture+errors mode (nominal geometry + nuisance parameters), so both use one implementation.
//
// Frames: base = local level NED (the table base is level); gimbal frames nested, axis 0 innermost.
// Gimbal i rotates relative to its parent (gimbal i+1, or the base for the outermost) by angle
// θ_i + zero_i about its axis a_i; a_i is the nominal axis tilted by two small angles. The platform
// is the innermost gimbal frame. The IMU case frame relates to the platform by the mount rotation
// C_imu←plat (nominal × small error rotation) and sits at lever arm r (platform frame, m) from the
// rotation centre (the intersection of the axes).
//   ω_ib = ω_ie (rotated into the platform) + table rate;   f = −g + ω̇_ib×r + ω_ib×(ω_ib×r)
// expressed in the IMU frame (exact rigid-body kinematics; g is plumb-bob gravity, see earth.h).
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "host/physics/earth.h"

namespace imuforge::physics {

constexpr int kMaxTableAxes = 3;

// Errors of one table axis (all rad). Names used by the solver as nuisance parameters:
//   fixture.axis<i>.tilt_a, fixture.axis<i>.tilt_b, fixture.axis<i>.zero
// tilt_a / tilt_b rotate the axis towards e_a / e_b, the two nominal directions perpendicular to it
// (for nominal axis x: e_a = y, e_b = z; y: z, x; z: x, y). a = normalize(a_nom + tilt_a e_a + tilt_b e_b).
// zero: the true mechanical angle is θ_reported + zero.
struct AxisError {
  double tilt_a_rad = 0.0;
  double tilt_b_rad = 0.0;
  double zero_rad = 0.0;
  // Component by index, part 0 tilt_a, 1 tilt_b, 2 zero (the nuisance order of the solver and the diagnosis).
  double& part(int p) { return p == 0 ? tilt_a_rad : p == 1 ? tilt_b_rad : zero_rad; }
  double part(int p) const { return p == 0 ? tilt_a_rad : p == 1 ? tilt_b_rad : zero_rad; }
};
// "fixture.axis<i>.tilt_a|tilt_b|zero": the one name of an axis error, as the fixture+errors solver, the simulator's
// truth and the diagnosis report it.
std::string axis_error_name(int axis, int part);

struct TableAxis {
  std::string name;          // e.g. "inner"
  Eigen::Vector3d axis_nominal = Eigen::Vector3d::UnitZ();  // unit vector in the parent frame
  AxisError error;           // used by table_kinematics() (set to zero for the nominal geometry)
};

struct Mount {
  Eigen::Matrix3d C_imu_plat = Eigen::Matrix3d::Identity();  // nominal mount: v_imu = C v_plat
  Eigen::Vector3d rot_error_rad = Eigen::Vector3d::Zero();   // small rotation: C_true = C·Exp(err×)
  Eigen::Vector3d lever_arm_m = Eigen::Vector3d::Zero();     // IMU reference point from centre, platform
};

struct TableGeometry {
  int n_axes = 1;
  std::array<TableAxis, kMaxTableAxes> axes{};
  Mount mount;
  // Copy with every error (axis tilts, zeros, mount error) zeroed.
  TableGeometry nominal() const;
};

// Per-axis motion state (angle as reported or true, depending on the caller), rad, rad/s, rad/s².
struct TableState {
  std::array<double, kMaxTableAxes> angle_rad{};
  std::array<double, kMaxTableAxes> rate_rad_s{};
  std::array<double, kMaxTableAxes> accel_rad_s2{};
};

struct ImuKinematics {
  Eigen::Vector3d f_mps2;        // specific force at the IMU reference point, IMU frame
  Eigen::Vector3d w_rad_s;       // ω_ib, IMU frame
  Eigen::Vector3d wdot_rad_s2;   // dω_ib/dt, IMU frame
  Eigen::Matrix3d C_imu_ned;     // attitude: v_imu = C v_ned
};

// The kinematics, with the errors stored in geom. g_ned = gravity_ned(site), wie_ned = earth_rate_ned(site)
// are passed in so per-sample calls do no trigonometry on the site. O(n_axes), no allocation.
ImuKinematics table_kinematics(const TableGeometry& geom, const TableState& st,
                               const Eigen::Vector3d& g_ned, const Eigen::Vector3d& wie_ned);

// The same with the geometry's constant parts (tilted axes, their skew matrices, the mount matrix)
// precomputed: build once per geometry, call per sample (what the simulator does; ~3× faster).
struct PreparedTable {
  int n_axes = 0;
  std::array<Eigen::Vector3d, kMaxTableAxes> a;      // true (tilted, normalised) axes
  std::array<Eigen::Matrix3d, kMaxTableAxes> S, S2;  // [a×], [a×]²
  std::array<double, kMaxTableAxes> zero_rad{};
  Eigen::Matrix3d C_imu_plat;                         // nominal mount × error rotation
  Eigen::Vector3d lever_arm_m;
  explicit PreparedTable(const TableGeometry& g);
};
ImuKinematics table_kinematics(const PreparedTable& geom, const TableState& st, const Eigen::Vector3d& g_ned,
                               const Eigen::Vector3d& wie_ned);

// Attitude kinematics for a free (hand-held) IMU: orientation C_imu_ned and body rate/accel
// given directly; lever arm ignored. f = C(−g) ... + nothing else (the hand's translation is not modelled).
ImuKinematics free_kinematics(const Eigen::Matrix3d& C_imu_ned, const Eigen::Vector3d& w_nb_imu,
                              const Eigen::Vector3d& wdot_nb_imu, const Eigen::Vector3d& g_ned,
                              const Eigen::Vector3d& wie_ned);

// Nominal axis from a name "x", "y", "z", "-x", ... (throws std::invalid_argument).
Eigen::Vector3d axis_from_name(const std::string& name);
// Rotation matrix from ZYX Euler angles (yaw, pitch, roll), deg: C_parent_child = Rz Ry Rx.
Eigen::Matrix3d rotation_zyx_deg(double yaw_deg, double pitch_deg, double roll_deg);

}  // namespace imuforge::physics
