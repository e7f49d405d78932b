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
                   (n_bp > 1 ? static_cast<std::uint32_t>(kModelTemperature) : 0u);
  // Drift rates at the generous end of MEMS data sheets: scale/misalignment 300 ppm/°C, accel bias
  // 5 mg/°C, gyro bias 0.03 °/s/°C; plus a per-breakpoint wiggle so interpolation is not just linear.
  float M0a[9], M1a[9], M0g[9], M1g[9], G0[9], G1[9], b0a[3], b1a[3], b0g[3], b1g[3];
  for (int m = 0; m < 9; ++m) {
    M0a[m] = static_cast<float>(rng.uniform(-0.02, 0.02));
    M0g[m] = static_cast<float>(rng.uniform(-0.02, 0.02));
    M1a[m] = static_cast<float>(rng.uniform(-3e-4, 3e-4));
    M1g[m] = static_cast<float>(rng.uniform(-3e-4, 3e-4));
    G0[m] = static_cast<float>(rng.uniform(-g_sens, g_sens));
    G1[m] = static_cast<float>(rng.uniform(-g_sens, g_sens) * 0.01);
  }
  for (int m = 0; m < 3; ++m) {
    b0a[m] = static_cast<float>(rng.uniform(-0.5, 0.5));
    b1a[m] = static_cast<float>(rng.uniform(-5e-3, 5e-3) * 9.80665);
    b0g[m] = static_cast<float>(rng.uniform(-0.05, 0.05));
    b1g[m] = static_cast<float>(rng.uniform(-5e-4, 5e-4));
  }
  float T = static_cast<float>(rng.uniform(-45.0, -35.0));
  for (int i = 0; i < n_bp; ++i) {
    t->breakpoints_degC[i] = T;
    const float tau = T - 25.0f;
    T += static_cast<float>(rng.uniform(0.5, 130.0 / n_bp + 1.0));
    BreakpointCoeffs& c = t->coeffs[i];
    for (int m = 0; m < 9; ++m) {
      const float diag = (m % 4 == 0) ? 1.0f : 0.0f;
      const float wig = static_cast<float>(rng.uniform(-2e-4, 2e-4));
      c.accel.C[m] = diag + M0a[m] + M1a[m] * tau + wig;
      c.gyro.C[m] = diag + M0g[m] + M1g[m] * tau - wig;
      c.G[m] = G0[m] + G1[m] * tau;
    }
    for (int m = 0; m < 3; ++m) {
      c.accel.b[m] = b0a[m] + b1a[m] * tau + static_cast<float>(rng.uniform(-1e-3, 1e-3));
      c.gyro.b[m] = b0g[m] + b1g[m] * tau + static_cast<float>(rng.uniform(-1e-4, 1e-4));
    }
  }
}

}  // namespace fwtest
