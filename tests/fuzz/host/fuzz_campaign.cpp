// libFuzzer: campaign JSON (host/sim/campaign.cpp) through load_campaign, as `simulate`, `solve` and
// `run` read it. An accepted campaign serialises and parses back to the same JSON.
#include "host/sim/campaign.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  sim::Campaign c;
  try {
    c = sim::load_campaign(fuzzio::write_file("campaign.json", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  const nlohmann::json j = sim::campaign_to_json(c);
  sim::Campaign c2;
  try {
    c2 = sim::campaign_from_json(j);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "an accepted campaign does not parse back: %s\n", e.what());
    std::abort();
  }
  FUZZ_CHECK(sim::campaign_to_json(c2) == j);
  FUZZ_CHECK(c2.num_steps() == c.num_steps());
  return 0;
}
