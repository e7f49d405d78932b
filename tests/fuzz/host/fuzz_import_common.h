// Import fuzzing: an accepted recording must convert to a log that reads back with the announced number
// of rows.
#pragma once
#include "host/io/import.h"
#include "host/io/log.h"
#include "tests/fuzz/host/fuzz_io.h"

namespace fuzzio {

inline void fuzz_import(const imuforge::io::ImportOptions& o) {
  using namespace imuforge::io;
  const std::string out = scratch("import.bin");
  ImportSummary s;
  try {
    s = import_recording(o, out, LogEncoding::kBinary);
  } catch (const std::exception& e) {
    check_refusal(e);
    return;
  }
  LogReader r(out);
  LogRow row;
  std::uint64_t n = 0;
  while (r.next(row)) ++n;
  FUZZ_CHECK(n == s.rows);
  FUZZ_CHECK(s.sample_rate_hz > 0);
}

}  // namespace fuzzio
