// The live multi-unit run (issue 14, docs/eol.md "Multi-unit stations"): one campaign for every slot of a
// station. The chamber and the table settle once; during every segment each unit is streamed on its own
// thread (one CAN client per node) into its own segment file, journal and tracker (steering on the
// honest σ); the step choice and the early stop serve all units (stop when every live unit meets spec);
// the verification poses are streamed for every unit at once. Then, on a thread pool, each unit is
// finished by the single-unit Runner resuming its own folder (solve, table, flash, read back, kernel
// check on the pre-collected verification segments, pass/fail, record, report), and the batch is
// recorded and reported with outliers (batch.h).
//
// A unit that fails (no answer, a stream that stops, a flash refused, out of limits) never stops the
// others: it is recorded with its reason. Folder layout: DIR/journal.log (station: run_start,
// unit_failed, batch_recording, batch_recorded, finished), DIR/<slot>/ (a single-unit run folder with
// "slot" in its run_start), DIR/batch.json, DIR/batch-report.html.
//
// Resume is per unit: a step a unit already made safe is never re-collected for it (the table still
// runs the step for the units that lack it), a unit already finished is not finished again, and record
// ids are chosen and journaled before any insert, so a crash anywhere and --resume give one record per
// unit and one batch record.
#pragma once
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "host/eol/batch.h"
#include "host/eol/ports.h"
#include "host/eol/station.h"

namespace imuforge::eol {

struct StationRunOptions {
  std::string out_dir;
  std::string campaign_path;
  std::string station_path;
  std::string db;               // overrides the station's records.db when non-empty
  bool resume = false;
  bool early_stop = true;       // AND the station's early_stop
  int threads = 0;              // finish pool; 0 = std::thread::hardware_concurrency()
  std::FILE* progress = stderr; // nullptr: silent
  // Test hook: throw SimulatedCrash after this many steps were made safe in THIS process (0 = off).
  int crash_after_steps = 0;
};

struct StationUnitResult {
  std::string slot, serial, dir, record_id, report_path;
  bool pass = false;
  bool collected = false;        // the unit answered and was streamed through the campaign
  std::vector<std::string> reasons;
  double finish_cpu_s = 0.0;     // CPU of this unit's finish (solve, table, flash, verify, record) on its thread
};

struct StationRunResult {
  std::vector<StationUnitResult> units;  // slot order
  int passed = 0;
  std::string batch_id, batch_report_path, db;
  double campaign_time_s = 0.0;          // fixture time of the collection (shared by all units)
  double schedule_time_s = 0.0;          // the campaign's nominal duration
  int steps_collected = 0;               // table steps run in this process
  int steps_total = 0;
  bool early_stopped = false;
  double collect_wall_s = 0.0, finish_wall_s = 0.0;
  BatchOutcome batch;
};

// Opens a unit's device for a station narrowed to its slot (node id, bus). May throw: the unit fails.
using DeviceFactory = std::function<std::unique_ptr<Device>(const StationConfig& slot_station)>;
using TableOpsFactory = std::function<std::unique_ptr<TableOps>()>;

class StationRunner {
 public:
  StationRunner(StationRunOptions opt, Bench& bench, DeviceFactory devices, TableOpsFactory table_ops);
  // Throws std::invalid_argument (usage, bad input), PeerError (the bench), JournalError. Unit failures
  // are results, not exceptions.
  StationRunResult run();

 private:
  StationRunOptions opt_;
  Bench& bench_;
  DeviceFactory devices_;
  TableOpsFactory table_ops_;
};

}  // namespace imuforge::eol
