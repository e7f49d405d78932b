// libFuzzer: sensor model JSON (host/model/sensor_model.cpp) through load_sensor_model. An accepted
// model serialises and parses back to the same JSON.
#include "host/model/sensor_model.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  model::SensorModel m;
  try {
    m = model::load_sensor_model(fuzzio::write_file("sensor.json", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  const nlohmann::json j = model::sensor_model_to_json(m);
  try {
    FUZZ_CHECK(model::sensor_model_to_json(model::sensor_model_from_json(j)) == j);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "an accepted sensor model does not parse back: %s\n", e.what());
    std::abort();
  }
  return 0;
}
