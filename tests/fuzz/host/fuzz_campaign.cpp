// libFuzzer: campaign JSON (host/io/campaign_file.cpp) through load_campaign, as `simulate`, `solve` and
// `run` read it. An accepted campaign serialises and parses back to the same JSON.
#include "host/io/campaign_file.h"
#include "tests/fuzz/host/fuzz_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imuforge;
  physics::Campaign c;
  try {
    c = io::load_campaign(fuzzio::write_file("campaign.json", data, size));
  } catch (const std::exception& e) {
    fuzzio::check_refusal(e);
    return 0;
  }
  const nlohmann::json j = io::campaign_to_json(c);
  physics::Campaign c2;
  try {
    c2 = io::campaign_from_json(j);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "an accepted campaign does not parse back: %s\n", e.what());
    std::abort();
  }
  FUZZ_CHECK(io::campaign_to_json(c2) == j);
  FUZZ_CHECK(c2.num_steps() == c.num_steps());
  return 0;
}
