// bench-kernel: instructions per 6-axis sample of the compensation kernel, measured under
// `qemu-system-arm -icount shift=0` (every guest instruction advances virtual time by 1 ns) with the
// SysTick down-counter running on the core clock. A calibration loop of known length converts SysTick
// ticks to instructions, so the figure does not depend on QEMU's clock model. Prints the lines of
// docs/kernel.md "Benchmark". Not a test: it asserts nothing.
#include <cstdint>
#include <cstdio>

#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"
#include "hal/mcu/systick_clock.h"

#ifndef IMUFORGE_TARGET_NAME
#define IMUFORGE_TARGET_NAME "unknown"
#endif

using namespace imuforge::fw;

namespace {

constexpr int kSamples = 4096;  // per measurement; ring of 64 different raw samples
constexpr int kRing = 64;
RawSample16 g_raw[kRing];
Table g_table;
#if !IMUFORGE_NO_FPU
KernelF32 g_kf;
ImuF32 g_of;
#endif
KernelQ g_kq;
ImuQ g_oq;
volatile std::uint32_t g_sink;

std::uint32_t ticks_between(std::uint32_t t0, std::uint32_t t1) { return (t0 - t1) & 0x00FFFFFFu; }

// Exactly 2 instructions per iteration (subs + bne).
__attribute__((noinline)) std::uint32_t calibrate(std::uint32_t n) {
  const std::uint32_t t0 = imuforge::hal::systick_value();
  __asm volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n) : : "cc");
  const std::uint32_t t1 = imuforge::hal::systick_value();
  return ticks_between(t0, t1);
}

#if !IMUFORGE_NO_FPU
__attribute__((noinline)) std::uint32_t empty_f32(KernelF32*, const RawSample16*, float, ImuF32*) { return 0; }
#endif
__attribute__((noinline)) std::uint32_t empty_q(KernelQ*, const RawSample16*, std::int32_t, ImuQ*) { return 0; }

template <typename Fn, typename K, typename T, typename O>
__attribute__((noinline)) std::uint32_t run_loop(Fn fn, K* k, T temp, O* out, T temp_step) {
  const std::uint32_t t0 = imuforge::hal::systick_value();
  std::uint32_t acc = 0;
  for (int i = 0; i < kSamples; ++i) {
    acc += fn(k, &g_raw[i & (kRing - 1)], temp, out);
    temp += temp_step;
  }
  const std::uint32_t t1 = imuforge::hal::systick_value();
  g_sink = acc;
  return ticks_between(t0, t1);
}

void make_table() {
  table_init_identity(&g_table, 16.0f * 9.80665f / 32768.0f, 2000.0f * 3.14159265f / 180.0f / 32768.0f, 16, 16);
  g_table.n_breakpoints = 4;
  g_table.model_flags = kModelAllKnown;
  for (int i = 0; i < 4; ++i) {
    g_table.breakpoints_degC[i] = -40.0f + 40.0f * static_cast<float>(i);
    BreakpointCoeffs& c = g_table.coeffs[i];
    for (int m = 0; m < 9; ++m) {
      const float d = (m % 4 == 0) ? 1.0f : 0.0f;
      c.accel.C[m] = d + 0.001f * static_cast<float>(m - 4 + i);
      c.gyro.C[m] = d - 0.001f * static_cast<float>(m - 3 - i);
      c.G[m] = 1e-4f * static_cast<float>(m + 1);
    }
    for (int m = 0; m < 3; ++m) {
      c.accel.b[m] = 0.05f * static_cast<float>(m + i);
      c.gyro.b[m] = 0.002f * static_cast<float>(m - i);
    }
  }
  g_sink = static_cast<std::uint32_t>(table_validate(&g_table));
  std::uint32_t s = 12345;
  for (auto& r : g_raw)
    for (int k = 0; k < 3; ++k) {
      s = s * 1664525u + 1013904223u;
      r.accel[k] = static_cast<std::int16_t>(s >> 17);
      s = s * 1664525u + 1013904223u;
      r.gyro[k] = static_cast<std::int16_t>(s >> 17);
    }
}

}  // namespace

int main() {
  imuforge::hal::systick_free_run_start();
  make_table();
  const std::uint32_t cal_n = 200000;
  const std::uint32_t cal_ticks = calibrate(cal_n);
  const double ipt = 2.0 * cal_n / cal_ticks;  // instructions per SysTick tick
  auto per_sample = [ipt](std::uint32_t kernel_ticks, std::uint32_t base_ticks) {
    // + 2: the empty function's own call and return are subtracted with the loop; the kernel has them too.
    return static_cast<long>((static_cast<double>(kernel_ticks) - static_cast<double>(base_ticks)) * ipt / kSamples +
                             2.5);
  };
  kernel_q_init(&g_kq, kQTempOne / 10);
  if (kernel_q_load(&g_kq, &g_table) != 0) return 1;
  const std::int32_t Tq = 25 * kQTempOne;
  const std::uint32_t bq = run_loop(empty_q, &g_kq, Tq, &g_oq, std::int32_t{0});
  const std::uint32_t kq_ticks = run_loop(kernel_q_run, &g_kq, Tq, &g_oq, std::int32_t{0});
  const std::uint32_t kq_re = run_loop(kernel_q_run, &g_kq, Tq, &g_oq, std::int32_t{kQTempOne / 8});  // re-interpolates
#if !IMUFORGE_NO_FPU
  kernel_f32_init(&g_kf, 0.1f);
  if (kernel_f32_load(&g_kf, &g_table) != 0) return 1;
  const std::uint32_t bf = run_loop(empty_f32, &g_kf, 25.0f, &g_of, 0.0f);
  const std::uint32_t kf_ticks = run_loop(kernel_f32_run, &g_kf, 25.0f, &g_of, 0.0f);
  // Temperature moves 0.125 °C per sample (step 0.1 °C), so every sample re-interpolates.
  const std::uint32_t kf_re = run_loop(kernel_f32_run, &g_kf, -40.0f, &g_of, 0.125f);
  std::printf("kernel f32 %s: %ld instructions per 6-axis sample\n", IMUFORGE_TARGET_NAME, per_sample(kf_ticks, bf));
#endif
  std::printf("kernel fixed %s: %ld instructions per 6-axis sample\n", IMUFORGE_TARGET_NAME,
              per_sample(kq_ticks, bq));
#if !IMUFORGE_NO_FPU
  std::printf("  (f32 sample that re-interpolates: %ld instructions)\n", per_sample(kf_re, bf));
#endif
  std::printf("  (fixed sample that re-interpolates: %ld instructions)\n", per_sample(kq_re, bq));
  std::printf("  calibration: %.2f instructions per SysTick tick\n", ipt);
  std::printf("kernel static RAM: 0 bytes (no globals); caller-owned instances: sizeof(KernelF32) = %u, "
              "sizeof(KernelQ) = %u, sizeof(Table) = %u bytes\n",
              static_cast<unsigned>(sizeof(KernelF32)), static_cast<unsigned>(sizeof(KernelQ)),
              static_cast<unsigned>(sizeof(Table)));
  return 0;
}
