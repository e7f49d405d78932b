// Honest σ benchmark (issue 14 item 6): the FULL end-of-line campaign (docs/examples/campaign-eol.json, four
// plateaus, thermal model), the matched sensor, `fixture` mode trusting the nominal table.
//   solver_bench_consider [seeds=10] [rate_hz=50]
// Row "shipped": the campaign's own fixture errors (0.001-0.03°), the reproduction. Then seeds
// with fixture errors drawn from the tolerance stated below. Prints NEES and |z| for the noise-only σ and
// the σ with the fixture considered.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "consider_mc.h"

using namespace imuforge;
using nlohmann::json;

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::atoi(argv[1]) : 10;
  const double rate = argc > 2 ? std::atof(argv[2]) : 50.0;
  const json tol = {{"axes", {{"tilt_sigma_deg", 0.005}, {"zero_sigma_deg", 0.01}}}, {"mount_sigma_deg", 0.03}};
  json campaign = mc::read_json_file(IMUFORGE_SOURCE_DIR "/docs/examples/campaign-eol.json");
  campaign["sample_rate_hz"] = rate;
  const model::SensorModel sensor = model::load_sensor_model(IMUFORGE_SOURCE_DIR "/docs/examples/sensor-matched.json");
  json m = mc::read_json_file(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json");
  m["fixture_tolerance"] = tol;
  const model::ModelSpec spec = model::model_spec_from_json(m);
  std::printf("campaign-eol at %.0f Hz, model-thermal, sensor-matched; tolerance %s\n", rate, tol.dump().c_str());
  std::printf("%-8s %12s %10s %12s %10s  %s\n", "draw", "NEES noise", "max|z|", "NEES honest", "max|z|", "worst (honest)");
  mc::Stats honest, noise;
  for (int s = -1; s < seeds; ++s) {
    json c = campaign;
    if (s >= 0) mc::draw_fixture_errors(c, tol, 5000u + static_cast<std::uint64_t>(s));
    const std::uint64_t seed = s < 0 ? 1u : 5000u + static_cast<std::uint64_t>(s);
    const mc::ConsiderDraw d = mc::consider_draw(c, sensor, spec, seed, "/tmp/");
    mc::Stats h1, n1;
    h1.add(d.honest, d.truth);
    n1.add(d.noise_only, d.truth);
    if (s >= 0) {
      honest.add(d.honest, d.truth);
      noise.add(d.noise_only, d.truth);
    }
    double zh = 0, zn = 0;
    std::string worst;
    const Eigen::VectorXd sh = d.honest.sigma(), sn = d.noise_only.sigma();
    for (long i = 0; i < sh.size(); ++i) {
      const double e = std::abs(d.honest.value[i] - d.truth.get(d.honest.names[size_t(i)]));
      if (e / sh[i] > zh) {
        zh = e / sh[i];
        worst = d.honest.names[size_t(i)];
      }
      zn = std::max(zn, e / sn[i]);
    }
    std::printf("%-8s %12.1f %10.1f %12.2f %10.2f  %s\n", s < 0 ? "shipped" : std::to_string(seed).c_str(), n1.nees(), zn,
                h1.nees(), zh, worst.c_str());
    std::fflush(stdout);
  }
  if (seeds > 0)
    std::printf("drawn fixtures, %d seeds, %ld parameters: NEES noise-only %.1f, honest %.2f (95%% interval %.2f..%.2f)\n",
                seeds, honest.n(), noise.nees(), honest.nees(), honest.nees_lo(), honest.nees_hi());
  return 0;
}
