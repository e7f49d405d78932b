// libFuzzer: log v1, CSV encoding (host/io/log.cpp), as `solve`, `diagnose` and `compensate` read it.
#include "tests/fuzz/host/fuzz_log_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size >= 8 && std::memcmp(data, imuforge::io::kLogBinaryMagic, 8) == 0) return 0;  // the binary target's
  fuzzio::fuzz_log(fuzzio::write_file("log.csv", data, size), imuforge::io::LogEncoding::kCsv, imuforge::io::LogEncoding::kCsv);
  return 0;
}
