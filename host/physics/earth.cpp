#include "host/physics/earth.h"

#include <cmath>

namespace imuforge::physics {

double normal_gravity_mps2(const Site& s) {
  using namespace wgs84;
  const double phi = s.latitude_deg * M_PI / 180.0;
  const double sin2 = std::sin(phi) * std::sin(phi);
  // Somigliana: γ = (a γe cos²φ + b γp sin²φ) / sqrt(a² cos²φ + b² sin²φ), written in the usual form
  // γ = γe (1 + k sin²φ) / sqrt(1 − e² sin²φ), k = b γp / (a γe) − 1.
  const double k = (kB_m * kGammaP_mps2) / (kA_m * kGammaE_mps2) - 1.0;
  const double gamma0 = kGammaE_mps2 * (1.0 + k * sin2) / std::sqrt(1.0 - kE2 * sin2);
  // Free-air correction to second order in h (NIMA TR8350.2 eq. 4-3):
  // γh = γ [1 − 2/a (1 + f + m − 2 f sin²φ) h + 3 h²/a²],  m = ω² a² b / GM.
  const double m = kOmegaE_rad_s * kOmegaE_rad_s * kA_m * kA_m * kB_m / kGM_m3_s2;
  const double h = s.height_m;
  return gamma0 * (1.0 - 2.0 / kA_m * (1.0 + kF + m - 2.0 * kF * sin2) * h + 3.0 * h * h / (kA_m * kA_m));
}

Eigen::Vector3d earth_rate_ned(const Site& s) {
  const double phi = s.latitude_deg * M_PI / 180.0;
  return Eigen::Vector3d(wgs84::kOmegaE_rad_s * std::cos(phi), 0.0, -wgs84::kOmegaE_rad_s * std::sin(phi));
}

Eigen::Vector3d gravity_ned(const Site& s) { return Eigen::Vector3d(0.0, 0.0, normal_gravity_mps2(s)); }

EarthRadii radii_of_curvature(double lat_rad) {
  const double s = std::sin(lat_rad);
  const double w2 = 1.0 - wgs84::kE2 * s * s;
  const double w = std::sqrt(w2);
  return EarthRadii{wgs84::kA_m * (1.0 - wgs84::kE2) / (w2 * w), wgs84::kA_m / w};
}

Eigen::Vector3d transport_rate_ned(double lat_rad, double h_m, const Eigen::Vector3d& v_ned) {
  const EarthRadii r = radii_of_curvature(lat_rad);
  const double rn = r.normal_m + h_m;
  return Eigen::Vector3d(v_ned.y() / rn, -v_ned.x() / (r.meridian_m + h_m), -v_ned.y() * std::tan(lat_rad) / rn);
}

}  // namespace imuforge::physics
