// Monte Carlo benchmark of the fixture solver (not a test: prints figures, asserts nothing, never runs in
// CI). The ctest solver_monte_carlo_test runs 1000 seeds of a small campaign; this runs more seeds and/or
// a larger campaign and model:
//
//   solver_bench_monte_carlo [small|large] [seeds] [first_seed]   (first_seed default 1000, as the ctest)
//     small  the ctest's campaign: 3 plateaus (−10, 25, 60 °C) × 20 dwells × 50 samples,
//            model-thermal.json (42 parameters); default 20000 seeds
//     large  5 plateaus (−20 … 70 °C) × 26 dwells (tumble + CW/CCW at 0.3, 1, 2 rad/s) × 100 samples,
//            temperature polynomials of order 3 on bias and scale (60 parameters); default 10000 seeds
//
// Prints: mean NEES with its two-sided 95 % χ² interval (N·n degrees of freedom, Wilson-Hilferty),
// the worst |mean error| in standard errors (CRB/√N), the range of RMS error / CRB over the parameters
// with the 95 % sampling interval of one parameter and the family-wise one (Bonferroni over the n
// parameters), and CPU time per seed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

#include <nlohmann/json.hpp>

#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"
#include "tests/solver/monte_carlo.h"
#include "tests/solver/synth.h"

using namespace imuforge;
using namespace imuforge::solver;

namespace {

model::ModelSpec thermal_model(int order) {
  nlohmann::json e;
  for (const char* s : {"accel", "gyro"}) {
    const std::string p(s);
    e[p + ".bias"] = nlohmann::json::object();
    e[p + ".scale"] = nlohmann::json::object();
    e[p + ".misalign"] = nlohmann::json::object();
    e[p + ".bias_temp"] = {{"order", order == 3 ? 3 : 2}};
    e[p + ".scale_temp"] = {{"order", order == 3 ? 3 : 1}};
  }
  return model::model_spec_from_json(
      {{"format", "imuforge-model"}, {"version", 1}, {"name", "bench"}, {"T_ref_C", 25.0}, {"effects", e}});
}

// Upper standard-normal quantile: z with P(Z > z) = p (bisection on erfc; p in (0, 0.5)).
double z_upper(double p) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string which = argc > 1 ? argv[1] : "small";
  if (which != "small" && which != "large") {
    std::fprintf(stderr, "usage: %s [small|large] [seeds] [first_seed]\n", argv[0]);
    return 2;
  }
  const bool large = which == "large";
  const int seeds = argc > 2 ? std::atoi(argv[2]) : (large ? 10000 : 20000);
  const std::uint64_t first_seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1000;
  if (seeds < 2) {
    std::fprintf(stderr, "seeds must be >= 2\n");
    return 2;
  }
  synth::Config cfg;
  model::ModelSpec spec;
  if (large) {
    cfg.plateaus_C = {-20, 0, 25, 50, 70};
    cfg.samples_per_dwell = 100;
    auto d = synth::tumble_and_rates(9.80665, 1.0);
    for (double rate : {0.3, 2.0}) {
      const auto extra = synth::tumble_and_rates(9.80665, rate);
      d.insert(d.end(), extra.end() - 6, extra.end());  // the rate runs only
    }
    cfg.dwells = d;
    spec = synth::unguarded(thermal_model(3));
  } else {
    cfg.plateaus_C = {-10, 25, 60};
    cfg.samples_per_dwell = 50;
    spec = synth::unguarded(model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json"));
  }
  auto truth = synth::truth_params();
  // Order-3 terms the truth does not set are zero (ParamSet default): still estimated, still scored.
  Sigma6 sig;
  for (int c = 0; c < 6; ++c) sig[size_t(c)] = cfg.sigma[c];

  mc::Stats st;
  const std::clock_t c0 = std::clock();
  for (int s = 0; s < seeds; ++s) {
    FixtureAccumulator acc(spec, synth::meta(cfg));
    synth::generate(cfg, truth, first_seed + std::uint64_t(s), [&](const io::LogRow& r) { acc.add(r); });
    acc.finish();
    st.add(solve_fixture(acc, sig).estimate, truth);
  }
  const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
  const long n = st.n();
  const double nees = st.nees(), lo = st.nees_lo(), hi = st.nees_hi();
  const std::vector<std::string>& names = st.names;
  double worst_bias = 0, eff_lo = 1e9, eff_hi = 0;
  std::string worst_bias_name, eff_lo_name, eff_hi_name;
  for (long i = 0; i < n; ++i) {
    const double bias_z = st.bias_z(i), eff = st.efficiency(i);
    if (std::abs(bias_z) > worst_bias) worst_bias = std::abs(bias_z), worst_bias_name = names[size_t(i)];
    if (eff < eff_lo) eff_lo = eff, eff_lo_name = names[size_t(i)];
    if (eff > eff_hi) eff_hi = eff, eff_hi_name = names[size_t(i)];
  }
  // Sampling interval of one parameter's RMS/CRB: sqrt(χ²(N)/N), 95 % two-sided.
  const double r_lo = std::sqrt(mc::chi2_quantile(seeds, -1.959964) / seeds);
  const double r_hi = std::sqrt(mc::chi2_quantile(seeds, 1.959964) / seeds);
  const double zf = z_upper(0.025 / double(n));  // family-wise 95 % over n parameters
  const double f_lo = std::sqrt(mc::chi2_quantile(seeds, -zf) / seeds), f_hi = std::sqrt(mc::chi2_quantile(seeds, zf) / seeds);
  std::printf("Monte Carlo (%s campaign): %d seeds from %llu, %ld parameters, %lld rows per seed\n", which.c_str(), seeds,
              static_cast<unsigned long long>(first_seed), n,
              static_cast<long long>(cfg.plateaus_C.size() * cfg.dwells.size() * (cfg.samples_per_dwell + 1)));
  std::printf("  mean NEES %.3f; 95%% chi-square interval [%.3f, %.3f] -> %s\n", nees, lo, hi,
              nees > lo && nees < hi ? "inside" : "OUTSIDE");
  std::printf("  worst |mean error| / (CRB/sqrt(N)) %.2f (%s); family-wise 95%% limit over %ld parameters %.2f\n",
              worst_bias, worst_bias_name.c_str(), n, zf);
  std::printf("  RMS error / CRB in [%.4f (%s), %.4f (%s)]\n", eff_lo, eff_lo_name.c_str(), eff_hi, eff_hi_name.c_str());
  std::printf("  95%% sampling interval of RMS/CRB: one parameter [%.4f, %.4f], family-wise [%.4f, %.4f]\n", r_lo, r_hi,
              f_lo, f_hi);
  std::printf("  CPU %.1f s (%.2f ms per seed: generate + accumulate + solve)\n", cpu, 1e3 * cpu / seeds);
  return 0;
}
