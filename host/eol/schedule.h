// The campaign as a station runs it, shared by the single-unit runner (runner.cpp) and the multi-unit
// station runner (station_runner.cpp): the flattened step list ("p<phase>s<step>"), the table kinematics
// of a nest (nominal geometry of the campaign, or a slot's mount and lever arm), and a station file
// narrowed to one slot. One schedule, so both runners collect the same segments under the same keys.
#pragma once
#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "host/eol/journal.h"
#include "host/eol/station.h"
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
