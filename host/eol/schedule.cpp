#include "host/eol/schedule.h"

#include <cmath>
#include <stdexcept>

#include "host/io/campaign_file.h"
#include "host/physics/earth.h"
#include "host/physics/units.h"
#include "host/records/store.h"
#include "host/solver/sha256.h"

namespace imuforge::eol {

std::string step_key(int phase, int step) { return "p" + std::to_string(phase) + "s" + std::to_string(step); }

namespace {
using physics::kDeg;  // host/physics/units.h
}

physics::ImuKinematics Kin::at(const std::array<double, 3>& angle_deg, const std::array<double, 3>& rate_dps) const {
  physics::TableState st;
  for (std::size_t i = 0; i < 3; ++i) {
    st.angle_rad[i] = angle_deg[i] * kDeg;
    st.rate_rad_s[i] = rate_dps[i] * kDeg;
  }
  return physics::table_kinematics(geom, st, g_ned, wie_ned);
}

Kin kinematics_of(const physics::Campaign& c) {
  Kin k;
  // mount_rotation_deg is the IMU's attitude in the platform frame (the eol -> sim convention).
  physics::TableGeometry& g = k.geom;
  g.n_axes = static_cast<int>(c.axes.size());
  for (std::size_t i = 0; i < c.axes.size() && i < 3; ++i) {
    g.axes[i].name = c.axes[i].name;
    g.axes[i].axis_nominal = physics::axis_from_name(c.axes[i].axis);
  }
  g.mount.C_imu_plat =
      physics::rotation_zyx_deg(c.mount_rotation_deg[0], c.mount_rotation_deg[1], c.mount_rotation_deg[2]).transpose();
  g.mount.lever_arm_m = Eigen::Vector3d(c.lever_arm_m[0], c.lever_arm_m[1], c.lever_arm_m[2]);
  physics::Site site{c.latitude_deg, c.height_m};
  k.g_ned = physics::gravity_ned(site);
  k.wie_ned = physics::earth_rate_ned(site);
  return k;
}

bool is_vertical_rotation(const Kin& k, const std::array<double, 3>& angle_deg, const std::array<double, 3>& rate_dps) {
  // Check f a quarter turn later.
  auto a = k.at(angle_deg, rate_dps);
  std::array<double, 3> later = angle_deg;
  for (std::size_t i = 0; i < 3; ++i) later[i] += 90.0 * (rate_dps[i] != 0 ? 1 : 0);
  auto b = k.at(later, rate_dps);
  return (a.f_mps2 - b.f_mps2).norm() < 1e-3;
}

std::vector<std::vector<StepInfo>> build_plan(const physics::Campaign& camp, const Kin& kin,
                                              const std::string& campaign_path, int* total_steps) {
  std::vector<std::vector<StepInfo>> plan(camp.phases.size());
  int total = 0;
  for (std::size_t p = 0; p < camp.phases.size(); ++p) {
    const auto& ph = camp.phases[p];
    std::array<double, 3> pos{};
    if (ph.kind == physics::CampaignPhase::Kind::kRamp) {
      StepInfo si;
      si.phase = static_cast<int>(p);
      si.key = step_key(si.phase, 0);
      si.label = ph.label.empty() ? "ramp" : ph.label;
      si.kind = physics::CampaignStep::Kind::kSoak;
      si.dwell_s = 0;  // until the chamber reaches the setpoint
      plan[p].push_back(si);
      ++total;
      continue;
    }
    for (std::size_t s = 0; s < ph.steps.size(); ++s) {
      const auto& cs = ph.steps[s];
      StepInfo si;
      si.phase = static_cast<int>(p);
      si.step = static_cast<int>(s);
      si.key = step_key(si.phase, si.step);
      si.label = cs.label.empty() ? si.key : cs.label;
      si.kind = cs.kind;
      si.dwell_s = cs.dwell_s;
      switch (cs.kind) {
        case physics::CampaignStep::Kind::kPosition: pos = cs.position_deg; si.position_deg = pos; break;
        case physics::CampaignStep::Kind::kRate:
          si.position_deg = pos;
          si.rate_dps = cs.rate_dps;
          si.accel_ok = is_vertical_rotation(kin, pos, cs.rate_dps);
          break;
        case physics::CampaignStep::Kind::kSoak: si.position_deg = pos; break;
        default:
          throw std::invalid_argument("campaign " + campaign_path + ": phases[" + std::to_string(p) + "].steps[" +
                                      std::to_string(s) + "]: step kind not supported on a station (only position, "
                                      "rate, soak): " + si.label);
      }
      if (!(si.dwell_s > 0)) throw std::invalid_argument("campaign: " + si.key + " has no dwell_s");
      plan[p].push_back(si);
      ++total;
    }
  }
  if (total_steps) *total_steps = total;
  return plan;
}

void narrow_to_slot(StationConfig& st, physics::Campaign& camp, const std::string& slot) {
  const StationSlot* sl = st.slot(slot);
  if (!sl) throw std::invalid_argument("station " + st.name + ": no slot named '" + slot + "'");
  const StationSlot s = *sl;
  st.can_node_id = s.node_id;
  if (!s.bus.empty()) st.can_bus = s.bus;
  if (s.has_geometry) {
    camp.mount_rotation_deg = s.mount_rotation_deg;
    camp.lever_arm_m = s.lever_arm_m;
  }
  if (s.mount_sigma_deg[0] >= 0) {
    if (!st.fixture_tolerance.is_object()) st.fixture_tolerance = nlohmann::json::object();
    st.fixture_tolerance["mount_sigma_deg"] = s.mount_sigma_deg;
  }
}

TableStepEnd table_step_end(const StepInfo& step, const io::LogRow& last_row, int table_axes) {
  TableStepEnd e;
  e.rotation = step.kind == physics::CampaignStep::Kind::kRate;
  e.phase = step.phase;
  e.start_deg = step.position_deg;
  e.have_state = table_axes > 0;
  for (int a = 0; a < table_axes && a < 3; ++a) {
    const auto i = static_cast<std::size_t>(a);
    e.angle_deg[i] = last_row.table_angle_rad[a] / kDeg;
    e.rate_dps[i] = last_row.table_rate_rad_s[a] / kDeg;
    e.have_state = e.have_state && std::isfinite(e.angle_deg[i]) && std::isfinite(e.rate_dps[i]);
  }
  return e;
}

nlohmann::json table_turning_entry(const StepInfo& si, const TableReading& r) {
  return {{"type", "table_turning"}, {"key", si.key}, {"angle_deg", r.angle_deg}, {"rate_dps", r.rate_dps}};
}

StepIndex index_steps(const std::vector<std::vector<StepInfo>>& plan) {
  StepIndex ix;
  for (const auto& ph : plan)
    for (const auto& s : ph) ix[s.key] = &s;
  return ix;
}

std::optional<TableStepEnd> journaled_turning(const std::map<std::string, nlohmann::json>& turning,
                                              const StepIndex& steps, const std::string& key) {
  const auto t = turning.find(key);
  const auto step = steps.find(key);
  if (t == turning.end() || step == steps.end()) return std::nullopt;
  const StepInfo& si = *step->second;
  const nlohmann::json& entry = t->second;
  TableStepEnd e;
  e.rotation = true;
  e.phase = si.phase;
  e.start_deg = si.position_deg;
  const auto a = entry.value("angle_deg", std::vector<double>{});
  const auto w = entry.value("rate_dps", std::vector<double>{});
  e.have_state = a.size() == 3 && w.size() == 3;
  for (std::size_t i = 0; i < 3 && e.have_state; ++i) {
    e.angle_deg[i] = a[i];
    e.rate_dps[i] = w[i];
  }
  return e;
}

namespace {
// `next` is commanded while the table still turns as `prev` left it. Not across plateaus: the settling
// in between lasts as long as the temperature takes, so the phase it leaves is reproduced by nothing.
bool continues_rotation(const TableStepEnd& prev, const StepInfo& next) {
  return next.kind == physics::CampaignStep::Kind::kRate && prev.rotation && prev.phase == next.phase &&
         prev.start_deg == next.position_deg;
}
}  // namespace

TableReading restore_turning(Bench& bench, const TableStepEnd& end, const TableMotion::WaitTable& wait_table,
                             const std::string& what) {
  // The axes that do not turn hold the step's start position (which IMU axis the rotation is about).
  std::array<double, 3> at{};
  for (std::size_t i = 0; i < 3; ++i)
    at[i] = std::fabs(end.rate_dps[i]) < 1e-9 ? end.start_deg[i] : std::remainder(end.angle_deg[i], 360.0);
  bench.command_rate({0, 0, 0});
  bench.command_position(at);
  wait_table(what + " (its start angle)");
  bench.command_rate(end.rate_dps);
  const TableReading r = wait_table(what + " (its rate)");
  std::size_t k = 0;
  for (std::size_t i = 1; i < 3; ++i)
    if (std::fabs(end.rate_dps[i]) > std::fabs(end.rate_dps[k])) k = i;
  const double w_dps = end.rate_dps[k];
  if (std::fabs(w_dps) < 1e-9) return r;
  // The time at which axis k next passes the end angle (modulo a turn), from the reading just taken.
  const double period_s = 360.0 / std::fabs(w_dps);
  const double x_s = (end.angle_deg[k] - r.angle_deg[k]) / w_dps;
  const double dt_s = x_s - std::floor(x_s / period_s) * period_s;
  if (dt_s > 0) bench.wait(dt_s);
  return r;
}

void TableMotion::command(const StepInfo& si) {
  TableStepEnd prev = last_;
  bool restore = false;
  if (first_) {
    // This process has not moved the table yet: its state is whatever the interrupted run left, or the
    // station's idle state, not the state the uninterrupted run commanded this step from.
    prev = before_ ? before_(si.key) : TableStepEnd{};
    restore = true;
  }
  if (si.kind == physics::CampaignStep::Kind::kPosition) {
    bench_.command_rate({0, 0, 0});
    bench_.command_position(si.position_deg);
  } else if (si.kind == physics::CampaignStep::Kind::kRate) {
    const bool continued = continues_rotation(prev, si);
    if (continued && restore && prev.have_state) {
      restore_turning(bench_, prev, wait_, "restoring the rotation before " + si.label);
    } else if (continued && !restore) {
      if (journal_) journal_(si, bench_.table());
    } else {
      // The axes that do not turn must hold the step's start position (it decides which IMU axis the
      // rotation is about): go there first.
      bench_.command_rate({0, 0, 0});
      bench_.command_position(si.position_deg);
      wait_("reaching the start of " + si.label);
    }
    bench_.command_rate(si.rate_dps);
  }
  last_ = TableStepEnd{};
  last_.rotation = si.kind == physics::CampaignStep::Kind::kRate;
  last_.phase = si.phase;
  last_.start_deg = si.position_deg;
  first_ = false;
}

void TableMotion::stopped() {
  last_ = TableStepEnd{};
  first_ = false;
}

JournalContents open_run_journal(const std::filesystem::path& journal_path, bool resume,
                                 std::unique_ptr<Journal>* journal) {
  namespace fs = std::filesystem;
  JournalContents jc;
  if (resume) {
    if (!fs::exists(journal_path)) throw std::invalid_argument("--resume: no journal at " + journal_path.string());
    *journal = std::make_unique<Journal>(Journal::open_existing(journal_path.string(), &jc));
    if (jc.entries.empty() || jc.entries[0]["type"] != "run_start")
      throw JournalCorruptError("journal " + journal_path.string() + " line 1: first entry is not run_start");
  } else if (fs::exists(journal_path)) {
    throw std::invalid_argument(journal_path.parent_path().string() +
                                " already holds a run (journal.log): use --resume, or a new --out");
  }
  return jc;
}

RunInputs load_run_inputs(const std::string& campaign_path, const std::string& station_path,
                          const std::string& db_override, const std::filesystem::path& out_dir) {
  namespace fs = std::filesystem;
  RunInputs in;
  try {
    in.camp = io::load_campaign(campaign_path);
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("campaign: ") + e.what());
  }
  in.st = load_station(station_path);
  if (in.st.model_path.empty())
    throw std::invalid_argument("station " + station_path + ": \"model\" (solver model file) is required");
  const std::string model_path =
      fs::path(in.st.model_path).is_absolute() ? in.st.model_path : (fs::path(in.st.dir) / in.st.model_path).string();
  try {
    in.spec = model::load_model_spec(model_path);
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("model: ") + e.what());
  }
  in.campaign_sha256 = solver::sha256_file_hex(campaign_path);
  in.station_sha256 = solver::sha256_file_hex(station_path);
  in.db = !db_override.empty() ? db_override : in.st.db;
  if (!records::is_postgres_url(in.db) && !fs::path(in.db).is_absolute()) in.db = (out_dir / in.db).string();
  return in;
}

}  // namespace imuforge::eol
