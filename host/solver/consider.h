// Honest σ under fixture tolerance: a consider (Schmidt) analysis of the fixture parameters a solve does
// not estimate.
//
// A fixture-mode solve trusts the rate table: its axis tilts and encoder zeros and the nest's mount
// rotation are taken as nominal. The real ones differ by up to the fixture's tolerance, and no campaign
// can tell a mount rotation from a common rotation of both triads' misalignments (fixture_errors.h), so
// more data never removes that error. A σ from the noise alone then claims a precision the station does
// not have. The consider analysis keeps the estimator unchanged and widens its covariance:
//
//   to first order a fixture error δη moves the estimate by δθ̂ = S·δη,  S = P·H_θη,
//   P = H_θθ⁻¹ (the noise-only covariance),
//   P_honest = P + S·Σ_η·Sᵀ,  Σ_η = diag(tolerance σ²)
//
// where H_θη is the model × fixture block of the joint information (fixture_joint_information(), the
// same linearisation the fixture+errors solve uses). Parameters that the solve does estimate (the free
// nuisance parameters of fixture+errors) belong to θ; only the rest are considered.
//
// Where the tolerance comes from: "fixture_tolerance" in the model file (docs/formats.md), or a station
// slot's tolerance (docs/eol.md). Values are 1σ, in degrees:
//   "fixture_tolerance": {"axes": {"tilt_sigma_deg": 0.005, "zero_sigma_deg": 0.01},   (all axes)
//                         "mount_sigma_deg": 0.03}                                     (or [x, y, z])
// "axes" may instead be a list with one such object per table axis, innermost first.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/solver/estimate.h"
#include "host/solver/fixture.h"

namespace imuforge::solver {

struct FixtureTolerance {
  std::vector<std::array<double, 3>> axis_sigma_rad;  // per table axis, innermost first: tilt_a, tilt_b, zero (1σ)
  std::array<double, 3> mount_sigma_rad{};             // rotation of the IMU in its nest, about x, y, z (1σ)
  // 1σ of a nuisance parameter named as in fixture_nuisance_names(); 0 for an axis the tolerance does
  // not list. O(1).
  double sigma_of(const std::string& nuisance_name) const;
  nlohmann::json to_json() const;  // the same format as read, degrees
};

// Parses a "fixture_tolerance" object. `where` prefixes every error message (e.g. "model 'm.json'");
// throws SolverError naming the key on a missing, negative or non-finite value, an unknown key, or a
// list of axes whose length differs from n_axes.
FixtureTolerance fixture_tolerance_from_json(const nlohmann::json& j, int n_axes, const std::string& where);
// The model's "fixture_tolerance", if stated.
std::optional<FixtureTolerance> fixture_tolerance_of(const model::ModelSpec& spec, int n_axes, const std::string& where);

struct ConsiderResult {
  Eigen::MatrixXd covariance;             // P + S Σ Sᵀ, over the estimate's names
  Eigen::MatrixXd sensitivity;            // S = ∂θ̂/∂η (estimate × considered)
  std::vector<std::string> considered;    // nuisance parameters with a nonzero tolerance, not estimated
  Eigen::VectorXd considered_sigma;       // their tolerance σ, rad
  // Per estimate parameter: the considered parameter contributing most to its fixture variance ("" if none).
  std::vector<std::string> dominant;
};

// `est` holds the model parameters in spec order, then (fixture+errors) the nuisance parameters it
// estimated, with the noise-only covariance; `sigma` the per-channel noise σ the solve weighted with.
// One streaming pass over the log (rewound first). Throws SolverError when the log cannot be linearised
// against the campaign's table (fixture_joint_information()).
ConsiderResult consider_fixture_tolerance(io::LogReader& log, const model::ModelSpec& spec, const physics::Campaign& campaign,
                                          const Estimate& est, const Sigma6& sigma, const FixtureTolerance& tol);

// Replaces est.covariance by r.covariance (the honest one) and returns the cal.json "fixture_tolerance"
// section: {"stated": true, "tolerance": .., "considered": [..], "sigma_covers": ..}. The noise-only σ
// (before) goes to *sigma_noise when given.
nlohmann::json apply_consider(Estimate& est, const ConsiderResult& r, const FixtureTolerance& tol,
                              Eigen::VectorXd* sigma_noise = nullptr);
// The section when no tolerance is stated: σ covers the noise only, and the file says so.
nlohmann::json fixture_tolerance_not_stated();

}  // namespace imuforge::solver
