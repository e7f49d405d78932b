// imuforge-fw.elf: the representative firmware image. No test harness, no printf, no semihosting, no heap
// (a ctest inspects the linked ELF for allocator symbols: firmware/image/check_no_heap.cmake).
//
// Structure, so later parts plug in without reshaping it:
//   platform_init()  clocks, SysTick time base (hal/mcu), peripherals
//   table_boot()     find and parse the coefficient table (today: a blob in the .imuforge_table section;
//                    the CAN node's A/B table store replaces this), load it into the kernel
//   main loop        read the sensor, compensate, publish; the CAN node's node_poll() goes here too
// The arithmetic path follows the part: f32 with an FPU, the integer path without (IMUFORGE_NO_FPU).
#include <cstddef>
#include <cstdint>

#include "firmware/can_node/node.h"
#include "firmware/common/endian.h"
#include "firmware/kernel/compensation.h"
#include "firmware/table/table.h"
#include "hal/mcu/systick_clock.h"

namespace {

using namespace imuforge::fw;

constexpr std::uint32_t kCoreHz = 25000000;  // mps2-an385/an386 SYSCLK

// The factory writes the table here (erased flash reads 0xFF, which fails the magic check: no table).
__attribute__((section(".rodata.imuforge_table"), used)) const std::uint8_t kTableBlob[kTableMaxSize] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,
                                                                                                0xFF, 0xFF, 0xFF, 0xFF};

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

// The CAN node (firmware/can_node/, docs/can-protocol.md). A board plugs in its CAN driver as a
// hal::CanPort and its flash driver as a hal::Flash; mps2 has neither, so this image links a port with
// no controller (nothing is sent or received) and keeps the A/B table store in RAM.
class NoCanPort final : public imuforge::hal::CanPort {
 public:
  int send(const imuforge::hal::CanFrame&) noexcept override { return imuforge::hal::kCanErrBusOff; }
  int receive(imuforge::hal::CanFrame&) noexcept override { return imuforge::hal::kCanErrWouldBlock; }
};
class RamFlash final : public imuforge::hal::Flash {
 public:
  static constexpr std::uint32_t kBytes = 16384, kSector = 2048;
  std::uint32_t size_bytes() const noexcept override { return kBytes; }
  std::uint32_t sector_bytes() const noexcept override { return kSector; }
  int read(std::uint32_t a, std::uint8_t* d, std::size_t n) noexcept override {
    if (a > kBytes || n > kBytes - a) return imuforge::hal::kFlashErrRange;
    for (std::size_t i = 0; i < n; ++i) d[i] = mem_[a + i];
    return imuforge::hal::kFlashOk;
  }
  int program(std::uint32_t a, const std::uint8_t* s, std::size_t n) noexcept override {
    if (a > kBytes || n > kBytes - a) return imuforge::hal::kFlashErrRange;
    for (std::size_t i = 0; i < n; ++i) mem_[a + i] = static_cast<std::uint8_t>(mem_[a + i] & s[i]);
    return imuforge::hal::kFlashOk;
  }
  int erase_sector(std::uint32_t a) noexcept override {
    if (a % kSector != 0u || a >= kBytes) return imuforge::hal::kFlashErrAlign;
    for (std::uint32_t i = 0; i < kSector; ++i) mem_[a + i] = 0xFF;
    return imuforge::hal::kFlashOk;
  }

 private:
  std::uint8_t mem_[kBytes];
};
class FrontEndSensor final : public imuforge::hal::Sensor {
 public:
  int read(std::uint64_t, imuforge::hal::ImuRawSample& s) noexcept override {
    for (int k = 0; k < 3; ++k) {
      s.accel_counts[k] = g_sensor_raw.accel[k];
      s.gyro_counts[k] = g_sensor_raw.gyro[k];
    }
    s.temp_cdegC = g_sensor_temp_cdegC;
    return imuforge::hal::kSensorOk;
  }
};
NoCanPort g_can_port;
RamFlash g_flash;
FrontEndSensor g_front_end;
CanNode g_node;

void can_init() {
  for (std::uint32_t a = 0; a < RamFlash::kBytes; a += RamFlash::kSector) (void)g_flash.erase_sector(a);
  NodeConfig cfg;
  cfg.node_id = 1;
  cfg.serial = 1;                 // from the part's unique-ID registers on a real board
  cfg.key_provisioned = false;    // the key comes from the protected key sector at manufacture
  cfg.store.slot_addr[0] = 0;
  cfg.store.slot_addr[1] = RamFlash::kBytes / 2;
  cfg.store.slot_bytes = 4096;
  cfg.isotp_block_size = 8;
  node_init(g_node, cfg, g_can_port, g_flash, g_front_end);
  (void)node_boot(g_node, g_clock.now_us());
}

void platform_init() { g_clock.init(kCoreHz); }

void table_boot() {
#if IMUFORGE_NO_FPU
  kernel_q_init(&g_kernel, kQTempOne / 10);  // re-interpolate every 0.1 °C
#else
  kernel_f32_init(&g_kernel, 0.1f);
#endif
  // The header's total_len says how much to parse; never more than the blob (erased flash: 0xFFFFFFFF).
  std::size_t len = load_le32(kTableBlob + 8);
  if (len > sizeof kTableBlob) len = sizeof kTableBlob;
  g_table_status = table_parse(kTableBlob, len, &g_table);
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
  can_init();
  for (;;) {
    sample_once();
    node_poll(g_node, g_clock.now_us());
  }
}
