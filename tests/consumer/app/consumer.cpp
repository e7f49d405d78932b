// The C++ side of the consumer test: builds a plausible 3-breakpoint coefficient table with the C++ API,
// writes it to table.bin, then compensates the gen.h stream with both kernels and prints every output
// bit pattern. consumer.c reads table.bin and prints the same lines through the C API; the test driver
// (tests/consumer/run.cmake) requires the two outputs to be byte-identical.
#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"
#include "gen.h"

namespace fw = imuforge::fw;

static unsigned long bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

static fw::Table table;
static fw::KernelF32 kf;
static fw::KernelQ kq;
static std::uint8_t blob[fw::kTableMaxSize];

int main() {
  // ±8 g, ±1000 °/s, 16-bit counts; misalignment ~1e-2, temperature slopes, g-sensitivity.
  fw::table_init_identity(&table, 8.0f * 9.80665f / 32768.0f, 1000.0f * 3.14159265f / 180.0f / 32768.0f, 16, 16);
  table.device_serial = 0x1511u;
  table.table_sequence = 3;
  table.created_unix_s = 1790000000;
  table.n_breakpoints = 3;
  table.model_flags = fw::kModelAccelMatrix | fw::kModelAccelBias | fw::kModelGyroMatrix | fw::kModelGyroBias |
                      fw::kModelGyroGSens | fw::kModelTemperature;
  const float T[3] = {-40.0f, 20.0f, 85.0f};
  for (int i = 0; i < 3; ++i) {
    table.breakpoints_degC[i] = T[i];
    fw::BreakpointCoeffs& c = table.coeffs[i];
    const float tau = (T[i] - 25.0f) * 1e-4f;
    for (int m = 0; m < 9; ++m) {
      const float diag = m % 4 == 0 ? 1.0f : 0.0f;
      c.accel.C[m] = diag + 0.01f * static_cast<float>((m * 7) % 5 - 2) * 0.3f + tau * static_cast<float>(m % 3);
      c.gyro.C[m] = diag - 0.008f * static_cast<float>((m * 5) % 7 - 3) * 0.2f - tau;
      c.G[m] = 1e-3f * static_cast<float>(m % 4 - 1) + tau * 0.1f;
    }
    for (int m = 0; m < 3; ++m) {
      c.accel.b[m] = 0.12f * static_cast<float>(m - 1) + 0.05f * tau * 1e3f;
      c.gyro.b[m] = 0.004f * static_cast<float>(1 - m) - 0.002f * tau * 1e3f;
    }
  }
  const int len = fw::table_serialize(&table, blob, sizeof blob);
  if (len < 0) {
    std::printf("table_serialize: %s\n", fw::table_strerror(len));
    return 1;
  }
  std::FILE* f = std::fopen("table.bin", "wb");
  if (f == nullptr || std::fwrite(blob, 1, static_cast<std::size_t>(len), f) != static_cast<std::size_t>(len) ||
      std::fclose(f) != 0) {
    std::printf("cannot write table.bin\n");
    return 1;
  }

  // What a corrupted image gives (same code through both APIs).
  blob[70] ^= 0x01u;
  static fw::Table bad;
  std::printf("corrupt %d %s\n", fw::table_parse(blob, static_cast<std::size_t>(len), &bad),
              fw::table_strerror(fw::table_parse(blob, static_cast<std::size_t>(len), &bad)));
  blob[70] ^= 0x01u;

  const int rc = fw::table_parse(blob, static_cast<std::size_t>(len), &table);
  std::printf("parse %d breakpoints %u flags %" PRIu32 "\n", rc, static_cast<unsigned>(table.n_breakpoints),
              table.model_flags);
  fw::kernel_f32_init(&kf, 0.25f);
  fw::kernel_q_init(&kq, fw::kQTempOne / 4);
  std::printf("load %d %d\n", fw::kernel_f32_load(&kf, &table), fw::kernel_q_load(&kq, &table));

  std::uint32_t seed = 15u;
  for (int i = 0; i < CONSUMER_SAMPLES; ++i) {
    std::int16_t r16[6];
    std::int32_t r32[6];
    float temp;
    std::int32_t temp_q;
    consumer_sample(&seed, i, r16, r32, &temp, &temp_q);
    const fw::RawSample16 s16 = {{r16[0], r16[1], r16[2]}, {r16[3], r16[4], r16[5]}};
    const fw::RawSample32 s32 = {{r32[0], r32[1], r32[2]}, {r32[3], r32[4], r32[5]}};
    fw::ImuF32 o;
    fw::ImuQ q;
    std::uint32_t st = fw::kernel_f32_run(&kf, &s16, temp, &o);
    std::printf("f %d %" PRIu32, i, st);
    for (int k = 0; k < 3; ++k) std::printf(" %08lx", bits(o.accel_mps2[k]));
    for (int k = 0; k < 3; ++k) std::printf(" %08lx", bits(o.gyro_rad_s[k]));
    st = fw::kernel_f32_run32(&kf, &s32, temp, &o);
    std::printf(" | %" PRIu32, st);
    for (int k = 0; k < 3; ++k) std::printf(" %08lx", bits(o.accel_mps2[k]));
    for (int k = 0; k < 3; ++k) std::printf(" %08lx", bits(o.gyro_rad_s[k]));
    st = fw::kernel_q_run(&kq, &s16, temp_q, &q);
    std::printf("\nq %d %" PRIu32, i, st);
    for (int k = 0; k < 3; ++k) std::printf(" %" PRId32, q.accel[k]);
    for (int k = 0; k < 3; ++k) std::printf(" %" PRId32, q.gyro[k]);
    st = fw::kernel_q_run32(&kq, &s32, temp_q, &q);
    std::printf(" | %" PRIu32, st);
    for (int k = 0; k < 3; ++k) std::printf(" %" PRId32, q.accel[k]);
    for (int k = 0; k < 3; ++k) std::printf(" %" PRId32, q.gyro[k]);
    std::printf("\n");
  }
  std::printf("end\n");
  return 0;
}
