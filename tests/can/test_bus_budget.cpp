// Bus budget (host/can/bus_budget.h): frame lengths against ISO 11898-1 counts worked by hand, the loads
// of docs/can-protocol.md, and the refusal message naming what would fit.
#include <gtest/gtest.h>

#include "host/can/bus_budget.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace can_test_bus_budget {

using namespace imuforge::can;

TEST(BusBudget, ClassicFrameLengthsMatchTheStandard) {
  BusTiming t;  // classic, 11-bit, 1 Mbit/s
  // 8 data bytes: 47 + 64 = 111 bits, stuffing at most floor((34 + 64 − 1) / 4) = 24.
  EXPECT_NEAR(frame_time_nominal_s(t, 8), 111e-6, 1e-12);
  EXPECT_NEAR(frame_time_worst_s(t, 8), 135e-6, 1e-12);
  EXPECT_NEAR(frame_time_nominal_s(t, 0), 47e-6, 1e-12);
  t.ext_id = true;  // 131 bits + 29 stuff bits
  EXPECT_NEAR(frame_time_nominal_s(t, 8), 131e-6, 1e-12);
  EXPECT_NEAR(frame_time_worst_s(t, 8), 160e-6, 1e-12);
  EXPECT_THROW(frame_time_worst_s(t, 9), std::invalid_argument);
}

TEST(BusBudget, FdFrameLengths) {
  BusTiming t;
  t.fd = true;
  t.nominal_bit_s = 1e6;
  t.data_bit_s = 1e6;  // one rate: the bit count itself
  // 64 bytes, 11-bit: arbitration 17 + tail 12, data 5 + 512 + 4 stuff count + 21 CRC + 7 fixed + 1 = 550.
  EXPECT_NEAR(frame_time_nominal_s(t, 64), (17 + 12 + 550) * 1e-6, 1e-12);
  // Worst case adds floor(16 / 4) = 4 in arbitration and floor(517 / 4) = 129 in the data phase.
  EXPECT_NEAR(frame_time_worst_s(t, 64), (17 + 12 + 550 + 4 + 129) * 1e-6, 1e-12);
  // 8 bytes: CRC-17, 6 fixed stuff bits.
  EXPECT_NEAR(frame_time_nominal_s(t, 8), (17 + 12 + 5 + 64 + 4 + 17 + 6 + 1) * 1e-6, 1e-12);
  EXPECT_THROW(frame_time_worst_s(t, 13), std::invalid_argument);
  // Bit-rate switch: the data phase at 5 Mbit/s.
  t.data_bit_s = 5e6;
  EXPECT_NEAR(frame_time_nominal_s(t, 64), 29e-6 + 550 / 5e6, 1e-12);
}

TEST(BusBudget, StreamLoadsAndTheDocumentedTable) {
  BusTiming classic;
  // docs/can-protocol.md: one unit at 1 kHz, 11-bit, 40.5 % worst case, 33.3 % nominal.
  EXPECT_NEAR(stream_load_worst(classic, 1, 1000), 0.405, 1e-9);
  EXPECT_NEAR(stream_load_nominal(classic, 1, 1000), 0.333, 1e-9);
  EXPECT_NEAR(stream_load_worst(classic, 4, 200), 4 * 0.081, 1e-9);
  BusTiming fd;
  fd.fd = true;
  // FD: 250 frames/s per unit at 1 kHz.
  EXPECT_NEAR(stream_load_worst(fd, 1, 1000), 250 * frame_time_worst_s(fd, 64), 1e-12);
  EXPECT_LT(stream_load_worst(fd, 16, 1000), stream_load_worst(classic, 16, 1000) / 3);
  // The highest rate that fits is the last one under the limit.
  const int r = max_rate_hz(classic, 8);
  EXPECT_LE(stream_load_worst(classic, 8, r), kDefaultLoadLimit);
  EXPECT_GT(stream_load_worst(classic, 8, r + 1), kDefaultLoadLimit);
  EXPECT_EQ(r, 216);  // 8 × r × 3 × 135 µs ≤ 0.7
}

TEST(BusBudget, RefusalSaysWhatWouldFit) {
  BusTiming classic;
  BudgetVerdict ok = check_budget(classic, {{"socketcan:can0", 4}}, 200);
  EXPECT_TRUE(ok.ok);
  EXPECT_TRUE(ok.message.empty());
  BudgetVerdict v = check_budget(classic, {{"socketcan:can0", 16}, {"socketcan:can1", 2}}, 1000);
  EXPECT_FALSE(v.ok);
  ASSERT_EQ(v.load.size(), 2u);
  EXPECT_NEAR(v.load[0], 16 * 0.405, 1e-9);
  EXPECT_NE(v.message.find("bus socketcan:can0: 16 units at 1000 Hz take 648.0 %"), std::string::npos) << v.message;
  EXPECT_NE(v.message.find("at most 108 Hz"), std::string::npos) << v.message;
  EXPECT_NE(v.message.find("or 16 buses at 1000 Hz (1 units per bus)"), std::string::npos) << v.message;
  EXPECT_NE(v.message.find("or CAN FD"), std::string::npos) << v.message;
  EXPECT_NE(v.message.find("bus socketcan:can1: 2 units"), std::string::npos) << v.message;  // 81 %: also over
}
}  // namespace can_test_bus_budget
