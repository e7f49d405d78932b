// A batch of units calibrated together (docs/eol.md "Batches"): every unit's log solved on a thread pool
// with the station's model and fixture tolerance (honest σ), a pass/fail per unit against the station's
// limits, and the spread of each parameter over the batch with outliers marked. A unit that fails (no
// log, a solve refused, out of limits) never stops the others and is reported with its reason.
//
//   BatchOutcome b = solve_batch(units, station, spec, campaign, {});
//   write_file_atomic(dir + "/batch-report.html", render_batch_report(b, "station-07 batch 12"));
//
// Threading: units are claimed through one atomic counter; each worker writes only its own unit's
// outcome; everything shared (station, spec, campaign) is read-only. No locks, no data races.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "host/eol/station.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/records/store.h"
#include "host/solver/estimate.h"

namespace imuforge::eol {

// One unit's batch solve (host/solver fixture mode) with the station's noise override and fixture
// tolerance: what the single-unit runner and the batch both do with a merged log.
struct UnitSolve {
  solver::Estimate estimate;          // honest covariance when a tolerance is stated and propagated
  Eigen::VectorXd sigma_noise;        // noise-only σ when the tolerance widened the covariance
  nlohmann::json fixture_section;     // cal.json "fixture_tolerance"
  std::string consider_error;         // non-empty: the stated tolerance could not be propagated
  nlohmann::json dwell_scatter;       // cal.json "dwell_scatter" (solver::dwell_scatter_json)
};
// Throws solver::SolverError when the fixture solve is refused, io errors when the log cannot be read.
UnitSolve solve_unit_log(const std::string& log_path, const StationConfig& station, const model::ModelSpec& spec,
                         const physics::Campaign& campaign);

struct BatchUnit {
  std::string slot;      // the nest, e.g. "slot03"
  std::string serial;
  std::string log_path;  // the unit's merged log (log v1)
};

struct UnitOutcome {
  std::string slot, serial, log_path;
  bool solved = false;                 // an estimate exists
  bool pass = false;
  std::vector<std::string> reasons;    // why it failed (empty on pass)
  solver::Estimate estimate;           // σ with the fixture tolerance when the station states one
  Eigen::VectorXd sigma_noise;         // noise-only σ (empty when no tolerance is stated)
  std::vector<records::ParameterRecord> params;  // value, honest σ, limits and pass per parameter
  std::vector<std::string> outliers;   // parameters far from the batch (suspicious even when passing)
  double cpu_s = 0.0;                  // CPU time of this unit's solve (its thread)
  std::string report_href;             // the unit's own report, relative to the batch report ("": none)
  nlohmann::json cal;                  // the unit's cal.json
  // The unit's calibration record id. recorded = true: already in the store (the live station runner's
  // per-unit record), the batch only names it; false: record_batch inserts the unit's record under this
  // id (a new one when empty).
  std::string record_id;
  bool recorded = false;
};

struct ParameterSpread {
  std::string name;
  int n = 0;                   // units with a finite value
  double median = 0.0;
  double robust_sigma = 0.0;   // 1.4826 × median absolute deviation
  double limit_abs = 0.0;      // station limit (0 = none)
};

struct BatchOptions {
  int threads = 0;                  // 0: std::thread::hardware_concurrency()
  // |x − median| > k · robust σ (and > 3 σ of the unit itself). 6, not 3: a batch of 16 units and 42
  // parameters makes 672 comparisons against a MAD that is itself uncertain to ±30 %.
  double outlier_k = 6.0;
  int min_units_for_outliers = 5;   // fewer units: no spread statistics
};

struct BatchOutcome {
  std::vector<UnitOutcome> units;       // input order
  std::vector<ParameterSpread> spread;  // model parameter order
  int passed = 0;
  double wall_s = 0.0;
  int threads = 1;
};

// Throws std::invalid_argument on an empty batch or duplicate slots; every per-unit problem becomes
// that unit's failure reason.
BatchOutcome solve_batch(const std::vector<BatchUnit>& units, const StationConfig& station,
                         const model::ModelSpec& spec, const physics::Campaign& campaign, const BatchOptions& opt = {});

// Fills spread and every unit's outliers from the solved units. O(units · parameters · log units).
void mark_outliers(BatchOutcome& b, const BatchOptions& opt = {});

// The batch report: one self-contained HTML file, verdict first (units passed, each failure with its
// reason, suspicious units), then every unit's row, then each parameter's spread as a strip chart.
std::string render_batch_report(const BatchOutcome& b, const std::string& title);
// Records the batch (docs/eol.md "Records"): one calibration record per unit (a unit without a
// calibration too: its reasons are what the station knows of it; solved units carry their parameters
// with limits and honest σ, no table: a solve of logs flashes nothing), then the batch record naming
// them. Returns the batch id. Throws records::RecordError.
struct BatchProvenance {
  std::string station, campaign, campaign_sha256, started_utc, finished_utc;
  std::string batch_id;  // "" = a new id
};
std::string record_batch(records::RecordStore& store, const BatchOutcome& b,
                         const BatchProvenance& prov);
nlohmann::json batch_to_json(const BatchOutcome& b);

}  // namespace imuforge::eol
