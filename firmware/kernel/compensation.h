// The compensation kernel: raw IMU counts in, calibrated SI values out, no heap, no exceptions.
// Math, Q formats, guard bits and error bounds: docs/kernel.md (this header is the normative summary).
//
//   accel  f = C_a(T) · (raw_a · lsb_a − b_a(T))                                     [m/s²]
//   gyro   w = C_g(T) · (raw_g · lsb_g − b_g(T)) + G(T) · f                           [rad/s]
//
// Coefficients come from a validated coefficient table v1 (firmware/table/table.h) and are interpolated
// linearly in temperature between its breakpoints; outside the range the temperature is clamped and
// kStatusTempClamped is set (never for a one-breakpoint table, which is temperature-independent).
// A NaN temperature counts as below the range. Interpolation is redone only when the temperature moved by MORE than the
// configured step since the last interpolation (|T − T_cached| > step; step 0 = on every change).
// Each re-interpolation folds LSB, C, b and G into one cached affine correction:
//     accel_out = A_a · raw_a + o_a                    (3×3 matrix + offset)
//     gyro_out  = A_g · raw_g + A_ga · raw_a + o_g     (A_ga = G·A_a, o_g includes G·o_a)
// so the per-sample cost is one matrix-vector product plus offset per triad, identical for both paths.
//
// Two arithmetic paths with the same API shape:
//   KernelF32 : float. temperature in °C (float), output float SI (m/s², rad/s).
//   KernelQ   : integer only per sample AND per re-interpolation (the float table is converted once, in
//               kernel_q_load). Temperature input is Q16.16 °C (int32, LSB 2^-16 °C). Output (ImuQ):
//                 accel  int32, LSB 2^-16 m/s²  (Q15.16, range ±32768 m/s²)
//                 gyro   int32, LSB 2^-18 rad/s (Q13.18, range ±8192 rad/s)
//               Per sample: x = clamp(raw) << (r−1) with r = 32 − raw_bits (|x| ≤ 2^30, 1 guard bit);
//               coefficients int32 with |K| < 2^29 (2 guard bits), products summed in int64 with the
//               offset o = 2^(S−1) − Σ K·β (β = bias in shifted counts, |β| ≤ 2^30 because |b| ≤ full
//               scale): |acc| < 2^61 + 6·2^59 + 6·2^59 = 2^63, so no intermediate can overflow.
//               The output is acc >> S with S ≥ 32 (per triad), taken as (high word) >> (S − 32),
//               rounded half up (the ½ is in the offset); it always fits int32, so the per-sample path
//               needs no saturation after the input clamp. kernel_q_load rejects a table whose range
//               would need S < 32 (kKernelFixedRange; e.g. accel full scale ≳ 2^12 m/s²).
//               Accuracy: within 1 output LSB of a double-precision evaluation (tests/firmware).
//
// Inputs: raw counts as int16 (run) or int32 (run32). Counts are clamped to the sensor's raw width
// [−2^(bits−1), 2^(bits−1)−1] from the table; a count at or beyond a limit sets kStatusAccelSaturated /
// kStatusGyroSaturated (for run with bits ≥ 16: the int16 limits −32768 and 32767).
// Without a valid table (after init, or after a failed load) outputs are zero and kStatusNoTable is set.
//
// Instances are plain structs owned by the caller (static storage recommended); no function allocates,
// blocks or touches global state. Not reentrant per instance (run updates the cache).
#pragma once
#include <cstdint>

#include "firmware/table/table.h"

namespace imuforge::fw {

// Output status bits (returned by every run call).
enum KernelStatus : std::uint32_t {
  kStatusOk = 0,
  kStatusTempClamped = 1u << 0,     // temperature outside the table's breakpoints: clamped to the range
  kStatusAccelSaturated = 1u << 1,  // an accel count at or beyond its raw limits (clamped)
  kStatusGyroSaturated = 1u << 2,   // a gyro count at or beyond its raw limits (clamped)
  kStatusNoTable = 1u << 3,         // no valid table loaded: outputs are zero
  kStatusInputSaturated = kStatusAccelSaturated | kStatusGyroSaturated,
};

// Stable error codes (block -200..-299). Never renumber.
enum KernelError : int {
  kKernelNullArgument = -200,  // a required pointer is null
  kKernelTableNotValid = -201, // the Table did not pass table_parse/table_validate
  kKernelFixedRange = -202,    // KernelQ: the table's ranges do not fit the fixed-point formats
};
const char* kernel_strerror(int code) noexcept;

struct RawSample16 {
  std::int16_t accel[3];  // counts
  std::int16_t gyro[3];   // counts
};
struct RawSample32 {
  std::int32_t accel[3];
  std::int32_t gyro[3];
};
struct ImuF32 {
  float accel_mps2[3];
  float gyro_rad_s[3];
};
// Fixed-path output: accel_mps2 = accel · 2^-16, gyro_rad_s = gyro · 2^-18.
struct ImuQ {
  std::int32_t accel[3];  // LSB kQAccelLsbMps2 (Q15.16 m/s²)
  std::int32_t gyro[3];   // LSB kQGyroLsbRadS (Q13.18 rad/s)
};
constexpr int kQAccelFracBits = 16;
constexpr int kQGyroFracBits = 18;
constexpr float kQAccelLsbMps2 = 1.0f / 65536.0f;   // 2^-16 m/s²
constexpr float kQGyroLsbRadS = 1.0f / 262144.0f;   // 2^-18 rad/s
constexpr std::int32_t kQTempOne = 65536;           // 1 °C in the Q16.16 temperature input

// °C in 0.01 steps (hal sensor readings) → Q16.16 °C, rounded to nearest. O(1).
constexpr std::int32_t temp_q16_from_cdegC(std::int32_t cdegC) noexcept {
  return static_cast<std::int32_t>((static_cast<std::int64_t>(cdegC) * 65536 + (cdegC >= 0 ? 50 : -50)) / 100);
}

// ---------------------------------------------------------------------------------------------- f32
struct KernelF32 {
  // Cached affine correction (valid while T is inside [T_lo, T_hi]).
  float A_a[9];   // accel: C_a · lsb_a, row-major
  float o_a[3];   // −C_a · b_a
  float A_g[9];   // gyro: C_g · lsb_g
  float A_ga[9];  // G · A_a
  float o_g[3];   // −C_g · b_g + G · o_a
  float T_lo_degC, T_hi_degC;  // re-interpolate when T is outside [lo, hi] (or NaN); empty after load
  float step_degC;
  std::uint32_t cached_status;  // kStatusTempClamped of the cached interpolation
  std::int32_t lim_a[2], lim_g[2];      // raw clamp limits, int32 entry
  std::int32_t lim16_a[2], lim16_g[2];  // raw clamp limits, int16 entry
  const Table* table;  // borrowed: must stay alive and unchanged while loaded
  bool narrow16;       // raw_bits < 16 on either triad: the int16 entry must clamp, not only flag
};

// No table, outputs zero with kStatusNoTable until a load succeeds. step_degC < 0 is taken as 0. O(1).
void kernel_f32_init(KernelF32* k, float step_degC) noexcept;
// Borrows *t (not copied). Returns 0, kKernelNullArgument or kKernelTableNotValid (then no table). O(1).
int kernel_f32_load(KernelF32* k, const Table* t) noexcept;
// One 6-axis sample. Returns KernelStatus bits. O(1); O(n_breakpoints) when it re-interpolates.
std::uint32_t kernel_f32_run(KernelF32* k, const RawSample16* raw, float temp_degC, ImuF32* out) noexcept;
std::uint32_t kernel_f32_run32(KernelF32* k, const RawSample32* raw, float temp_degC, ImuF32* out) noexcept;

// -------------------------------------------------------------------------------------------- fixed
struct KernelQBreakpoint {
  std::int32_t Ka[9];     // accel coefficients, frac fa (see docs/kernel.md)
  std::int32_t Kg[9];     // gyro coefficients, frac fg
  std::int32_t G[9];      // g-sensitivity in gyro-LSB per accel-LSB, frac fG
  std::int32_t beta_a[3]; // bias in counts · 2^(r_a−1)
  std::int32_t beta_g[3]; // bias in counts · 2^(r_g−1)
};
struct KernelQ {
  KernelQBreakpoint bp[kTableMaxBreakpoints];  // converted table (owned copy; the Table may go away)
  std::int32_t bp_q16[kTableMaxBreakpoints];   // breakpoints, Q16.16 °C
  std::uint8_t n_bp;
  // Cached per-sample form (valid while T is inside [T_lo_q16, T_hi_q16]).
  std::int32_t Ka[9];
  std::int32_t Kg[9];
  std::int32_t Kga[9];
  std::int64_t oa[3];
  std::int64_t og[3];
  // Shifts (bits): raw pre-shift, output shift S−32, coefficient fractions.
  std::uint8_t xs_a, xs_g;    // r − 1
  std::uint8_t os_a, os_g;    // S − 32
  std::uint8_t fa, fg, fG, fga;
  bool has_G;
  std::int32_t T_lo_q16, T_hi_q16;  // re-interpolate when T is outside [lo, hi]; empty after load
  std::int32_t step_q16;
  std::uint32_t cached_status;
  std::int32_t lim_a[2], lim_g[2];
  std::int32_t lim16_a[2], lim16_g[2];
  bool has_table;
  bool narrow16;
};

// No table, outputs zero with kStatusNoTable until a load succeeds. step_q16 < 0 is taken as 0. O(1).
void kernel_q_init(KernelQ* k, std::int32_t step_q16) noexcept;
// Converts *t to the integer form (uses float/double arithmetic once, here only). Returns 0,
// kKernelNullArgument, kKernelTableNotValid or kKernelFixedRange (then no table). O(n_breakpoints).
int kernel_q_load(KernelQ* k, const Table* t) noexcept;
// One 6-axis sample. Returns KernelStatus bits. O(1); O(n_breakpoints) when it re-interpolates.
std::uint32_t kernel_q_run(KernelQ* k, const RawSample16* raw, std::int32_t temp_q16_degC, ImuQ* out) noexcept;
std::uint32_t kernel_q_run32(KernelQ* k, const RawSample32* raw, std::int32_t temp_q16_degC, ImuQ* out) noexcept;

}  // namespace imuforge::fw
