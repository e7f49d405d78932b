// libFuzzer: model spec JSON (host/model/sensor_model.cpp) through load_model_spec, as `solve` and
// `run` read it. An accepted spec lists its parameters and serialises and parses back to the same JSON.
#include "host/model/sensor_model.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  model::ModelSpec m;
  try {
    m = model::load_model_spec(fuzzio::write_file("model.json", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  (void)m.parameters();
  const nlohmann::json j = model::model_spec_to_json(m);
  try {
    FUZZ_CHECK(model::model_spec_to_json(model::model_spec_from_json(j)) == j);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "an accepted model spec does not parse back: %s\n", e.what());
    std::abort();
  }
  return 0;
}
