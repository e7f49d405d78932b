// libFuzzer: log v1, binary encoding (host/io/log.cpp). The 8 magic bytes are forced so that every input
// reaches the header and record parser.
#include "tests/fuzz/host/fuzz_log_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> b(data, data + size);
  if (b.size() < 8) b.resize(8);
  std::memcpy(b.data(), imuforge::io::kLogBinaryMagic, 8);
  fuzzio::fuzz_log(fuzzio::write_file("log.bin", b.data(), b.size()), imuforge::io::LogEncoding::kBinary,
                   imuforge::io::LogEncoding::kBinary);
  return 0;
}
