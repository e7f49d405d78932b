// imuforge-fw.elf: the representative firmware image. No test harness, no printf, no semihosting, no heap
// (a ctest inspects the linked ELF for allocator symbols: firmware/image/check_no_heap.cmake).
//
// Structure, so later parts plug in without reshaping it:
//   platform_init()  clocks, SysTick time base (hal/mcu), peripherals
//   table_boot()     find and parse the coefficient table (today: a blob in the .imuforge_table section;
//                    the CAN node's A/B table store replaces this), load it into the kernel
//   main loop        read the sensor, compensate, publish; the CAN node's node_poll() goes here too
// The arithmetic path follows the part: f32 with an FPU, the integer path without (IMUFORGE_NO_FPU).
#include <cstdint>

#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"
#include "hal/mcu/systick_clock.h"

namespace {

using namespace imuforge::fw;

constexpr std::uint32_t kCoreHz = 25000000;  // mps2-an385/an386 SYSCLK

// The factory writes the table here (erased flash reads 0xFF, which fails the magic check: no table).
__attribute__((section(".rodata.imuforge_table"), used)) const std::uint8_t kTableBlob[kTableMaxSize] = {0xFF};

imuforge::hal::SysTickClock g_clock;
Table g_table;
#if IMUFORGE_NO_FPU
KernelQ g_kernel;
ImuQ g_out;
#else
KernelF32 g_kernel;
ImuF32 g_out;
#endif
int g_table_status = 0;

// Stand-in for the sensor front end (an SPI/I2C driver on a real board): a memory location the debugger
// or a DMA engine fills. Volatile so the compiler keeps the whole data path.
volatile RawSample16 g_sensor_raw;
volatile std::int16_t g_sensor_temp_cdegC = 2500;
volatile std::uint32_t g_published_status;
volatile std::int32_t g_published_q[6];
volatile float g_published_f[6];
volatile std::uint64_t g_published_t_us;

void platform_init() { g_clock.init(kCoreHz); }

void table_boot() {
#if IMUFORGE_NO_FPU
  kernel_q_init(&g_kernel, kQTempOne / 10);  // re-interpolate every 0.1 °C
#else
  kernel_f32_init(&g_kernel, 0.1f);
#endif
  g_table_status = table_parse(kTableBlob, table_serialized_size(kTableBlob[50]), &g_table);
  if (g_table_status != kTableOk) return;  // kernel stays in kStatusNoTable
#if IMUFORGE_NO_FPU
  g_table_status = kernel_q_load(&g_kernel, &g_table);
#else
  g_table_status = kernel_f32_load(&g_kernel, &g_table);
#endif
}

void sample_once() {
  RawSample16 raw;
  for (int k = 0; k < 3; ++k) {
    raw.accel[k] = g_sensor_raw.accel[k];
    raw.gyro[k] = g_sensor_raw.gyro[k];
  }
  const std::int32_t temp_cdegC = g_sensor_temp_cdegC;
#if IMUFORGE_NO_FPU
  g_published_status = kernel_q_run(&g_kernel, &raw, temp_q16_from_cdegC(temp_cdegC), &g_out);
  for (int k = 0; k < 3; ++k) {
    g_published_q[k] = g_out.accel[k];
    g_published_q[3 + k] = g_out.gyro[k];
  }
#else
  g_published_status = kernel_f32_run(&g_kernel, &raw, static_cast<float>(temp_cdegC) * 0.01f, &g_out);
  for (int k = 0; k < 3; ++k) {
    g_published_f[k] = g_out.accel_mps2[k];
    g_published_f[3 + k] = g_out.gyro_rad_s[k];
  }
#endif
  g_published_t_us = g_clock.now_us();
}

}  // namespace

int main() {
  platform_init();
  table_boot();
  for (;;) {
    sample_once();
    // node_poll(...) of the CAN node goes here.
  }
}
