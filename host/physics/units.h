// Angle units shared by the host (one definition, so unity builds and readers see one constant).
#pragma once

namespace imuforge::physics {

// Radians per degree.
inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

}  // namespace imuforge::physics
