// The campaign as a station runs it, shared by the single-unit runner (runner.cpp) and the multi-unit
// station runner (station_runner.cpp): the flattened step list ("p<phase>s<step>"), the table kinematics
// of a nest (nominal geometry of the campaign, or a slot's mount and lever arm), and a station file
// narrowed to one slot. One schedule, so both runners collect the same segments under the same keys.
#pragma once
#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host/eol/journal.h"
#include "host/eol/ports.h"
#include "host/eol/station.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/physics/campaign.h"
#include "host/physics/table.h"

namespace imuforge::eol {

// The campaign's schedule flattened: phase p, step s -> key "p<p>s<s>" (also declared in runner.h).
std::string step_key(int phase, int step);

// One step's table command and label.
struct StepInfo {
  int phase = 0, step = 0;
  std::string key, label;
  physics::CampaignStep::Kind kind = physics::CampaignStep::Kind::kPosition;
  std::array<double, 3> position_deg{};  // the table position during the dwell (for rates: the start)
  std::array<double, 3> rate_dps{};
  double dwell_s = 0.0;
  bool accel_ok = true;  // the reference specific force is constant over the dwell
};

// Reference kinematics at the IMU for reported table angles and rates.
struct Kin {
  physics::TableGeometry geom;
  Eigen::Vector3d g_ned, wie_ned;
  physics::ImuKinematics at(const std::array<double, 3>& angle_deg, const std::array<double, 3>& rate_dps) const;
};
Kin kinematics_of(const physics::Campaign& c);

// The reference f stays constant in a rate run when the rotation is about the local vertical.
bool is_vertical_rotation(const Kin& k, const std::array<double, 3>& angle_deg, const std::array<double, 3>& rate_dps);

// plan[p] = the steps of phase p (a ramp phase is one soak step). Throws std::invalid_argument naming the
// step on a kind a station cannot run or a step without dwell_s.
std::vector<std::vector<StepInfo>> build_plan(const physics::Campaign& camp, const Kin& kin,
                                              const std::string& campaign_path, int* total_steps);

// Where a step left the table: the state a rotation that continues it (CW then CCW from the same start,
// commanded while the table still turns) starts from. The continued rotation's data depend on the
// table's phase when it was commanded, so a resumed run must recreate that state (TableMotion).
struct TableStepEnd {
  bool rotation = false;                 // the step was a rate run
  int phase = -1;                        // its phase (-1: none, or a verification pose)
  std::array<double, 3> start_deg{};     // its start position (the plan's)
  bool have_state = false;               // angle_deg/rate_dps known
  std::array<double, 3> angle_deg{};     // the table at the step's last sample (reported angles and rates,
  std::array<double, 3> rate_dps{};      // as logged in the segment's rows)
};
// From the step and its safe segment's last row. No state when the log has no table angles (a segment
// file written before the rows carried them): the continued rotation then starts from its start position.
TableStepEnd table_step_end(const StepInfo& step, const io::LogRow& last_row, int table_axes);

// The journal entry `table_turning` (key, angle_deg, rate_dps): the table read just before a continued
// rotation `si` was commanded, appended before the command. The exact state a resume must recreate (the
// previous segment's last row is that state only when no table time passes between the two: a real host
// hashes, journals and folds in between). A journal without it (written before, or a kill between
// segment_done and this entry) falls back on the previous segment's last row.
nlohmann::json table_turning_entry(const StepInfo& si, const TableReading& r);
// The plan's steps by key (pointers into `plan`, which must outlive the index).
using StepIndex = std::map<std::string, const StepInfo*>;
StepIndex index_steps(const std::vector<std::vector<StepInfo>>& plan);
// After a resume: the state the `table_turning` entry journaled for step `key` holds (`turning`: the
// journal's entries by step key), as the end of the step it continued; nullopt when none was journaled
// for it (the caller then falls back on the previous segment's last row) or `key` is not in the plan.
std::optional<TableStepEnd> journaled_turning(const std::map<std::string, nlohmann::json>& turning,
                                              const StepIndex& steps, const std::string& key);

// The table's motion from step to step, shared by both runners. A position step stops the table and
// moves; a rate step goes to its start position first unless the previous step was a rotation of the
// same plateau from the same start (then it is commanded while the table turns: CW then CCW). The first
// step a resumed process runs asks `before(key)` for the step the interrupted process collected before
// it: when that step continues a rotation, the table is first brought back to that step's end state
// (restore_turning), so the re-run segment meets gravity at the same phase as in an uninterrupted run.
class TableMotion {
 public:
  using WaitTable = std::function<TableReading(const std::string& what)>;
  // journal_turning(si, reading): appends table_turning_entry before a continued rotation is commanded.
  using JournalTurning = std::function<void(const StepInfo& si, const TableReading& r)>;
  TableMotion(Bench& bench, WaitTable wait_table, JournalTurning journal_turning)
      : bench_(bench), wait_(std::move(wait_table)), journal_(std::move(journal_turning)) {}
  void on_resume(std::function<TableStepEnd(const std::string& key)> before) { before_ = std::move(before); }
  // Commands the table for `si`; the caller then waits for in-position and settled. Throws what the
  // bench or wait_table throws.
  void command(const StepInfo& si);
  // The table was stopped: the next rotation starts from its start position.
  void stopped();

 private:
  Bench& bench_;
  WaitTable wait_;
  JournalTurning journal_;
  std::function<TableStepEnd(const std::string&)> before_;
  TableStepEnd last_;  // the last step commanded by this process
  bool first_ = true;
};

// Brings the table to `end`'s state: at its angles and turning at its rates (one full spin-up, then a
// wait of less than one turn so that the fastest-turning axis passes end.angle_deg, modulo 360°, when
// this returns; with several axes turning at once only the fastest is phase-matched). Returns the
// reading the wait was computed from.
TableReading restore_turning(Bench& bench, const TableStepEnd& end, const TableMotion::WaitTable& wait_table,
                             const std::string& what);

// A multi-slot station narrowed to one slot: the slot's node and bus, its nest geometry in the campaign
// (mount rotation, lever arm) and its mount tolerance in the fixture tolerance. What imuforge batch does
// per unit, so the live runner and the offline batch solve the same problem. Throws std::invalid_argument
// on an unknown slot.
void narrow_to_slot(StationConfig& st, physics::Campaign& camp, const std::string& slot);

// The run folder's journal, as both runners open it. resume: the existing journal (its first entry must
// be run_start; that entry carries the run's inputs) is opened into *journal and its contents returned.
// Otherwise the folder must not hold a journal yet, *journal stays empty (the caller creates it once its
// inputs load) and the contents are empty. Throws std::invalid_argument or JournalCorruptError naming
// the file. O(journal size).
JournalContents open_run_journal(const std::filesystem::path& journal_path, bool resume,
                                 std::unique_ptr<Journal>* journal);

// What both runners load before anything moves: the campaign, the station, the station's solver model,
// the SHA-256 of the campaign and station files (a resume refuses changed inputs), and the records
// database (db_override, else the station's; a relative SQLite path lies under out_dir). Throws
// std::invalid_argument naming the file or key.
struct RunInputs {
  physics::Campaign camp;
  StationConfig st;
  model::ModelSpec spec;
  std::string campaign_sha256, station_sha256, db;
};
RunInputs load_run_inputs(const std::string& campaign_path, const std::string& station_path,
                          const std::string& db_override, const std::filesystem::path& out_dir);

}  // namespace imuforge::eol
