// Table generators shared by the firmware tests (header-only, no heap).
#pragma once
#include "firmware/table/table.h"
#include "tests/firmware/fwtest.h"

namespace fwtest {

constexpr float kPi = 3.14159265358979f;

// A random but physically plausible table: C = I + small M, bias and g-sensitivity varying with T.
// accel full scale in g and gyro full scale in deg/s select the LSBs for `bits`-bit counts.
inline void make_random_table(imuforge::fw::Table* t, Rng& rng, int n_bp, float accel_fs_g, float gyro_fs_dps,
                              std::uint8_t bits = 16, float g_sens = 2e-3f) {
  using namespace imuforge::fw;
  const float half = static_cast<float>(1ul << (bits - 1u));
  table_init_identity(t, accel_fs_g * 9.80665f / half, gyro_fs_dps * kPi / 180.0f / half, bits, bits);
  t->device_serial = 0x1234567890ull;
  t->table_sequence = 7;
  t->created_unix_s = 1790000000;
  t->n_breakpoints = static_cast<std::uint8_t>(n_bp);
  t->model_flags = kModelAccelMatrix | kModelAccelBias | kModelGyroMatrix | kModelGyroBias | kModelGyroGSens |
                   (n_bp > 1 ? kModelTemperature : 0u);
  float T = static_cast<float>(rng.uniform(-45.0, -35.0));
  for (int i = 0; i < n_bp; ++i) {
    t->breakpoints_degC[i] = T;
    T += static_cast<float>(rng.uniform(0.5, 130.0 / n_bp + 1.0));
    BreakpointCoeffs& c = t->coeffs[i];
    for (int m = 0; m < 9; ++m) {
      const float diag = (m % 4 == 0) ? 1.0f : 0.0f;
      c.accel.C[m] = diag + static_cast<float>(rng.uniform(-0.02, 0.02));
      c.gyro.C[m] = diag + static_cast<float>(rng.uniform(-0.02, 0.02));
      c.G[m] = static_cast<float>(rng.uniform(-g_sens, g_sens));
    }
    for (int m = 0; m < 3; ++m) {
      c.accel.b[m] = static_cast<float>(rng.uniform(-0.6, 0.6));
      c.gyro.b[m] = static_cast<float>(rng.uniform(-0.05, 0.05));
    }
  }
}

}  // namespace fwtest
