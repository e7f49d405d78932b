// libFuzzer: cal.json (host/solver/calfile.cpp): the shared JSON reader, then calibration_from_json.
// An accepted file has one value and one variance per named parameter.
#include "host/io/input_error.h"
#include "host/solver/calfile.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  solver::Estimate e;
  try {
    e = solver::calibration_from_json(io::read_json_file(fuzzio::write_file("cal.json", data, size)));
  } catch (const std::exception& ex) {
    fuzzio::check_refusal(ex);
    return 0;
  }
  FUZZ_CHECK(static_cast<long>(e.names.size()) == e.value.size());
  FUZZ_CHECK(e.covariance.rows() == e.value.size() && e.covariance.cols() == e.value.size());
  return 0;
}
