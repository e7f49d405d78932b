// Short names for the project's firmware test harness (tests/firmware/fwtest.h) used by the CAN
// firmware tests; the harness does the counting and printing (host and qemu semihosting alike).
#pragma once
#include "tests/firmware/fwtest.h"

#define CHECK(expr) FW_EXPECT(expr)
#define CHECK_EQ(a, b) FW_EXPECT_EQ_INT(a, b)
#define FW_TEST_RESULT(name) fwtest::summary(name)
