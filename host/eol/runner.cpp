// The single-unit end-of-line run (runner.h). One piece, ~840 lines, because resume, collection and the
// finish share one journal-backed state (segments made safe, record id journaled before the insert) whose
// ordering is the crash-consistency guarantee (docs/eol.md); the multi-unit StationRunner finishes each
// unit through this same run() with a bench that refuses moves.
#include "host/io/campaign_file.h"
#include "host/eol/runner.h"
#include "host/physics/units.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include "firmware/common/crc32.h"
#include "host/eol/batch.h"
#include "host/eol/journal.h"
#include "host/eol/passfail.h"
#include "host/eol/progress.h"
#include "host/eol/report.h"
#include "host/eol/schedule.h"
#include "host/eol/settle.h"
#include "host/io/log.h"
#include "host/model/sensor_model.h"
#include "host/records/store.h"
#include "host/physics/earth.h"
#include "host/physics/table.h"
#include "host/solver/consider.h"
#include "host/solver/fixture.h"
#include "host/solver/sha256.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace imuforge::eol {


namespace {

using physics::kDeg;  // host/physics/units.h

// Wraps a port call so any failure becomes a PeerError naming what was being done.
template <typename F>
auto peer(const std::string& what, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const PeerError&) {
    throw;
  } catch (const SimulatedCrash&) {
    throw;
  } catch (const std::exception& e) {
    throw PeerError(what + ": " + e.what());
  }
}

double now_wall() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string file_sha(const std::string& p) { return solver::sha256_file_hex(p); }

}  // namespace

Runner::Runner(RunOptions opt, Bench& bench, Device& device, TableOps& table)
    : opt_(std::move(opt)), bench_(bench), dev_(device), table_(table) {}

RunResult Runner::run() {
  const double wall0 = now_wall();
  RunResult res;
  if (opt_.out_dir.empty()) throw std::invalid_argument("--out DIR is required");
  const fs::path out = fs::absolute(opt_.out_dir);
  const fs::path jpath = out / "journal.log";

  // ---- resume: the journal's run_start carries the inputs (schedule.h, shared with StationRunner) --
  std::unique_ptr<Journal> journal;
  JournalContents jc = open_run_journal(jpath, opt_.resume, &journal);
  if (opt_.resume) {
    const json& s0 = jc.entries[0];
    if (opt_.campaign_path.empty()) opt_.campaign_path = s0.value("campaign_path", "");
    if (opt_.station_path.empty()) opt_.station_path = s0.value("station_path", "");
    if (opt_.serial.empty()) opt_.serial = s0.value("serial", "");
    if (opt_.slot.empty()) opt_.slot = s0.value("slot", "");
    if (opt_.db.empty()) opt_.db = s0.value("db", "");
    opt_.early_stop = opt_.early_stop && s0.value("early_stop", true);
  }
  if (opt_.campaign_path.empty() || opt_.station_path.empty() || opt_.serial.empty())
    throw std::invalid_argument("--campaign, --station and --serial are required");

  RunInputs in = load_run_inputs(opt_.campaign_path, opt_.station_path, opt_.db, out);
  physics::Campaign& camp = in.camp;
  StationConfig& st = in.st;
  const model::ModelSpec& spec = in.spec;
  // A multi-slot station runs its units through StationRunner (station_runner.h), which finishes each
  // unit here with opt_.slot set: the slot's node, nest geometry and mount tolerance.
  if (!opt_.slot.empty()) {
    narrow_to_slot(st, camp, opt_.slot);
  } else if (st.slots.size() > 1) {
    throw std::invalid_argument("station " + opt_.station_path + " lists " + std::to_string(st.slots.size()) +
                                " slots: a multi-unit station is run by StationRunner (imuforge run without --serial)");
  }
  // The fixture tolerance is checked against the campaign's table now, not after hours of collection.
  if (!st.fixture_tolerance.is_null()) {
    try {
      solver::fixture_tolerance_from_json(st.fixture_tolerance, static_cast<int>(camp.axes.size()),
                                          "station " + opt_.station_path);
    } catch (const solver::SolverError& e) {
      throw std::invalid_argument(e.what());
    }
  }
  const std::string& campaign_sha = in.campaign_sha256;
  const std::string& station_sha = in.station_sha256;
  const std::string& db = in.db;
  res.db = db;

  // ---- the schedule ---------------------------------------------------------------------------
  Kin kin = kinematics_of(camp);
  physics::Site site{camp.latitude_deg, camp.height_m};
  int total_steps = 0;
  const std::vector<std::vector<StepInfo>> plan = build_plan(camp, kin, opt_.campaign_path, &total_steps);
  res.segments_total = total_steps;
  res.schedule_time_s = camp.nominal_duration_s();

  // ---- tracker, specs --------------------------------------------------------------------------
  Tracker tracker(spec);
  tracker.set_noise(st.accel_noise_mps2, st.gyro_noise_rad_s);
  // The tracker steers on the honest σ: the station's fixture tolerance, considered as the batch solve
  // will (checked against the campaign's table above).
  if (!st.fixture_tolerance.is_null())
    tracker.set_fixture_tolerance(solver::fixture_tolerance_from_json(st.fixture_tolerance, static_cast<int>(camp.axes.size()),
                                                                      "station " + opt_.station_path),
                                  spec, camp);
  const int n = tracker.size();
  Eigen::VectorXd sigma_spec = Eigen::VectorXd::Zero(n);
  bool have_spec = false;
  for (int i = 0; i < n; ++i) {
    const ParamLimit* l = st.limit_for(tracker.names()[static_cast<std::size_t>(i)]);
    if (l && l->sigma_max > 0) {
      sigma_spec[i] = l->sigma_max * st.early_stop_sigma_fraction;
      have_spec = true;
    }
  }
  const bool early = opt_.early_stop && st.early_stop && have_spec;

  // ---- the device -------------------------------------------------------------------------------
  DeviceInfo info = peer("CAN identify", [&] { return dev_.identify(); });
  if (info.serial != opt_.serial)
    throw std::invalid_argument("device on " + st.can_bus + " identifies as serial '" + info.serial + "', not --serial '" +
                                opt_.serial + "'");
  if (!(info.accel_lsb_mps2 > 0) || !(info.gyro_lsb_rad_s > 0))
    throw PeerError("device " + info.serial + " reports no accelerometer/gyro LSB");

  io::LogMeta meta;
  meta.serial = info.serial;
  meta.sample_rate_hz = dev_.effective_rate_hz(st.stream_rate_hz);
  meta.accel_lsb_mps2 = info.accel_lsb_mps2;
  meta.gyro_lsb_rad_s = info.gyro_lsb_rad_s;
  meta.accel_bits = info.accel_raw_bits;  // width of the streamed counts: the log's clip rule follows it
  meta.gyro_bits = info.gyro_raw_bits;
  meta.latitude_deg = camp.latitude_deg;
  meta.height_m = camp.height_m;
  meta.gravity_mps2 = physics::normal_gravity_mps2(site);
  // The reported table angles and rates go into every row: the consider analysis (honest σ) re-runs the
  // table kinematics on them with the fixture's errors.
  meta.table_axes = static_cast<int>(camp.axes.size());
  meta.set("source", "imuforge-run");
  meta.set("campaign", camp.name);
  meta.set("station", st.name);

  fs::create_directories(out / "segments");
  if (!journal) {
    journal = std::make_unique<Journal>(Journal::create(jpath.string()));
    journal->append({{"type", "run_start"},
                     {"serial", opt_.serial},
                     {"campaign_path", fs::absolute(opt_.campaign_path).string()},
                     {"campaign_sha256", campaign_sha},
                     {"station_path", fs::absolute(opt_.station_path).string()},
                     {"station_sha256", station_sha},
                     {"db", opt_.db},
                     {"early_stop", opt_.early_stop},
                     {"software_version", IMUFORGE_VERSION},
                     {"started_utc", records::utc_now_iso8601()}});
    jc.entries.push_back(json{{"type", "run_start"}, {"started_utc", records::utc_now_iso8601()}});
  } else {
    const json& s0 = jc.entries[0];
    if (s0.value("campaign_sha256", "") != campaign_sha)
      throw std::invalid_argument("--resume: the campaign file changed since the run started (" + opt_.campaign_path + ")");
    if (s0.value("station_sha256", "") != station_sha)
      throw std::invalid_argument("--resume: the station file changed since the run started (" + opt_.station_path + ")");
    if (s0.value("serial", "") != opt_.serial)
      throw std::invalid_argument("--resume: the run is for serial " + s0.value("serial", "") + ", not " + opt_.serial);
  }
  const std::string started_utc = jc.entries[0].value("started_utc", records::utc_now_iso8601());

  // ---- replay what is safe ------------------------------------------------------------------------
  std::set<std::string> done;
  std::vector<std::string> seg_files;  // collection order
  std::vector<bool> phase_done(camp.phases.size(), false);
  bool collection_done = false, early_stopped = false;
  double run_clock_base = 0.0;  // run time (fixture seconds) already spent by earlier processes
  json finish;                  // finish-stage entries by type
  std::map<std::string, json> verify_segments;  // verification segments collected with the station's units
  // Where the last safe segment left the table: a continued rotation in flight at the crash is re-run
  // from that state (TableMotion), not from its start position.
  const StepIndex step_by_key = index_steps(plan);
  TableStepEnd last_end;
  std::map<std::string, json> turning;  // table_turning entries by step key
  ReportData rd;
  rd.names = tracker.names();
  rd.spec = sigma_spec;
  for (const auto& e : jc.entries) {
    const std::string type = e["type"];
    if (type == "segment_done") {
      std::string file = (out / e.at("file").get<std::string>()).string();
      if (!fs::exists(file) || file_sha(file) != e.at("sha256").get<std::string>())
        throw JournalError("journal says segment " + e.at("key").get<std::string>() + " is safe in " + file +
                           " but the file is missing or its SHA-256 differs");
      io::LogReader r(file);
      std::vector<io::LogRow> rows;
      io::LogRow row;
      while (r.next(row)) rows.push_back(row);
      tracker.add_segment(r.meta(), rows, static_cast<int>(seg_files.size()), e.value("label", ""));
      tracker.add_fixture_segment(file);
      seg_files.push_back(file);
      const auto step = step_by_key.find(e.at("key").get<std::string>());
      if (step != step_by_key.end() && !rows.empty()) last_end = table_step_end(*step->second, rows.back(), r.meta().table_axes);
      done.insert(e.at("key").get<std::string>());
      run_clock_base = std::max(run_clock_base, e.value("t_end_s", 0.0));
      if (!rows.empty()) {
        rd.imu_temp_C.push_back({rows.front().t_s, rows.front().temp_C});
        rd.chamber_temp_C.push_back({rows.front().t_s, rows.front().chamber_C});
      }
      rd.sigma_t_s.push_back(e.value("t_end_s", 0.0));
      rd.sigma_hist.push_back(tracker.honest_sigma());
      ++res.segments_resumed;
    } else if (type == "table_turning") {
      turning[e.at("key").get<std::string>()] = e;
    } else if (type == "verify_segment") {
      verify_segments[e.at("key").get<std::string>()] = e;  // collected by StationRunner, not yet used
    } else if (type == "plateau_done") {
      phase_done[e.at("phase").get<std::size_t>()] = true;
    } else if (type == "clock") {
      run_clock_base = std::max(run_clock_base, e.value("t_s", 0.0));
    } else if (type == "collection_done") {
      collection_done = true;
      early_stopped = e.value("early_stop", false);
      run_clock_base = std::max(run_clock_base, e.value("t_s", 0.0));
    } else if (type != "run_start") {
      finish[type] = e;
    }
  }
  if (finish.contains("finished")) {
    const json& f = finish["finished"];
    res.pass = f.value("pass", false);
    res.reasons = f.value("reasons", std::vector<std::string>{});
    res.record_id = f.value("record_id", "");
    res.report_path = (out / "report.html").string();
    res.early_stopped = early_stopped;
    res.campaign_time_s = run_clock_base;
    // The estimate of the finished run, from its cal.json (written before the flash, the record and
    // "finished"): a resume after a kill in the last moments reports what was recorded, not an empty estimate.
    {
      std::ifstream cf(out / "cal.json");
      const json cal = cf ? json::parse(cf, nullptr, false) : json();
      if (cal.is_object() && cal.contains("parameters") && cal["parameters"].is_array()) {
        const auto& ps = cal["parameters"];
        const Eigen::Index n = static_cast<Eigen::Index>(ps.size());
        res.estimate.value = Eigen::VectorXd::Zero(n);
        res.estimate.covariance = Eigen::MatrixXd::Zero(n, n);
        const bool full = cal.contains("covariance") && cal["covariance"].is_array() &&
                          static_cast<Eigen::Index>(cal["covariance"].size()) == n;
        for (Eigen::Index i = 0; i < n; ++i) {
          const json& p = ps[static_cast<std::size_t>(i)];
          res.estimate.names.push_back(p.value("name", ""));
          res.estimate.value[i] = p.value("value", 0.0);
          const double sg = p.value("sigma", -1.0);
          res.estimate.covariance(i, i) = sg >= 0 ? sg * sg : NAN;
          if (full)
            for (Eigen::Index k = 0; k < n; ++k) res.estimate.covariance(i, k) = cal["covariance"][static_cast<std::size_t>(i)][static_cast<std::size_t>(k)].get<double>();
          res.record.parameters.push_back({res.estimate.names.back(), res.estimate.value[i], sg >= 0 ? sg : NAN, 0, 0, true});
        }
        res.record.id = res.record_id;
      }
    }
    if (opt_.progress) std::fprintf(opt_.progress, "run in %s already finished: %s\n", out.c_str(), res.pass ? "PASS" : "FAIL");
    return res;
  }
  if (opt_.progress && opt_.resume)
    std::fprintf(opt_.progress, "resume %s: %d segment(s) safe, not re-collected%s\n", out.c_str(), res.segments_resumed,
                 jc.torn_tail ? " (torn last journal line dropped)" : "");

  // Run clock: fixture seconds since the run started, continuous across resumes.
  const double bench_t0 = peer("fixture clock", [&] { return bench_.time_s(); });
  auto run_clock = [&] { return run_clock_base + (bench_.time_s() - bench_t0); };
  int collected_here = 0;
  double last_air_C = NAN, temp_offset_C = 0.0;

  auto progress = [&](int phase, const std::string& label, bool table) {
    if (!opt_.progress) return;
    ProgressState ps;
    ps.phase = phase;
    ps.phases = static_cast<int>(camp.phases.size());
    ps.setpoint_C = camp.phases[static_cast<std::size_t>(phase)].setpoint_C;
    ps.done_steps = static_cast<int>(done.size());
    ps.total_steps = total_steps;
    ps.label = label;
    ps.wall_elapsed_s = now_wall() - wall0;
    ps.fixture_elapsed_s = run_clock() - run_clock_base;
    double left = 0;
    for (const auto& ph : plan)
      for (const auto& s : ph)
        if (!done.count(s.key)) left += s.dwell_s + 2.0;
    for (std::size_t p = static_cast<std::size_t>(phase) + 1; p < camp.phases.size(); ++p) left += st.settle_window_s;
    ps.fixture_remaining_s = left;
    ps.names = &tracker.names();
    ps.sigma = tracker.honest_sigma();
    ps.spec = sigma_spec;
    std::fprintf(opt_.progress, "%s\n", progress_line(ps).c_str());
    if (table) std::fprintf(opt_.progress, "%s", sigma_table(ps).c_str());
    std::fflush(opt_.progress);
  };

  auto wait_table = [&](const std::string& what) {
    const double t0 = bench_.time_s();
    for (;;) {
      TableReading r = peer("rate table status", [&] { return bench_.table(); });
      if (r.fault) throw PeerError("rate table fault while " + what + ": " + r.fault_text);
      if (r.in_position && r.settled) return r;
      if (bench_.time_s() - t0 > st.table_timeout_s)
        throw PeerError("rate table not in position and settled within " + std::to_string(st.table_timeout_s) +
                        " s while " + what + " (angles " + std::to_string(r.angle_deg[0]) + ", " +
                        std::to_string(r.angle_deg[1]) + ", " + std::to_string(r.angle_deg[2]) + " deg, rates " +
                        std::to_string(r.rate_dps[0]) + ", " + std::to_string(r.rate_dps[1]) + ", " +
                        std::to_string(r.rate_dps[2]) + " dps, in_position " + std::to_string(r.in_position) +
                        ", settled " + std::to_string(r.settled) + ")");
      bench_.wait(0.1);
    }
  };

  TableMotion motion(
      bench_, [&](const std::string& what) { return wait_table(what); },
      [&](const StepInfo& si, const TableReading& r) { journal->append(table_turning_entry(si, r)); });
  if (opt_.resume)
    motion.on_resume([&](const std::string& key) {
      if (const auto j = journaled_turning(turning, step_by_key, key)) return *j;
      return last_end;
    });

  // Waits, from the IMU's own temperature, until the plateau is reached and settled.
  auto settle_temperature = [&](int phase, double setpoint_C) {
    SlopeSettleDetector det(st.settle_window_s, st.settle_slope_C_per_min / 60.0);
    double t_first = NAN, next_check = 0, next_report = 0, air = NAN;
    bool ok = false, timeout = false;
    peer("stream (settling)", [&] {
      return dev_.stream(st.stream_rate_hz, [&](const ImuSample& s) {
        if (std::isnan(t_first)) t_first = s.t_s;
        det.add(s.t_s, s.temp_C);
        double el = s.t_s - t_first;
        if (el >= next_check) {
          next_check = el + 1.0;
          air = bench_.chamber_air_C();
          double rc = run_clock();
          rd.imu_temp_C.push_back({rc, s.temp_C});
          rd.chamber_temp_C.push_back({rc, air});
          if (opt_.progress && el >= next_report) {
            next_report = el + 60.0;
            std::fprintf(opt_.progress, "  settling p%d %+.1fC: IMU %.2f C, slope %+.3f C/min over %.0f s, chamber %.2f C\n",
                         phase + 1, setpoint_C, s.temp_C, det.slope_per_s() * 60, det.span_s(), air);
            std::fflush(opt_.progress);
          }
          // The die's offset from the air (self-heating) is the part's own: only its slope matters.
          if (det.settled() && std::fabs(air - setpoint_C) <= st.settle_band_C) {
            ok = true;
            return false;
          }
          if (el > st.settle_timeout_s) {
            timeout = true;
            return false;
          }
        }
        return true;
      });
    });
    if (!ok || timeout)
      throw PeerError("plateau " + std::to_string(phase) + " (" + std::to_string(setpoint_C) + " C): IMU temperature did not settle within " +
                      std::to_string(st.settle_timeout_s) + " s (slope " + std::to_string(det.slope_per_s() * 60) +
                      " C/min, chamber " + std::to_string(air) + " C)");
    last_air_C = air;
    temp_offset_C = det.mean() - setpoint_C;
    journal->append({{"type", "plateau_settled"}, {"phase", phase}, {"temp_C", det.mean()}, {"air_C", air},
                     {"t_s", run_clock()}});
  };

  // Collects one step's segment, makes it safe, folds it into the tracker.
  auto collect = [&](const StepInfo& si, const std::string& seg_name, bool calibration,
                     std::vector<io::LogRow>* rows_out, std::vector<ImuSample>* raw_out, double dwell_override) {
    // Steps may run out of file order (early stop): TableMotion goes to a rotation's start position
    // unless the table already turns from it (CW then CCW), and after a resume restores that state.
    peer("rate table command", [&] { motion.command(si); return 0; });
    TableReading r0 = wait_table("reaching " + si.label);
    const double t_read = bench_.time_s();  // fixture time of r0 (one Modbus round trip later)
    last_air_C = peer("chamber status", [&] { return bench_.chamber_air_C(); });
    const double t_start = run_clock();
    const double dwell = dwell_override > 0 ? dwell_override : si.dwell_s;
    std::string file = (out / "segments" / (seg_name + ".bin")).string();
    io::LogWriter w(file, meta, io::LogEncoding::kBinary);
    std::vector<io::LogRow> rows;
    double t_first = NAN, sensor_to_fixture = 0.0;
    StreamStats ss = peer("CAN stream", [&] {
      return dev_.stream(st.stream_rate_hz, [&](const ImuSample& s) {
        if (std::isnan(t_first)) {
          t_first = s.t_s;
          // Sensor clock -> fixture clock, so a rate run's reference angle follows the table's phase.
          // Only rate runs need it (f_ref of a static dwell does not depend on time).
          if (si.kind == physics::CampaignStep::Kind::kRate) sensor_to_fixture = bench_.time_s() - s.t_s;
        }
        double el = s.t_s - t_first;
        double dt_table = si.kind == physics::CampaignStep::Kind::kRate ? s.t_s + sensor_to_fixture - t_read : 0.0;
        std::array<double, 3> ang = r0.angle_deg;
        for (int i = 0; i < 3; ++i) ang[static_cast<std::size_t>(i)] += r0.rate_dps[static_cast<std::size_t>(i)] * dt_table;
        auto k = kin.at(ang, r0.rate_dps);
        io::LogRow row;
        row.t_s = t_start + el;
        row.segment = static_cast<std::int32_t>(seg_files.size());
        row.temp_C = s.temp_C;
        row.chamber_C = last_air_C;
        row.has_ref = true;
        for (int j = 0; j < 3; ++j) {
          row.f_ref[j] = k.f_mps2[j];
          row.w_ref[j] = k.w_rad_s[j];
        }
        for (int j = 0; j < 6; ++j) row.raw[j] = s.raw[j];
        for (int a = 0; a < meta.table_axes; ++a) {
          row.table_angle_rad[a] = ang[static_cast<std::size_t>(a)] * kDeg;
          row.table_rate_rad_s[a] = r0.rate_dps[static_cast<std::size_t>(a)] * kDeg;
        }
        w.write(row);
        rows.push_back(row);
        if (raw_out) raw_out->push_back(s);
        return el + 1.0 / st.stream_rate_hz < dwell;
      });
    });
    w.sync();
    w.close();
    const double t_end = run_clock();
    if (rows.size() < 2) throw PeerError("CAN stream: no samples during " + si.label);
    if (calibration) {
      std::string sha = file_sha(file);
      journal->append({{"type", "segment_done"}, {"key", si.key}, {"phase", si.phase}, {"step", si.step},
                       {"label", si.label}, {"index", seg_files.size()}, {"file", "segments/" + seg_name + ".bin"},
                       {"sha256", sha}, {"rows", rows.size()}, {"t_start_s", t_start}, {"t_end_s", t_end},
                       {"lost", ss.lost}, {"duplicated", ss.duplicated}, {"reordered", ss.reordered}});
      const std::size_t rejected_before = tracker.rejections().size();
      tracker.add_segment(meta, rows, static_cast<int>(seg_files.size()), si.label);
      // The operator must see why a static step added no accelerometer rows. Journalled once, live: on
      // --resume the tracker re-derives the same rejection from the same safe segment file.
      for (std::size_t k = rejected_before; k < tracker.rejections().size(); ++k)
        journal->append({{"type", "segment_rejected"}, {"key", si.key}, {"index", tracker.rejections()[k].segment},
                         {"label", tracker.rejections()[k].label}, {"reason", tracker.rejections()[k].reason}});
      tracker.add_fixture_segment(file);
      seg_files.push_back(file);
      done.insert(si.key);
      rd.imu_temp_C.push_back({t_start, rows.front().temp_C});
      rd.chamber_temp_C.push_back({t_start, last_air_C});
      rd.sigma_t_s.push_back(t_end);
      rd.sigma_hist.push_back(tracker.honest_sigma());
      ++res.segments_collected;
      ++collected_here;
      if (opt_.crash_after_segments > 0 && collected_here >= opt_.crash_after_segments) throw SimulatedCrash();
    }
    if (rows_out) *rows_out = std::move(rows);
    return ss;
  };

  // σ meets spec for every parameter that has one (and every parameter is observable).
  auto meets = [&](const Eigen::VectorXd& sig) {
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(sig[i])) return false;
      if (sigma_spec[i] > 0 && sig[i] > sigma_spec[i]) return false;
    }
    return true;
  };
  // Σ log(max(σ/spec, 1)) with unobservable parameters heavily penalised: 0 ⇔ spec met.
  auto badness = [&](const Eigen::VectorXd& sig) {
    double b = 0;
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(sig[i]) || sig[i] > 1e12) b += 100;
      else if (sigma_spec[i] > 0) b += std::log(std::max(sig[i] / sigma_spec[i], 1.0));
    }
    return b;
  };
  // A predicted noise-only σ with today's fixture part added: the fixture part does not shrink with more
  // data (no campaign separates a nest rotation from a common misalignment), so it is carried as a floor.
  auto with_floor = [&](const Eigen::VectorXd& sig) {
    const Eigen::VectorXd f = tracker.fixture_variance();
    Eigen::VectorXd h = sig;
    for (Eigen::Index i = 0; i < h.size(); ++i)
      if (std::isfinite(h[i])) h[i] = std::sqrt(h[i] * h[i] + f[i]);
    return h;
  };
  std::map<std::pair<int, int>, Eigen::MatrixXd> info_cache;
  auto step_info = [&](int p, int s, double T_C) -> const Eigen::MatrixXd& {
    auto key = std::make_pair(p, s);
    auto it = info_cache.find(key);
    if (it != info_cache.end()) return it->second;
    const StepInfo& si = plan[static_cast<std::size_t>(p)][static_cast<std::size_t>(s)];
    auto k = kin.at(si.position_deg, si.rate_dps);
    return info_cache[key] =
               tracker.predicted_information(k.f_mps2, k.w_rad_s, T_C, si.dwell_s, st.stream_rate_hz, si.accel_ok);
  };

  // ---- collection ----------------------------------------------------------------------------------
  if (!collection_done) {
    for (std::size_t p = 0; p < camp.phases.size() && !early_stopped; ++p) {
      if (phase_done[p]) continue;
      const auto& ph = camp.phases[p];
      const int pi = static_cast<int>(p);
      if (early && tracker.segments() > 0 && meets(tracker.honest_sigma())) {
        early_stopped = true;
        break;
      }
      if (ph.kind == physics::CampaignPhase::Kind::kRamp) {
        const StepInfo& si = plan[p][0];
        if (!done.count(si.key)) {
          peer("chamber", [&] { bench_.set_chamber(ph.setpoint_C, ph.rate_C_per_min); return 0; });
          double from = std::isnan(last_air_C) ? camp.initial_C : last_air_C;
          double dur = std::fabs(ph.setpoint_C - from) / std::max(1e-6, ph.rate_C_per_min) * 60.0;
          collect(si, si.key, true, nullptr, nullptr, std::max(dur, 10.0));
          progress(pi, si.label, false);
        }
      } else {
        peer("chamber", [&] { bench_.set_chamber(ph.setpoint_C, camp.ramp_limit_C_per_min); return 0; });
        settle_temperature(pi, ph.setpoint_C);
        info_cache.clear();  // temperatures of the remaining plateaus are re-predicted from this one
        std::vector<int> todo;
        for (std::size_t s = 0; s < plan[p].size(); ++s)
          if (!done.count(plan[p][s].key)) todo.push_back(static_cast<int>(s));
        std::vector<int> pattern;
        for (std::size_t s = 0; s < plan[p].size(); ++s)
          if (done.count(plan[p][s].key)) pattern.push_back(static_cast<int>(s));
        // Later plateaus: the same step indices (campaigns repeat their step list per plateau).
        std::vector<std::size_t> later;
        for (std::size_t q = p + 1; q < camp.phases.size(); ++q)
          if (camp.phases[q].kind == physics::CampaignPhase::Kind::kPlateau) later.push_back(q);
        auto projected = [&](const std::vector<int>& pat) {
          Eigen::MatrixXd h = tracker.information();
          for (std::size_t q : later)
            for (int s : pat)
              if (static_cast<std::size_t>(s) < plan[q].size())
                h += step_info(static_cast<int>(q), s, camp.phases[q].setpoint_C + temp_offset_C);
          return h;
        };
        while (!todo.empty()) {
          std::size_t pick = 0;
          if (early) {
            Eigen::VectorXd now_sig = tracker.honest_sigma();
            if (tracker.segments() > 0 && meets(now_sig)) {
              early_stopped = true;
              break;
            }
            if (!later.empty() && !pattern.empty() && meets(with_floor(tracker.sigma_of(projected(pattern))))) break;
            // Greedy design: the step that, repeated on the later plateaus, brings the spec closest.
            double best = std::numeric_limits<double>::infinity();
            for (std::size_t c = 0; c < todo.size(); ++c) {
              std::vector<int> pat = pattern;
              pat.push_back(todo[c]);
              Eigen::MatrixXd h = projected(pat) + step_info(pi, todo[c], ph.setpoint_C + temp_offset_C);
              double b = badness(with_floor(tracker.sigma_of(h)));
              if (b < best - 1e-12) {
                best = b;
                pick = c;
              }
            }
          }
          const StepInfo& si = plan[p][static_cast<std::size_t>(todo[pick])];
          collect(si, si.key, true, nullptr, nullptr, 0.0);
          pattern.push_back(todo[pick]);
          todo.erase(todo.begin() + static_cast<std::ptrdiff_t>(pick));
          progress(pi, si.label, false);
        }
        if (early_stopped) break;
      }
      journal->append({{"type", "plateau_done"}, {"phase", pi}, {"t_s", run_clock()}});
      phase_done[p] = true;
      progress(pi, "plateau done", true);
    }
    if (!early_stopped && early && meets(tracker.honest_sigma())) early_stopped = done.size() < static_cast<std::size_t>(total_steps);
    peer("rate table stop", [&] { bench_.command_rate({0, 0, 0}); return 0; });
    motion.stopped();
    journal->append({{"type", "collection_done"}, {"early_stop", early_stopped}, {"t_s", run_clock()},
                     {"segments", seg_files.size()}});
    run_clock_base = run_clock();
  }
  res.early_stopped = early_stopped;
  res.campaign_time_s = collection_done ? run_clock_base : run_clock_base;

  // ---- finish: merged log, solve, table, flash, verify, record, report -------------------------------
  const std::string log_path = (out / "log.bin").string();
  std::string log_sha;
  if (finish.contains("log_merged") && fs::exists(log_path) && file_sha(log_path) == finish["log_merged"].value("sha256", "")) {
    log_sha = finish["log_merged"]["sha256"];
  } else {
    io::LogMeta m = meta;
    m.set("segments", std::to_string(seg_files.size()));
    io::LogWriter w(log_path, m, io::LogEncoding::kBinary);
    for (const auto& f : seg_files) {
      io::LogReader r(f);
      io::LogRow row;
      while (r.next(row)) w.write(row);
    }
    w.sync();
    w.close();
    log_sha = file_sha(log_path);
    journal->append({{"type", "log_merged"}, {"file", "log.bin"}, {"sha256", log_sha}});
  }

  // Batch solve of the merged log (host/solver fixture mode). The recursive estimate that steered the
  // collection is kept for comparison in cal.json.
  const solver::Estimate recursive = tracker.estimate();
  solver::Estimate est = recursive;
  std::string solve_note = "srif";
  Eigen::VectorXd sigma_noise;  // noise-only σ when the fixture tolerance widened est's covariance
  json fixture_section = solver::fixture_tolerance_not_stated();
  json dwell_scatter;  // null: the batch solve was not used
  std::string consider_error;
  try {
    UnitSolve us = solve_unit_log(log_path, st, spec, camp);
    if (us.estimate.names == est.names) {
      est = us.estimate;
      sigma_noise = us.sigma_noise;
      fixture_section = us.fixture_section;
      dwell_scatter = us.dwell_scatter;
      consider_error = us.consider_error;
      solve_note = "batch fixture mode (host/solver)";
    } else {
      solve_note = "srif (batch names differ: per-plateau model?)";
      // The recursive estimate's σ know nothing of the fixture: a stated tolerance not carried is a failure.
      if (!st.fixture_tolerance.is_null()) {
        fixture_section = {{"stated", true}, {"error", "not propagated: the batch solve's parameters differ"}};
        consider_error = "fixture tolerance: not propagated (the batch solve's parameters differ from the recursive estimate's)";
      }
    }
  } catch (const solver::SolverError& e) {
    solve_note = std::string("srif (batch solve refused: ") + e.what() + ")";
    if (!st.fixture_tolerance.is_null()) {
      fixture_section = {{"stated", true}, {"error", std::string("not propagated: ") + e.what()}};
      consider_error = std::string("fixture tolerance: not propagated (batch solve refused: ") + e.what() + ")";
    }
  }
  res.estimate = est;
  Eigen::VectorXd sig = est.sigma();
  std::vector<std::string> extra_reasons;
  records::CalibrationRecord& rec = res.record;
  for (int i = 0; i < n; ++i)
    rec.parameters.push_back({est.names[static_cast<std::size_t>(i)], est.value[i], sig[i], 0, 0, true});
  bool solvable = true;
  for (int i = 0; i < n; ++i) solvable = solvable && std::isfinite(sig[i]);
  {
    json cal;
    cal["parameters"] = json::array();
    for (int i = 0; i < n; ++i) {
      json p = {{"name", est.names[static_cast<std::size_t>(i)]},
                {"value", std::isfinite(est.value[i]) ? est.value[i] : 0.0},
                {"sigma", std::isfinite(sig[i]) ? sig[i] : -1.0}};
      if (sigma_noise.size() == n) p["sigma_noise"] = sigma_noise[i];
      cal["parameters"].push_back(p);
    }
    cal["fixture_tolerance"] = fixture_section;
    cal["dwell_scatter"] = dwell_scatter;
    if (solvable) {
      json cov = json::array();
      for (int i = 0; i < n; ++i) {
        json row = json::array();
        for (int j = 0; j < n; ++j) row.push_back(est.covariance(i, j));
        cov.push_back(row);
      }
      cal["covariance"] = cov;
    }
    cal["model"] = model::model_spec_to_json(spec);
    cal["recursive"] = json::array();
    Eigen::VectorXd rs = recursive.sigma();
    for (int i = 0; i < n; ++i)
      cal["recursive"].push_back({{"name", recursive.names[static_cast<std::size_t>(i)]},
                                  {"value", std::isfinite(recursive.value[i]) ? recursive.value[i] : 0.0},
                                  {"sigma", std::isfinite(rs[i]) ? rs[i] : -1.0}});
    cal["provenance"] = {{"log_sha256", log_sha}, {"software_version", IMUFORGE_VERSION},
                         {"time_utc", records::utc_now_iso8601()}, {"method", solve_note}};
    std::ofstream(out / "cal.json") << cal.dump(2) << "\n";
  }
  if (!solvable) extra_reasons.push_back("solve: some parameters are not observable from the collected segments");
  if (!consider_error.empty()) extra_reasons.push_back(consider_error);

  std::vector<std::uint8_t> blob, readback;
  std::uint32_t crc = 0;
  if (solvable) {
    std::uint32_t seq = info.table_seq + 1;
    if (finish.contains("flashed")) seq = finish["flashed"].value("seq", seq);
    // Breakpoints span the die temperatures seen, so the kernel interpolates and never extrapolates.
    double tmin = INFINITY, tmax = -INFINITY;
    for (const auto& r : tracker.residuals()) {
      tmin = std::min(tmin, r.temp_C);
      tmax = std::max(tmax, r.temp_C);
    }
    std::vector<double> bps;
    if (!(tmax - tmin > 1.0)) {
      bps.push_back(std::isfinite(tmin) ? 0.5 * (tmin + tmax) : tracker.T_ref_C());
    } else {
      const int nb = 9;
      for (int i = 0; i < nb; ++i) bps.push_back(tmin - 2.0 + (tmax - tmin + 4.0) * i / (nb - 1));
    }
    try {
      blob = table_.build(est, tracker.T_ref_C(), bps, info, seq);
    } catch (const std::exception& e) {
      throw std::invalid_argument(std::string("table: ") + e.what());
    }
    crc = fw::crc32(blob.data(), blob.size());
    { std::ofstream(out / "table.bin", std::ios::binary).write(reinterpret_cast<const char*>(blob.data()), static_cast<std::streamsize>(blob.size())); }
    if (!finish.contains("flashed")) {
      peer("CAN flash", [&] { dev_.flash_table(blob, seq); return 0; });
    }
    readback = peer("CAN read table", [&] { return dev_.read_table(); });
    bool same = readback == blob;
    if (!finish.contains("flashed"))
      journal->append({{"type", "flashed"}, {"seq", seq}, {"crc32", crc}, {"bytes", blob.size()}, {"readback_ok", same}});
    rec.verification.push_back({"readback", same ? 0.0 : 1.0, 0.5, same});
    if (!same) extra_reasons.push_back("flash: the table read back differs from the table written");

    // Post-calibration check with the firmware kernel and the READ-BACK table.
    int vi = 0;
    for (const auto& vp : st.verification) {
      std::string key = "verify" + std::to_string(vi);
      StepInfo si;
      si.key = key;
      si.phase = -1;  // not a plateau's step: never continues a calibration rotation
      si.label = vp.label;
      bool is_rate = vp.rate_dps[0] != 0 || vp.rate_dps[1] != 0 || vp.rate_dps[2] != 0;
      si.kind = is_rate ? physics::CampaignStep::Kind::kRate : physics::CampaignStep::Kind::kPosition;
      si.position_deg = vp.position_deg;
      si.rate_dps = vp.rate_dps;
      si.dwell_s = vp.dwell_s;
      std::array<double, 6> mean_after{};
      if (finish.contains("verified_" + key)) {
        auto v = finish["verified_" + key]["after"].get<std::vector<double>>();
        for (int k = 0; k < 6; ++k) mean_after[static_cast<std::size_t>(k)] = v[static_cast<std::size_t>(k)];
      } else {
        std::vector<io::LogRow> rows;
        std::vector<ImuSample> raws;
        auto vs = verify_segments.find(key);
        if (vs != verify_segments.end()) {
          // A multi-unit station streamed every unit at this pose at once (station_runner.cpp); the raw
          // counts do not depend on the table flashed since, so the kernel check runs on them now.
          const std::string file = (out / vs->second.at("file").get<std::string>()).string();
          if (!fs::exists(file) || file_sha(file) != vs->second.at("sha256").get<std::string>())
            throw JournalError("journal says verification segment " + key + " is safe in " + file +
                               " but the file is missing or its SHA-256 differs");
          io::LogReader r(file);
          io::LogRow row;
          while (r.next(row)) {
            ImuSample x;
            x.t_s = row.t_s;
            x.temp_C = row.temp_C;
            for (int j = 0; j < 6; ++j) x.raw[j] = row.raw[j];
            rows.push_back(row);
            raws.push_back(x);
          }
          if (rows.empty()) throw JournalError("verification segment " + file + " holds no rows");
        } else {
          collect(si, key, false, &rows, &raws, 0.0);
        }
        bool accel_ok = !is_rate || is_vertical_rotation(kin, vp.position_deg, vp.rate_dps);
        for (std::size_t i = 0; i < rows.size(); ++i) {
          double o[6];
          table_.compensate(readback, raws[i], o);
          for (int k = 0; k < 3; ++k) {
            mean_after[static_cast<std::size_t>(k)] += o[k] - rows[i].f_ref[k];
            mean_after[static_cast<std::size_t>(3 + k)] += o[3 + k] - rows[i].w_ref[k];
          }
        }
        for (auto& m : mean_after) m /= static_cast<double>(rows.size());
        if (!accel_ok) mean_after[0] = mean_after[1] = mean_after[2] = std::nan("");
        journal->append({{"type", "verified_" + key}, {"label", vp.label},
                         {"after", std::vector<double>(mean_after.begin(), mean_after.end())}});
      }
      static const char* ax[6] = {"accel.x", "accel.y", "accel.z", "gyro.x", "gyro.y", "gyro.z"};
      for (int k = 0; k < 6; ++k) {
        double v = mean_after[static_cast<std::size_t>(k)];
        if (std::isnan(v)) continue;  // accel during a rate run about a tilted axis: no constant reference
        double lim = k < 3 ? st.verify_accel_mps2 : st.verify_gyro_rad_s;
        rec.verification.push_back({vp.label + "." + ax[k], v, lim, true});
      }
      ++vi;
    }
    if (st.verification.empty()) extra_reasons.push_back("station: no verification poses configured");
    peer("rate table stop", [&] { bench_.command_rate({0, 0, 0}); return 0; });
  }

  Verdict verdict = evaluate(st, rec.parameters, rec.verification, extra_reasons);
  rec.pass = verdict.pass;
  rec.reasons = verdict.reasons;
  rec.serial = info.serial;
  rec.station = st.name;
  rec.fixture = bench_.describe();
  rec.campaign = camp.name;
  rec.campaign_sha256 = campaign_sha;
  rec.software_version = IMUFORGE_VERSION;
  rec.firmware_version = info.firmware_version;
  rec.started_utc = started_utc;
  rec.finished_utc = records::utc_now_iso8601();
  rec.table_blob = blob;
  rec.table_crc32 = crc;
  rec.log_path = log_path;
  rec.log_sha256 = log_sha;
  rec.run_dir = out.string();
  rec.campaign_time_s = res.campaign_time_s;
  rec.early_stop = early_stopped;
  if (finish.contains("recorded")) rec.id = finish["recorded"].value("id", "");

  tracker.finalize_residuals(est.value.unaryExpr([](double v) { return std::isfinite(v) ? v : 0.0; }));
  rd.rec = rec;
  rd.db = db;
  rd.residuals = tracker.residuals();
  rd.rejections = tracker.rejections();
  rd.schedule_time_s = res.schedule_time_s;
  rd.segments_total = total_steps;
  rd.segments_used = static_cast<int>(seg_files.size());
  rd.segments_resumed = res.segments_resumed;
  res.report_path = (out / "report.html").string();

  std::string record_error;
  if (!finish.contains("recorded")) {
    try {
      auto store = records::open_store(db);
      store->ensure_schema();
      // The id is chosen and journaled before the insert: a crash between the insert and its "recorded"
      // entry leaves the id in the journal, and the resumed run finds that record instead of adding a
      // second one (found by tests/eol/test_crash.cpp).
      bool present = false;
      if (finish.contains("recording")) {
        rec.id = finish["recording"].value("id", "");
        try {
          (void)store->get(rec.id);
          present = true;
        } catch (const records::RecordError&) {
        }
      } else {
        rec.id = records::new_record_id();
        journal->append({{"type", "recording"}, {"id", rec.id}});
      }
      if (!present) store->insert(rec);
      journal->append({{"type", "recorded"}, {"id", rec.id}, {"backend", store->backend()}});
    } catch (const std::exception& e) {
      record_error = e.what();
    }
  }
  rd.rec = rec;
  write_report(res.report_path, rd);
  if (!record_error.empty()) throw PeerError("records: " + record_error + " (report written to " + res.report_path + ")");
  res.record_id = rec.id;
  res.pass = verdict.pass;
  res.reasons = verdict.reasons;
  journal->append({{"type", "finished"}, {"pass", res.pass}, {"reasons", res.reasons}, {"record_id", rec.id}});
  return res;
}

}  // namespace imuforge::eol
