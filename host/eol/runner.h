// The end-of-line run (docs/eol.md): for each temperature plateau, set the chamber and wait for the IMU
// temperature to settle (from data); for each step, command the table and wait for in-position +
// settled; collect the segment to DIR/segments/ (fsync'd) and journal it; update the recursive
// estimate; stop early once every σ meets its spec; then solve, build the table, flash it, read it back,
// verify at the station's verification poses with the firmware kernel, decide pass/fail, record, report.
// A run is resumable: Runner with resume = true continues from the journal in DIR.
#pragma once
#include <cstdio>
#include <string>
#include <vector>

#include "host/eol/ports.h"
#include "host/eol/station.h"
#include "host/eol/tracker.h"
#include "host/records/record.h"
#include "host/physics/campaign.h"

namespace imuforge::eol {

struct RunOptions {
  std::string out_dir;
  std::string serial;           // expected device serial (checked against identify())
  std::string campaign_path;
  std::string station_path;
  std::string db;               // overrides the station's records.db when non-empty
  bool resume = false;
  // The unit's slot in a multi-slot station (StationRunner finishes each unit with it): the slot's node,
  // nest geometry and mount tolerance replace the station's single-unit ones. "" = single-unit station.
  std::string slot;
  bool early_stop = true;       // AND the station's early_stop
  std::FILE* progress = stderr; // nullptr: silent
  // Test hook: throw SimulatedCrash after this many segments were made safe in THIS process (0 = off).
  int crash_after_segments = 0;
};

// Thrown only by the crash_after_segments test hook.
struct SimulatedCrash : std::runtime_error {
  SimulatedCrash() : std::runtime_error("simulated crash (test hook)") {}
};

// A failure of an external peer (fixture, CAN, database): exit code 3.
struct PeerError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct RunResult {
  bool pass = false;
  std::vector<std::string> reasons;
  std::string report_path;
  std::string record_id;
  std::string db;
  double campaign_time_s = 0.0;      // fixture time from the first chamber command to the last segment
  double schedule_time_s = 0.0;      // the campaign's nominal duration (full schedule)
  int segments_collected = 0;        // in this process
  int segments_resumed = 0;          // made safe by an earlier process, not re-collected
  int segments_total = 0;            // steps in the campaign
  bool early_stopped = false;
  solver::Estimate estimate;
  records::CalibrationRecord record;
};

class Runner {
 public:
  Runner(RunOptions opt, Bench& bench, Device& device, TableOps& table);
  // Runs (or resumes) to the end. Throws on a usage problem (std::invalid_argument), a peer failure
  // (PeerError), or a damaged journal (JournalError). A FAIL verdict is a normal return with pass=false.
  RunResult run();

 private:
  RunOptions opt_;
  Bench& bench_;
  Device& dev_;
  TableOps& table_;
};

// The campaign's schedule flattened for the runner: phase p, step s -> key "p<p>s<s>".
std::string step_key(int phase, int step);

}  // namespace imuforge::eol
