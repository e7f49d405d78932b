// One Monte Carlo draw of the honest-σ claim (host/solver/consider.h), shared by solver_consider_test and
// solver_bench_consider: the fixture's errors are DRAWN from its stated tolerance (each seed is another
// fixture and another sensor realisation), the campaign is simulated with them, `solve --mode fixture`
// trusts the nominal fixture, and the consider analysis widens σ. Errors are taken against the sensor's
// TRUE case-frame parameters: what a station user wants to know, and what no table campaign can separate
// from the mount rotation.
#pragma once

#include <cstdio>
#include <fstream>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "host/model/sensor_model.h"
#include "host/io/campaign_file.h"
#include "host/sim/simulator.h"
#include "host/solver/consider.h"
#include "host/solver/fixture.h"
#include "monte_carlo.h"

namespace mc {

inline nlohmann::json read_json_file(const std::string& path) {
  std::ifstream f(path);
  return nlohmann::json::parse(f);
}

// Writes fixture errors drawn from tol (1σ, deg) into the campaign's simulation block.
inline void draw_fixture_errors(nlohmann::json& campaign, const nlohmann::json& tol, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 7919u + 17u);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double tilt = tol["axes"]["tilt_sigma_deg"].get<double>(), zero = tol["axes"]["zero_sigma_deg"].get<double>();
  const double mount = tol["mount_sigma_deg"].get<double>();
  nlohmann::json axes = nlohmann::json::array();
  for (std::size_t a = 0; a < campaign["table"]["axes"].size(); ++a)
    axes.push_back({{"tilt_a_deg", tilt * n01(rng)}, {"tilt_b_deg", tilt * n01(rng)}, {"zero_deg", zero * n01(rng)}});
  campaign["simulation"]["fixture_errors"] = {
      {"axes", axes}, {"mount_error_deg", {mount * n01(rng), mount * n01(rng), mount * n01(rng)}}};
}

struct ConsiderDraw {
  imuforge::solver::Estimate noise_only, honest;  // same values, the two covariances
  imuforge::model::ParamSet truth;
};

// Simulates `campaign` (fixture errors already in it) with `sensor`, solves in fixture mode with `spec`,
// and applies the tolerance stated in spec. The log goes to a temporary file, removed before returning.
inline ConsiderDraw consider_draw(const nlohmann::json& campaign, const imuforge::model::SensorModel& sensor,
                                  const imuforge::model::ModelSpec& spec, std::uint64_t seed, const std::string& tmp_dir) {
  using namespace imuforge;
  const physics::Campaign c = io::campaign_from_json(campaign);
  sim::SimOptions opt;
  opt.seed = seed;
  const std::string path = tmp_dir + "consider_mc_" + std::to_string(seed) + ".bin";
  ConsiderDraw d;
  {
    io::LogWriter w(path, sim::make_log_meta(c, sensor, opt));
    const sim::SimSummary sum = sim::simulate(c, sensor, opt, w);
    w.close();
    for (auto it = sum.truth["parameters"].begin(); it != sum.truth["parameters"].end(); ++it)
      if (it.value().is_number()) d.truth.set(it.key(), it.value().get<double>());
  }
  io::LogReader r(path);
  solver::FixtureAccumulator acc(spec, r.meta());
  io::LogRow row;
  while (r.next(row)) acc.add(row);
  acc.finish();
  const solver::Sigma6 sigma = acc.static_noise_sigma();
  d.noise_only = solver::solve_fixture(acc, sigma).estimate;
  d.honest = d.noise_only;
  const auto tol = solver::fixture_tolerance_of(spec, static_cast<int>(c.axes.size()), "model");
  const solver::ConsiderResult cr = solver::consider_fixture_tolerance(r, spec, c, d.noise_only, sigma, *tol);
  solver::apply_consider(d.honest, cr, *tol);
  std::remove(path.c_str());
  return d;
}

}  // namespace mc
