// libFuzzer: `imuforge import --format si-csv` (host/io/import.cpp): floats in SI mapped to counts.
#include "tests/fuzz/host/fuzz_import_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  imuforge::io::ImportOptions o;
  o.format = "si-csv";
  o.in = fuzzio::write_file("si.csv", data, size);
  o.accel_lsb_mps2 = 1e-5;
  o.gyro_lsb_rad_s = 1e-6;
  o.bits = 24;
  fuzzio::fuzz_import(o);
  return 0;
}
