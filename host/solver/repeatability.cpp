#include "host/solver/repeatability.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "host/poses/gravity_fit.h"
#include "host/estimator/robust.h"

namespace imuforge::solver {

Repeatability repeatability(const std::vector<const RawRecording*>& recs, const std::vector<std::string>& names,
                            const model::ModelSpec& spec, const ReferenceFreeOptions& opt) {
  if (recs.size() < 2) throw SolverError("repeatability needs at least two recordings of the unit");
  Repeatability out;
  // Each recording alone with the basic terms only: the spreads compare the same parameters, and a
  // single recording's poses are too few to choose extra terms on for a day-to-day comparison. The joint
  // calibration (all poses) may add extras by cross-validation; they have no per-recording spread.
  ReferenceFreeOptions each_opt = opt;
  each_opt.select_terms = false;
  for (std::size_t r = 0; r < recs.size(); ++r) {
    try {
      out.each.push_back(solve_reference_free(*recs[r], spec, each_opt));
    } catch (const std::exception& e) {
      throw SolverError("recording '" + names[r] + "': " + e.what());
    }
  }
  out.joint = solve_reference_free(recs, spec, opt);
  const std::size_t n = recs.size();
  const Estimate& j = out.joint.estimate;
  const Eigen::VectorXd js = j.sigma();
  for (std::size_t k = 0; k < j.names.size(); ++k) {
    if (out.each.front().estimate.index_of(j.names[k]) < 0) continue;  // an extra term of the joint fit only
    ParameterSpread p;
    p.name = j.names[k];
    p.joint = j.value[static_cast<long>(k)];
    p.joint_sigma = js[static_cast<long>(k)];
    double mean = 0;
    for (const auto& e : out.each) {
      const int i = e.estimate.index_of(p.name);
      p.values.push_back(e.estimate.value[i]);
      p.sigmas.push_back(e.estimate.sigma()[i]);
      mean += p.values.back() / static_cast<double>(n);
    }
    double ss = 0;
    for (double v : p.values) ss += (v - mean) * (v - mean);
    p.spread = std::sqrt(ss / static_cast<double>(n - 1));
    std::vector<double> s = p.sigmas;
    p.sigma = estimator::upper_median_in_place(s);
    p.ratio = p.sigma > 0 ? p.spread / p.sigma : INFINITY;
    p.sigma_covering = std::hypot(p.sigma, p.spread);
    if (p.ratio > kSpreadWarnRatio) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "%s: spread between recordings %.3g is %.1f x its sigma %.3g; sigma does not cover placement or "
                    "day-to-day effects, use %.3g",
                    p.name.c_str(), p.spread, p.ratio, p.sigma, p.sigma_covering);
      out.warnings.push_back(buf);
    }
    out.params.push_back(std::move(p));
  }
  out.cross_rms.resize(static_cast<long>(n), static_cast<long>(n));
  const double g = recs.front()->gravity_mps2;
  for (std::size_t a = 0; a < n; ++a) {
    const poses::GravityFit cal = accel_fit_from_estimate(out.each[a].estimate);
    for (std::size_t b = 0; b < n; ++b)
      out.cross_rms(static_cast<long>(a), static_cast<long>(b)) =
          poses::gravity_rms(out.each[b].intervals, g, [&](const Eigen::Vector3d& y) { return cal.apply(y); });
  }
  const poses::GravityFit jc = accel_fit_from_estimate(j);
  for (std::size_t b = 0; b < n; ++b)
    out.joint_rms.push_back(poses::gravity_rms(out.each[b].intervals, g, [&](const Eigen::Vector3d& y) { return jc.apply(y); }));
  out.self_min = out.cross_min = INFINITY;
  out.self_max = out.cross_max = 0;
  for (long a = 0; a < static_cast<long>(n); ++a)
    for (long b = 0; b < static_cast<long>(n); ++b) {
      const double v = out.cross_rms(a, b);
      if (a == b) {
        out.self_min = std::min(out.self_min, v);
        out.self_max = std::max(out.self_max, v);
      } else {
        out.cross_min = std::min(out.cross_min, v);
        out.cross_max = std::max(out.cross_max, v);
      }
    }
  if (out.cross_max > 2 * out.self_max) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "cross-application: one recording's calibration on another's poses leaves |a|-g RMS %.3g..%.3g m/s^2 "
                  "against %.3g..%.3g self-fit; expect the former on a new recording",
                  out.cross_min, out.cross_max, out.self_min, out.self_max);
    out.warnings.push_back(buf);
  }
  return out;
}

nlohmann::json Repeatability::to_json(const std::vector<std::string>& logs) const {
  nlohmann::json pj = nlohmann::json::array();
  for (const auto& p : params)
    pj.push_back({{"name", p.name}, {"values", p.values}, {"sigmas", p.sigmas}, {"joint", p.joint},
                  {"joint_sigma", p.joint_sigma}, {"spread", p.spread}, {"sigma", p.sigma}, {"spread_over_sigma", p.ratio},
                  {"sigma_covering", p.sigma_covering}});
  nlohmann::json cross = nlohmann::json::array();
  for (long a = 0; a < cross_rms.rows(); ++a) {
    std::vector<double> row(static_cast<std::size_t>(cross_rms.cols()));
    for (long b = 0; b < cross_rms.cols(); ++b) row[static_cast<std::size_t>(b)] = cross_rms(a, b);
    cross.push_back(row);
  }
  nlohmann::json poses = nlohmann::json::array();
  for (const auto& e : each) poses.push_back(e.intervals.size());
  return {{"logs", logs},
          {"poses", poses},
          {"parameters", pj},
          {"gravity_rms_cross_mps2", cross},
          {"gravity_rms_joint_mps2", joint_rms},
          {"self_fit_rms_range_mps2", {self_min, self_max}},
          {"cross_application_rms_range_mps2", {cross_min, cross_max}},
          {"warnings", warnings}};
}

std::string Repeatability::report(const std::vector<std::string>& logs) const {
  std::string s;
  char buf[512];
  std::snprintf(buf, sizeof buf, "repeatability over %zu recordings: %zu of %zu parameters spread beyond %.0f sigma\n",
                each.size(),
                static_cast<std::size_t>(std::count_if(params.begin(), params.end(),
                                                       [](const ParameterSpread& p) { return p.ratio > kSpreadWarnRatio; })),
                params.size(), kSpreadWarnRatio);
  s += buf;
  s += "  accelerometer |a|-g RMS (m/s^2): row = calibration from, column = poses of\n";
  for (long a = 0; a < cross_rms.rows(); ++a) {
    std::snprintf(buf, sizeof buf, "    %-40.40s", logs[static_cast<std::size_t>(a)].c_str());
    s += buf;
    for (long b = 0; b < cross_rms.cols(); ++b) {
      std::snprintf(buf, sizeof buf, " %10.3e%s", cross_rms(a, b), a == b ? "*" : " ");
      s += buf;
    }
    s += "\n";
  }
  s += "    joint calibration                       ";
  for (double v : joint_rms) {
    std::snprintf(buf, sizeof buf, " %10.3e ", v);
    s += buf;
  }
  std::snprintf(buf, sizeof buf, "\n  (* self-fit) self-fit %.3g..%.3g, cross-application %.3g..%.3g m/s^2\n", self_min,
                self_max, cross_min, cross_max);
  s += buf;
  std::snprintf(buf, sizeof buf, "  %-20s %13s %11s %11s %8s %13s\n", "parameter", "joint", "spread", "sigma",
                "spread/s", "sigma_cover");
  s += buf;
  for (const auto& p : params) {
    std::snprintf(buf, sizeof buf, "  %-20s % 13.5e %11.3e %11.3e %8.2f %13.3e%s\n", p.name.c_str(), p.joint, p.spread,
                  p.sigma, p.ratio, p.sigma_covering, p.ratio > kSpreadWarnRatio ? "  WARNING" : "");
    s += buf;
  }
  for (const auto& w : warnings) s += "  warning: " + w + "\n";
  return s;
}

}  // namespace imuforge::solver
