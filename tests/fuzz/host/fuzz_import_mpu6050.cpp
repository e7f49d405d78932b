// libFuzzer: `imuforge import --format mpu6050-csv` (host/io/import.cpp).
#include "tests/fuzz/host/fuzz_import_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  imuforge::io::ImportOptions o;
  o.format = "mpu6050-csv";
  o.in = fuzzio::write_file("mpu.csv", data, size);
  fuzzio::fuzz_import(o);
  return 0;
}
