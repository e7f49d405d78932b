// libFuzzer: the HDF5 log encoding (host/io/log_h5.cpp), structure-aware. The input is a CSV log; one the
// CSV reader accepts is written by the HDF5 writer and read back by the HDF5 reader, which must return
// the same metadata and rows bit for bit. So hostile contents (strings in every attribute, NaN, extreme
// numbers, long files) go through imuforge's HDF5 code in well-formed containers.
//
// Why not mutate the container's bytes: that fuzzes libhdf5 itself, and libhdf5 1.10.8 (Debian 12) is
// not memory-safe on corrupt containers. Byte-level mutation found, within seconds, a leak in a failed
// H5Fopen (H5G_mkroot) and a memcpy overlap in H5T__conv_vlen reading a corrupt global heap: inside the
// library, before any imuforge code sees a value. An HDF5 log is therefore trusted input: docs/formats.md
// says so, and points untrusted files at the CSV or binary encodings, whose parsers are ours and fuzzed.
#include "tests/fuzz/host/fuzz_log_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::uint8_t kHdf5Magic[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  if (size >= 8 && std::memcmp(data, kHdf5Magic, 8) == 0) return 0;  // a container: see above
  if (size >= 8 && std::memcmp(data, imuforge::io::kLogBinaryMagic, 8) == 0) return 0;  // the binary target's
  fuzzio::fuzz_log(fuzzio::write_file("log.csv", data, size), imuforge::io::LogEncoding::kCsv,
                   imuforge::io::LogEncoding::kHdf5);
  return 0;
}
