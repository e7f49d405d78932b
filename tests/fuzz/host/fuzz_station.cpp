// libFuzzer: station JSON (host/eol/station.cpp) through load_station, as `run` reads it.
#include "host/eol/station.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  eol::StationConfig s;
  try {
    s = eol::load_station(fuzzio::write_file("station.json", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  (void)s.limit_for("accel.bias.x");
  (void)s.limit_for("gyro.scale.z");
  return 0;
}
