// The live multi-unit run: see station_runner.h. One piece because collection, per-unit resume and the
// batch record share the unit state below; the per-unit finish is the single-unit Runner's.
#include "host/eol/station_runner.h"

#include <time.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "host/eol/journal.h"
#include "host/eol/report.h"
#include "host/eol/runner.h"
#include "host/eol/schedule.h"
#include "host/eol/settle.h"
#include "host/eol/tracker.h"
#include "host/io/campaign_file.h"
#include "host/io/log.h"
#include "host/physics/earth.h"
#include "host/physics/units.h"
#include "host/records/store.h"
#include "host/solver/consider.h"
#include "host/solver/sha256.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace imuforge::eol {

namespace {

using physics::kDeg;  // host/physics/units.h

double now_wall() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// The bench seen by a unit's finish: everything that moves the table happened during collection (the
// verification poses included), so a finish that tries to move it is a bug, said loudly.
class FinishBench final : public Bench {
 public:
  explicit FinishBench(std::string d) : d_(std::move(d)) {}
  std::string describe() const override { return d_; }
  void set_chamber(double, double) override { nope(); }
  double chamber_air_C() override { return nope(); }
  void command_position(const std::array<double, 3>&) override { nope(); }
  void command_rate(const std::array<double, 3>& r) override {
    if (r[0] != 0 || r[1] != 0 || r[2] != 0) nope();  // the runner's final "stop the table" is harmless
  }
  TableReading table() override {
    nope();
    return {};
  }
  double time_s() override { return 0.0; }
  void wait(double) override { nope(); }

 private:
  static double nope() { throw std::logic_error("station runner: a unit's finish tried to move the bench"); }
  std::string d_;
};

struct Unit {
  std::string slot, dir, serial;
  StationConfig st;          // narrowed to the slot
  physics::Campaign camp;    // the slot's nest geometry
  Kin kin;
  std::unique_ptr<Device> dev;
  DeviceInfo info;
  io::LogMeta meta;
  std::unique_ptr<Journal> journal;
  std::unique_ptr<Tracker> tracker;
  std::set<std::string> done;        // calibration steps safe
  std::set<std::string> verified;    // verification segments safe
  std::vector<bool> phase_done;
  // The safe segments in collection order with where each left the table (a resume re-runs a continued
  // rotation from its predecessor's end state: TableMotion, schedule.h).
  std::vector<std::pair<std::string, TableStepEnd>> order;
  int segments = 0;
  bool alive = true, collection_done = false;
  std::string failure;               // why it is not alive
  double temp_offset_C = 0.0;
  std::map<std::pair<int, int>, Eigen::MatrixXd> info_cache;
  StationUnitResult result;
  // Filled by the finish.
  bool finished = false;
  RunResult run;
};

}  // namespace

StationRunner::StationRunner(StationRunOptions opt, Bench& bench, DeviceFactory devices, TableOpsFactory table_ops)
    : opt_(std::move(opt)), bench_(bench), devices_(std::move(devices)), table_ops_(std::move(table_ops)) {}

StationRunResult StationRunner::run() {
  const double wall0 = now_wall();
  StationRunResult res;
  if (opt_.out_dir.empty()) throw std::invalid_argument("--out DIR is required");
  const fs::path out = fs::absolute(opt_.out_dir);
  const fs::path jpath = out / "journal.log";

  // ---- the station journal and the inputs (schedule.h, shared with the single-unit runner) ----------
  std::unique_ptr<Journal> journal;
  JournalContents jc = open_run_journal(jpath, opt_.resume, &journal);
  if (opt_.resume) {
    const json& s0 = jc.entries[0];
    if (opt_.campaign_path.empty()) opt_.campaign_path = s0.value("campaign_path", "");
    if (opt_.station_path.empty()) opt_.station_path = s0.value("station_path", "");
    if (opt_.db.empty()) opt_.db = s0.value("db", "");
    opt_.early_stop = opt_.early_stop && s0.value("early_stop", true);
  }
  if (opt_.campaign_path.empty() || opt_.station_path.empty())
    throw std::invalid_argument("--campaign and --station are required");

  RunInputs in = load_run_inputs(opt_.campaign_path, opt_.station_path, opt_.db, out);
  const physics::Campaign& camp = in.camp;
  const StationConfig& st = in.st;
  const model::ModelSpec& spec = in.spec;
  if (st.slots.empty()) throw std::invalid_argument("station " + opt_.station_path + " lists no slots");
  const std::string& campaign_sha = in.campaign_sha256;
  const std::string& station_sha = in.station_sha256;
  const std::string& db = in.db;
  res.db = db;

  fs::create_directories(out);
  if (!journal) {
    json slots = json::array();
    for (const auto& s : st.slots) slots.push_back(s.name);
    journal = std::make_unique<Journal>(Journal::create(jpath.string()));
    journal->append({{"type", "run_start"}, {"campaign_path", fs::absolute(opt_.campaign_path).string()},
                     {"campaign_sha256", campaign_sha}, {"station_path", fs::absolute(opt_.station_path).string()},
                     {"station_sha256", station_sha}, {"db", opt_.db}, {"early_stop", opt_.early_stop},
                     {"software_version", IMUFORGE_VERSION}, {"started_utc", records::utc_now_iso8601()},
                     {"slots", slots}});
    jc = read_journal(jpath.string());
  } else {
    const json& s0 = jc.entries[0];
    if (s0.value("campaign_sha256", "") != campaign_sha)
      throw std::invalid_argument("--resume: the campaign file changed since the run started (" + opt_.campaign_path + ")");
    if (s0.value("station_sha256", "") != station_sha)
      throw std::invalid_argument("--resume: the station file changed since the run started (" + opt_.station_path + ")");
  }
  const std::string started_utc = jc.entries[0].value("started_utc", records::utc_now_iso8601());
  std::map<std::string, std::string> failed_before;  // slot -> reason, from unit_failed entries
  json batch_recording, batch_recorded, finished;
  std::map<std::string, json> turning;  // table_turning entries by step key (schedule.h)
  for (const auto& e : jc.entries) {
    const std::string type = e.value("type", "");
    if (type == "unit_failed") failed_before[e.value("slot", "")] = e.value("reason", "");
    else if (type == "table_turning") turning[e.value("key", "")] = e;
    else if (type == "batch_recording") batch_recording = e;
    else if (type == "batch_recorded") batch_recorded = e;
    else if (type == "finished") finished = e;
  }

  // ---- the schedule (the table is common; each unit has its own nest geometry) ---------------------
  int total_steps = 0;
  const std::vector<std::vector<StepInfo>> plan = build_plan(camp, kinematics_of(camp), opt_.campaign_path, &total_steps);
  res.steps_total = total_steps;
  res.schedule_time_s = camp.nominal_duration_s();
  const StepIndex step_by_key = index_steps(plan);

  // ---- the units ------------------------------------------------------------------------------------
  std::vector<Unit> units(st.slots.size());
  double run_clock_base = 0.0;
  bool early_stopped = false;
  auto fail_unit = [&](Unit& u, const std::string& why) {
    u.alive = false;
    u.failure = why;
    journal->append({{"type", "unit_failed"}, {"slot", u.slot}, {"reason", why}});
    if (opt_.progress) std::fprintf(opt_.progress, "%s: FAILED: %s\n", u.slot.c_str(), why.c_str());
  };
  for (std::size_t k = 0; k < units.size(); ++k) {
    Unit& u = units[k];
    u.slot = st.slots[k].name;
    u.dir = (out / u.slot).string();
    u.st = st;
    u.camp = camp;
    narrow_to_slot(u.st, u.camp, u.slot);
    u.kin = kinematics_of(u.camp);
    u.phase_done.assign(camp.phases.size(), false);
    u.result.slot = u.slot;
    u.result.dir = u.dir;
    if (failed_before.count(u.slot)) {
      u.alive = false;
      u.failure = failed_before[u.slot];
      continue;
    }
    if (!u.st.fixture_tolerance.is_null()) {
      try {
        solver::fixture_tolerance_from_json(u.st.fixture_tolerance, static_cast<int>(camp.axes.size()),
                                            "station " + opt_.station_path + " slot " + u.slot);
      } catch (const solver::SolverError& e) {
        throw std::invalid_argument(e.what());
      }
    }
    try {
      u.dev = devices_(u.st);
      u.info = u.dev->identify();
    } catch (const std::exception& e) {
      fail_unit(u, "no answer from node " + std::to_string(u.st.can_node_id) + " on " + u.st.can_bus + ": " + e.what());
      continue;
    }
    u.serial = u.info.serial;
    u.result.serial = u.serial;
    if (!(u.info.accel_lsb_mps2 > 0) || !(u.info.gyro_lsb_rad_s > 0)) {
      fail_unit(u, "device " + u.serial + " reports no accelerometer/gyro LSB");
      continue;
    }
    u.tracker = std::make_unique<Tracker>(spec);
    u.tracker->set_noise(st.accel_noise_mps2, st.gyro_noise_rad_s);
    if (!u.st.fixture_tolerance.is_null())
      u.tracker->set_fixture_tolerance(solver::fixture_tolerance_from_json(u.st.fixture_tolerance,
                                                                          static_cast<int>(camp.axes.size()), u.slot),
                                       spec, u.camp);
    io::LogMeta& meta = u.meta;
    meta.serial = u.serial;
    meta.sample_rate_hz = u.dev->effective_rate_hz(st.stream_rate_hz);
    meta.accel_lsb_mps2 = u.info.accel_lsb_mps2;
    meta.gyro_lsb_rad_s = u.info.gyro_lsb_rad_s;
    meta.accel_bits = u.info.accel_raw_bits;
    meta.gyro_bits = u.info.gyro_raw_bits;
    meta.latitude_deg = camp.latitude_deg;
    meta.height_m = camp.height_m;
    meta.gravity_mps2 = physics::normal_gravity_mps2(physics::Site{camp.latitude_deg, camp.height_m});
    meta.table_axes = static_cast<int>(camp.axes.size());
    meta.set("source", "imuforge-run");
    meta.set("campaign", camp.name);
    meta.set("station", st.name);
    meta.set("slot", u.slot);

    const fs::path ujp = fs::path(u.dir) / "journal.log";
    fs::create_directories(fs::path(u.dir) / "segments");
    if (fs::exists(ujp)) {
      JournalContents ujc;
      u.journal = std::make_unique<Journal>(Journal::open_existing(ujp.string(), &ujc));
      if (ujc.entries.empty() || ujc.entries[0].value("type", "") != "run_start")
        throw JournalCorruptError("journal " + ujp.string() + " line 1: first entry is not run_start");
      if (ujc.entries[0].value("serial", "") != u.serial)
        throw std::invalid_argument("--resume: " + u.slot + " held serial " + ujc.entries[0].value("serial", "") +
                                    ", the node now identifies as " + u.serial);
      for (const auto& e : ujc.entries) {
        const std::string type = e.value("type", "");
        if (type == "segment_done") {
          const std::string file = (fs::path(u.dir) / e.at("file").get<std::string>()).string();
          if (!fs::exists(file) || solver::sha256_file_hex(file) != e.at("sha256").get<std::string>())
            throw JournalError("journal " + ujp.string() + " says segment " + e.at("key").get<std::string>() +
                               " is safe in " + file + " but the file is missing or its SHA-256 differs");
          io::LogReader r(file);
          std::vector<io::LogRow> rows;
          io::LogRow row;
          while (r.next(row)) rows.push_back(row);
          u.tracker->add_segment(r.meta(), rows, u.segments, e.value("label", ""));
          u.tracker->add_fixture_segment(file);
          const auto step = step_by_key.find(e.at("key").get<std::string>());
          if (step != step_by_key.end() && !rows.empty())
            u.order.emplace_back(step->first, table_step_end(*step->second, rows.back(), r.meta().table_axes));
          ++u.segments;
          u.done.insert(e.at("key").get<std::string>());
          run_clock_base = std::max(run_clock_base, e.value("t_end_s", 0.0));
        } else if (type == "verify_segment") {
          u.verified.insert(e.at("key").get<std::string>());
        } else if (type == "plateau_done") {
          u.phase_done[e.at("phase").get<std::size_t>()] = true;
        } else if (type == "collection_done") {
          u.collection_done = true;
          early_stopped = early_stopped || e.value("early_stop", false);
          run_clock_base = std::max(run_clock_base, e.value("t_s", 0.0));
        }
      }
    } else {
      u.journal = std::make_unique<Journal>(Journal::create(ujp.string()));
      u.journal->append({{"type", "run_start"}, {"serial", u.serial},
                         {"campaign_path", fs::absolute(opt_.campaign_path).string()}, {"campaign_sha256", campaign_sha},
                         {"station_path", fs::absolute(opt_.station_path).string()}, {"station_sha256", station_sha},
                         {"db", db}, {"early_stop", opt_.early_stop}, {"software_version", IMUFORGE_VERSION},
                         {"started_utc", started_utc}, {"slot", u.slot}});
    }
  }
  std::vector<Unit*> live;
  auto refresh_live = [&] {
    live.clear();
    for (auto& u : units)
      if (u.alive) live.push_back(&u);
  };
  refresh_live();
  if (opt_.progress)
    std::fprintf(opt_.progress, "station %s: %zu slot(s), %zu answering%s\n", st.name.c_str(), units.size(), live.size(),
                 opt_.resume ? " (resumed)" : "");

  // σ specs (the same limits for every unit).
  const int n = static_cast<int>(spec.parameters().size());
  Eigen::VectorXd sigma_spec = Eigen::VectorXd::Zero(n);
  bool have_spec = false;
  {
    Tracker names_only(spec);
    for (int i = 0; i < n; ++i) {
      const ParamLimit* l = st.limit_for(names_only.names()[static_cast<std::size_t>(i)]);
      if (l && l->sigma_max > 0) {
        sigma_spec[i] = l->sigma_max * st.early_stop_sigma_fraction;
        have_spec = true;
      }
    }
  }
  const bool early = opt_.early_stop && st.early_stop && have_spec;
  auto meets = [&](const Eigen::VectorXd& sig) {
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(sig[i])) return false;
      if (sigma_spec[i] > 0 && sig[i] > sigma_spec[i]) return false;
    }
    return true;
  };
  auto badness = [&](const Eigen::VectorXd& sig) {
    double b = 0;
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(sig[i]) || sig[i] > 1e12) b += 100;
      else if (sigma_spec[i] > 0) b += std::log(std::max(sig[i] / sigma_spec[i], 1.0));
    }
    return b;
  };
  auto with_floor = [&](const Tracker& t, const Eigen::VectorXd& sig) {
    const Eigen::VectorXd f = t.fixture_variance();
    Eigen::VectorXd h = sig;
    for (Eigen::Index i = 0; i < h.size(); ++i)
      if (std::isfinite(h[i])) h[i] = std::sqrt(h[i] * h[i] + f[i]);
    return h;
  };
  auto all_meet = [&] {
    bool any = false;
    for (Unit* u : live) {
      if (u->tracker->segments() == 0 || !meets(u->tracker->honest_sigma())) return false;
      any = true;
    }
    return any;
  };

  // ---- collection ---------------------------------------------------------------------------------
  std::mutex bench_mu;  // the bench (one Modbus link) is shared by the units' stream threads
  auto bench_call = [&](auto&& f) {
    std::lock_guard<std::mutex> lk(bench_mu);
    return f();
  };
  const double bench_t0 = bench_call([&] { return bench_.time_s(); });
  auto run_clock = [&] { return run_clock_base + (bench_call([&] { return bench_.time_s(); }) - bench_t0); };
  double last_air_C = NAN;
  int steps_here = 0;

  auto wait_table = [&](const std::string& what) {
    const double t0 = bench_.time_s();
    for (;;) {
      TableReading r = bench_.table();
      if (r.fault) throw PeerError("rate table fault while " + what + ": " + r.fault_text);
      if (r.in_position && r.settled) return r;
      if (bench_.time_s() - t0 > st.table_timeout_s)
        throw PeerError("rate table not in position and settled within " + std::to_string(st.table_timeout_s) +
                        " s while " + what);
      bench_.wait(0.1);
    }
  };
  // After a resume, the state the interrupted run commanded `key` from: its table_turning entry in the
  // station journal; else the end of the step collected before it: in a unit that has `key` (a step re-run
  // for the units that lack it), the segment before it; else the last segment of the unit that got furthest.
  TableMotion motion(
      bench_, [&](const std::string& what) { return wait_table(what); },
      [&](const StepInfo& si, const TableReading& r) { journal->append(table_turning_entry(si, r)); });
  if (opt_.resume)
    motion.on_resume([&units, &turning, &step_by_key](const std::string& key) {
      if (const auto j = journaled_turning(turning, step_by_key, key)) return *j;
      const Unit* furthest = nullptr;
      for (const Unit& u : units) {
        for (std::size_t i = 0; i < u.order.size(); ++i)
          if (u.order[i].first == key) return i > 0 ? u.order[i - 1].second : TableStepEnd{};
        if (!u.order.empty() && (furthest == nullptr || u.order.size() > furthest->order.size())) furthest = &u;
      }
      return furthest != nullptr ? furthest->order.back().second : TableStepEnd{};
    });
  auto guarded = [&](const std::string& what, auto&& f) {
    try {
      return f();
    } catch (const PeerError&) {
      throw;
    } catch (const std::exception& e) {
      throw PeerError(what + ": " + e.what());
    }
  };

  // Runs `body(unit)` for every unit on its own thread; a unit whose body throws fails with the reason.
  auto per_unit = [&](const std::vector<Unit*>& us, const std::string& what, auto&& body) {
    std::vector<std::string> errs(us.size());
    std::vector<std::thread> th;
    for (std::size_t i = 0; i < us.size(); ++i)
      th.emplace_back([&, i] {
        try {
          // Staggered starts: N stream-start commands at the same instant time out on a loaded bus.
          std::this_thread::sleep_for(std::chrono::milliseconds(15 * static_cast<int>(i)));
          body(*us[i]);
        } catch (const std::exception& e) {
          errs[i] = what + ": " + e.what();
        }
      });
    for (auto& t : th) t.join();
    for (std::size_t i = 0; i < us.size(); ++i)
      if (!errs[i].empty()) fail_unit(*us[i], errs[i]);
    refresh_live();
  };

  // A unit's stream; a stream that fails before its first sample (the start command timed out on a busy
  // bus) is tried once more before the unit is failed. Nothing was received, so nothing is duplicated.
  auto stream_unit = [&](Unit& u, const std::function<bool(const ImuSample&)>& cb) {
    bool any = false;
    auto wrapped = [&](const ImuSample& s) {
      any = true;
      return cb(s);
    };
    try {
      return u.dev->stream(st.stream_rate_hz, wrapped);
    } catch (const std::exception&) {
      if (any) throw;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    return u.dev->stream(st.stream_rate_hz, wrapped);
  };

  // Waits, from every unit's own die temperature, until the plateau is settled for each.
  auto settle_all = [&](const std::vector<Unit*>& us, int phase, double setpoint_C) {
    per_unit(us, "plateau " + std::to_string(phase) + " settling", [&](Unit& u) {
      SlopeSettleDetector det(st.settle_window_s, st.settle_slope_C_per_min / 60.0);
      double t_first = NAN, next_check = 0, air = NAN;
      bool ok = false;
      stream_unit(u, [&](const ImuSample& s) {
        if (std::isnan(t_first)) t_first = s.t_s;
        det.add(s.t_s, s.temp_C);
        const double el = s.t_s - t_first;
        if (el < next_check) return true;
        next_check = el + 1.0;
        air = bench_call([&] { return bench_.chamber_air_C(); });
        if (det.settled() && std::fabs(air - setpoint_C) <= st.settle_band_C) {
          ok = true;
          return false;
        }
        return el <= st.settle_timeout_s;
      });
      if (!ok)
        throw std::runtime_error("IMU temperature did not settle within " + std::to_string(st.settle_timeout_s) +
                                 " s (slope " + std::to_string(det.slope_per_s() * 60) + " C/min, chamber " +
                                 std::to_string(air) + " C)");
      u.temp_offset_C = det.mean() - setpoint_C;
      u.journal->append({{"type", "plateau_settled"}, {"phase", phase}, {"temp_C", det.mean()}, {"air_C", air},
                         {"t_s", run_clock()}});
    });
    if (opt_.progress) {
      std::fprintf(opt_.progress, "  plateau %d %+.1f C settled for %zu unit(s)\n", phase + 1, setpoint_C, us.size());
      std::fflush(opt_.progress);
    }
  };

  // Moves the table for one step (as the single-unit runner does) and streams every listed unit into its
  // own segment file; calibration segments are journaled and tracked, verification ones journaled.
  auto collect_all = [&](const StepInfo& si, const std::vector<Unit*>& us, bool calibration, double dwell_override) {
    guarded("rate table", [&] {
      motion.command(si);
      return 0;
    });
    const TableReading r0 = guarded("rate table", [&] { return wait_table("reaching " + si.label); });
    const double t_read = bench_.time_s();
    last_air_C = guarded("chamber status", [&] { return bench_.chamber_air_C(); });
    const double t_start = run_clock();
    const double dwell = dwell_override > 0 ? dwell_override : si.dwell_s;
    const bool is_rate = si.kind == physics::CampaignStep::Kind::kRate;
    per_unit(us, "CAN stream during " + si.label, [&](Unit& u) {
      const std::string rel = "segments/" + si.key + ".bin";
      const std::string file = (fs::path(u.dir) / rel).string();
      io::LogWriter w(file, u.meta, io::LogEncoding::kBinary);
      std::vector<io::LogRow> rows;
      double t_first = NAN, sensor_to_fixture = 0.0;
      const StreamStats ss = stream_unit(u, [&](const ImuSample& s) {
        if (std::isnan(t_first)) {
          t_first = s.t_s;
          if (is_rate) sensor_to_fixture = bench_call([&] { return bench_.time_s(); }) - s.t_s;
        }
        const double el = s.t_s - t_first;
        const double dt_table = is_rate ? s.t_s + sensor_to_fixture - t_read : 0.0;
        std::array<double, 3> ang = r0.angle_deg;
        for (std::size_t i = 0; i < 3; ++i) ang[i] += r0.rate_dps[i] * dt_table;
        const auto kk = u.kin.at(ang, r0.rate_dps);
        io::LogRow row;
        row.t_s = t_start + el;
        row.segment = u.segments;
        row.temp_C = s.temp_C;
        row.chamber_C = last_air_C;
        row.has_ref = true;
        for (int j = 0; j < 3; ++j) {
          row.f_ref[j] = kk.f_mps2[j];
          row.w_ref[j] = kk.w_rad_s[j];
        }
        for (int j = 0; j < 6; ++j) row.raw[j] = s.raw[j];
        for (int a = 0; a < u.meta.table_axes; ++a) {
          row.table_angle_rad[a] = ang[static_cast<std::size_t>(a)] * kDeg;
          row.table_rate_rad_s[a] = r0.rate_dps[static_cast<std::size_t>(a)] * kDeg;
        }
        w.write(row);
        rows.push_back(row);
        return el + 1.0 / st.stream_rate_hz < dwell;
      });
      w.sync();
      w.close();
      if (rows.size() < 2) throw std::runtime_error("no samples");
      const std::string sha = solver::sha256_file_hex(file);
      if (calibration) {
        u.journal->append({{"type", "segment_done"}, {"key", si.key}, {"phase", si.phase}, {"step", si.step},
                           {"label", si.label}, {"index", u.segments}, {"file", rel}, {"sha256", sha},
                           {"rows", rows.size()}, {"t_start_s", t_start}, {"t_end_s", run_clock()},
                           {"lost", ss.lost}, {"duplicated", ss.duplicated}, {"reordered", ss.reordered}});
        u.tracker->add_segment(u.meta, rows, u.segments, si.label);
        u.tracker->add_fixture_segment(file);
        ++u.segments;
        u.done.insert(si.key);
        u.order.emplace_back(si.key, table_step_end(si, rows.back(), u.meta.table_axes));
      } else {
        u.journal->append({{"type", "verify_segment"}, {"key", si.key}, {"label", si.label}, {"file", rel},
                           {"sha256", sha}, {"rows", rows.size()}});
        u.verified.insert(si.key);
      }
    });
    ++steps_here;
    ++res.steps_collected;
    if (opt_.progress) {
      int met = 0;
      for (Unit* u : live) met += u->tracker->segments() > 0 && meets(u->tracker->honest_sigma());
      std::fprintf(opt_.progress, "  %-24s %zu unit(s) streamed | fixture %.0f s | wall %.0f s | %d/%zu at spec\n",
                   si.label.c_str(), us.size(), run_clock(), now_wall() - wall0, met, live.size());
      std::fflush(opt_.progress);
    }
    if (opt_.crash_after_steps > 0 && steps_here >= opt_.crash_after_steps) throw SimulatedCrash();
  };

  const bool already_finished = !finished.is_null();
  if (!already_finished) {
    for (std::size_t p = 0; p < camp.phases.size() && !early_stopped && !live.empty(); ++p) {
      const auto& ph = camp.phases[p];
      const int pi = static_cast<int>(p);
      std::vector<Unit*> active;
      for (Unit* u : live)
        if (!u->collection_done && !u->phase_done[p]) active.push_back(u);
      if (active.empty()) continue;
      if (early && all_meet()) {
        early_stopped = true;
        break;
      }
      auto lacking = [&](const std::string& key) {
        std::vector<Unit*> v;
        for (Unit* u : active)
          if (u->alive && !u->done.count(key)) v.push_back(u);
        return v;
      };
      if (ph.kind == physics::CampaignPhase::Kind::kRamp) {
        const StepInfo& si = plan[p][0];
        auto us = lacking(si.key);
        if (!us.empty()) {
          guarded("chamber", [&] { bench_.set_chamber(ph.setpoint_C, ph.rate_C_per_min); return 0; });
          const double from = std::isnan(last_air_C) ? camp.initial_C : last_air_C;
          const double dur = std::fabs(ph.setpoint_C - from) / std::max(1e-6, ph.rate_C_per_min) * 60.0;
          collect_all(si, us, true, std::max(dur, 10.0));
        }
      } else {
        guarded("chamber", [&] { bench_.set_chamber(ph.setpoint_C, camp.ramp_limit_C_per_min); return 0; });
        settle_all(active, pi, ph.setpoint_C);
        for (Unit* u : active) u->info_cache.clear();
        std::vector<std::size_t> later;
        for (std::size_t q = p + 1; q < camp.phases.size(); ++q)
          if (camp.phases[q].kind == physics::CampaignPhase::Kind::kPlateau) later.push_back(q);
        auto step_info = [&](Unit& u, int q, int s, double T_C) -> const Eigen::MatrixXd& {
          auto key = std::make_pair(q, s);
          auto it = u.info_cache.find(key);
          if (it != u.info_cache.end()) return it->second;
          const StepInfo& x = plan[static_cast<std::size_t>(q)][static_cast<std::size_t>(s)];
          auto kk = u.kin.at(x.position_deg, x.rate_dps);
          return u.info_cache[key] =
                     u.tracker->predicted_information(kk.f_mps2, kk.w_rad_s, T_C, x.dwell_s, st.stream_rate_hz, x.accel_ok);
        };
        // The unit's steps done on this plateau, repeated at the same indices on the later plateaus.
        auto projected = [&](Unit& u, const std::vector<int>& pat) {
          Eigen::MatrixXd h = u.tracker->information();
          for (std::size_t q : later)
            for (int s : pat)
              if (static_cast<std::size_t>(s) < plan[q].size())
                h += step_info(u, static_cast<int>(q), s, camp.phases[q].setpoint_C + u.temp_offset_C);
          return h;
        };
        auto pattern_of = [&](const Unit& u) {
          std::vector<int> pat;
          for (std::size_t s = 0; s < plan[p].size(); ++s)
            if (u.done.count(plan[p][s].key)) pat.push_back(static_cast<int>(s));
          return pat;
        };
        for (;;) {
          std::vector<int> todo;  // steps some active unit still lacks
          for (std::size_t s = 0; s < plan[p].size(); ++s)
            if (!lacking(plan[p][s].key).empty()) todo.push_back(static_cast<int>(s));
          if (todo.empty() || live.empty()) break;
          std::size_t pick = 0;
          if (early) {
            if (all_meet()) {
              early_stopped = true;
              break;
            }
            // The plateau ends when every unit's steps so far, repeated later, are predicted to meet spec.
            bool plateau_enough = !later.empty();
            for (Unit* u : active) {
              if (!u->alive) continue;
              auto pat = pattern_of(*u);
              if (pat.empty() || !meets(with_floor(*u->tracker, u->tracker->sigma_of(projected(*u, pat))))) {
                plateau_enough = false;
                break;
              }
            }
            if (plateau_enough) break;
            // Greedy design over the units: the step that brings the units' summed shortfall lowest.
            double best = std::numeric_limits<double>::infinity();
            for (std::size_t c = 0; c < todo.size(); ++c) {
              double b = 0;
              for (Unit* u : active) {
                if (!u->alive || u->done.count(plan[p][static_cast<std::size_t>(todo[c])].key)) continue;
                auto pat = pattern_of(*u);
                pat.push_back(todo[c]);
                const Eigen::MatrixXd h = projected(*u, pat) + step_info(*u, pi, todo[c], ph.setpoint_C + u->temp_offset_C);
                b += badness(with_floor(*u->tracker, u->tracker->sigma_of(h)));
              }
              if (b < best - 1e-12) {
                best = b;
                pick = c;
              }
            }
          }
          const StepInfo& si = plan[p][static_cast<std::size_t>(todo[pick])];
          collect_all(si, lacking(si.key), true, 0.0);
        }
        if (early_stopped) break;
      }
      const double t = run_clock();
      for (Unit* u : active)
        if (u->alive) {
          u->journal->append({{"type", "plateau_done"}, {"phase", pi}, {"t_s", t}});
          u->phase_done[p] = true;
        }
    }
    if (!early_stopped && early && all_meet()) {
      for (Unit* u : live) early_stopped = early_stopped || u->done.size() < static_cast<std::size_t>(total_steps);
    }
    // The verification poses, for every unit at once: the raw counts do not depend on the table flashed
    // later, so each unit's finish runs the kernel check on these segments with its read-back table.
    for (std::size_t i = 0; i < st.verification.size() && !live.empty(); ++i) {
      const VerificationPose& vp = st.verification[i];
      StepInfo si;
      si.key = "verify" + std::to_string(i);
      si.phase = -1;  // not a plateau's step: never continues a calibration rotation
      si.label = vp.label;
      const bool is_rate = vp.rate_dps[0] != 0 || vp.rate_dps[1] != 0 || vp.rate_dps[2] != 0;
      si.kind = is_rate ? physics::CampaignStep::Kind::kRate : physics::CampaignStep::Kind::kPosition;
      si.position_deg = vp.position_deg;
      si.rate_dps = vp.rate_dps;
      si.dwell_s = vp.dwell_s;
      std::vector<Unit*> us;
      for (Unit* u : live)
        if (!u->collection_done && !u->verified.count(si.key)) us.push_back(u);
      if (!us.empty()) collect_all(si, us, false, 0.0);
    }
    guarded("rate table stop", [&] { bench_.command_rate({0, 0, 0}); return 0; });
    motion.stopped();
    const double t_end = run_clock();
    for (Unit* u : live)
      if (!u->collection_done) {
        u->journal->append({{"type", "collection_done"}, {"early_stop", early_stopped}, {"t_s", t_end},
                            {"segments", u->segments}});
        u->collection_done = true;
      }
    run_clock_base = t_end;
  }
  res.campaign_time_s = run_clock_base;
  res.early_stopped = early_stopped;
  res.collect_wall_s = now_wall() - wall0;

  // ---- finish, per unit on a thread pool ------------------------------------------------------------
  const double finish0 = now_wall();
  {
    auto store = records::open_store(db);
    store->ensure_schema();  // once, before the units insert concurrently
  }
  const std::string bench_name = bench_.describe();
  // A unit the batch record already names (a crash after batch_recording) is not finished again: its
  // verdict is the journaled one, so no second flash and no second record.
  std::vector<Unit*> todo;
  for (Unit* u : live) {
    const json* known = batch_recording.is_null() ? nullptr : &batch_recording["units"];
    if (known && known->contains(u->slot)) {
      u->failure = (*known)[u->slot].value("reasons", std::vector<std::string>{"not finished"}).front();
      continue;
    }
    todo.push_back(u);
  }
  const int threads = std::max(1, std::min<int>(static_cast<int>(todo.size()),
                                                opt_.threads > 0 ? opt_.threads
                                                                 : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))));
  std::atomic<std::size_t> next{0};
  std::vector<std::string> finish_err(units.size());
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&] {
      std::unique_ptr<TableOps> ops;
      for (;;) {
        const std::size_t i = next++;
        if (i >= todo.size()) return;
        Unit& u = *todo[i];
        const double cpu0 = thread_cpu_s();
        try {
          if (!ops) ops = table_ops_();
          FinishBench fb(bench_name + " " + u.slot);
          RunOptions ro;
          ro.out_dir = u.dir;
          ro.resume = true;
          ro.slot = u.slot;
          ro.db = db;
          ro.early_stop = opt_.early_stop;
          ro.progress = nullptr;
          u.journal.reset();  // the unit's Runner appends to the same journal
          Runner r(ro, fb, *u.dev, *ops);
          u.run = r.run();
          u.finished = true;
        } catch (const std::exception& e) {
          u.failure = e.what();
        }
        u.result.finish_cpu_s = thread_cpu_s() - cpu0;
      }
    });
  for (auto& t : pool) t.join();
  res.finish_wall_s = now_wall() - finish0;

  // ---- the batch: outcomes, outliers, records, report ---------------------------------------------
  BatchOutcome& b = res.batch;
  b.threads = threads;
  b.wall_s = res.finish_wall_s;
  for (auto& u : units) {
    UnitOutcome o;
    o.slot = u.slot;
    o.serial = u.serial;
    o.log_path = u.finished ? (fs::path(u.dir) / "log.bin").string() : "";
    o.cpu_s = u.result.finish_cpu_s;
    if (u.finished) {
      o.solved = !u.run.estimate.names.empty() && u.run.estimate.sigma().allFinite();
      o.pass = u.run.pass;
      o.reasons = u.run.reasons;
      o.estimate = u.run.estimate;
      o.params = u.run.record.parameters;
      o.record_id = u.run.record_id;
      o.recorded = !u.run.record_id.empty();
      u.result.report_path = u.run.report_path;
      if (!u.run.report_path.empty())
        o.report_href = fs::relative(u.run.report_path, out).generic_string();
      u.result.collected = true;
    } else {
      o.reasons = {u.failure.empty() ? "not finished" : u.failure};
    }
    if (o.pass) ++b.passed;
    b.units.push_back(std::move(o));
  }
  mark_outliers(b);
  // Record ids are chosen and journaled before any insert (as the single-unit runner does), so a resume
  // after a crash between inserts finds them and inserts only what is absent.
  auto store = records::open_store(db);
  if (batch_recording.is_null()) {
    batch_recording = {{"type", "batch_recording"}, {"id", records::new_record_id()}, {"units", json::object()}};
    for (auto& o : b.units)
      if (!o.recorded) batch_recording["units"][o.slot] = {{"id", records::new_record_id()}, {"reasons", o.reasons}};
    journal->append(batch_recording);
  }
  for (auto& o : b.units) {
    if (o.recorded) continue;
    const json& known = batch_recording["units"];
    if (known.contains(o.slot)) {
      o.record_id = known[o.slot].value("id", "");
      o.reasons = known[o.slot].value("reasons", o.reasons);
    }
    if (o.record_id.empty()) throw JournalError("journal " + jpath.string() + ": batch_recording has no id for " + o.slot);
    try {
      (void)store->get(o.record_id);
      o.recorded = true;  // inserted before a crash
    } catch (const records::RecordError&) {
    }
  }
  BatchProvenance prov{st.name, camp.name, campaign_sha, started_utc, records::utc_now_iso8601(), ""};
  prov.batch_id = batch_recording.value("id", "");
  if (batch_recorded.is_null()) {
    bool present = false;
    try {
      (void)store->get_batch(prov.batch_id);
      present = true;
    } catch (const records::RecordError&) {
    }
    if (!present) record_batch(*store, b, prov);
    journal->append({{"type", "batch_recorded"}, {"id", prov.batch_id}, {"backend", store->backend()}});
  }
  res.batch_id = prov.batch_id;
  for (std::size_t k = 0; k < units.size(); ++k) {
    Unit& u = units[k];
    const UnitOutcome& o = b.units[k];
    u.result.pass = o.pass;
    u.result.reasons = o.reasons;
    u.result.record_id = o.record_id;
    res.units.push_back(u.result);
  }
  res.passed = b.passed;
  write_file_atomic((out / "batch.json").string(), batch_to_json(b).dump(2) + "\n");
  res.batch_report_path = (out / "batch-report.html").string();
  write_file_atomic(res.batch_report_path, render_batch_report(b, "Station " + st.name + " run " + started_utc));
  if (!already_finished)
    journal->append({{"type", "finished"}, {"passed", b.passed}, {"units", units.size()}, {"batch_id", res.batch_id}});
  return res;
}

}  // namespace imuforge::eol
