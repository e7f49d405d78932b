// Proof of quality on simulated campaigns (label: slow). 1000 seeds of a small three-plateau campaign
// through the catalog's measurement function, solved with the thermal model (42 parameters):
//   - unbiased: every parameter's mean error within 4 standard errors of zero;
//   - NEES: the average normalised estimation error squared within its two-sided 95% χ² interval;
//   - efficient: every parameter's RMS error within 10% of its Cramér-Rao bound (the covariance the
//     solver reports is the inverse Fisher information of the same design).
// 1000 seeds rather than the required 100: with 100 the sample RMS itself scatters by 7%, so a 10% bound
// on 42 parameters would fail by chance; at 1000 the scatter is 2.2% and the bound sits at 4.5σ.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "host/model/sensor_model.h"
#include "host/solver/fixture.h"
#include "tests/solver/monte_carlo.h"
#include "tests/solver/synth.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace solver_monte_carlo_test {

using namespace imuforge;
using namespace imuforge::solver;

TEST(MonteCarlo, UnbiasedConsistentAndEfficient) {
  synth::Config cfg;
  cfg.plateaus_C = {-10, 25, 60};
  cfg.samples_per_dwell = 50;
  const auto spec = synth::unguarded(model::load_model_spec(IMUFORGE_SOURCE_DIR "/docs/examples/model-thermal.json"));
  const auto truth = synth::truth_params();
  Sigma6 sig;
  for (int c = 0; c < 6; ++c) sig[size_t(c)] = cfg.sigma[c];
  const int seeds = 1000;
  mc::Stats st;
  for (int s = 0; s < seeds; ++s) {
    FixtureAccumulator acc(spec, synth::meta(cfg));
    synth::generate(cfg, truth, 1000 + std::uint64_t(s), [&](const io::LogRow& r) { acc.add(r); });
    acc.finish();
    st.add(solve_fixture(acc, sig).estimate, truth);
  }
  const long n = st.n();
  const double nees = st.nees(), lo = st.nees_lo(), hi = st.nees_hi();
  std::printf("Monte Carlo: %d seeds, %ld parameters; mean NEES %.3f (95%% interval [%.3f, %.3f])\n", seeds, n, nees, lo, hi);
  EXPECT_GT(nees, lo);
  EXPECT_LT(nees, hi);
  double worst_bias = 0, worst_eff_lo = 10, worst_eff_hi = 0;
  for (long i = 0; i < n; ++i) {
    const double bias_z = st.bias_z(i), eff = st.efficiency(i);
    worst_bias = std::max(worst_bias, std::abs(bias_z));
    worst_eff_lo = std::min(worst_eff_lo, eff);
    worst_eff_hi = std::max(worst_eff_hi, eff);
    EXPECT_LT(std::abs(bias_z), 4.0) << st.names[size_t(i)];
    EXPECT_GT(eff, 0.9) << st.names[size_t(i)];
    EXPECT_LT(eff, 1.1) << st.names[size_t(i)];
  }
  std::printf("Monte Carlo: worst |mean error|/(CRB/sqrt(N)) %.2f; RMS error / CRB in [%.3f, %.3f]\n", worst_bias,
              worst_eff_lo, worst_eff_hi);
}
}  // namespace solver_monte_carlo_test
