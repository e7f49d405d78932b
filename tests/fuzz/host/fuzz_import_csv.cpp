// libFuzzer: `imuforge import --format csv --map MAP` (host/io/import_csv.cpp), the column-mapping
// import. One input carries both files the user hands it: the column map (JSON), a NUL byte, then the
// delimited text export. Without a NUL the whole input is the map, applied to a fixed small export, so
// the map's own parser is reached by every input.
#include <cstring>

#include "tests/fuzz/host/fuzz_import_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const char kExport[] =
      "t,ax,ay,az,gx,gy,gz,temp\n0.00,1,2,4096,10,-3,1,25.0\n0.01,2,1,4095,11,-2,0,25.0\n"
      "0.02,0,3,4097,9,-4,2,25.1\n0.03,1,2,4096,10,-3,1,25.1\n";
  const void* nul = size > 0 ? std::memchr(data, 0, size) : nullptr;
  const std::size_t map_len = nul != nullptr ? static_cast<std::size_t>(static_cast<const std::uint8_t*>(nul) - data) : size;
  imuforge::io::ImportOptions o;
  o.format = "csv";
  o.map = fuzzio::write_file("map.json", data, map_len);
  if (nul != nullptr) {
    o.in = fuzzio::write_file("export.csv", data + map_len + 1, size - map_len - 1);
  } else {
    o.in = fuzzio::write_file("export.csv", reinterpret_cast<const std::uint8_t*>(kExport), sizeof kExport - 1);
  }
  fuzzio::fuzz_import(o);
  return 0;
}
