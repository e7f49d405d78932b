// libFuzzer: `imuforge import --format xsens-imutk` (host/io/import.cpp). One input holds both files,
// accelerometer then gyro, split at the first form feed (\f) so that mutations reach both.
#include <cstring>

#include "tests/fuzz/host/fuzz_import_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto* ff = static_cast<const std::uint8_t*>(std::memchr(data, '\f', size));
  const std::size_t na = ff != nullptr ? static_cast<std::size_t>(ff - data) : size;
  imuforge::io::ImportOptions o;
  o.format = "xsens-imutk";
  o.in = fuzzio::write_file("acc.txt", data, na);
  o.in_gyro = fuzzio::write_file("gyr.txt", ff != nullptr ? ff + 1 : data + size, ff != nullptr ? size - na - 1 : 0);
  fuzzio::fuzz_import(o);
  return 0;
}
