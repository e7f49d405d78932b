// libFuzzer: Modbus register map JSON (host/fixture/register_map.cpp) through RegisterMap::load, as the
// fixture drivers and `bench-sim` read it. An accepted map gives every point an address per axis that
// no other point uses, and encodes a value inside the point's range or refuses it cleanly.
#include <set>

#include "host/fixture/register_map.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge::fixture;
  RegisterMap m;
  try {
    m = RegisterMap::load(fuzzio::write_file("map.json", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  FUZZ_CHECK(m.axes() >= 0);
  std::set<unsigned> used;
  for (const auto& p : m.points()) {
    FUZZ_CHECK(m.find(p.name) == &p || m.find(p.name) != nullptr);
    const int axes = p.per_axis ? m.axes() : 1;
    for (int a = 0; a < axes && a < 16; ++a) {
      for (int w = 0; w < p.words(); ++w) FUZZ_CHECK(used.insert(m.address(p, a) + static_cast<unsigned>(w)).second);
      (void)m.label(p, a);
    }
    try {
      const double v = p.min > 0 ? p.min : (p.max < 0 ? p.max : 0.0);
      (void)m.encode(p, v);
    } catch (const std::exception& e) {
      fuzzio::check_refusal(e);
    }
  }
  return 0;
}
