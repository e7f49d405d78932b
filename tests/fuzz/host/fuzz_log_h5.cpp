// libFuzzer: log v1, HDF5 encoding (host/io/log_h5.cpp), as `solve`, `diagnose`, `compensate` and
// `convert` read it. Inputs without the HDF5 signature are the CSV target's (the reader picks the
// encoding from the first bytes); the seeds are real HDF5 logs, so mutations land inside the container.
#include "tests/fuzz/host/fuzz_log_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::uint8_t kHdf5Magic[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  if (size < 8 || std::memcmp(data, kHdf5Magic, 8) != 0) return 0;
  fuzzio::fuzz_log(fuzzio::write_file("log.h5", data, size), imuforge::io::LogEncoding::kHdf5);
  return 0;
}
