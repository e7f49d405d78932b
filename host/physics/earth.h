// Earth model: WGS-84 constants, Earth rate and normal (plumb-bob) gravity in the local-level frame.
//
// Local-level frame: NED (x north, y east, z down). A level, static IMU therefore reads
// f = (0, 0, −g): specific force points UP with magnitude of local normal gravity.
// Normal gravity g(φ, h) (Somigliana + free-air term) is the PLUMB-BOB gravity: it already contains
// the centripetal acceleration of Earth's rotation. Specific force is f = a_inertial − G = −g + a_rel;
// never subtract ω_ie×(ω_ie×r) again (the RTSim error, 2.3 mg at 35°).
#pragma once

#include <Eigen/Core>

namespace imuforge::physics {

namespace wgs84 {
constexpr double kA_m = 6378137.0;                    // semi-major axis
constexpr double kF = 1.0 / 298.257223563;            // flattening
constexpr double kB_m = kA_m * (1.0 - kF);            // semi-minor axis
constexpr double kE2 = kF * (2.0 - kF);               // first eccentricity squared
constexpr double kOmegaE_rad_s = 7.292115e-5;         // Earth rotation rate
constexpr double kGM_m3_s2 = 3.986004418e14;
constexpr double kGammaE_mps2 = 9.7803253359;         // normal gravity at the equator
constexpr double kGammaP_mps2 = 9.8321849378;         // normal gravity at the poles
}  // namespace wgs84

struct Site {
  double latitude_deg = 45.0;
  double height_m = 0.0;
};

// Normal gravity magnitude (m/s²): Somigliana closed form on the ellipsoid plus the second-order
// free-air correction (NIMA TR8350.2, eq. 4-1 and 4-3).
double normal_gravity_mps2(const Site& s);
// Earth rate in NED: Ω (cos φ, 0, −sin φ).
Eigen::Vector3d earth_rate_ned(const Site& s);
// Gravity vector in NED: (0, 0, +g).
Eigen::Vector3d gravity_ned(const Site& s);

// Geodetic position on the WGS-84 ellipsoid (radians, metres above the ellipsoid).
struct Geodetic {
  double lat_rad = 0, lon_rad = 0, h_m = 0;
};

// Radii of curvature at latitude φ: meridian M = a(1 − e²)/(1 − e² sin²φ)^{3/2} and prime vertical
// (normal) N = a/√(1 − e² sin²φ). Moving north by dφ covers (M + h) dφ; east by dλ, (N + h) cos φ dλ.
struct EarthRadii {
  double meridian_m = 0, normal_m = 0;
};
EarthRadii radii_of_curvature(double lat_rad);
// Transport rate ω_en (the local-level frame turning as it is carried over the ellipsoid), NED:
// (v_E/(N + h), −v_N/(M + h), −v_E tan φ/(N + h)).
Eigen::Vector3d transport_rate_ned(double lat_rad, double h_m, const Eigen::Vector3d& v_ned);

}  // namespace imuforge::physics
