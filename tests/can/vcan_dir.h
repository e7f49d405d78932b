// Test helper: the virtual CAN buses of one test program (or benchmark) live in a directory of its own
// (IMUFORGE_VCAN_DIR, which the processes it starts inherit), removed with its contents when the program exits.
#pragma once
#include <stdlib.h>

#include <string>

#include "tests/temp_dir.h"

namespace imuforge::testing {

// "virtual:<name>" on this program's bus directory; the first call makes the directory and sets the variable.
inline std::string virtual_test_bus(const std::string& name) {
  static const TempDir dir("imuforge-vcan-test-");
  static const bool env = ::setenv("IMUFORGE_VCAN_DIR", dir.path.c_str(), 1) == 0;
  (void)env;
  return "virtual:" + name;
}

}  // namespace imuforge::testing
